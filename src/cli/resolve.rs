//! `gbuf resolve FILE [--scene SIDECAR | --lights N --seed S] [--detector D] [--culling …] [--brdf …]
//! [--falloff …] [--schedule …] [-o OUT.exr] [--png OUT.png] [--ldr gamma2.2] [--heatmap OUT.png] [--json]`:
//! light the G-buffer on the CPU, measure it against the f64 reference (RMSE, PSNR and FLIP; with `--layout` the
//! layout's and the detector's errors apart), write the images.

use crate::cli::common::{print_json, InputArgs, ThresholdArgs};
use anyhow::Context;
use gbuf::analysis::job::{resolve_frame, ResolveJob, ResolveOutcome};
use gbuf::base::picture::heatmap_png;
use gbuf::base::timing::timed;
use gbuf::detect::Detector;
use gbuf::image::{LdrEncoding, ToneCurve, ToneMap};
use gbuf::light::Light;
use gbuf::measure::image::{ErrorSet, ImageError, Viewing};
use gbuf::resolve::{self, Culling, Lighting, ResolveConfig, ResolveStats, Resolved, Schedule};
use gbuf::GBuffer;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// Flags of `gbuf resolve`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump to light.
    #[command(flatten)]
    pub input: InputArgs,
    /// Scatter N point lights over the visible surfaces (replacing the dump's or sidecar's lights, if any).
    #[arg(long, value_name = "N")]
    pub lights: Option<usize>,
    /// Pack and unpack with this layout (built-in name or layout file) before lighting; the reference uses the
    /// unpacked-free original.
    #[arg(long, value_name = "L")]
    pub layout: Option<String>,
    /// Seed for `--lights`.
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Edge detector choosing the pixels shaded per sample.
    #[arg(long, value_name = "D", default_value = "lauritzen")]
    pub detector: Detector,
    /// Detector thresholds.
    #[command(flatten)]
    pub thresholds: ThresholdArgs,
    /// Light culling.
    #[arg(long, value_name = "C", default_value = "tiled")]
    pub culling: Culling,
    /// Lighting model.
    #[command(flatten)]
    pub lighting: crate::cli::common::LightingArgs,
    /// Schedule.
    #[arg(long, value_name = "S", default_value = "deferred")]
    pub schedule: Schedule,
    /// Tile edge in pixels.
    #[arg(long, value_name = "PX", default_value_t = resolve::DEFAULT_TILE_SIZE)]
    pub tile_size: u32,
    /// Depth slices per tile (clustered culling).
    #[arg(long, value_name = "N", default_value_t = resolve::DEFAULT_DEPTH_SLICES)]
    pub depth_slices: u32,
    /// How MSAA work is laid out over SIMD lanes: packed (Lauritzen 2010's per-tile lists), per-pixel (a lane per
    /// pixel, looping over its samples), two-pass (every pixel once, then the edge samples, culling twice). The
    /// image is the same; the time and the lane utilisation differ.
    #[arg(long, value_name = "S", default_value = "packed")]
    pub msaa_schedule: gbuf::resolve::MsaaSchedule,
    /// Write the lit image as a float EXR (channels R, G, B).
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    pub output: Option<PathBuf>,
    /// Write an 8-bit sRGB PNG (tone map from --tonemap / --exposure, or the demo's encoding with --ldr).
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Encode the PNG as the ISPC demo does instead: clamp to [0,1], ^(1/2.2), ×255, truncate.
    #[arg(long, value_name = "ENC")]
    pub ldr: Option<LdrEncoding>,
    /// Tone map of the PNG (reinhard: x/(1+x); clamp), then sRGB encoding.
    #[arg(long, value_name = "TM", default_value = "reinhard")]
    pub tonemap: ToneCurve,
    /// Exposure multiplied in before the tone map.
    #[arg(long, value_name = "E", default_value_t = 1.0)]
    pub exposure: f32,
    /// Write a heatmap PNG of light evaluations per pixel (legend strip at the bottom: 0 left, max right).
    #[arg(long, value_name = "OUT.png")]
    pub heatmap: Option<PathBuf>,
    /// Skip the f64 reference (no error numbers; much faster with many lights).
    #[arg(long)]
    pub no_reference: bool,
    /// Pixels per degree of the viewer FLIP models (LDR-FLIP sees the PNG's tone map and exposure).
    #[arg(long, value_name = "PPD", default_value_t = gbuf::measure::flip::default_ppd())]
    pub ppd: f32,
    /// Skip FLIP (the perceptual errors beside RMSE/PSNR).
    #[arg(long)]
    pub no_flip: bool,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Milliseconds per stage as reported.
