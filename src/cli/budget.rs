//! `gbuf budget FILE… --max-bytes N [--over mean|worst] [--max-error E] [--resolution WxH --msaa S]
//! [-o LAYOUT.toml] [--json]`: the layout of at most N bytes per sample with the least layout error over the
//! dumps (each candidate's worst frame by default, or its mean; or the smallest under an error cap), why it won,
//! how far the search's prediction was off, and a layout file `--layout` accepts.

use crate::cli::common::{print_json, say_lighting, FramesArgs, LightingArgs, Resolution};
use anyhow::Context;
use gbuf::analysis::aggregate::Over;
use gbuf::analysis::budget::{search_frames, BudgetConfig, BudgetResult};
use gbuf::detect::{Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::report::format::fmt_opt;
use gbuf::resolve::ResolveConfig;
use serde::Serialize;
use std::path::PathBuf;

/// Flags of `gbuf budget`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dumps and how to read them.
    #[command(flatten)]
    pub input: FramesArgs,
    /// Largest layout size in bytes per sample.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_bytes: u32,
    /// Layout error cap (image RMSE against the exact G-buffer): pick the smallest layout whose error stays at or
    /// under it.
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
    /// Over several dumps: rank each candidate by its mean or its worst frame.
    #[arg(long, value_name = "HOW", default_value = "worst")]
    pub over: Over,
    /// The lights.
    #[command(flatten)]
    pub scatter: crate::cli::common::LightsArgs,
    /// The lighting model the candidates are measured under (the budget keeps the bits its BRDF reads).
    #[command(flatten)]
    pub lighting: LightingArgs,
    /// Write the winning layout here (TOML, or JSON for `.json`).
    #[arg(short = 'o', long = "out", value_name = "LAYOUT.toml")]
    pub out: Option<PathBuf>,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
    /// The winning layout as shader code (glsl, hlsl or wgsl): on stdout instead of the table, or beside `-o LAYOUT.toml` as
    /// `LAYOUT.<lang>`.
    #[arg(long, value_name = "LANG", conflicts_with = "json")]
    pub emit: Option<gbuf::layout::shader::Lang>,
    /// Only layouts whose targets bind as one pass at the frame's sample count on each of these platforms
    /// (comma-separated: webgpu, d3d12, metal-apple4, …; `gbuf layouts --check` lists them).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pub fit: Vec<String>,
}

#[derive(Serialize)]
struct Output<'a> {
    #[serde(flatten)]
    result: &'a BudgetResult,
    lighting: &'a gbuf::resolve::Lighting,
    resolution: [u32; 2],
    msaa: u32,
    footprint_bytes: u64,
    layout_file: Option<String>,
}

