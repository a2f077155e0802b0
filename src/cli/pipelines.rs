//! `gbuf pipelines FILE [--detector D] [--layout L] [--warps 8,16,32,64] [--heatmap OUT.png] [--flip] [--json]`:
//! forward, forward MSAA, forward+, deferred (quad-culled, tiled), light pre-pass and visibility buffer on one
//! frame, in one table.

use crate::cli::common::{print_json, InputArgs, ThresholdArgs};
use anyhow::Context;
use gbuf::analysis::pipelines::{pipelines, PipelinesConfig};
use gbuf::detect::{self, Detector};
use gbuf::image::mlaa::MlaaConfig;
use gbuf::layout::Layout;
use gbuf::measure::image::Viewing;
use gbuf::resolve::ResolveConfig;
use std::io::Write;
use std::path::PathBuf;

/// Flags of `gbuf pipelines`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The dump to read.
    #[command(flatten)]
    pub input: InputArgs,
    /// Edge detector of the deferred rows.
    #[arg(long, value_name = "D", default_value = "lauritzen")]
    pub detector: Detector,
    /// Detector thresholds.
    #[command(flatten)]
    pub thresholds: ThresholdArgs,
    /// G-buffer layout of the deferred rows (built-in name or TOML/JSON file): its bytes per sample set their
    /// footprint and traffic.
    #[arg(long, value_name = "L", default_value = "fat-20")]
    pub layout: String,
    /// Layout of the visibility-buffer row (built-in name or layout file; IDs + depth): its bytes per sample set the
    /// row's footprint and traffic, and the frame is packed with it to check the IDs survive.
    #[arg(long, value_name = "L", default_value = "visibility-8")]
    pub visibility_layout: String,
    /// Edge detectors the anti-aliasing table compares as adaptive MSAA (beside no AA, MLAA and SSAA).
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_values_t = gbuf::analysis::pipelines::DEFAULT_AA_DETECTORS)]
    pub aa_detectors: Vec<Detector>,
    /// Warp widths of the MSAA schedules' utilisation table.
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_value = "8,16,32,64")]
    pub warps: Vec<u32>,
    /// Lighting model of the resolve and the reference.
    #[command(flatten)]
    pub lighting: crate::cli::common::LightingArgs,
    /// The lights.
    #[command(flatten)]
    pub scatter: crate::cli::common::LightsArgs,
    /// Also compute LDR-FLIP and HDR-FLIP of every pipeline's image (Reinhard tone map, exposure 1).
    #[arg(long)]
    pub flip: bool,
    /// Write forward MSAA's lanes per pixel beside the deferred evaluations per pixel as a heatmap PNG (same scale;
    /// needs primitive IDs).
    #[arg(long, value_name = "OUT.png")]
    pub heatmap: Option<PathBuf>,
    /// The dump is gbuf's analytic scene NAME (`gbuf scene NAME`, same size): re-materialise the visibility
    /// buffer's attributes from its triangles and compare them with the G-buffer.
    #[arg(long, value_name = "NAME")]
    pub geometry: Option<gbuf::scene::SceneName>,
    /// Write the anti-aliasing picture: the crop where no AA errs most, under the reference and each method.
    #[arg(long, value_name = "OUT.png")]
    pub aa_crops: Option<PathBuf>,
    /// The same frame rendered with 1 sample per pixel at pixel centres (same size, read with the same options):
    /// the no-AA image that MLAA smooths, and forward shading's exact quads. Without it sample 0 of an MSAA dump
    /// stands in, off the pixel centre, and those rows are marked as estimates.
    #[arg(long, value_name = "FILE")]
    pub single: Option<PathBuf>,
    /// Surface slots per pixel of the compressed-G-buffer rows (Kerzner & Salvi's streaming compression):
    /// default 1 to 4 and the sample count (plus a row of 2 AGAA-style aggregates); `none` for no compressed rows.
    #[arg(long, value_name = "LIST|none", value_delimiter = ',')]
    pub slots: Option<Vec<String>>,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gbuf pipelines`.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.warps.is_empty() || args.warps.iter().any(|&w| w == 0 || w > 1024) {
        crate::usage!("--warps: widths between 1 and 1024 lanes, got {:?}", args.warps);
    }
    let compression_slots = match args.slots.as_deref() {
        None => None,
        Some([none]) if none == "none" => Some(Vec::new()),
        Some(list) => match list.iter().map(|k| k.parse::<u32>().ok().filter(|&k| k >= 1)).collect() {
            Some(k) => Some(k),
            None => crate::usage!("--slots: counts of at least 1 separated by commas, or none; got {list:?}"),
        },
    };
    crate::cli::common::check_output_folders(
        [&args.aa_crops, &args.heatmap].into_iter().flatten().map(std::path::PathBuf::as_path),
    )?;
    let layout = Layout::by_name_or_path(&args.layout).with_context(|| format!("--layout {}", args.layout))?;
    let file = args.input.file.display().to_string();
    let pb = crate::cli::spinner(format!("loading {file}"));
    let loaded = args.input.load().with_context(|| format!("loading {file}"))?;
    let (lights, lights_source) = args.scatter.of(&loaded);
    let gb = loaded.gbuffer;
    if args.heatmap.is_some() && !gb.has(gbuf::gbuffer::Attribute::PrimitiveId) {
        anyhow::bail!(
            "--heatmap: {file} has no primitive IDs, so forward shading's quads cannot be counted (nothing was \
             written)"
        );
    }
    let lighting = args.lighting.choose(&gb.attributes());
    pb.suspend(|| crate::cli::common::say_lighting(&lighting));
    let cfg = PipelinesConfig {
        detector: args.detector,
        detector_config: args.thresholds.config()?,
        resolve: lighting.apply(ResolveConfig::default()),
        gbuffer_bytes: layout.bytes_per_sample() as u32,
        layout: layout.name().to_string(),
        warps: args.warps.clone(),
        viewing: args.flip.then(Viewing::default),
        aa_detectors: args.aa_detectors.clone(),
        mlaa: MlaaConfig::default(),
        geometry: args.geometry,
        visibility_layout: Layout::by_name_or_path(&args.visibility_layout)
            .with_context(|| format!("--visibility-layout {}", args.visibility_layout))?,
        compression_slots,
    };
    let single = match &args.single {
        Some(path) => {
            let one = args.input.load_path(path).with_context(|| format!("loading --single {}", path.display()))?;
            gbuf::analysis::pipelines::check_single(&gb, &one.gbuffer)
                .with_context(|| format!("--single {} against {file}", path.display()))?;
            Some(one.gbuffer)
        }
        None => None,
    };
    pb.set_message(format!("{file}: the every-sample reference"));
    let reference =
        gbuf::resolve::reference(&gb, &lights, &cfg.resolve).with_context(|| format!("{file}: reference"))?;
    pb.set_message(format!(
        "{file}: forward, deferred and visibility-buffer rows, anti-aliasing, compressed G-buffers{}",
        if cfg.viewing.is_some() { ", FLIP" } else { "" }
    ));
    let p = pipelines(&gb, &lights, &cfg, Some(&reference), single.as_ref())
        .with_context(|| format!("{file}: pipelines"))?;
    pb.finish_and_clear();
    if let (Some(name), Some(e)) = (args.geometry, &p.rematerialise_error) {
        anyhow::bail!("{file}: --geometry {name}: {e}");
    }
    // Both pictures are staged and renamed into place together: a failure leaves neither.
    let mut staged = gbuf::base::files::Staged::default();
    let mut said = Vec::new();
    if let Some(path) = &args.aa_crops {
        let (pic, (x, y, w, h)) = gbuf::report::pipelines::aa_crop_picture(&p, &reference)?;
        let png = gbuf::base::picture::png_bytes(&pic).with_context(|| format!("encoding {}", path.display()))?;
        staged.stage_bytes(path, &png).with_context(|| format!("writing {}", path.display()))?;
        said.push(format!("wrote {}: the {w}×{h} crop at ({x}, {y}) under each anti-aliasing method", path.display()));
    }
    if let Some(path) = &args.heatmap {
        let fwd = p.forward_msaa.as_ref().with_context(|| {
            format!("--heatmap: {file} has no primitive IDs, so forward shading's quads cannot be counted")
        })?;
        let mask = detect::detect(&gb, args.detector, &cfg.detector_config)?;
        let (png, max) = gbuf::report::pipelines::shading_heatmaps_png(fwd, &mask)
            .with_context(|| format!("encoding {}", path.display()))?;
        staged.stage_bytes(path, &png).with_context(|| format!("writing {}", path.display()))?;
        said.push(format!(
            "wrote {}: forward MSAA lanes (left) and deferred evaluations (right) per pixel, scale 0..{max}",
            path.display()
        ));
    }
    staged.commit().context("renaming the pictures into place")?;
    for s in said {
        eprintln!("{s}");
    }
    if args.json {
        return print_json(&p);
    }
    let mut out = std::io::stdout().lock();
    writeln!(out, "{file}: lights {lights_source}")?;
    write!(out, "{}", gbuf::report::pipelines::pipelines_markdown(&p, 2))?;
    Ok(())
}
