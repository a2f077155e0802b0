//! `gbuf bench [--mib N] [--width W --height H --lights N] [--json]`: this machine's own limits (read and copy
//! bandwidth on one and on every thread, each instruction-set path's multiply-add peak) and one frame of the resolve set against
//! them: the room rendered at W×H, 1 sample, N point lights, written as an ISPC `.bin` and lit from it on one
//! thread as `gbuf resolve` lights it (`analysis::job::resolve_frame`), then its 8-bit PNG, the f64 reference and
//! FLIP against it, as `gbuf resolve --png` and `gbuf report` do: each stage's time with its rate and, where a limit
//! applies, the fraction of it reached (bytes read against the read bandwidth).

use crate::cli::common::print_json;
use anyhow::Context;
use gbuf::analysis::job::{resolve_frame, ResolveJob};
use gbuf::measure::machine::{fma_peaks, memory_bandwidth, Bandwidth, Peak};
use serde::Serialize;
use std::io::Write;

/// Flags of `gbuf bench`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// MiB of memory the bandwidth probes read (far beyond the caches); the copy probe writes a second buffer as
    /// large.
    #[arg(long, value_name = "N", default_value_t = 512, value_parser = clap::value_parser!(u64).range(1..=65536))]
    pub mib: u64,
    /// Width of the frame lit (the ISPC example's 1280×720 by default).
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(8..=8192))]
    pub width: u32,
    /// Height of the frame lit.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(8..=8192))]
    pub height: u32,
    /// Point lights scattered over the frame (the ISPC example's 1024 by default).
    #[arg(long, value_name = "N", default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub lights: u32,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One stage of the frame: its time and the fraction of the machine's limit it reaches.
#[derive(Serialize)]
struct Stage {
    stage: &'static str,
    ms: f64,
    /// What the rate is counted in.
    rate: &'static str,
    /// The stage's rate (bytes/s for reading the file and the image the output encodes, light-sample pairs/s for
    /// the light loop's stages, pixel passes/s for FLIP: one pass per exposure and one for LDR, per pixel).
    per_second: Option<f64>,
    /// A stage that streams bytes: its rate against one thread's read bandwidth.
    fraction_of_limit: Option<f64>,
}

/// What `gbuf bench --json` prints.
#[derive(Serialize)]
struct Bench {
    bandwidth: Bandwidth,
    fma_peaks: Vec<Peak>,
    /// The light loop's instruction set.
    isa: &'static str,
    frame: String,
    file_bytes: u64,
    light_pairs: u64,
    stages: Vec<Stage>,
    /// HDR-FLIP's exposures for this frame (FLIP's passes are these plus the LDR one).
    flip_exposures: usize,
    /// The multiply-adds a light-sample pair may take at the light loop's measured rate if the loop ran at the FMA
    /// peak of its instruction set, per lane: how far the shading is from the arithmetic limit.
    fma_per_pair_at_peak: Option<f64>,
}

