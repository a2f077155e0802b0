//! The report stage (issue 5): what one layout × detector row of `gbuf report` costs, against the plain resolve of
//! the same frame.
//!
//! - `report/row/<layout>/<detector>/WxHxS`: `analysis::sweep::sweep` with one layout and one detector and one timing
//!   run — the f64 reference, the exact-G-buffer resolve the row's `layout_rmse` compares with, the layout's pack /
//!   unpack, attribute error maps, the detector, its ground-truth scores, the resolve and the image errors;
//! - `report/plain-resolve/<detector>/WxHxS`: the baseline, what `gbuf resolve --no-reference` does for the same
//!   frame: the detector and the resolve on the unpacked G-buffer.
//!
//! - `report/reference/WxHxS`: the f64 every-sample reference alone, the largest part of a row, beside
//!   `report/resolve-every-sample/WxHxS`, the f32 resolve shading every sample (its baseline: issue 14 asks for the
//!   reference within 3× of it).
//!
//! - `report-timing/resolve-whole|resolve-estimate/1920x1080x4`: the report's sampled timing runs (issue 34) against
//!   whole-frame runs; the ratio of the estimate to the whole time is printed before.
//!
//! The ratio of the two (measured in the same run) is what a report row costs in resolves. The room and its lights
//! are built once, outside the timed loop. Run briefly:
//! `cargo bench --bench report -- --warm-up-time 1 --measurement-time 3`.
//!
//! Measured (2 shared cores, load average 4–5.5 from other work, so the absolute times are noisy): plain resolve
//! 7.8 ms, reference 79.7 ms, row 161 ms — a row costs about 21 plain resolves, half of it the f64 reference, which
//! `gbuf report` computes once per sweep, not once per row. An earlier run in the same session gave 2.4 / 107 ms
//! (45×): the 2-thread plain resolve is the figure most sensitive to the load.

use criterion::{criterion_group, criterion_main, Criterion};
use gbuf::analysis::sweep::{sweep, FlipRows, SweepConfig};
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::resolve::{reference, resolve, ResolveConfig};
use gbuf::scene::{default_lights, render, SceneName};
use std::hint::black_box;

const W: u32 = 320;
const H: u32 = 180;
const SAMPLES: u32 = 4;
const LAYOUT: &str = "lauritzen-15";
const DETECTOR: Detector = Detector::Lauritzen;

fn benches(c: &mut Criterion) {
    let gb = render(SceneName::Room, W, H, SAMPLES).expect("room");
    let lights = default_lights(SceneName::Room, &gb);
    let layout = Layout::by_name_or_path(LAYOUT).expect("built-in layout");
    let det_cfg = DetectorConfig::default();
    let resolve_cfg = ResolveConfig::default();
    let sweep_cfg = SweepConfig {
        layouts: vec![layout],
        detectors: vec![DETECTOR],
        detector_config: det_cfg,
        culling: Vec::new(),
        resolve: resolve_cfg,
        runs: 1,
        // FLIP off: the bench measures the sweep's own work against a plain resolve.
        flip: FlipRows::None,
        viewing: Default::default(),
    };
    let size = format!("{W}x{H}x{SAMPLES}");
    let mut group = c.benchmark_group("report");
    group.sample_size(10);
    group.bench_function(format!("plain-resolve/{}/{size}", DETECTOR.name()), |b| {
        b.iter(|| {
            let mask = detect(black_box(&gb), DETECTOR, &det_cfg).unwrap();
            resolve(&gb, black_box(&lights), &mask, &resolve_cfg).unwrap()
        })
    });
    // The f32 resolve doing the reference's work (every sample shaded, tiled culling): the reference's baseline
    // (issue 14: the f64 reference with conservative culling within 3× of it).
    group.bench_function(format!("resolve-every-sample/{size}"), |b| {
        b.iter(|| {
            let mask = detect(black_box(&gb), Detector::Ssaa, &det_cfg).unwrap();
            resolve(&gb, black_box(&lights), &mask, &resolve_cfg).unwrap()
        })
    });
    group.bench_function(format!("reference/{size}"), |b| {
        b.iter(|| reference(black_box(&gb), black_box(&lights), &resolve_cfg).unwrap())
    });
    group.bench_function(format!("row/{LAYOUT}/{}/{size}", DETECTOR.name()), |b| {
        b.iter(|| {
            let out = sweep(black_box(&gb), black_box(&lights), &sweep_cfg, &mut |_, _, _| {}).unwrap();
            assert!(out.rows.len() == 1 && out.rows[0].error.is_none(), "the row must succeed");
            out
        })
    });
    group.finish();
    timing_estimate(c);
}

/// The report's sampled timing runs against whole-frame runs (issue 34): the resolve and the edge pass of a packed
/// 1080p × 4 room timed whole and estimated from every `TIMING_STRIDE`-th band, interleaved, 7 rounds; the ratio of
/// the medians is printed (an estimate within a few percent of the whole time is what the report's spread assumes),
/// and criterion times both calls (the estimate's own cost is about 1/8 of a frame).
fn timing_estimate(c: &mut Criterion) {
    use gbuf::resolve::time_sampled;
    let (w, h) = (1920, 1080);
    let gb = render(SceneName::Room, w, h, SAMPLES).expect("room");
    let lights = default_lights(SceneName::Room, &gb);
    let layout = Layout::by_name_or_path(LAYOUT).expect("built-in layout");
    let packed = layout.pack(&gb).expect("pack");
    let frame = layout.frame(&packed, &gb).expect("frame");
    let det_cfg = DetectorConfig::default();
    let cfg = ResolveConfig::default();
    let mask = gbuf::detect::detect_packed(&frame, DETECTOR, &det_cfg).expect("detect");
    let stride = gbuf::resolve::TIMING_STRIDE;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (mut full, mut est, mut dfull, mut dest) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for _ in 0..7 {
        let t = std::time::Instant::now();
        resolve(&frame, &lights, &mask, &cfg).unwrap();
        full.push(t.elapsed().as_secs_f64() * 1e3);
        est.push(time_sampled(&frame, &lights, &mask, &cfg).unwrap());
        let t = std::time::Instant::now();
        gbuf::detect::detect_packed(&frame, DETECTOR, &det_cfg).unwrap();
        dfull.push(t.elapsed().as_secs_f64() * 1e3);
        dest.push(gbuf::detect::time_packed_sampled(&frame, DETECTOR, &det_cfg, stride).unwrap());
    }
    let (f, e, df, de) = (median(full), median(est), median(dfull), median(dest));
    eprintln!(
        "timing estimate ({w}x{h}x{SAMPLES}, {LAYOUT} packed, every {stride}th band): resolve whole {f:.1} ms, \
         estimate {e:.1} ms ({:.3}x); detect whole {df:.1} ms, estimate {de:.1} ms ({:.3}x)",
        e / f,
        de / df
    );
    let mut group = c.benchmark_group("report-timing");
    group.sample_size(10);
    group.bench_function(format!("resolve-whole/{w}x{h}x{SAMPLES}"), |b| {
        b.iter(|| resolve(black_box(&frame), black_box(&lights), &mask, &cfg).unwrap())
    });
    group.bench_function(format!("resolve-estimate/{w}x{h}x{SAMPLES}"), |b| {
        b.iter(|| time_sampled(black_box(&frame), black_box(&lights), &mask, &cfg).unwrap())
    });
    group.finish();
}

criterion_group!(report, benches);
criterion_main!(report);
