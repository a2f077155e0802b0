//! Time per frame of issue 4's bench frame (ignored by default; run in release):
//! `cargo test --release --test resolve_perf -- --ignored --nocapture`.
//!
//! The frame: `fixture::room(1280, 720, ·)`, 1024 point lights whose range is tuned to about 40 lights per sample
//! after tile culling, Blinn-Phong with linear falloff. Criterion measures wall time, which on a shared machine
//! includes waiting for a core; this prints, per case, the process CPU time per frame on a one-thread pool (Linux
//! `/proc/self/stat`, utime + stime: what one idle core needs) and the best wall time of the frames on one and on
//! two threads (the best run is the one least disturbed by other processes). No assertion on time: it prints
//! numbers for docs/RESOLVE.md. Environment: `GBUF_PERF_CASE` (the name of the one case to run),
//! `GBUF_PERF_SIZE` (`WxH`), `GBUF_PERF_FRAMES` (default 10), `GBUF_PERF_LIGHTS_PER_SAMPLE` (default 40).

use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::resolve::{
    fixture, resolve, resolve_into, Culling, ResolveConfig, ResolveInput, ResolveStats, Resolved, SplitSamples,
};
use std::time::Instant;

fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

/// CPU seconds used so far by each thread of this process whose name starts with `prefix`.
fn thread_cpu(prefix: &str) -> Vec<f64> {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else { return Vec::new() };
    let mut out: Vec<f64> = dir
        .filter_map(|e| {
            let stat = std::fs::read_to_string(e.ok()?.path().join("stat")).ok()?;
            let (head, rest) = stat.rsplit_once(')')?;
            if !head.split_once('(')?.1.starts_with(prefix) {
                return None;
            }
            let f: Vec<&str> = rest.split_whitespace().collect();
            Some((f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?) / 100.0)
        })
        .collect();
    out.sort_by(f64::total_cmp);
    out
}

fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|s| s.parse().ok())
}

/// `GBUF_PERF_SIZE` (`WxH`), else `default`.
fn perf_size(default: (u32, u32)) -> (u32, u32) {
    std::env::var("GBUF_PERF_SIZE")
        .ok()
        .and_then(|s| s.split_once('x').and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?))))
        .unwrap_or(default)
}