/// Runs `gbuf bench`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let pb = crate::cli::spinner("measuring read bandwidth".to_string());
    let bandwidth = memory_bandwidth(args.mib as usize);
    pb.set_message("measuring the multiply-add peak of each instruction set");
    let fma_peaks = fma_peaks();
    pb.set_message("rendering the frame");
    let gb = gbuf::scene::render(gbuf::scene::SceneName::Room, args.width, args.height, 1)?;
    let lights = gbuf::scene::scatter_lights(&gb, args.lights as usize, 1);
    let dir = tempfile::tempdir().context("a temporary folder for the frame")?;
    let path = dir.path().join("frame.bin");
    gbuf::io::ispc::write(&path, &gb, &lights)?;
    let file_bytes = std::fs::metadata(&path).with_context(|| path.display().to_string())?.len();
    pb.set_message("lighting the frame on one thread");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    // Opening (the coverage pass) runs on the same single thread as the lighting.
    let (opened, t_open) =
        pool.install(|| gbuf::base::timing::timed(|| gbuf::io::open_packed(&path, &gbuf::io::LoadOptions::default())));
    let mut dump = opened?.context("the written .bin opens as its arrays")?;
    let lighting = gbuf::resolve::Lighting::choose(None, None, &dump.loaded.gbuffer.attributes());
    let job = ResolveJob {
        layout: None,
        detector: gbuf::detect::Detector::Lauritzen,
        thresholds: Default::default(),
        config: lighting.apply(Default::default()),
        reference: false,
        flip: None,
    };
    let viewing = gbuf::measure::image::Viewing::default();
    let frame_gb = &dump.loaded.gbuffer;
    let (done, ()) = pool.install(|| {
        resolve_frame("frame.bin", frame_gb, Some(&dump.arrays), &lights_of(&dump), &job, &|_| {}, |_| ())
    })?;
    // The load's checks, counted on the bands the resolve decoded.
    let (checked, t_check) = pool.install(|| gbuf::base::timing::timed(|| dump.check().map(|_| ())));
    checked?;
    // What `gbuf resolve --ldr gamma2.2 --png` writes, the f64 reference and FLIP against it, on the same thread.
    let image = &done.resolved.image;
    pb.set_message("encoding the 8-bit PNG, lighting the f64 reference, FLIP");
    let (png, t_output) = pool.install(|| gbuf::base::timing::timed(|| image.ldr_gamma22_png()));
    png?;
    // The reference reads every plane at once: the file loaded whole (not timed), as `gbuf resolve` does for it.
    let whole = gbuf::io::ispc::read(&path, &gbuf::io::LoadOptions::default())?;
    let (reference, t_reference) = pool.install(|| {
        gbuf::base::timing::timed(|| gbuf::resolve::reference(&whole.gbuffer, &lights_of(&dump), &job.config))
    });
    let reference = reference?;
    let (flip, t_flip) =
        pool.install(|| gbuf::base::timing::timed(|| gbuf::measure::image::flip_pair(&reference, image, &viewing)));
    flip.context("FLIP of the lit frame against its reference")?;
    let flip_exposures = gbuf::measure::flip::hdr_exposure_count(bytemuck::cast_slice(&reference.rgb));
    pb.finish_and_clear();
    let isa = gbuf::resolve::instruction_set();
    let peak = fma_peaks.iter().find(|p| p.isa == isa).or(fma_peaks.last());
    let s = &done.stages;
    let pairs = done.resolved.stats.light_pairs_tested;
    let decode_ms = t_open + s.decode + t_check;
    let loop_ms = s.gather + s.cull + s.shade;
    let per_s = |n: f64, ms: f64| (ms > 0.0).then(|| n / (ms / 1e3));
    let file_rate = per_s(file_bytes as f64, decode_ms);
    let pair_rate = per_s(pairs as f64, loop_ms);
    let pixels = f64::from(args.width) * f64::from(args.height);
    // The output reads the lit image's floats (12 bytes a pixel).
    let output_rate = per_s(12.0 * pixels, t_output);
    let pair_stage = |stage: &'static str, ms: f64| Stage {
        stage,
        ms,
        rate: "light-sample pairs/s",
        per_second: per_s(pairs as f64, ms),
        fraction_of_limit: None,
    };
    // Multiply-adds a second across the lanes, per pair a second: what the peak leaves each pair.
    let fma_per_pair_at_peak = peak.zip(pair_rate).map(|(p, r)| p.flops / 2.0 / r);
    let stages = vec![
        Stage {
            stage: "read and decode the file (the load's checks included)",
            ms: decode_ms,
            rate: "file bytes/s",
            per_second: file_rate,
            fraction_of_limit: file_rate.map(|r| r / bandwidth.one_thread),
        },
        Stage { stage: "edges", ms: s.detect, rate: "", per_second: None, fraction_of_limit: None },
        pair_stage("work list", s.gather),
        pair_stage("culling", s.cull),
        pair_stage("shading", s.shade),
        pair_stage("light loop (work list, culling, shading)", loop_ms),
        Stage {
            stage: "8-bit gamma-2.2 image and PNG",
            ms: t_output,
            rate: "image bytes/s",
            per_second: output_rate,
            fraction_of_limit: output_rate.map(|r| r / bandwidth.one_thread),
        },
        Stage {
            stage: "f64 reference (every sample)",
            ms: t_reference,
            rate: "",
            per_second: None,
            fraction_of_limit: None,
        },
        Stage {
            stage: "FLIP against the reference (HDR and LDR)",
            ms: t_flip,
            rate: "pixel passes/s",
            per_second: per_s(pixels * (flip_exposures + 1) as f64, t_flip),
            fraction_of_limit: None,
        },
    ];
    let report = Bench {
        bandwidth,
        fma_peaks,
        isa,
        frame: format!("room {}×{}, 1 sample, {} lights, ISPC .bin", args.width, args.height, args.lights),
        file_bytes,
        light_pairs: pairs,
        stages,
        flip_exposures,
        fma_per_pair_at_peak,
    };
    if args.json {
        return print_json(&report);
    }
    let mut out = std::io::stdout().lock();
    let b = &report.bandwidth;
    writeln!(
        out,
        "read bandwidth   {:.1} GB/s one thread, {:.1} GB/s on {} threads ({} MiB)",
        b.one_thread / 1e9,
        b.all_threads / 1e9,
        b.threads,
        b.bytes >> 20
    )?;
    writeln!(
        out,
        "copy bandwidth   {:.1} GB/s one thread, {:.1} GB/s on {} threads (STREAM Copy's counting: 16 B per element)",
        b.copy_one_thread / 1e9,
        b.copy_all_threads / 1e9,
        b.threads
    )?;
    for p in &report.fma_peaks {
        writeln!(out, "FMA peak         {:<8} {:.1} GFLOP/s one thread ({} lanes)", p.isa, p.flops / 1e9, p.lanes)?;
    }
    writeln!(
        out,
        "frame            {} ({} bytes, {} light-sample pairs), light loop on {isa}",
        report.frame, file_bytes, pairs
    )?;
    for st in &report.stages {
        let rate = st.per_second.map_or(String::new(), |r| format!(", {:.3e} {}", r, st.rate));
        let frac = st.fraction_of_limit.map_or(String::new(), |f| format!(", {:.1}% of the limit", 100.0 * f));
        writeln!(out, "  {:<44} {:>8.2} ms{rate}{frac}", st.stage, st.ms)?;
    }
    if let Some(n) = report.fma_per_pair_at_peak {
        writeln!(
            out,
            "at this rate the FMA peak of {isa} would allow {n:.0} multiply-adds per light-sample pair; the file is set \
             against one thread's read bandwidth"
        )?;
    }
    Ok(())
}

/// The lights of the opened `.bin` (its own, or its sidecar's).
fn lights_of(dump: &gbuf::io::PackedDump) -> Vec<gbuf::light::Light> {
    dump.loaded.lights.clone().unwrap_or_default()
}
