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
    for k in ["one_thread", "all_threads"] {
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
    assert_eq!(stages.len(), 3);
    assert!(stages.iter().all(|s| s["ms"].as_f64().unwrap() >= 0.0));
    let f = stages[0]["fraction_of_limit"].as_f64().unwrap();
    assert!(f > 0.0 && f.is_finite(), "{f}");
    assert!(j["fma_per_pair_at_peak"].as_f64().unwrap() > 0.0);
}

#[test]
fn bench_refuses_sizes_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let o = gbuf(dir.path(), &["bench", "--mib", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