#[test]
#[ignore = "measurement, not a test: run in release with --ignored --nocapture"]
fn time_per_frame() {
    let (w, h) = perf_size((1280, 720));
    let frames: u32 = env("GBUF_PERF_FRAMES").unwrap_or(10);
    let density: f64 = env("GBUF_PERF_LIGHTS_PER_SAMPLE").unwrap_or(40.0);
    let gb1 = fixture::room(w, h, 1).unwrap();
    let gb4 = fixture::room(w, h, 4).unwrap();
    let lights = fixture::lights_for_density(w, h, 1024, density, 7).unwrap();
    let mask1 = gbuf::detect::baselines::none(&gb1);
    let t0 = Instant::now();
    let mask4 = detect(&gb4, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    let t_detect = t0.elapsed();
    let t0 = Instant::now();
    let split4 = SplitSamples::new(&gb4).unwrap();
    let t_reorder = t0.elapsed();
    let t0 = Instant::now();
    let copy = gb4.clone();
    let t_copy = t0.elapsed();
    drop(copy);
    println!(
        "4x: lauritzen edge detection {:.1} ms; reordering to split {:.1} ms (once per G-buffer, current pool; \
         a plain copy of the G-buffer: {:.1} ms)",
        t_detect.as_secs_f64() * 1e3,
        t_reorder.as_secs_f64() * 1e3,
        t_copy.as_secs_f64() * 1e3
    );
    let pools: Vec<_> = [1, 2]
        .map(|n| {
            rayon::ThreadPoolBuilder::new().num_threads(n).thread_name(move |i| format!("p{n}-{i}")).build().unwrap()
        })
        .into();
    println!("kernel instruction set: {}", gbuf::resolve::instruction_set());
    // The bench frame has few edges (0.3% of pixels: sphere silhouettes); real frames have more. The same frame
    // with pixels scattered at random (the worst case for locality) also shaded per sample, up to 10%.
    let widened = |percent: u64| {
        let mut m = mask4.clone();
        for (p, c) in m.shade_count.iter_mut().enumerate() {
            let h = (p as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
            if h % 1000 < percent * 10 {
                *c = 4;
            }
        }
        m
    };
    let (mask4_5, mask4_10) = (widened(5), widened(10));
    let (in1, in4, split4): (ResolveInput, ResolveInput, ResolveInput) =
        ((&gb1).into(), (&gb4).into(), (&split4).into());
    let tiled = ResolveConfig::default();
    for (name, gb, mask, cfg, reuse) in [
        ("tiled 1x", in1, &mask1, tiled, false),
        ("tiled 1x reusing the output", in1, &mask1, tiled, true),
        ("tiled 4x adaptive", in4, &mask4, tiled, false),
        ("tiled 4x adaptive reusing the output", in4, &mask4, tiled, true),
        ("tiled 4x adaptive split", split4, &mask4, tiled, false),
        ("tiled 4x adaptive split reusing the output", split4, &mask4, tiled, true),
        ("tiled 4x, +5% of pixels per sample", in4, &mask4_5, tiled, false),
        ("tiled 4x, +5% of pixels per sample, split", split4, &mask4_5, tiled, false),
        ("tiled 4x, +10% of pixels per sample", in4, &mask4_10, tiled, false),
        ("tiled 4x, +10% of pixels per sample, split", split4, &mask4_10, tiled, false),
        ("none 1x", in1, &mask1, ResolveConfig { culling: Culling::None, ..Default::default() }, false),
    ] {
        // `resolve` allocates the image and heatmap per frame; `resolve_into` reuses one `Resolved`, as a
        // renderer keeps its render targets.
        let mut out = Resolved::default();
        let mut run = || -> ResolveStats {
            if reuse {
                resolve_into(gb, &lights, mask, &cfg, &mut out).unwrap();
                out.stats.clone()
            } else {
                resolve(gb, &lights, mask, &cfg).unwrap().stats
            }
        };
        if std::env::var("GBUF_PERF_CASE").is_ok_and(|c| c != name) {
            continue;
        }
        let warm = pools[0].install(&mut run);
        let before2 = thread_cpu("p2-");
        let mut best = [f64::INFINITY; 2];
        let mut split = [0.0f64; 3];
        let (mut cpu, mut cpu2) = (0.0, 0.0);
        for (t, pool) in pools.iter().enumerate() {
            let c0 = cpu_seconds().unwrap_or(0.0);
            for _ in 0..frames {
                let t0 = Instant::now();
                let r = pool.install(&mut run);
                best[t] = best[t].min(t0.elapsed().as_secs_f64());
                if t == 0 {
                    for (acc, v) in split.iter_mut().zip([r.ms.gather, r.ms.cull, r.ms.shade]) {
                        *acc += v / f64::from(frames);
                    }
                }
            }
            if t == 0 {
                cpu = (cpu_seconds().unwrap_or(0.0) - c0) / f64::from(frames);
            } else {
                cpu2 = (cpu_seconds().unwrap_or(0.0) - c0) / f64::from(frames);
            }
        }
        // How the 2-thread frames' work divided between the pool's threads (CPU seconds each): on a machine whose
        // other core is busy the wall-time ratio says nothing, but an even split shows the work is parallel.
        let split2: Vec<String> = thread_cpu("p2-")
            .iter()
            .zip(before2.iter().chain(std::iter::repeat(&0.0)))
            .map(|(a, b)| format!("{:.0}", (a - b) * 1e3 / f64::from(frames)))
            .collect();
        let s = &warm;
        println!(
            "{name}: {:.1} ms CPU/frame on 1 thread ({:.1} on 2, per thread {} ms); best wall {:.1} ms on 1 thread, \
             {:.1} ms on 2 (×{:.2}); \
             {} pairs tested ({:.1}/sample, {:.0}% lit); edge pixels {:.2}%, shading fraction {:.3}; 1-thread split gather {:.1} cull {:.1} shade {:.1} ms",
            cpu * 1e3,
            cpu2 * 1e3,
            split2.join(" + "),
            best[0] * 1e3,
            best[1] * 1e3,
            best[0] / best[1],
            s.light_pairs_tested,
            s.lights_per_sample,
            100.0 * s.light_pairs_lit as f64 / s.light_pairs_tested.max(1) as f64,
            100.0 * s.edge_fraction,
            s.shading_fraction,
            split[0],
            split[1],
            split[2]
        );
    }
}

/// Coarse shading's time against the full-rate resolve's on the room at `GBUF_PERF_SIZE` (default 1920×1080) × 4
/// with its default lights, lauritzen edges and gbuf's SRI at tile 16 with its lighting preview (broadcast): per case
/// the best wall time of
/// `GBUF_PERF_FRAMES` frames on one thread, alternating, with the stage split and the evaluations.
#[test]
#[ignore = "measurement, not a test: run in release with --ignored --nocapture"]
fn coarse_shading_time() {
    use gbuf::detect::rate::{gbuffer_sri, CoarseMode};
    use gbuf::resolve::{resolve_coarse, Coarse};
    let (w, h) = perf_size((1920, 1080));
    let frames: u32 = env("GBUF_PERF_FRAMES").unwrap_or(7);
    let gb = gbuf::scene::render(gbuf::scene::SceneName::Room, w, h, 4).unwrap();
    let lights = gbuf::scene::default_lights(gbuf::scene::SceneName::Room, &gb);
    let mask = detect(&gb, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    let brdf = gbuf::resolve::Brdf::Ggx;
    let cfg = ResolveConfig { brdf, ..Default::default() };
    // The rule as `gbuf vrs` runs it: the G-buffer tests and the preview of the lighting.
    let preview = gbuf::resolve::LightPreview::new(&gb, &lights, cfg.falloff, brdf, Default::default()).unwrap();
    let t0 = Instant::now();
    let sri = gbuffer_sri(&gb, Some(&preview), &mask, 16, false, &Default::default()).unwrap();
    let t_sri = t0.elapsed().as_secs_f64() * 1e3;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let coarse = Coarse { sri: &sri, mode: CoarseMode::Broadcast };
    let mut best = [f64::INFINITY; 2];
    let mut stats: [Option<ResolveStats>; 2] = [None, None];
    for _ in 0..frames {
        for (k, best) in best.iter_mut().enumerate() {
            let t = Instant::now();
            let r = pool.install(|| {
                if k == 0 {
                    resolve(&gb, &lights, &mask, &cfg)
                } else {
                    resolve_coarse(&gb, &lights, &mask, coarse, &cfg)
                }
            });
            let r = r.unwrap();
            *best = best.min(t.elapsed().as_secs_f64() * 1e3);
            stats[k] = Some(r.stats);
        }
    }
    println!("{w}×{h}×4 room, {} lights, GGX, SRI (tile 16) in {t_sri:.1} ms", lights.len());
    for (k, name) in ["full rate", "coarse"].iter().enumerate() {
        let s = stats[k].as_ref().unwrap();
        println!(
            "{name}: best {:.1} ms on 1 thread; evaluations {} ({:.1}/sample lights); gather {:.1} cull {:.1} shade {:.1} \
             (last run's split)",
            best[k], s.shading_evaluations, s.lights_per_sample, s.ms.gather, s.ms.cull, s.ms.shade
        );
    }
    println!("coarse / full: {:.2} of the time", best[1] / best[0]);
}
