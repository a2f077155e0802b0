//! `gbuf report FILE… [--scene SIDECAR] [--candidates LIST] [--detectors LIST] [--culling LIST] [--flip WHICH]
//! [--over mean|worst] [-o DIR] [--json]`: sweep layouts × detectors on one or more dumps (frames), one after
//! another, and write the report folder with per-frame and aggregated rows. Also the pieces `gbuf demo` and
//! `gbuf merge` reuse: the sweep flags, the progress bar, the human summary.

use crate::cli::common::{print_json, say_lighting, FramesArgs, LightingArgs};
use anyhow::Context;
use gbuf::analysis::aggregate::Over;
use gbuf::analysis::record::Report;
use gbuf::analysis::sweep::{FlipRows, SweepConfig};
use gbuf::detect::{Detector, DetectorConfig};
use gbuf::image::ToneCurve;
use gbuf::layout::Layout;
use gbuf::measure::image::Viewing;
use gbuf::report::format::fmt_opt;
use gbuf::resolve::{Culling, ResolveConfig};
pub use gbuf::study::FrameInput;
use gbuf::study::{Assembly, Event};
use std::path::{Path, PathBuf};

/// The detectors a report sweeps by default: Lauritzen's 2010 test, the normal-angle test and Lauritzen + IDs.
pub const DEFAULT_DETECTORS: &str = "lauritzen,normal,combined";

/// Sweep flags shared by `gbuf report` and `gbuf demo`.
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// The layouts to sweep and rank: built-in names or layout files, comma-separated (default: every built-in).
    /// (`--input-layout` names the layout of an input that is packed render targets.)
    #[arg(long = "candidates", alias = "layouts", value_name = "LIST")]
    pub layouts: Option<String>,
    /// Edge detectors, comma-separated.
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_value = DEFAULT_DETECTORS)]
    pub detectors: Vec<Detector>,
    /// Light culling modes to compare, comma-separated (default: the resolve's default only).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pub culling: Vec<Culling>,
    /// Timing runs per stage (medians and min–max are reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
    pub runs: u32,
    /// The lights.
    #[command(flatten)]
    pub scatter: crate::cli::common::LightsArgs,
    /// Which rows get FLIP: `decisive` (each layout's errors with the first detector, each detector's AA
    /// error), `all`, or `none`.
    #[arg(long, value_name = "WHICH", default_value = "decisive")]
    pub flip: FlipRows,
    /// Pixels per degree of the viewer FLIP models (default: a 0.7 m wide 4K monitor seen from 0.7 m).
    #[arg(long, value_name = "PPD", default_value_t = gbuf::measure::flip::default_ppd())]
    pub ppd: f32,
    /// Tone map of the displayed image LDR-FLIP sees (as `gbuf resolve --tonemap`).
    #[arg(long, value_name = "TM", default_value = "reinhard")]
    pub tonemap: ToneCurve,
    /// Exposure of the displayed image (as `gbuf resolve --exposure`).
    #[arg(long, value_name = "E", default_value_t = 1.0)]
    pub exposure: f32,
    /// BRDF the layouts are ranked under: lambert, blinn-phong or ggx (default: from the frame — ggx when it stores
    /// roughness or metallic, else blinn-phong). `gbuf report` takes several, comma-separated: one report per BRDF
    /// in a subfolder of the output, and a table of each layout's error and rank under each.
    #[arg(long, value_name = "B", value_delimiter = ',')]
    pub brdf: Vec<gbuf::resolve::Brdf>,
    /// Distance falloff: linear or gltf (default: linear).
    #[arg(long, value_name = "F")]
    pub falloff: Option<gbuf::resolve::Falloff>,
}

fn split(list: &str) -> impl Iterator<Item = &str> {
    list.split(',').map(str::trim).filter(|s| !s.is_empty())
}

impl SweepArgs {
    /// The one lighting model asked for (the data's choice without `--brdf`); several are a usage error here.
    pub fn lighting(&self) -> anyhow::Result<LightingArgs> {
        match self.lightings().as_slice() {
            [] => Ok(LightingArgs { brdf: None, falloff: self.falloff }),
            [one] => Ok(*one),
            many => crate::usage!("--brdf: one BRDF here ({} given); `gbuf report` compares several", many.len()),
        }
    }

