//! `gbuf report FILE [--scene SIDECAR] [--layouts LIST] [--detectors LIST] [--culling LIST] [-o DIR] [--json]`:
//! sweep layouts × detectors on a dump and write the report folder. Also the pieces `gbuf demo` reuses: the
//! sweep flags, the progress bar, the human summary.

use crate::cli::common::{print_json, InputArgs};
use anyhow::Context;
use gbuf::analysis::row::Report;
use gbuf::analysis::sweep::SweepConfig;
use gbuf::detect::{Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::report::markdown::fmt_opt;
use gbuf::resolve::{Culling, ResolveConfig};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// The detectors a report sweeps by default: Lauritzen's 2010 test, the normal-angle test and Lauritzen + IDs.
pub const DEFAULT_DETECTORS: &str = "lauritzen,normal,combined";

/// Sweep flags shared by `gbuf report` and `gbuf demo`.
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// Layouts to sweep: built-in names or layout files, comma-separated (default: every built-in).
    #[arg(long, value_name = "LIST")]
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
    /// Point lights to scatter when the dump brings none.
    #[arg(long, default_value_t = 64)]
    pub lights: u32,
    /// Seed for scattered lights.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

fn split(list: &str) -> impl Iterator<Item = &str> {
    list.split(',').map(str::trim).filter(|s| !s.is_empty())
}

impl SweepArgs {
    /// The library sweep configuration.
    pub fn config(&self) -> anyhow::Result<SweepConfig> {
        let layouts = match &self.layouts {
            None => Layout::builtins(),
            Some(list) => split(list)
                .map(|n| Layout::by_name_or_path(n).with_context(|| format!("--layouts: {n}")))
                .collect::<anyhow::Result<Vec<_>>>()?,
        };
        anyhow::ensure!(!layouts.is_empty(), "--layouts: no layout given");
        let detectors = self.detectors.clone();
        anyhow::ensure!(!detectors.is_empty(), "--detectors: no detector given");
        let culling = self.culling.clone();
        Ok(SweepConfig {
            layouts,
            detectors,
            detector_config: DetectorConfig::default(),
            culling,
            resolve: ResolveConfig::default(),
            runs: self.runs as usize,
        })
    }
}

/// A progress bar on stderr, hidden when stderr is not a terminal.
pub fn progress_bar() -> ProgressBar {
    let pb = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::stderr());
    if !std::io::stderr().is_terminal() {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    if let Ok(style) = ProgressStyle::with_template("{elapsed:>4} [{bar:30}] {pos}/{len} {msg}") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// Prints the human summary of a report.
pub fn print_summary(rep: &Report, dir: &Path) {
    println!(
        "{}: {}×{} × {} samples, {:.1}% covered, {} lights ({})",
        rep.input,
        rep.width,
        rep.height,
        rep.samples,
        100.0 * rep.coverage,
        rep.lights,
        rep.lights_source
    );
    println!("{}", rep.needs.summary_line());
    if let Some(p) = &rep.needs.pruned_layout {
        println!(
            "pruned layout {}: {} B/sample ({} B less than {}), RMSE {} (base {})",
            p.name,
            p.bytes_per_sample,
            p.bytes_saved,
            p.base,
            fmt_opt(p.rmse, 5),
            fmt_opt(p.base_rmse, 5)
        );
    }
    println!(
        "{:<22} {:>7} {:<13} {:>9} {:>9} {:>8} {:>9} {:>10}  pareto",
        "layout", "B/samp", "detector", "normal°", "PSNR dB", "shaded", "rmse", "total ms"
    );
    for r in &rep.rows {
        if let Some(e) = &r.error {
            println!("{:<22} {:>7} {:<13} error: {e}", r.layout, r.bytes_per_sample, r.detector);
            continue;
        }
        let p = match (r.pareto.bytes, r.pareto.time) {
            (true, true) => "bytes+time",
            (true, false) => "bytes",
            (false, true) => "time",
            _ => "",
        };
        println!(
            "{:<22} {:>7} {:<13} {:>9} {:>9} {:>7.1}% {:>9} {:>10}  {p}",
            r.layout,
            r.bytes_per_sample,
            r.detector,
            fmt_opt(r.normal_max_deg, 3),
            fmt_opt(r.psnr_db, 2),
            100.0 * r.shading_fraction.unwrap_or(f64::NAN),
            fmt_opt(r.rmse, 5),
            fmt_opt(r.total_ms, 1)
        );
    }
    println!(
        "sweep: {} rows in {:.1} s; report written to {}",
        rep.rows.len(),
        rep.sweep_seconds,
        dir.join("report.md").display()
    );
}

/// Sweeps, writes the folder, prints the summary (or the JSON report).
pub fn run_and_write(
    name: &str,
    gb: &gbuf::GBuffer,
    lights: &[gbuf::Light],
    lights_source: &str,
    cfg: &SweepConfig,
    out: &Path,
    json: bool,
) -> anyhow::Result<Report> {
    let pb = progress_bar();
    let mut progress = |done: usize, total: usize, what: &str| {
        pb.set_length(total as u64);
        pb.set_position(done as u64);
        pb.set_message(what.to_string());
    };
    let input = gbuf::analysis::ReportInput {
        name: name.to_string(),
        gbuffer: gb,
        lights,
        lights_source: lights_source.to_string(),
    };
    let (rep, files) = gbuf::report::run(&input, cfg, &mut progress)?;
    pb.finish_and_clear();
    gbuf::report::write::write_folder(out, &rep, &files)
        .with_context(|| format!("writing the report to {}", out.display()))?;
    if json {
        print_json(&rep)?;
    } else {
        print_summary(&rep, out);
    }
    Ok(rep)
}

/// Flags of `gbuf report`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// What to sweep.
    #[command(flatten)]
    pub sweep: SweepArgs,
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
    let loaded = args.input.load()?;
    let gb = &loaded.gbuffer;
    let (lights, source) = match &loaded.lights {
        Some(l) if !l.is_empty() => (l.clone(), "from the dump/sidecar".to_string()),
        _ => (
            gbuf::scene::scatter_lights(gb, args.sweep.lights as usize, args.sweep.seed),
            format!("{} scattered, seed {}", args.sweep.lights, args.sweep.seed),
        ),
    };
    run_and_write(&args.input.file.display().to_string(), gb, &lights, &source, &cfg, &args.out, args.json)?;
    Ok(())
}
