//! `gbuf merge R1.json R2.json … -o DIR [--over mean|worst] [--max-bytes N] [--json]`: merges the `report.json`
//! of separate `gbuf report` runs (one per frame, e.g. spread over a job scheduler) into one report: the same
//! aggregate tables, fronts and budget choice as one `gbuf report` over all the frames. Per-frame figures stay in
//! the runs' own folders; the merged folder gets the aggregate plots.

use crate::cli::report::{write_and_print, Say};
use anyhow::Context;
use gbuf::analysis::aggregate::Over;
use gbuf::analysis::record::Report;
use gbuf::study::Assembly;
use std::path::PathBuf;

/// Flags of `gbuf merge`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// `report.json` files, or report folders holding one.
    #[arg(required = true, num_args = 1.., value_name = "REPORT")]
    pub reports: Vec<PathBuf>,
    /// Rank the aggregate by each layout's mean or worst frame.
    #[arg(long, value_name = "HOW", default_value = "worst")]
    pub over: Over,
    /// Also pick the layout of at most N bytes per sample with the least layout error over the frames.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_bytes: Option<u32>,
    /// Output folder (created if missing; other files in it are left alone).
    #[arg(short = 'o', long = "out", default_value = "gbuf-merged")]
    pub out: PathBuf,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Largest `report.json` read (a report of thousands of rows is a few MB).
const MAX_REPORT_BYTES: u64 = 256 << 20;

fn read_report(path: &std::path::Path) -> anyhow::Result<Report> {
    let file = if path.is_dir() { path.join("report.json") } else { path.to_path_buf() };
    gbuf::base::files::protect_input(&file);
    let len = std::fs::metadata(&file).with_context(|| format!("{}: cannot read", file.display()))?.len();
    anyhow::ensure!(len <= MAX_REPORT_BYTES, "{}: {len} bytes is too large for a report.json", file.display());
    let text = std::fs::read_to_string(&file).with_context(|| format!("{}: cannot read", file.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a gbuf report.json", file.display()))
}

/// Runs `gbuf merge`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut frames = Vec::new();
    let mut rows = Vec::new();
    let mut first: Option<(PathBuf, Report)> = None;
    for p in &args.reports {
        let rep = read_report(p)?;
        anyhow::ensure!(!rep.frames.is_empty(), "{}: the report has no frame", p.display());
        if let Some((fp, f)) = &first {
            anyhow::ensure!(
                f.viewing == rep.viewing,
                "{} and {}: FLIP was computed with different viewing conditions ({:?} and {:?}); their errors do not \
                 compare",
                fp.display(),
                p.display(),
                f.viewing,
                rep.viewing
            );
            let (a, b) =
                (f.lighting.as_ref().map(|l| (l.brdf, l.falloff)), rep.lighting.as_ref().map(|l| (l.brdf, l.falloff)));
            anyhow::ensure!(
                a == b,
                "{} and {}: the frames were lit with different lighting models ({} and {}); their errors do not \
                 compare (give `gbuf report` the same --brdf and --falloff)",
                fp.display(),
                p.display(),
                f.lighting.as_ref().map_or("not recorded".into(), gbuf::resolve::Lighting::summary),
                rep.lighting.as_ref().map_or("not recorded".into(), gbuf::resolve::Lighting::summary)
            );
        }
        for f in &rep.frames {
            anyhow::ensure!(
                !frames.iter().any(|g: &gbuf::analysis::record::Frame| g.input == f.input),
                "{}: frame {} is already in an earlier report; each frame once",
                p.display(),
                f.input
            );
        }
        frames.extend(rep.frames.iter().cloned());
        rows.extend(rep.rows.iter().cloned());
        if first.is_none() {
            first = Some((p.clone(), rep));
        }
    }
    let (_, f) = first.context("no report given")?;
    let how = Assembly {
        runs: f.runs,
        viewing: f.viewing,
        flip: f.flip,
        over: args.over,
        max_bytes: args.max_bytes,
        lighting: f.lighting.clone(),
    };
    let (rep, files) = gbuf::study::assemble(frames, rows, vec![], &how)?;
    write_and_print(&rep, &files, &args.out, Say::of(args.json))
}