    /// Each BRDF asked for, in order, without repeats.
    pub fn lightings(&self) -> Vec<LightingArgs> {
        let mut out: Vec<LightingArgs> = Vec::new();
        for &b in &self.brdf {
            if !out.iter().any(|l| l.brdf == Some(b)) {
                out.push(LightingArgs { brdf: Some(b), falloff: self.falloff });
            }
        }
        out
    }

    /// The library sweep configuration.
    pub fn config(&self) -> anyhow::Result<SweepConfig> {
        let layouts = match &self.layouts {
            None => Layout::builtins(),
            Some(list) => split(list)
                .map(|n| Layout::by_name_or_path(n).with_context(|| format!("--candidates: {n}")))
                .collect::<anyhow::Result<Vec<_>>>()?,
        };
        anyhow::ensure!(!layouts.is_empty(), "--candidates: no layout given");
        let detectors = self.detectors.clone();
        anyhow::ensure!(!detectors.is_empty(), "--detectors: no detector given");
        let culling = self.culling.clone();
        anyhow::ensure!(
            self.ppd.is_finite() && self.ppd > 0.0,
            "--ppd must be a positive number of pixels per degree, got {}",
            self.ppd
        );
        anyhow::ensure!(
            self.exposure.is_finite() && self.exposure > 0.0,
            "--exposure must be a positive number, got {}",
            self.exposure
        );
        Ok(SweepConfig {
            flip: self.flip,
            viewing: Viewing { tone_map: self.tonemap, exposure: self.exposure, pixels_per_degree: self.ppd },
            layouts,
            detectors,
            detector_config: DetectorConfig::default(),
            culling,
            resolve: ResolveConfig::default(),
            runs: self.runs as usize,
        })
    }
}

fn pareto_word(p: gbuf::analysis::row::ParetoFlags) -> &'static str {
    match (p.bytes, p.time) {
        (true, true) => "bytes+time",
        (true, false) => "bytes",
        (false, true) => "time",
        _ => "",
    }
}

