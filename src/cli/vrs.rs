//! `gbuf vrs FILE [--tile 8,16,32] [--mode broadcast|lighting] [--extra-rates] [--out DIR] [--json]`: shading less
//! than once per pixel where the G-buffer says it is safe: gbuf's shading-rate image per tile size, the lighting
//! evaluations it saves and what it costs in the image (`gbuf::analysis::vrs`).

use crate::cli::common::{print_json, InputArgs, ThresholdArgs};
use anyhow::Context;
use gbuf::analysis::vrs::{vrs, VrsConfig};
use gbuf::detect::rate::CoarseMode;
use gbuf::detect::Detector;
use gbuf::measure::image::Viewing;
use gbuf::resolve::ResolveConfig;
use std::path::PathBuf;

/// Flags of `gbuf vrs`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump to read.
    #[command(flatten)]
    pub input: InputArgs,
    /// Shading-rate tile sizes in pixels (8, 16, 32).
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_value = "8,16,32")]
    pub tile: Vec<u32>,
    /// How a coarse pixel's evaluation reaches its pixels: `broadcast` (its colour copied) or `lighting` (its
    /// lighting times each pixel's own albedo).
    #[arg(long, value_name = "MODE", default_value = "broadcast")]
    pub mode: String,
    /// Allow the additional rates 2x4, 4x2 and 4x4 (D3D12 `AdditionalShadingRatesSupported`); `ffx` is then AMD's
    /// build of its pass with them.
    #[arg(long)]
    pub extra_rates: bool,
    /// Edge detector whose pixels are shaded per sample whatever their tile's rate.
    #[arg(long, value_name = "D", default_value = "lauritzen")]
    pub detector: Detector,
    /// Detector thresholds.
    #[command(flatten)]
    pub thresholds: ThresholdArgs,
    /// Lighting model of the resolve and the reference.
    #[command(flatten)]
    pub lighting: crate::cli::common::LightingArgs,
    /// The lights.
    #[command(flatten)]
    pub scatter: crate::cli::common::LightsArgs,
    /// Skip FLIP (numerical errors only).
    #[arg(long, conflicts_with = "max_flip")]
    pub no_flip: bool,
    /// Also find, per tile size, the largest saving of gbuf's rule (its thresholds scaled from 1/16 to 16×) whose
    /// LDR-FLIP against the full-rate image stays at or under this value: a `gbuffer-max-flip` row.
    #[arg(long, value_name = "FLIP")]
    pub max_flip: Option<f64>,
    /// Write, per generator and tile size, the SRI as D3D12 reads it (`sri_<generator>_<tile>.dds`: R8_UINT, one
    /// `D3D12_SHADING_RATE` per tile), as a picture in the rate colours (`sri_<generator>_<tile>.png`) and the
    /// coarse-shaded image (`coarse_<generator>_<tile>.png`, Reinhard tone map) into this folder, and the full-rate
    /// image `ffx` reads (`full_rate.exr`, linear).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// The wave width FidelityFX VRS's reductions run over: 64 on AMD's GPUs (its SDK's build), 32 on NVIDIA's.
    #[arg(long, value_name = "LANES", default_value_t = gbuf::analysis::vrs::FFX_WAVE)]
    pub ffx_wave: u32,
    /// FidelityFX VRS's `VarianceCutoff`: the luminance difference (linear, 0.30 R + 0.59 G + 0.11 B) under which
    /// it shades coarser. AMD's sample sets 0.015.
    #[arg(long, value_name = "LUMINANCE", default_value_t = gbuf::analysis::vrs::FFX_VARIANCE_CUTOFF)]
    pub ffx_cutoff: f32,
    /// gbuf's rule: the largest mean error per pixel of a tile, in 8-bit codes, that sharing evaluations may cost
    /// by the lighting's preview (0: the G-buffer alone, without the lights).
    #[arg(long, value_name = "CODES", default_value_t = gbuf::detect::rate::DEFAULT_PREVIEW * 255.0)]
    pub preview: f32,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf vrs`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mode = match args.mode.to_ascii_lowercase().as_str() {
        "broadcast" => CoarseMode::Broadcast,
        "lighting" => CoarseMode::Lighting,
        m => crate::usage!("--mode {m}: broadcast or lighting"),
    };
    if args.tile.is_empty() || args.tile.iter().any(|t| ![8, 16, 32].contains(t)) {
        crate::usage!("--tile: sizes 8, 16 or 32 separated by commas, got {:?}", args.tile);
    }
    let file = args.input.file.display().to_string();
    let loaded = args.input.load().with_context(|| format!("loading {file}"))?;
    let (lights, _) = args.scatter.of(&loaded);
    let gb = loaded.gbuffer;
    let lighting = args.lighting.choose(&gb.attributes());
    if !args.json {
        crate::cli::common::say_lighting(&lighting);
    }
    let cfg = VrsConfig {
        tiles: args.tile.clone(),
        extra_rates: args.extra_rates,
        mode,
        detector: args.detector,
        detector_config: args.thresholds.config()?,
        resolve: lighting.apply(ResolveConfig::default()),
        viewing: (!args.no_flip).then(Viewing::default),
        rule: gbuf::detect::rate::Smoothness { preview: args.preview / 255.0, ..Default::default() },
        max_flip: args.max_flip,
        ffx_wave: args.ffx_wave,
        ffx_cutoff: args.ffx_cutoff,
    };
    if !(args.ffx_wave.is_power_of_two() && (4..=128).contains(&args.ffx_wave)) {
        crate::usage!("--ffx-wave {}: a power of two from 4 to 128", args.ffx_wave);
    }
    if !(args.ffx_cutoff.is_finite() && args.ffx_cutoff >= 0.0) {
        crate::usage!("--ffx-cutoff {}: a luminance difference of 0 or more", args.ffx_cutoff);
    }
    if !(args.preview.is_finite() && args.preview >= 0.0) {
        crate::usage!("--preview {}: a mean error in 8-bit codes ≥ 0, e.g. 0.1 (0: no preview term)", args.preview);
    }
    if args.max_flip.is_some_and(|f| !(f.is_finite() && f > 0.0)) {
        crate::usage!("--max-flip: a positive FLIP value, e.g. 0.01");
    }
    let out = vrs(&gb, &lights, &cfg).with_context(|| format!("{file}: shading rates"))?;
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut staged = gbuf::base::files::Staged::default();
        for ((row, sri), image) in out.rows.iter().zip(&out.sris).zip(&out.images) {
            let dds = gbuf::layout::dds::r8_uint_dds(sri.cols, sri.rows, &sri.d3d12_texels());
            staged.stage_bytes(&dir.join(format!("sri_{}_{}.dds", row.generator, row.tile)), &dds)?;
            let pic = gbuf::base::png::encode_rgb8(gb.width, gb.height, &sri.picture(gb.width, gb.height))?;
            staged.stage_bytes(&dir.join(format!("sri_{}_{}.png", row.generator, row.tile)), &pic)?;
            let shown = gbuf::base::png::encode_rgb8(gb.width, gb.height, &image.to_srgb8(Default::default()))?;
            staged.stage_bytes(&dir.join(format!("coarse_{}_{}.png", row.generator, row.tile)), &shown)?;
        }
        let exr = dir.join("full_rate.exr");
        staged.stage_bytes(&exr, &out.full_rate.exr_bytes(&exr)?)?;
        staged.commit()?;
    }
    if args.json {
        return print_json(&out);
    }
    let flip = |e: &gbuf::measure::image::ErrorSet| match (e.flip_ldr, e.flip_hdr) {
        (Some(l), Some(h)) => format!("{l:>8.4} {h:>8.4}"),
        _ => format!("{:>8} {:>8}", "-", "-"),
    };
    let allowed: Vec<&str> = gbuf::detect::rate::Rate::ALL
        .iter()
        .filter(|r| r.allowed(gb.samples, args.extra_rates))
        .map(|r| r.name())
        .collect();
    println!(
        "{file}: {}×{}×{}, detector {} ({:.3} evaluations per pixel at full rate), coarse pixels {} their evaluation, \
         rates {} (D3D12 at {} sample{}{})",
        gb.width,
        gb.height,
        gb.samples,
        out.detector,
        out.full_rate_evaluations_per_pixel,
        if mode == CoarseMode::Broadcast { "broadcast" } else { "remodulate by their albedo" },
        allowed.join(" "),
        gb.samples,
        if gb.samples == 1 { "" } else { "s" },
        if args.extra_rates { ", additional rates on" } else { "" }
    );
    println!(
        "{:<26} {:>5} {:>9} {:>7} {:>8} {:>6} | vs full rate: {:>9} {:>8} {:>8} | vs reference: {:>9} {:>8} {:>8} | \
         tiles per rate",
        "generator",
        "tile",
        "eval/px",
        "saved",
        "shade ms",
        "SRI ms",
        "RMSE",
        "LDR-FLIP",
        "HDR-FLIP",
        "RMSE",
        "LDR-FLIP",
        "HDR-FLIP"
    );
    let r = &out.full_rate_vs_reference;
    println!(
        "{:<26} {:>5} {:>9.3} {:>6.1}% {:>8.1} {:>6} | {:>23} {:>9} {:>8} | {:>28.3e} {} |",
        "full rate",
        "-",
        out.full_rate_evaluations_per_pixel,
        0.0,
        out.full_rate_shade_ms,
        "-",
        "",
        "",
        "",
        r.rmse,
        flip(r)
    );
    for row in &out.rows {
        let rates: Vec<String> = row.rates.iter().map(|(n, k)| format!("{n} {k}")).collect();
        let name = match row.rule_scale {
            Some(k) => format!("{} (rule ×{k})", row.generator),
            None => row.generator.clone(),
        };
        println!(
            "{:<26} {:>5} {:>9.3} {:>6.1}% {:>8.1} {:>6} | {:>23.3e} {} | {:>28.3e} {} | {}",
            name,
            row.tile,
            row.evaluations_per_pixel,
            100.0 * row.saved,
            row.shade_ms,
            row.sri_ms.map_or_else(|| "-".to_string(), |ms| format!("{ms:.1}")),
            row.vs_full_rate.rmse,
            flip(&row.vs_full_rate),
            row.vs_reference.rmse,
            flip(&row.vs_reference),
            rates.join(", ")
        );
    }
    println!(
        "(the coarse resolve shades each coarse pixel once and its edge pixels per sample; shade ms: the light \
         loop, the work lists shaded against their lights, one run each on this machine's {} threads)",
        rayon::current_num_threads()
    );
    Ok(())
}