#[derive(Serialize)]
struct Ms {
    decode: f64,
    detect: f64,
    gather: f64,
    cull: f64,
    shade: f64,
    total: f64,
    reference: f64,
    /// The full deferred resolve run to measure the light pre-pass against (0 for the deferred schedule).
    deferred_for_prepass: f64,
    /// Writing the files asked for (`-o` EXR, `--png` with its 8-bit encode, `--heatmap`); 0 when none.
    output: f64,
}

/// What `--json` prints.
#[derive(Serialize)]
struct Report {
    file: String,
    width: u32,
    height: u32,
    samples: u32,
    lights_source: &'static str,
    layout: Option<String>,
    detector: &'static str,
    /// The instruction set the light loop ran with (`GBUF_ISA` caps it).
    isa: &'static str,
    /// The BRDF and falloff, and why (`config` holds them too).
    lighting: Lighting,
    config: ResolveConfig,
    shading_fraction: f64,
    edge_fraction: f64,
    light_pairs_tested: u64,
    light_pairs_lit: u64,
    shading_evaluations: u64,
    lights_per_sample: f64,
    rmse: Option<f64>,
    psnr_db: Option<f64>,
    max_abs: Option<f64>,
    rel_mse: Option<f64>,
    error: Option<ImageError>,
    psnr_peak: &'static str,
    /// Against the reference in every measure, FLIP included (unless `--no-flip`).
    total_error: Option<ErrorSet>,
    /// With `--layout`: the unpacked G-buffer's image against the exact G-buffer lit with the same detector.
    layout_error: Option<ErrorSet>,
    /// With `--layout`: the exact G-buffer lit with the detector against the reference.
    aa_error: Option<ErrorSet>,
    /// How the images were shown for FLIP.
    viewing: Option<Viewing>,
    /// With `--schedule light-prepass`: the pre-pass image against full deferred shading of the same G-buffer,
    /// mask and lights (PSNR peak: the deferred image's largest channel value).
    prepass_vs_deferred: Option<ImageError>,
    stats: ResolveStats,
    ms: Ms,
    heatmap_max: Option<u32>,
}