/// Runs `gbuf budget`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let fit = super::common::platforms("--fit", &args.fit)?;
    let detector = args.detector;
    if let Some(e) = args.max_error {
        anyhow::ensure!(e.is_finite() && e >= 0.0, "--max-error must be a finite number ≥ 0, got {e}");
    }
    let paths = args.input.frames()?;
    if let Some(out) = &args.out {
        crate::cli::common::check_output_folders([out.as_path()])?;
    }
    // The first frame decides the lighting model (the data's choice unless --brdf); it is loaded once, here, and
    // handed to the search as its first visit.
    let load_frame = |i: usize| -> anyhow::Result<(gbuf::GBuffer, Vec<gbuf::Light>)> {
        let loaded = args.input.load(&paths[i])?;
        let (lights, _) = args.scatter.of(&loaded);
        Ok((loaded.gbuffer, lights))
    };
    let first = load_frame(0)?;
    let lighting = args.lighting.choose(&first.0.attributes());
    say_lighting(&lighting);
    let mut first = Some(first);
    let cfg = BudgetConfig {
        max_bytes: args.max_bytes,
        max_error: args.max_error,
        detector,
        detector_config: DetectorConfig::default(),
        resolve: lighting.apply(ResolveConfig::default()),
        over: args.over,
        shader_code: args.emit.is_some(),
        fit,
    };
    let names: Vec<String> = paths.iter().map(super::common::FrameRef::name).collect();
    let load = |i: usize| match first.take() {
        Some(f) if i == 0 => Ok(f),
        _ => load_frame(i),
    };
    let pb = crate::cli::spinner(format!("searching layouts within the budget over {} frame(s)", names.len()));
    let (res, size) = search_frames(&names, load, &cfg).with_context(|| format!("budget over {}", names.join(", ")))?;
    pb.finish_and_clear();
    let (rw, rh) = args.resolution.map_or((size.0, size.1), |r| (r.width, r.height));
    let msaa = args.msaa.unwrap_or(size.2);
    let layout = Layout::from_spec(res.winner.spec.clone())?;
    if let (Some(lang), None) = (args.emit, &args.out) {
        return super::layouts::emit(&layout, lang, None);
    }
    // The layout file and its shader code are staged and renamed into place together: a failure leaves neither.
    if let Some(path) = &args.out {
        let mut staged = gbuf::base::files::Staged::default();
        let text = layout.spec().to_text(gbuf::layout::SpecSyntax::detect(path, ""))?;
        staged
            .stage_bytes(path, text.as_bytes())
            .with_context(|| format!("writing the layout to {}", path.display()))?;
        if let Some(lang) = args.emit {
            let code_path = path.with_extension(lang.name());
            let code = gbuf::layout::shader::emit(&layout, lang)?;
            staged
                .stage_bytes(&code_path, code.as_bytes())
                .with_context(|| format!("writing {}", code_path.display()))?;
        }
        staged.commit().context("renaming the layout files into place")?;
    }
    let footprint = layout.footprint_bytes(rw, rh, msaa);
    if args.json {
        return print_json(&Output {
            result: &res,
            lighting: &lighting,
            resolution: [rw, rh],
            msaa,
            footprint_bytes: footprint,
            layout_file: args.out.as_ref().map(|p| p.display().to_string()),
        });
    }
    let w = &res.winner;
    let over = if names.len() > 1 { format!(" ({} of {} frames)", args.over, names.len()) } else { String::new() };
    println!(
        "winner: {} ({}), {} B/sample = {:.1} MiB at {rw}×{rh} × {msaa}; layout error RMSE {}{over} (PSNR {} dB), \
         predicted {} — with {}",
        w.name,
        w.kind,
        w.bytes_per_sample,
        footprint as f64 / (1024.0 * 1024.0),
        fmt_opt(w.rmse, 6),
        fmt_opt(w.psnr_db, 2),
        fmt_opt(w.predicted_rmse, 6),
        args.detector
    );
    println!("  {}", w.summary);
    println!("  measured under {}", lighting.summary());
    if names.len() > 1 {
        for m in &w.frames {
            println!(
                "  {}: layout error RMSE {} (predicted {})",
                m.frame,
                fmt_opt(m.layout_error.map(|e| e.rmse), 6),
                fmt_opt(m.predicted_rmse, 6)
            );
        }
    }
    println!("{}", res.needs.summary_line());
    if res.builtin_is_best {
        println!("a built-in layout is the best within {} B: {}", res.max_bytes, w.name);
    } else if let Some(b) = &res.best_builtin {
        let bb = res.measured.iter().find(|c| &c.name == b);
        println!(
            "beats the best fitting built-in {b} ({} B, layout error RMSE {})",
            bb.map_or(0, |c| c.bytes_per_sample),
            fmt_opt(bb.and_then(|c| c.rmse), 6)
        );
    } else {
        println!("no built-in layout fits in {} B", res.max_bytes);
    }
    println!("finalists (measured layout error, best first; predicted by the single-option model beside it):");
    for c in res.measured.iter().take(8) {
        println!(
            "  {:<48} {:>4} B  measured {:>10}  predicted {:>10}  ×{:<7} {}",
            c.name,
            c.bytes_per_sample,
            c.error.as_ref().map_or(fmt_opt(c.rmse, 6), |_| "error".into()),
            fmt_opt(c.predicted_rmse, 6),
            fmt_opt(c.prediction_ratio, 2),
            c.error.as_ref().map_or(c.kind.clone(), |e| format!("{}: {e}", c.kind))
        );
    }
    let pr = &res.prediction;
    if let (Some(med), Some(worst)) = (pr.median_ratio, pr.worst_ratio) {
        println!(
            "prediction: measured / predicted over {} finalists: median ×{:.2}, furthest ×{:.2} ({}){}",
            pr.finalists,
            med,
            worst,
            pr.worst_candidate.as_deref().unwrap_or("?"),
            if !(0.5..=2.0).contains(&med) {
                " — the single-option model is off by more than 2×: trust the measured column"
            } else {
                ""
            }
        );
    }
    println!("searched {} generated combinations within budget in {:.1} s", res.combinations, res.seconds);
    if !args.fit.is_empty() && !res.measured.iter().any(|c| c.kind == "generated") {
        println!(
            "--fit {}: no generated combination binds there at {}× (they pack fields into 32-bit integer targets, \
             which WebGPU, Vulkan and Metal do not guarantee to multisample); `gbuf layouts --check LAYOUT` says why \
             for any layout",
            args.fit.join(","),
            size.2
        );
    }
    if let Some(p) = &args.out {
        println!("layout written to {} (use it with --layout {})", p.display(), p.display());
    }
    Ok(())
}
