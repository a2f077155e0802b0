//! `gbuf edges FILE [--detector D|all] [threshold flags] [--shading-tolerance T] [--mask OUT.png [--mask-truth
//! id|shading]] [--json]`: run edge detectors and score them against the ID ground truth and the shading truth.

use crate::cli::common::{print_json, InputArgs, ThresholdArgs};
use anyhow::Context;
use gbuf::base::names::{NameParser, Named};
use gbuf::detect::{self, Detector, DetectorConfig};
use gbuf::measure::edges::{true_fraction, truth_agreement, MaskScores, ShadingTolerance, TruthAgreement, Truths};
use gbuf::GBuffer;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// `--detector`: one detector, or `all` of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DetectorChoice {
    /// One detector.
    One(Detector),
    /// Every detector, one row each.
    All,
}

impl DetectorChoice {
    /// The detectors chosen.
    pub fn detectors(self) -> Vec<Detector> {
        match self {
            DetectorChoice::One(d) => vec![d],
            DetectorChoice::All => Detector::ALL.to_vec(),
        }
    }
}

/// Every choice: each detector, then `all`.
const CHOICES: [DetectorChoice; Detector::ALL.len() + 1] = {
    let mut c = [DetectorChoice::All; Detector::ALL.len() + 1];
    let mut i = 0;
    while i < Detector::ALL.len() {
        c[i] = DetectorChoice::One(Detector::ALL[i]);
        i += 1;
    }
    c
};

impl Named for DetectorChoice {
    const KIND: &'static str = "detector";
    fn all() -> &'static [Self] {
        &CHOICES
    }
    fn name(self) -> &'static str {
        match self {
            DetectorChoice::One(d) => d.name(),
            DetectorChoice::All => "all",
        }
    }
}

impl clap::builder::ValueParserFactory for DetectorChoice {
    type Parser = NameParser<DetectorChoice>;
    fn value_parser() -> Self::Parser {
        NameParser::default()
    }
}

gbuf::named_enum! {
    /// `--mask-truth`: the truth the mask picture's misses and false alarms are drawn against.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum MaskTruth: "mask truth" {
        /// Object IDs.
        Id => "id",
        /// The shading truth (needs lights).
        Shading => "shading",
    }
}

/// Flags of `gbuf edges`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump to read.
    #[command(flatten)]
    pub input: InputArgs,
    /// Edge detector, or `all` for one row each.
    #[arg(long, value_name = "D", default_value = "lauritzen")]
    pub detector: DetectorChoice,
    /// Detector thresholds.
    #[command(flatten)]
    pub thresholds: ThresholdArgs,
    /// Shading truth: a pixel needs per-sample shading when some sample's reference shading differs from sample
    /// 0's by more than this, beyond the image's smooth gradient: `CODES` or `display:CODES` = 8-bit code steps
    /// after the PNG's Reinhard tone map and sRGB (default 1); `linear:X` = linear radiance. Needs lights (sidecar
    /// or dump). See docs/RESOLVE.md.
    #[arg(long, value_name = "T", default_value = "display:1", value_parser = ShadingTolerance::parse)]
    pub shading_tolerance: ShadingTolerance,
    /// Exposure of the display tone map used by the shading truth (as `gbuf resolve --exposure`).
    #[arg(long, value_name = "E", default_value_t = 1.0)]
    pub exposure: f32,
    /// Write a PNG of the scene with per-sample pixels in red, misses in yellow, false alarms in cyan.
    #[arg(long, value_name = "OUT.png")]
    pub mask: Option<PathBuf>,
    /// Which truth colours the misses and false alarms of --mask: id (object IDs) or shading (needs lights).
    /// Default: id when the dump has object IDs, else shading when it has lights.
    #[arg(long, value_name = "TRUTH")]
    pub mask_truth: Option<MaskTruth>,
    /// Lighting model of the shading truth's reference.
    #[command(flatten)]
    pub lighting: crate::cli::common::LightingArgs,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One detector's row.
#[derive(Debug, serde::Serialize)]
struct Row {
    detector: Detector,
    /// `None` when the detector could not run on this G-buffer (the reason is in `skipped`).
    #[serde(skip_serializing_if = "Option::is_none")]
    skipped: Option<String>,
    /// Cost and scores against each truth the dump gives (all zero / absent for a skipped detector).
    #[serde(flatten)]
    scores: MaskScores,
    ms: f64,
}

