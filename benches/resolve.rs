//! Resolve benches (issue 4's speed section): 1280×720, 1024 point lights placed so about 40 survive tile culling
//! per sample, the demo's Blinn-Phong with linear falloff.
//!
//! - `resolve/tiled/1x/1280x720`: 1 sample per pixel, the < 15 ms target on 2 cores;
//! - `resolve/tiled/4x-adaptive/1280x720`: 4× MSAA, lauritzen-style adaptive (edge pixels per sample), ≤ 1.5× the
//!   1-sample cost; `…/split` the same frame in split order ([`gbuf::resolve::SplitSamples`]: every
//!   pixel's sample 0 in planes of their own); `resolve/tiled/4x-ssaa` for scale;
//! - `resolve/none/1x/1280x720`: no culling, same lights;
//! - `resolve/tiled/1x/1280x720/threads-1` and `threads-2`: thread scaling (local rayon pools);
//! - `resolve/layout/<layout>/packed|unpack-then-resolve|unpacked-copy/…`: a layout's packed targets lit directly
//!   (decoded a tile row at a time inside the resolve) against unpacking the frame first, and against lighting an
//!   unpacked copy made beforehand;
//! - `resolve/bin/loaded-then-resolve|arrays/1x/1280x720`: an ISPC `.bin` loaded whole then lit, against lit from
//!   its own arrays (issue 34: the file's conversion inside the resolve).
//!
//! - `resolve/vrs/…`: the shading-rate generators' time per frame (as pixels per second), and the resolve shaded by
//!   gbuf's SRI (tile 16) against the full-rate resolve with the same mask.
//!
//! The G-buffer is built in code once, outside the timed loop. Run briefly:
//! `cargo bench --bench resolve -- --warm-up-time 1 --measurement-time 3`.

use criterion::{criterion_group, criterion_main, Criterion};
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::resolve::{fixture, resolve, Culling, ResolveConfig, SplitSamples};
use std::hint::black_box;

const W: u32 = 1280;
const H: u32 = 720;
const LIGHTS: usize = 1024;
/// Lights per sample after tile culling that the light range is tuned for.
const TARGET_LIGHTS_PER_SAMPLE: f64 = 40.0;