/// Prints the human summary of a report.
pub fn print_summary(rep: &Report, dir: &Path) {
    let multi = rep.frames.len() > 1;
    for f in &rep.frames {
        println!(
            "{}: {}×{} × {} samples, {:.1}% covered, {} lights ({})",
            f.input,
            f.width,
            f.height,
            f.samples,
            100.0 * f.coverage,
            f.lights,
            f.lights_source
        );
        for n in &f.notes {
            println!("note: {n}");
        }
        println!("{}", f.needs.summary_line());
        if let Some(p) = &f.needs.pruned_layout {
            println!(
                "pruned layout {}: {} B/sample ({} B less than {}), layout RMSE {} (base {})",
                p.name,
                p.bytes_per_sample,
                p.bytes_saved,
                p.base,
                fmt_opt(p.rmse, 5),
                fmt_opt(p.base_rmse, 5)
            );
        }
    }
    println!("detectors (exact G-buffer; AA error = against the every-sample reference):");
    for d in &rep.detectors {
        println!(
            "  {:<13} shaded {:>6.1}%  AA RMSE {:>9}  AA FLIP {:>7}{}",
            d.detector,
            100.0 * d.shading_fraction.as_ref().map_or(f64::NAN, |s| s.mean),
            fmt_opt(d.aa_rmse.as_ref().map(|s| s.over(rep.over)), 5),
            fmt_opt(d.aa_flip_ldr.as_ref().map(|s| s.over(rep.over)), 4),
            if d.on_front { "  front" } else { "" }
        );
    }
    if multi {
        println!(
            "{:<22} {:>7} {:<13} {:>12} {:>12} {:>11} {:>10}  pareto ({} frame)",
            "layout",
            "B/samp",
            "detector",
            "layout RMSE",
            "layout FLIP",
            "worst frame",
            "pass ms",
            rep.over.name()
        );
        for r in &rep.aggregate {
            let l = r.layout_rmse.as_ref();
            println!(
                "{:<22} {:>7} {:<13} {:>12} {:>12} {:>11} {:>10}  {}",
                r.layout,
                r.bytes_per_sample,
                r.detector,
                fmt_opt(l.map(|s| s.over(rep.over)), 5),
                fmt_opt(r.layout_flip_ldr.as_ref().map(|s| s.over(rep.over)), 4),
                l.map_or("—".into(), |s| short(&s.worst_frame)),
                fmt_opt(r.resolve_pass_ms.as_ref().map(|s| s.mean), 1),
                pareto_word(r.pareto)
            );
        }
    } else {
        println!(
            "{:<22} {:>7} {:<13} {:>9} {:>11} {:>9} {:>9} {:>8} {:>9}  pareto",
            "layout", "B/samp", "detector", "normal°", "layout RMSE", "FLIP", "AA RMSE", "shaded", "pass ms"
        );
        for r in &rep.rows {
            if let Some(e) = &r.error {
                println!("{:<22} {:>7} {:<13} error: {e}", r.layout, r.bytes_per_sample, r.detector);
                continue;
            }
            println!(
                "{:<22} {:>7} {:<13} {:>9} {:>11} {:>9} {:>9} {:>7.1}% {:>9}  {}",
                r.layout,
                r.bytes_per_sample,
                r.detector,
                fmt_opt(r.normal_max_deg, 3),
                fmt_opt(r.layout_rmse(), 5),
                fmt_opt(r.layout_error.and_then(|e| e.flip_ldr), 4),
                fmt_opt(r.aa_error.map(|e| e.rmse), 5),
                100.0 * r.shading_fraction.unwrap_or(f64::NAN),
                fmt_opt(r.resolve_pass_ms, 1),
                pareto_word(r.pareto)
            );
        }
    }
    if let Some(b) = &rep.budget {
        match (&b.layout, &b.layout_rmse) {
            (Some(l), Some(st)) => println!(
                "budget {} B/sample over {} frame(s), by the {} frame: {l} ({} B, layout RMSE mean {} / worst {} on {})",
                b.max_bytes,
                rep.frames.len(),
                b.over.name(),
                b.bytes_per_sample.unwrap_or(0),
                fmt_opt(Some(st.mean), 5),
                fmt_opt(Some(st.worst), 5),
                short(&st.worst_frame)
            ),
            _ => println!("budget {} B/sample: no layout of the report fits and was measured on every frame", b.max_bytes),
        }
    }
    let secs: f64 = rep.frames.iter().map(|f| f.sweep_seconds).sum();
    println!(
        "sweep: {} rows over {} frame(s) in {:.1} s; report written to {} (and report.md, report.json, \
         report.csv beside it)",
        rep.rows.len(),
        rep.frames.len(),
        secs,
        dir.join("report.html").display()
    );
    if let Some(l) = &rep.lighting {
        println!("lit with {}", l.summary());
    }
    let stages = gbuf::report::format::stage_summary(rep.frames.iter().flat_map(|f| &f.stage_seconds));
    if !stages.is_empty() {
        println!("sweep time by stage: {stages}");
    }
    let other = gbuf::report::format::stage_summary(rep.frames.iter().flat_map(|f| &f.other_seconds));
    if !other.is_empty() {
        println!("time outside the sweep: {other}");
    }
}

