//! `gbuf bench`: the machine's limits and one frame against them, as JSON a script reads.
mod support;

use support::{gbuf, stderr};

#[test]
fn bench_measures_the_machine_and_sets_a_frame_against_it() {
    let dir = tempfile::tempdir().unwrap();
    let o = gbuf(dir.path(), &["bench", "--mib", "16", "--width", "160", "--height", "90", "--lights", "64", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bw = &j["bandwidth"];
    assert_eq!(bw["bytes"], 16 << 20);
    for k in ["one_thread", "all_threads", "copy_one_thread", "copy_all_threads"] {
        let v = bw[k].as_f64().unwrap();
        assert!(v.is_finite() && v > 1e8, "{k}: {v}");
    }
    // One peak per instruction set the CPU has, baseline first; the light loop's own among them.
    let peaks = j["fma_peaks"].as_array().unwrap();
    assert_eq!(peaks[0]["isa"], "baseline");
    assert!(peaks.iter().all(|p| p["flops"].as_f64().unwrap() > 1e8 && p["lanes"].as_u64().unwrap() >= 4));
    let isa = j["isa"].as_str().unwrap();
    assert!(isa == "neon" || peaks.iter().any(|p| p["isa"] == isa), "{isa}");
    // The frame: a real .bin lit from its arrays; every stage timed, the file's rate set against the bandwidth.
    assert!(j["file_bytes"].as_u64().unwrap() > 160 * 90 * 15);
    assert!(j["light_pairs"].as_u64().unwrap() > 0);
    let stages = j["stages"].as_array().unwrap();
    let names: Vec<&str> = stages.iter().map(|s| s["stage"].as_str().unwrap()).collect();
    assert_eq!(names.len(), 9, "{names:?}");
    for want in
        ["read and decode", "edges", "work list", "culling", "shading", "light loop", "8-bit", "f64 reference", "FLIP"]
    {
        assert!(names.iter().any(|n| n.starts_with(want)), "no stage {want:?} in {names:?}");
    }
    assert!(stages.iter().all(|s| s["ms"].as_f64().unwrap() >= 0.0));
    // The streaming stages are set against the read bandwidth; the light loop's parts add up to it.
    for i in [0, 6] {
        let f = stages[i]["fraction_of_limit"].as_f64().unwrap();
        assert!(f > 0.0 && f.is_finite(), "{}: {f}", names[i]);
    }
    let ms = |i: usize| stages[i]["ms"].as_f64().unwrap();
    assert!((ms(2) + ms(3) + ms(4) - ms(5)).abs() <= 1e-9 * ms(5).max(1.0), "{names:?}");
    // FLIP: one pass per exposure plus the LDR one, over every pixel.
    let exposures = j["flip_exposures"].as_u64().unwrap();
    assert!(exposures >= 2, "{exposures}");
    let passes = stages[8]["per_second"].as_f64().unwrap() * ms(8) / 1e3;
    let want = (160 * 90) as f64 * (exposures + 1) as f64;
    assert!((passes - want).abs() <= 1e-6 * want, "{passes} pixel passes, {want} expected");
    assert!(j["fma_per_pair_at_peak"].as_f64().unwrap() > 0.0);
}

#[test]
fn bench_refuses_sizes_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let o = gbuf(dir.path(), &["bench", "--mib", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