fn benches(c: &mut Criterion) {
    let gb1 = fixture::room(W, H, 1).expect("fixture");
    let gb4 = fixture::room(W, H, 4).expect("fixture");
    let lights = fixture::lights_for_density(W, H, LIGHTS, TARGET_LIGHTS_PER_SAMPLE, 7).expect("lights");
    let mask1 = gbuf::detect::baselines::none(&gb1);
    let mask4 = detect(&gb4, Detector::Lauritzen, &DetectorConfig::default()).expect("detect");
    let ssaa4 = gbuf::detect::baselines::ssaa(&gb4);
    let split4 = SplitSamples::new(&gb4).expect("reorder");
    let tiled = ResolveConfig::default();
    let none = ResolveConfig { culling: Culling::None, ..tiled };

    let probe = resolve(&gb1, &lights, &mask1, &tiled).unwrap();
    let probe4 = resolve(&gb4, &lights, &mask4, &tiled).unwrap();
    eprintln!(
        "resolve bench: {} lights, {:.1} lights/sample after tile culling, {} pairs tested (1x); 4x adaptive: \
         {:.1}% edge pixels, {:.3} shading fraction, {} pairs",
        lights.len(),
        probe.stats.lights_per_sample,
        probe.stats.light_pairs_tested,
        100.0 * probe4.stats.edge_fraction,
        probe4.stats.shading_fraction,
        probe4.stats.light_pairs_tested
    );

    let mut g = c.benchmark_group("resolve");
    g.sample_size(10);
    g.bench_function("tiled/1x/1280x720", |b| {
        b.iter(|| resolve(black_box(&gb1), black_box(&lights), &mask1, &tiled).unwrap())
    });
    g.bench_function("tiled/4x-adaptive/1280x720", |b| {
        b.iter(|| resolve(black_box(&gb4), black_box(&lights), &mask4, &tiled).unwrap())
    });
    g.bench_function("tiled/4x-adaptive/1280x720/split", |b| {
        b.iter(|| resolve(black_box(&split4), black_box(&lights), &mask4, &tiled).unwrap())
    });
    // The MSAA schedules on the same 4× adaptive frame (same image; the baseline is `packed`).
    for msaa in gbuf::resolve::MsaaSchedule::ALL {
        let cfg = ResolveConfig { msaa, ..tiled };
        let r = resolve(&gb4, &lights, &mask4, &cfg).unwrap();
        eprintln!(
            "msaa schedule {msaa}: {} evaluations in {} lane steps ({:.1}% utilisation), {} pairs",
            r.stats.shading_evaluations,
            r.stats.lane_steps,
            100.0 * r.stats.shading_evaluations as f64 / r.stats.lane_steps.max(1) as f64,
            r.stats.light_pairs_tested
        );
        g.bench_function(format!("msaa/{msaa}/4x-adaptive/1280x720"), |b| {
            b.iter(|| resolve(black_box(&gb4), black_box(&lights), &mask4, &cfg).unwrap())
        });
    }
    g.bench_function("tiled/4x-ssaa/1280x720", |b| {
        b.iter(|| resolve(black_box(&gb4), black_box(&lights), &ssaa4, &tiled).unwrap())
    });
    g.bench_function("none/1x/1280x720", |b| {
        b.iter(|| resolve(black_box(&gb1), black_box(&lights), &mask1, &none).unwrap())
    });
    // The same frame on every instruction set this CPU has, each BRDF: the ratios between paths measured in one run
    // (issue 14: AVX2 + FMA within 2.2× of AVX-512; the portable path is what non-x86 CPUs run).
    for isa in gbuf::base::isa::Isa::available() {
        for brdf in [gbuf::resolve::Brdf::Lambert, gbuf::resolve::Brdf::BlinnPhong, gbuf::resolve::Brdf::Ggx] {
            let cfg = ResolveConfig { brdf, ..tiled };
            g.bench_function(format!("isa/{}/{brdf}/1x/1280x720", isa.name()), |b| {
                b.iter(|| gbuf::resolve::resolve_isa(isa, black_box(&gb1), black_box(&lights), &mask1, &cfg).unwrap())
            });
        }
    }
    // Issue 34's data flow: a layout's packed targets lit directly (each tile row decoded inside the resolve) against
    // today's unpack-then-resolve and the resolve of the unpacked copy alone (the decode not counted): the same image
    // bit for bit (tests/resolve_packed.rs).
    for name in ["lauritzen-15", "destiny-96"] {
        let layout = gbuf::layout::Layout::by_name_or_path(name).expect("built-in layout");
        let packed = layout.pack(&gb4).expect("pack");
        let frame = layout.frame(&packed, &gb4).expect("frame");
        let unpacked = layout.unpack(&packed, &gb4).expect("unpack");
        g.bench_function(format!("layout/{name}/packed/4x-adaptive/1280x720"), |b| {
            b.iter(|| resolve(black_box(&frame), black_box(&lights), &mask4, &tiled).unwrap())
        });
        g.bench_function(format!("layout/{name}/unpack-then-resolve/4x-adaptive/1280x720"), |b| {
            b.iter(|| {
                let gb = layout.unpack(black_box(&packed), &gb4).unwrap();
                resolve(&gb, black_box(&lights), &mask4, &tiled).unwrap()
            })
        });
        g.bench_function(format!("layout/{name}/unpacked-copy/4x-adaptive/1280x720"), |b| {
            b.iter(|| resolve(black_box(&unpacked), black_box(&lights), &mask4, &tiled).unwrap())
        });
    }
    // An ISPC `.bin` (the room at 1280×720 with the bench's lights, written once to a temporary file): loaded whole
    // into planes then lit, against lit from its own arrays (`io::open_packed`: a coverage pass, then each tile
    // row converted inside the resolve, which counts the load's checks on it). Both from the file, the load's checks included; the same
    // image bit for bit (tests/resolve_bin.rs).
    let dir = tempfile::tempdir().expect("temporary directory");
    let bin = dir.path().join("room720.bin");
    gbuf::io::ispc::write(&bin, &gb1, &lights).expect("write .bin");
    let opts = gbuf::io::LoadOptions::default();
    g.bench_function("bin/loaded-then-resolve/1x/1280x720", |b| {
        b.iter(|| {
            let loaded = gbuf::io::load(black_box(&bin), &opts).unwrap();
            resolve(&loaded.gbuffer, black_box(&lights), &mask1, &tiled).unwrap()
        })
    });
    g.bench_function("bin/arrays/1x/1280x720", |b| {
        b.iter(|| {
            let mut dump = gbuf::io::open_packed(black_box(&bin), &opts).unwrap().expect("a .bin");
            let lit = {
                let frame = gbuf::layout::PackedFrame::of_source(&dump.loaded.gbuffer, &dump.arrays).unwrap();
                resolve(&frame, black_box(&lights), &mask1, &tiled).unwrap()
            };
            dump.check().unwrap();
            lit
        })
    });
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        g.bench_function(format!("tiled/1x/1280x720/threads-{threads}"), |b| {
            b.iter(|| pool.install(|| resolve(black_box(&gb1), black_box(&lights), &mask1, &tiled).unwrap()))
        });
    }
    g.finish();
    vrs_benches(c, &gb4, &lights, &mask4);
}

