//! FLIP (issue 17): what the perceptual error costs per 1920×1080 image pair, against the numerical error of the
//! same pair measured in the same run.
//!
//! - `flip/ldr/1920x1080`: `measure::flip::ldr_flip` of two sRGB images (the displayed images of a report row);
//! - `flip/hdr/1920x1080`: `measure::flip::hdr_flip` of two linear images (the exposure sweep: one LDR-FLIP per
//!   exposure, the count taken from the reference image as NVIDIA's code does);
//! - `flip/ldr-4-pairs/1920x1080` and `flip/ldr-4-batched/1920x1080`: four tests against one reference, as four
//!   pairs and as one `ldr_flip_many` (the reference filtered once; the same maps bit for bit);
//! - `flip/hdr-4-means/1920x1080` and `flip/hdr-4-means-sky/1920x1080`: four linear tests against one reference,
//!   means only (`hdr_flip_means`, as the report's batches), the second with the top third of every test equal to
//!   the reference, as a sky or background is: the ratio is what skipping the shared windows saves;
//! - `flip/rmse/1920x1080`: the baseline, `measure::image::compare` (RMSE, PSNR, max, relative MSE) of the same
//!   pair: what every report row computes anyway.
//!
//! The images are a smooth HDR gradient with a few highlights and a test copy with noise added (fixed seed), built
//! outside the timed loop. Run briefly: `cargo bench --bench flip -- --warm-up-time 1 --measurement-time 5`.
//! The goal is ≤ 0.3 s per 1080p LDR-FLIP on 2 cores; NVIDIA's `flip-evaluator` 1.7 took 7.2–8.1 s (LDR) and
//! 45 s (HDR) for the same size on the same machine (AMD EPYC Zen 3, 2 cores, AVX2 + FMA, no AVX-512).

use criterion::{criterion_group, criterion_main, Criterion};
use gbuf::image::HdrImage;
use gbuf::measure::flip::{hdr_flip, hdr_flip_means, ldr_flip, ldr_flip_many, FlipOptions};
use gbuf::measure::image::compare;
use glam::Vec3;
use std::hint::black_box;

const W: usize = 1920;
const H: usize = 1080;

fn images() -> (HdrImage, HdrImage) {
    let mut a = HdrImage::new(W as u32, H as u32);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for (i, c) in a.rgb.iter_mut().enumerate() {
        let (x, y) = ((i % W) as f32 / W as f32, (i / W) as f32 / H as f32);
        *c = Vec3::new(x, y, 0.5 * (x + y)) * 2.0;
        if i % 9973 == 0 {
            *c *= 40.0;
        }
    }
    let mut b = a.clone();
    for c in &mut b.rgb {
        *c *= 1.0 + 0.1 * (rnd() - 0.5);
    }
    (a, b)
}

fn benches(c: &mut Criterion) {
    let (a, b) = images();
    let srgb = |img: &HdrImage| -> Vec<f32> {
        img.to_srgb8(Default::default()).iter().map(|&v| f32::from(v) / 255.0).collect()
    };
    let linear = |img: &HdrImage| -> Vec<f32> { img.rgb.iter().flat_map(|c| c.to_array()).collect() };
    let (sa, sb, la, lb) = (srgb(&a), srgb(&b), linear(&a), linear(&b));
    let opts = FlipOptions::default();
    let mut group = c.benchmark_group("flip");
    group.sample_size(10);
    group.bench_function(format!("rmse/{W}x{H}"), |bn| bn.iter(|| compare(black_box(&a), black_box(&b))));
    group
        .bench_function(format!("ldr/{W}x{H}"), |bn| bn.iter(|| ldr_flip(black_box(&sa), black_box(&sb), W, H, &opts)));
    group
        .bench_function(format!("hdr/{W}x{H}"), |bn| bn.iter(|| hdr_flip(black_box(&la), black_box(&lb), W, H, &opts)));
    // Four tests against one reference, as a report's rows are: four pairs, then the batch that filters the
    // reference once (the same maps bit for bit). The ratio of the two is what batching saves.
    let tests: Vec<Vec<f32>> =
        (0..4).map(|k| sb.iter().map(|v| (v * (1.0 - 0.01 * k as f32)).min(1.0)).collect()).collect();
    let refs: Vec<&[f32]> = tests.iter().map(Vec::as_slice).collect();
    group.bench_function(format!("ldr-4-pairs/{W}x{H}"), |bn| {
        bn.iter(|| refs.iter().map(|t| ldr_flip(black_box(&sa), t, W, H, &opts).mean).sum::<f64>())
    });
    group.bench_function(format!("ldr-4-batched/{W}x{H}"), |bn| {
        bn.iter(|| ldr_flip_many(black_box(&sa), &refs, W, H, &opts).iter().map(|m| m.mean).sum::<f64>())
    });
    // Four HDR tests, means only; then the same with their top third equal to the reference (a sky).
    let hdr_tests: Vec<Vec<f32>> = (0..4).map(|k| lb.iter().map(|v| v * (1.0 - 0.01 * k as f32)).collect()).collect();
    let sky = 3 * W * (H / 3);
    let sky_tests: Vec<Vec<f32>> =
        hdr_tests.iter().map(|t| la[..sky].iter().chain(&t[sky..]).copied().collect()).collect();
    for (name, tests) in [("hdr-4-means", &hdr_tests), ("hdr-4-means-sky", &sky_tests)] {
        let views: Vec<&[f32]> = tests.iter().map(Vec::as_slice).collect();
        group.bench_function(format!("{name}/{W}x{H}"), |bn| {
            bn.iter(|| hdr_flip_means(black_box(&la), &views, W, H, &opts).iter().sum::<f64>())
        });
    }
    group.finish();
}

criterion_group!(flip, benches);
criterion_main!(flip);