/// The whole output.
#[derive(Debug, serde::Serialize)]
struct Output {
    file: PathBuf,
    width: u32,
    height: u32,
    samples: u32,
    /// "object" when object IDs give a ground truth, else null.
    truth: Option<&'static str>,
    true_edge_fraction: Option<f64>,
    /// Fraction of pixels whose samples span several primitives (or mix background in): the primitive-ID truth.
    primitive_true_edge_fraction: Option<f64>,
    /// The shading truth, when the dump comes with lights.
    shading_truth: Option<ShadingTruth>,
    /// The truth the --mask picture was coloured with ("id", "shading"), when a picture was drawn with one.
    #[serde(skip_serializing_if = "Option::is_none")]
    mask_truth: Option<&'static str>,
    thresholds: DetectorConfig,
    results: Vec<Row>,
    /// How many surfaces each pixel holds (by IDs and by geometry): the pixels an edge detector should find.
    surfaces_per_pixel: gbuf::analysis::surfaces::SurfacesPerPixel,
}

/// How the shading truth was made.
#[derive(Debug, serde::Serialize)]
struct ShadingTruth {
    tolerance: ShadingTolerance,
    /// The tolerance in words.
    rule: String,
    lights: usize,
    brdf: &'static str,
    falloff: &'static str,
    true_edge_fraction: f64,
    /// How the shading truth (`a`) agrees with the ID truth (`b`), when there are object IDs.
    agreement_with_id_truth: Option<TruthAgreement>,
}

/// Runs `gbuf edges`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = args.thresholds.config()?;
    let detectors = args.detector.detectors();
    if args.mask.is_some() && detectors.len() > 1 {
        crate::usage!("--mask draws one detector's mask; pick one with --detector instead of `all`");
    }
    if args.mask_truth.is_some() && args.mask.is_none() {
        crate::usage!("--mask-truth chooses the colours of the --mask picture; give --mask OUT.png too");
    }
    let tolerance = match args.shading_tolerance {
        ShadingTolerance::Display { codes, .. } => ShadingTolerance::Display { codes, exposure: args.exposure },
        t => t,
    };
    tolerance.validate().context("--shading-tolerance / --exposure")?;
    let loaded = args.input.load()?;
    let gb = &loaded.gbuffer;
    let lights = loaded.lights.as_deref();
    // The shading truth needs the reference radiance, so lights: from the sidecar or the dump.
    let lighting = args.lighting.choose(&gb.attributes());
    if lights.is_some() {
        crate::cli::common::say_lighting(&lighting);
    }
    let resolve_cfg = lighting.apply(gbuf::resolve::ResolveConfig::default());
    let truths = Truths::of(gb, lights, &resolve_cfg, tolerance)
        .with_context(|| format!("{}: reference shading", args.input.file.display()))?;
    let mut rows = Vec::new();
    let mut last_mask = None;
    for &d in &detectors {
        let t0 = Instant::now();
        let result = detect::detect(gb, d, &cfg);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        match result {
            Ok(mask) => {
                rows.push(Row { detector: d, skipped: None, scores: truths.score(&mask), ms });
                last_mask = Some(mask);
            }
            // A single detector that cannot run is an error; in `all` mode it is a skipped row.
            Err(e) if detectors.len() == 1 => {
                return Err(e).with_context(|| format!("{}: detector {d}", args.input.file.display()))
            }
            Err(e) => rows.push(Row { detector: d, skipped: Some(e.to_string()), scores: MaskScores::default(), ms }),
        }
    }
    let mut mask_truth = None;
    if let (Some(path), Some(mask)) = (&args.mask, &last_mask) {
        let (ids, shading_flags) = (truths.ids.as_deref(), truths.shading.as_deref());
        let picked = match args.mask_truth {
            Some(MaskTruth::Id) => Some((
                MaskTruth::Id,
                ids.with_context(|| format!("--mask-truth id: {} has no object IDs", args.input.file.display()))?,
            )),
            Some(MaskTruth::Shading) => Some((
                MaskTruth::Shading,
                shading_flags.with_context(|| {
                    format!(
                        "--mask-truth shading: {} comes with no lights (sidecar or dump)",
                        args.input.file.display()
                    )
                })?,
            )),
            None => ids.map(|t| (MaskTruth::Id, t)).or(shading_flags.map(|t| (MaskTruth::Shading, t))),
        };
        mask_truth = picked.map(|(which, _)| which.name());
        detect::picture::write_png(path, gb, mask, picked.map(|(_, t)| t))
            .with_context(|| format!("writing the mask picture {}", path.display()))?;
    }
    let out = Output {
        file: args.input.file.clone(),
        width: gb.width,
        height: gb.height,
        samples: gb.samples,
        truth: truths.ids.as_ref().map(|_| "object"),
        true_edge_fraction: truths.ids.as_deref().map(true_fraction),
        primitive_true_edge_fraction: truths.primitives.as_deref().map(true_fraction),
        shading_truth: truths.shading.as_deref().map(|t| ShadingTruth {
            tolerance,
            rule: tolerance.to_string(),
            lights: lights.map_or(0, <[_]>::len),
            brdf: resolve_cfg.brdf.name(),
            falloff: resolve_cfg.falloff.name(),
            true_edge_fraction: true_fraction(t),
            agreement_with_id_truth: truths.ids.as_deref().map(|ids| truth_agreement(t, ids)),
        }),
        mask_truth,
        thresholds: cfg,
        results: rows,
        surfaces_per_pixel: gbuf::analysis::surfaces::surfaces_per_pixel(gb),
    };
    if args.json {
        print_json(&out)
    } else {
        print_table(&out, gb)
    }
}