/// Shading less than once per pixel on the 4× bench frame: the SRI generators' own time (pixels per second; gbuf's
/// with and without its preview of the lights), and the
/// resolve shaded by gbuf's SRI at tile 16 against the full-rate resolve with the same mask, the evaluations of
/// each printed beside them (`resolve/vrs/…`).
fn vrs_benches(c: &mut Criterion, gb4: &gbuf::GBuffer, lights: &[gbuf::Light], mask4: &gbuf::base::mask::EdgeMask) {
    use gbuf::detect::rate::{evaluations, ffx_sri, gbuffer_sri, CoarseMode, Rate, Sri};
    use gbuf::resolve::{resolve_coarse, Coarse};
    let tiled = ResolveConfig::default();
    let sri = gbuffer_sri(gb4, None, mask4, 16, false, &Default::default()).expect("sri");
    let full_image = resolve(gb4, lights, mask4, &tiled).unwrap().image;
    let full = evaluations(gb4, mask4, &Sri::uniform(W, H, 16, Rate::R1x1));
    let coarse = evaluations(gb4, mask4, &sri);
    eprintln!(
        "vrs bench: gbuf's SRI at tile 16 leaves {coarse} of {full} evaluations ({:.1}% saved)",
        100.0 * (1.0 - coarse as f64 / full as f64)
    );
    let mut g = c.benchmark_group("resolve/vrs");
    g.sample_size(10);
    g.throughput(criterion::Throughput::Elements(u64::from(W * H)));
    g.bench_function("sri/gbuffer-16/4x/1280x720", |b| {
        b.iter(|| black_box(gbuffer_sri(gb4, None, mask4, 16, false, &Default::default()).unwrap()))
    });
    // With the lights: the rule's preview term lights every covered pixel once (its lights culled per tile).
    let preview = gbuf::resolve::LightPreview::new(gb4, lights, tiled.falloff, tiled.brdf, Default::default()).unwrap();
    g.bench_function("sri/gbuffer-preview-16/4x/1280x720", |b| {
        b.iter(|| black_box(gbuffer_sri(gb4, Some(&preview), mask4, 16, false, &Default::default()).unwrap()))
    });
    // With the previous frame as the preview (the full-rate image, as `ffx` reads it): its luminance as shown, then
    // the rule.
    g.bench_function("sri/gbuffer-prev-16/4x/1280x720", |b| {
        b.iter(|| {
            let shown = gbuf::resolve::ImagePreview::new(&full_image, Default::default());
            black_box(gbuffer_sri(gb4, Some(&shown), mask4, 16, false, &Default::default()).unwrap())
        })
    });
    g.bench_function("sri/ffx-16/1280x720", |b| {
        b.iter(|| black_box(ffx_sri(&full_image, 16, 0.015, 64, false).unwrap()))
    });
    // AMD's build of the pass with the additional rates (to 4 × 4).
    g.bench_function("sri/ffx-extra-16/1280x720", |b| {
        b.iter(|| black_box(ffx_sri(&full_image, 16, 0.015, 64, true).unwrap()))
    });
    g.bench_function("full-rate/4x-adaptive/1280x720", |b| {
        b.iter(|| black_box(resolve(gb4, lights, mask4, &tiled).unwrap()))
    });
    let by = Coarse { sri: &sri, mode: CoarseMode::Broadcast };
    g.bench_function("gbuffer-16/4x-adaptive/1280x720", |b| {
        b.iter(|| black_box(resolve_coarse(gb4, lights, mask4, by, &tiled).unwrap()))
    });
    g.finish();
}

criterion_group!(resolve_benches, benches);
criterion_main!(resolve_benches);