/// Runs `gbuf resolve`: flags in, [`gbuf::analysis::job::resolve_frame`] lights and measures, the pictures are
/// encoded beside its measurements and written together.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = ResolveConfig {
        culling: args.culling,
        schedule: args.schedule,
        tile_size: args.tile_size,
        depth_slices: args.depth_slices,
        msaa: args.msaa_schedule,
        ..ResolveConfig::default()
    };
    cfg.validate().context("resolve configuration")?;
    if args.ldr.is_some() && args.png.is_none() {
        crate::usage!("--ldr gamma2.2 selects the encoding of --png; give --png OUT.png too");
    }
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        anyhow::bail!("--exposure must be a positive number, got {}", args.exposure);
    }
    anyhow::ensure!(args.ppd.is_finite() && args.ppd > 0.0, "--ppd must be a positive number, got {}", args.ppd);
    let outputs = [&args.output, &args.png, &args.heatmap];
    crate::cli::common::check_output_folders(outputs.into_iter().flatten().map(PathBuf::as_path))?;
    let thresholds = args.thresholds.config()?;
    let layout = match &args.layout {
        Some(name) => Some(gbuf::layout::Layout::by_name_or_path(name).with_context(|| format!("--layout {name}"))?),
        None => None,
    };
    let file = args.input.file.display().to_string();

    let pb = crate::cli::spinner(format!("loading {file}"));
    // An ISPC `.bin` is lit from its own arrays, decoded band by band (as the example's shading loop reads it):
    // not with a layout (which packs the decoded frame), scattered lights (placed from the decoded depths) or the
    // reference (which reads every plane at once: the frame decoded whole serves it and the resolve).
    let from_arrays = args.layout.is_none() && args.lights.is_none() && args.no_reference;
    let (opened, t_open) = timed(|| -> anyhow::Result<Opened> {
        match from_arrays.then(|| args.input.open_packed()).transpose()?.flatten() {
            Some(dump) => Ok(Opened::Arrays(dump)),
            None => args.input.load().map(Opened::Planes),
        }
    });
    let mut opened = opened.with_context(|| format!("loading {file}"))?;
    let gb: &GBuffer = &opened.loaded().gbuffer;
    let lighting = args.lighting.choose(&gb.attributes());
    pb.suspend(|| crate::cli::common::say_lighting(&lighting));
    let (lights, lights_source) = pick_lights(opened.loaded().lights.clone(), args.lights, args.seed, gb, &file)?;
    let viewing = Viewing { tone_map: args.tonemap, exposure: args.exposure, pixels_per_degree: args.ppd };
    let job = ResolveJob {
        layout: layout.as_ref(),
        detector: args.detector,
        thresholds,
        config: lighting.apply(cfg),
        reference: !args.no_reference,
        flip: (!args.no_flip).then_some(viewing),
    };
    let source = match &opened {
        Opened::Arrays(d) => Some(&d.arrays as &dyn gbuf::layout::BandSource),
        Opened::Planes(_) => None,
    };
    let progress = |what: &str| pb.set_message(format!("{file}: {what}"));
    let (done, encoded) = resolve_frame(&file, gb, source, &lights, &job, &progress, |r| timed(|| encode(&args, r)))?;
    // The load's checks of a `.bin` lit from its arrays, counted on the bands the resolve decoded: before any file
    // is written, so a frame they refuse leaves nothing behind.
    let (checked, t_check) = timed(|| match &mut opened {
        Opened::Arrays(d) => pb.suspend(|| args.input.check_packed(d)),
        Opened::Planes(_) => Ok(()),
    });
    checked.with_context(|| format!("loading {file}"))?;
    let t_load = t_open + t_check;
    let (files, heatmap_max) = encoded.0?;
    // Every file is staged beside its destination and renamed into place only when all were written: a failure
    // leaves none of them half done or alone.
    let (written, t_write) = timed(|| -> anyhow::Result<()> {
        let mut staged = gbuf::base::files::Staged::default();
        for (path, bytes) in &files {
            staged.stage_bytes(path, bytes).with_context(|| format!("writing {}", path.display()))?;
        }
        staged.commit().context("renaming the outputs into place")
    });
    written?;
    let gb = &opened.loaded().gbuffer;
    pb.finish_and_clear();
    let report =
        Report::of(&args, file, gb, lights_source, lighting, job, &done, t_load, encoded.1 + t_write, heatmap_max);
    if args.json {
        print_json(&report)
    } else {
        print_human(&report)
    }
}

/// The input as loaded: decoded into planes, or an ISPC `.bin` held as its arrays and lit band by band.
// One value per run, on the stack of `run`: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum Opened {
    Planes(gbuf::io::Loaded),
    Arrays(gbuf::io::PackedDump),
}

impl Opened {
    fn loaded(&self) -> &gbuf::io::Loaded {
        match self {
            Opened::Planes(l) => l,
            Opened::Arrays(d) => &d.loaded,
        }
    }
}

/// Files encoded in memory: (destination, bytes).
type Files = Vec<(PathBuf, Vec<u8>)>;

