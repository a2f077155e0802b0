//! `gbuf budget FILE --max-bytes N [--max-error E] [--resolution WxH --msaa S] [-o LAYOUT.toml] [--json]`: the
//! layout of at most N bytes per sample with the least image error on this dump (or the smallest under an error
//! cap), why it won, and a layout file `--layout` accepts.

use crate::cli::common::{print_json, InputArgs, Resolution};
use anyhow::Context;
use gbuf::analysis::budget::{search, BudgetConfig, BudgetResult};
use gbuf::detect::{Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::report::markdown::fmt_opt;
use gbuf::resolve::ResolveConfig;
use serde::Serialize;
use std::path::PathBuf;

/// Flags of `gbuf budget`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Largest layout size in bytes per sample.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_bytes: u32,
    /// Image RMSE cap: pick the smallest layout whose error stays at or under it.
    #[arg(long, value_name = "E")]
    pub max_error: Option<f64>,
    /// Resolution the footprint is quoted at (default: the dump's).
    #[arg(long, value_name = "WxH")]
    pub resolution: Option<Resolution>,
    /// MSAA sample count the footprint is quoted at (default: the dump's).
    #[arg(long, value_name = "S")]
    pub msaa: Option<u32>,
    /// Edge detector the candidates are measured with.
    #[arg(long, default_value = "lauritzen")]
    pub detector: Detector,
    /// Point lights to scatter when the dump brings none.
    #[arg(long, default_value_t = 64)]
    pub lights: u32,
    /// Seed for scattered lights.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the winning layout here (TOML, or JSON for `.json`).
    #[arg(short = 'o', long = "out", value_name = "LAYOUT.toml")]
    pub out: Option<PathBuf>,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Output<'a> {
    #[serde(flatten)]
    result: &'a BudgetResult,
    resolution: [u32; 2],
    msaa: u32,
    footprint_bytes: u64,
    layout_file: Option<String>,
}

/// Runs `gbuf budget`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let detector = args.detector;
    if let Some(e) = args.max_error {
        anyhow::ensure!(e.is_finite() && e >= 0.0, "--max-error must be a finite number ≥ 0, got {e}");
    }
    let (rw, rh) = args.resolution.map_or((0, 0), |r| (r.width, r.height));
    let loaded = args.input.load()?;
    let gb = &loaded.gbuffer;
    let (rw, rh) = if rw == 0 { (gb.width, gb.height) } else { (rw, rh) };
    let msaa = args.msaa.unwrap_or(gb.samples);
    let lights = match &loaded.lights {
        Some(l) if !l.is_empty() => l.clone(),
        _ => gbuf::scene::scatter_lights(gb, args.lights as usize, args.seed),
    };
    let cfg = BudgetConfig {
        max_bytes: args.max_bytes,
        max_error: args.max_error,
        detector,
        detector_config: DetectorConfig::default(),
        resolve: ResolveConfig::default(),
    };
    let res = search(gb, &lights, &cfg).with_context(|| format!("{}: budget search", args.input.file.display()))?;
    let layout = Layout::from_spec(res.winner.spec.clone())?;
    if let Some(path) = &args.out {
        layout.save(path).with_context(|| format!("writing the layout to {}", path.display()))?;
    }
    let footprint = layout.footprint_bytes(rw, rh, msaa);
    if args.json {
        return print_json(&Output {
            result: &res,
            resolution: [rw, rh],
            msaa,
            footprint_bytes: footprint,
            layout_file: args.out.as_ref().map(|p| p.display().to_string()),
        });
    }
    let w = &res.winner;
    println!(
        "winner: {} ({}), {} B/sample = {:.1} MiB at {rw}×{rh} × {msaa}; image RMSE {} (PSNR {} dB) with {}",
        w.name,
        w.kind,
        w.bytes_per_sample,
        footprint as f64 / (1024.0 * 1024.0),
        fmt_opt(w.rmse, 6),
        fmt_opt(w.psnr_db, 2),
        args.detector
    );
    println!("  {}", w.summary);
    println!("{}", res.needs.summary_line());
    if res.builtin_is_best {
        println!("a built-in layout is the best within {} B: {}", res.max_bytes, w.name);
    } else if let Some(b) = &res.best_builtin {
        let bb = res.measured.iter().find(|c| &c.name == b);
        println!(
            "beats the best fitting built-in {b} ({} B, RMSE {})",
            bb.map_or(0, |c| c.bytes_per_sample),
            fmt_opt(bb.and_then(|c| c.rmse), 6)
        );
    } else {
        println!("no built-in layout fits in {} B", res.max_bytes);
    }
    println!("rivals (measured, best first):");
    for c in res.measured.iter().skip(1).take(6) {
        println!(
            "  {:<48} {:>4} B  RMSE {:>10}  {}",
            c.name,
            c.bytes_per_sample,
            c.error.as_ref().map_or(fmt_opt(c.rmse, 6), |e| format!("error: {e}")),
            c.kind
        );
    }
    println!("searched {} generated combinations within budget in {:.1} s", res.combinations, res.seconds);
    if let Some(p) = &args.out {
        println!("layout written to {} (use it with --layout {})", p.display(), p.display());
    }
    Ok(())
}