fn short(frame: &str) -> String {
    Path::new(frame).file_name().map_or(frame.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Sweeps the frames one after another ([`gbuf::study::run_frames`]: `next` yields them, so only one is in memory
/// at a time) with a progress bar, writes the folder, prints the summary (or the JSON report).
pub fn run_frames(
    count: usize,
    next: impl FnMut(usize) -> anyhow::Result<FrameInput>,
    cfg: &SweepConfig,
    lighting: LightingArgs,
    how: &Assembly,
    out: &Path,
    say: Say,
) -> anyhow::Result<Report> {
    let pb = crate::cli::progress_bar(1);
    let mut on = |event: Event<'_>| match event {
        Event::Lighting(l) => pb.suspend(|| say_lighting(l)),
        Event::LightingDiffers { frame, would, chosen } => pb.suspend(|| {
            eprintln!(
                "warning: {frame}: its data would choose BRDF {} ({}); every frame of the report is lit as the first: \
                 {}",
                would.brdf,
                would.why,
                chosen.summary()
            );
        }),
        Event::Progress { frame, count, done, total, what } => {
            pb.set_length(total as u64);
            pb.set_position(done as u64);
            pb.set_message(if count > 1 { format!("frame {}/{count}: {what}", frame + 1) } else { what.to_string() });
        }
    };
    let (rep, files) = gbuf::study::run_frames(count, next, cfg, &|a| lighting.choose(a), how, &mut on)?;
    pb.finish_and_clear();
    write_and_print(&rep, &files, out, say)?;
    Ok(rep)
}

/// What a written report prints on stdout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Say {
    /// The human summary.
    Summary,
    /// The JSON report (`--json`).
    Json,
    /// Nothing (a part of a larger job that prints its own).
    Nothing,
}

impl Say {
    /// The JSON report with `--json`, else the summary.
    #[must_use]
    pub fn of(json: bool) -> Say {
        if json {
            Say::Json
        } else {
            Say::Summary
        }
    }
}

/// Writes the report folder and prints what `say` asks.
pub fn write_and_print(
    rep: &Report,
    files: &[gbuf::report::format::Attachment],
    out: &Path,
    say: Say,
) -> anyhow::Result<()> {
    gbuf::report::write::write_folder(out, rep, files)
        .with_context(|| format!("writing the report to {}", out.display()))?;
    match say {
        Say::Json => print_json(rep),
        Say::Summary => {
            print_summary(rep, out);
            Ok(())
        }
        Say::Nothing => Ok(()),
    }
}

/// Sweeps one in-memory frame (what `gbuf demo` runs).
pub fn run_and_write(
    frame: FrameInput,
    cfg: &SweepConfig,
    lighting: LightingArgs,
    out: &Path,
    json: bool,
) -> anyhow::Result<Report> {
    let mut frame = Some(frame);
    let how = Assembly::of(cfg, Over::default(), None, "");
    run_frames(1, |_| frame.take().context("one frame"), cfg, lighting, &how, out, Say::of(json))
}

/// Flags of `gbuf report`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dumps and how to read them.
    #[command(flatten)]
    pub input: FramesArgs,
    /// What to sweep.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Over several frames, rank the aggregate by each layout's mean or worst frame.
    #[arg(long, value_name = "HOW", default_value = "worst")]
    pub over: Over,
    /// Also pick the layout of at most N bytes per sample with the least layout error over the frames.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_bytes: Option<u32>,
    /// The same frame rendered with 1 sample per pixel at pixel centres (one input only): the no-AA image that MLAA
    /// smooths in the pipelines section, and forward shading's exact quads. Without it sample 0 of the MSAA dump
    /// stands in, off the pixel centre.
    #[arg(long, value_name = "FILE")]
    pub single: Option<PathBuf>,
    /// Output folder (created if missing; other files in it are left alone).
    #[arg(short = 'o', long = "out", default_value = "gbuf-report")]
    pub out: PathBuf,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf report`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = args.sweep.config()?;
    let paths = args.input.frames()?;
    if args.single.is_some() && paths.len() != 1 {
        crate::usage!("--single goes with one input frame; got {}", paths.len());
    }
    let next = |i: usize| -> anyhow::Result<FrameInput> {
        let p = &paths[i];
        let loaded = args.input.load(p)?;
        let (lights, lights_source) = args.sweep.scatter.of(&loaded);
        let single = match &args.single {
            Some(s) => {
                let one = args.input.load_file(s)?.gbuffer;
                gbuf::analysis::pipelines::check_single(&loaded.gbuffer, &one)
                    .with_context(|| format!("--single {} against {}", s.display(), p.name()))?;
                Some(one)
            }
            None => None,
        };
        let notes = loaded
            .warnings
            .iter()
            .filter(|w| w.code == gbuf::layout::targets::NO_FLOAT_TRUTH)
            .map(|w| w.message.clone())
            .collect();
        Ok(FrameInput { name: p.name(), gbuffer: loaded.gbuffer, lights, lights_source, single, geometry: None, notes })
    };
    let how = Assembly::of(&cfg, args.over, args.max_bytes, "");
    let lightings = args.sweep.lightings();
    if lightings.len() < 2 {
        run_frames(paths.len(), next, &cfg, args.sweep.lighting()?, &how, &args.out, Say::of(args.json))?;
        return Ok(());
    }
    // Several BRDFs: a whole report under each (its own fronts, budget and figures), then how the layouts' errors
    // and ranks move between them.
    let mut reports = Vec::new();
    for l in &lightings {
        let out = args.out.join(l.brdf.map_or("auto", gbuf::resolve::Brdf::name));
        let say = if args.json { Say::Nothing } else { Say::Summary };
        reports.push(run_frames(paths.len(), &next, &cfg, *l, &how, &out, say)?);
    }
    let rows = brdf_comparison(&reports);
    let text = brdf_comparison_markdown(&reports, &rows);
    let mut staged = gbuf::base::files::Staged::default();
    let md = args.out.join("brdf_comparison.md");
    staged.stage_bytes(&md, text.as_bytes()).with_context(|| format!("writing {}", md.display()))?;
    let json = serde_json::to_vec_pretty(&rows)?;
    let jp = args.out.join("brdf_comparison.json");
    staged.stage_bytes(&jp, &json).with_context(|| format!("writing {}", jp.display()))?;
    staged.commit()?;
    if args.json {
        return print_json(&rows);
    }
    print!("{text}");
    println!("written to {} (each BRDF's report in its subfolder)", md.display());
    Ok(())
}

/// One layout under each BRDF of a comparison: its layout error (the reports' `over` statistic, with their first
/// detector) and its rank among the layouts under that BRDF (1 = least error).
#[derive(serde::Serialize)]
pub struct BrdfRow {
    /// The layout.
    pub layout: String,
    /// Bytes per sample.
    pub bytes_per_sample: u32,
    /// Per BRDF, in the order given: its name, the layout RMSE and the rank.
    pub under: Vec<(String, Option<f64>, Option<usize>)>,
}

/// The comparison rows of reports lit with different BRDFs (same frames, layouts and detectors).
fn brdf_comparison(reports: &[Report]) -> Vec<BrdfRow> {
    let Some(first) = reports.first() else { return Vec::new() };
    let detector = first.aggregate.first().map(|r| r.detector.clone()).unwrap_or_default();
    let pick = |rep: &Report| -> Vec<(String, u32, Option<f64>)> {
        rep.aggregate
            .iter()
            .filter(|r| r.detector == detector && r.culling == first.aggregate[0].culling)
            .map(|r| (r.layout.clone(), r.bytes_per_sample, r.layout_rmse.as_ref().map(|s| s.over(rep.over))))
            .collect()
    };
    let per: Vec<Vec<(String, u32, Option<f64>)>> = reports.iter().map(pick).collect();
    let rank = |list: &[(String, u32, Option<f64>)], layout: &str| -> Option<usize> {
        let mine = list.iter().find(|r| r.0 == layout)?.2?;
        Some(1 + list.iter().filter(|r| r.2.is_some_and(|e| e < mine)).count())
    };
    per[0]
        .iter()
        .map(|(layout, bytes, _)| BrdfRow {
            layout: layout.clone(),
            bytes_per_sample: *bytes,
            under: reports
                .iter()
                .zip(&per)
                .map(|(rep, list)| {
                    let name = rep.lighting.as_ref().map_or("?".to_string(), |l| l.brdf.name().to_string());
                    (name, list.iter().find(|r| &r.0 == layout).and_then(|r| r.2), rank(list, layout))
                })
                .collect(),
        })
        .collect()
}

/// The comparison as a Markdown table: a column pair (RMSE, rank) per BRDF.
fn brdf_comparison_markdown(reports: &[Report], rows: &[BrdfRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("# Layouts under each BRDF\n\n");
    let detector = reports.first().and_then(|r| r.aggregate.first()).map_or("", |r| r.detector.as_str());
    let _ = writeln!(
        s,
        "Layout error (RMSE against the exact G-buffer lit the same way, detector {detector}) and rank among the \
         layouts (1 = least error) under each BRDF. A layout that ranks well under one and badly under another \
         stores coarsely what only the second reads (GGX reads roughness and metallic; Blinn-Phong a specular \
         amount and power).\n"
    );
    use gbuf::base::table::{Align, Table};
    let mut columns = vec![("layout".to_string(), Align::Left), ("B/sample".to_string(), Align::Right)];
    for r in reports {
        let b = r.lighting.as_ref().map_or("?", |l| l.brdf.name());
        columns.extend([(format!("{b} RMSE"), Align::Right), (format!("{b} rank"), Align::Right)]);
    }
    let mut t = Table::new(columns);
    for r in rows {
        let mut cells = vec![r.layout.clone(), r.bytes_per_sample.to_string()];
        for (_, e, k) in &r.under {
            cells.extend([fmt_opt(*e, 5), k.map_or("—".to_string(), |k| k.to_string())]);
        }
        t.row(cells);
    }
    s.push_str(&t.finish());
    s
}