/// The pictures asked for, encoded in memory, and the heatmap's maximum.
fn encode(args: &Args, r: &Resolved) -> anyhow::Result<(Files, Option<u32>)> {
    let mut files = Vec::new();
    let named = |out: &PathBuf| format!("encoding {}", out.display());
    if let Some(out) = &args.output {
        files.push((out.clone(), r.image.exr_bytes(out).with_context(|| named(out))?));
    }
    if let Some(out) = &args.png {
        let png = match args.ldr {
            Some(_) => r.image.ldr_gamma22_png(),
            None => r.image.png(ToneMap::new(args.tonemap, args.exposure)),
        };
        files.push((out.clone(), png.with_context(|| named(out))?));
    }
    let mut heatmap_max = None;
    if let Some(out) = &args.heatmap {
        let (png, max) = heatmap_png(r.image.width, r.image.height, &r.lights_per_pixel).with_context(|| named(out))?;
        files.push((out.clone(), png));
        heatmap_max = Some(max);
    }
    Ok((files, heatmap_max))
}

impl Report {
    /// What `--json` prints, from the job's outcome.
    #[allow(clippy::too_many_arguments)]
    fn of(
        args: &Args,
        file: String,
        gb: &GBuffer,
        lights_source: &'static str,
        lighting: Lighting,
        job: ResolveJob<'_>,
        done: &ResolveOutcome,
        t_load: f64,
        t_output: f64,
        heatmap_max: Option<u32>,
    ) -> Report {
        let s = &done.resolved.stats;
        let stage = &done.stages;
        let error = done.error;
        let writes = args.output.is_some() || args.png.is_some() || args.heatmap.is_some();
        Report {
            file,
            width: gb.width,
            height: gb.height,
            samples: gb.samples,
            lights_source,
            layout: args.layout.clone(),
            detector: args.detector.name(),
            isa: gbuf::resolve::instruction_set(),
            lighting,
            config: job.config,
            shading_fraction: s.shading_fraction,
            edge_fraction: s.edge_fraction,
            light_pairs_tested: s.light_pairs_tested,
            light_pairs_lit: s.light_pairs_lit,
            shading_evaluations: s.shading_evaluations,
            lights_per_sample: s.lights_per_sample,
            rmse: error.map(|e| e.rmse),
            psnr_db: error.map(|e| e.psnr_db),
            max_abs: error.map(|e| e.max_abs),
            rel_mse: error.map(|e| e.rel_mse),
            error,
            psnr_peak: "the reference image's largest channel value",
            total_error: done.triad.total,
            layout_error: done.triad.layout,
            aa_error: done.triad.aa,
            viewing: job.flip,
            prepass_vs_deferred: done.prepass_vs_deferred,
            stats: s.clone(),
            ms: Ms {
                decode: t_load + stage.decode,
                detect: stage.detect,
                gather: stage.gather,
                cull: stage.cull,
                shade: stage.shade,
                total: t_load + stage.total,
                reference: done.reference_ms,
                deferred_for_prepass: done.deferred_for_prepass_ms,
                output: if writes { t_output } else { 0.0 },
            },
            heatmap_max,
        }
    }
}

/// Lights by the rule of every command ([`gbuf::scene::choose_lights`]), with no fallback: an error saying how to
/// get some.
fn pick_lights(
    from_file: Option<Vec<Light>>,
    scatter: Option<usize>,
    seed: u64,
    gb: &GBuffer,
    file: &str,
) -> anyhow::Result<(Vec<Light>, &'static str)> {
    match gbuf::scene::choose_lights(gb, from_file.as_deref(), scatter, None, seed) {
        Some((l, gbuf::scene::LightsSource::Dump)) => Ok((l, "file")),
        Some((l, _)) => Ok((l, "scattered")),
        None => anyhow::bail!(
            "{file}: no lights: the dump and its sidecar define none; pass --scene SIDECAR with a \"lights\" list, \
             or --lights N [--seed S] to scatter N point lights"
        ),
    }
}

