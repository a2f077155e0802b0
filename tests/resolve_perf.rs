//! CPU-time measurement of the bench frame (ignored by default; run in release):
//! `cargo test --release --test resolve_perf -- --ignored --nocapture`.
//!
//! Criterion measures wall time, which on a shared machine includes waiting for a core. This reports the process
//! CPU time per frame (Linux `/proc/self/stat`, utime + stime), on a one-thread pool, so it estimates what one idle
//! core needs. No assertion on time: it prints numbers for docs/RESOLVE.md.

use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::resolve::{fixture, resolve, uniform_mask, Culling, ResolveConfig};

fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

#[test]
#[ignore = "measurement, not a test: run in release with --ignored --nocapture"]
fn cpu_time_per_frame() {
    let (w, h): (u32, u32) = match std::env::var("GBUF_PERF_SIZE")
        .ok()
        .and_then(|s| s.split_once('x').map(|(a, b)| (a.parse().ok(), b.parse().ok())))
    {
        Some((Some(w), Some(h))) => (w, h),
        _ => (1280, 720),
    };
    let gb1 = fixture::room(w, h, 1).unwrap();
    let gb4 = fixture::room(w, h, 4).unwrap();
    // Light range from GBUF_RANGE (default 1.0: about 31 lights per sample after tile culling).
    let range: f32 = std::env::var("GBUF_RANGE").ok().and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let lights = fixture::lights_on_surfaces(&gb1, 1024, range, 7);
    let mask1 = uniform_mask(&gb1, false);
    let mask4 = detect(&gb4, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let frames: u32 = std::env::var("GBUF_PERF_FRAMES").ok().and_then(|s| s.parse().ok()).unwrap_or(5);
    for (name, gb, mask, cfg) in [
        ("tiled 1x", &gb1, &mask1, ResolveConfig::default()),
        ("tiled 4x adaptive", &gb4, &mask4, ResolveConfig::default()),
        ("none 1x", &gb1, &mask1, ResolveConfig { culling: Culling::None, ..Default::default() }),
    ] {
        if std::env::var("GBUF_PERF_CASE").is_ok_and(|c| !name.starts_with(c.as_str())) {
            continue;
        }
        let warm = pool.install(|| resolve(gb, &lights, mask, &cfg)).unwrap();
        let t0 = cpu_seconds().unwrap_or(0.0);
        let mut split = [0.0f64; 3];
        for _ in 0..frames {
            let r = pool.install(|| resolve(gb, &lights, mask, &cfg)).unwrap();
            for (acc, v) in split.iter_mut().zip([r.stats.ms.gather, r.stats.ms.cull, r.stats.ms.shade]) {
                *acc += v / f64::from(frames);
            }
        }
        let cpu = (cpu_seconds().unwrap_or(0.0) - t0) / f64::from(frames);
        let s = &warm.stats;
        println!(
            "{name}: {:.1} ms CPU/frame, {} pairs tested ({:.1}/sample, {:.0}% lit), gather {:.1} cull {:.1} shade \
             {:.1} ms (mean wall of {frames} frames)",
            cpu * 1e3,
            s.light_pairs_tested,
            s.lights_per_sample,
            100.0 * s.light_pairs_lit as f64 / s.light_pairs_tested.max(1) as f64,
            split[0],
            split[1],
            split[2]
        );
    }
}