fn print_table(out: &Output, gb: &GBuffer) -> anyhow::Result<()> {
    let mut w = std::io::stdout().lock();
    let truth = match out.true_edge_fraction {
        Some(f) => format!("ID truth (object IDs): {:.2} % true edge pixels", 100.0 * f),
        None => "no object IDs: no ID truth".to_string(),
    };
    writeln!(w, "{}: {}×{}, {} samples/pixel; {truth}", out.file.display(), gb.width, gb.height, gb.samples)?;
    if gb.samples > 1 {
        write!(w, "{}", out.surfaces_per_pixel.to_text())?;
    }
    if let Some(f) = out.primitive_true_edge_fraction {
        writeln!(
            w,
            "primitive-ID truth (forward MSAA's rate): {:.2} % of pixels (scores under `primitive` in --json)",
            100.0 * f
        )?;
    }
    match &out.shading_truth {
        Some(t) => {
            writeln!(
                w,
                "shading truth ({} lights, {} / {}; edge when {}): {:.2} % of pixels",
                t.lights,
                t.brdf,
                t.falloff,
                t.rule,
                100.0 * t.true_edge_fraction
            )?;
            if let Some(a) = &t.agreement_with_id_truth {
                writeln!(
                    w,
                    "shading truth vs ID truth: flags {:.1} % of the ID edges; {:.1} % of its pixels are ID edges",
                    100.0 * a.b_covered_by_a,
                    100.0 * a.a_covered_by_b
                )?;
            }
        }
        None => writeln!(w, "no lights (sidecar or dump): no shading truth")?,
    }
    if let Some(t) = out.mask_truth {
        writeln!(w, "mask picture: misses and false alarms against the {t} truth")?;
    }
    writeln!(
        w,
        "{:<13} {:>7} {:>10} {:>9} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}",
        "detector", "edge %", "shading %", "precision", "recall", "tp", "fp", "fn", "sh.prec", "sh.recall", "ms"
    )?;
    let dash = |n: usize| format!("{:>n$}", "-");
    for r in &out.results {
        if let Some(why) = &r.skipped {
            writeln!(w, "{:<13} skipped: {why}", r.detector.name())?;
            continue;
        }
        let ids = match &r.scores.ids {
            Some(s) => format!("{:>9.4} {:>7.4} {:>9} {:>9} {:>9}", s.precision, s.recall, s.tp, s.fp, s.fn_),
            None => [dash(9), dash(7), dash(9), dash(9), dash(9)].join(" "),
        };
        let shading = match &r.scores.shading {
            Some(s) => format!("{:>9.4} {:>9.4}", s.precision, s.recall),
            None => [dash(9), dash(9)].join(" "),
        };
        writeln!(
            w,
            "{:<13} {:>7.3} {:>10.3} {ids} {shading} {:>8.2}",
            r.detector.name(),
            100.0 * r.scores.edge_fraction,
            100.0 * r.scores.shading_fraction,
            r.ms
        )?;
    }
    Ok(())
}