fn fmt_flip(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.4}"))
}

fn print_human(r: &Report) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {}×{} × {} samples, {} lights ({})",
        r.file, r.width, r.height, r.samples, r.stats.lights, r.lights_source
    )?;
    writeln!(
        out,
        "config: culling {}, brdf {}, falloff {}, schedule {}, tiles {}px, detector {}, isa {}",
        r.config.culling, r.config.brdf, r.config.falloff, r.config.schedule, r.config.tile_size, r.detector, r.isa
    )?;
    writeln!(
        out,
        "shading: {:.2}% of samples shaded, {:.2}% edge pixels, {} light-sample pairs tested ({:.1} per sample), {} lit",
        100.0 * r.shading_fraction,
        100.0 * r.edge_fraction,
        r.light_pairs_tested,
        r.lights_per_sample,
        r.light_pairs_lit
    )?;
    if let Some(e) = &r.error {
        writeln!(
            out,
            "error vs reference: rmse {:.3e}, psnr {:.2} dB (peak {:.3e} = reference max), max |Δ| {:.3e}, rel. mse {:.3e}",
            e.rmse, e.psnr_db, e.peak, e.max_abs, e.rel_mse
        )?;
    }
    if let (Some(t), Some(v)) = (&r.total_error, &r.viewing) {
        writeln!(
            out,
            "FLIP vs reference: LDR {} (displayed: {} tone map, exposure {}), HDR {}, at {:.2} pixels per degree",
            fmt_flip(t.flip_ldr),
            v.tone_map,
            v.exposure,
            fmt_flip(t.flip_hdr),
            v.pixels_per_degree
        )?;
    }
    for (what, e) in [
        ("layout error (vs exact G-buffer, same detector)", &r.layout_error),
        ("AA error (exact G-buffer vs reference)", &r.aa_error),
    ] {
        if let Some(e) = e {
            writeln!(
                out,
                "{what}: rmse {:.3e}, psnr {:.2} dB, FLIP LDR {} / HDR {}",
                e.rmse,
                e.psnr_db,
                fmt_flip(e.flip_ldr),
                fmt_flip(e.flip_hdr)
            )?;
        }
    }
    if let Some(e) = &r.prepass_vs_deferred {
        writeln!(
            out,
            "light pre-pass vs full deferred (same G-buffer, mask, lights): rmse {:.3e}, psnr {:.2} dB (peak {:.3e} = \
             deferred max), max |Δ| {:.3e}, rel. mse {:.3e}",
            e.rmse, e.psnr_db, e.peak, e.max_abs, e.rel_mse
        )?;
    }
    let m = &r.ms;
    writeln!(
        out,
        "time (ms, wall): decode {:.1} (read, convert, sanitise, checks), detect {:.1}, resolve {:.1} (split by \
         sampling 1 tile in 8, estimates: gather ~{:.1}, cull ~{:.1}, shade ~{:.1}), total {:.1}; reference {:.1}",
        m.decode,
        m.detect,
        (m.total - m.decode - m.detect).max(0.0),
        m.gather,
        m.cull,
        m.shade,
        m.total,
        m.reference
    )?;
    if m.deferred_for_prepass > 0.0 {
        writeln!(out, "time (ms): full deferred for the pre-pass comparison {:.1}", m.deferred_for_prepass)?;
    }
    if m.output > 0.0 {
        writeln!(out, "time (ms): writing the output files {:.1} (8-bit encode and PNG included)", m.output)?;
    }
    let s = &r.stats.sanitized;
    if s.total() > 0 {
        writeln!(out, "sanitised: {s:?}")?;
    }
    if let Some(max) = r.heatmap_max {
        writeln!(out, "heatmap: dark violet = 0, yellow = {max} light evaluations per pixel (viridis-like map)")?;
    }
    Ok(())
}
