//! A study: the report job over one or many frames. Per frame the scene-needs analysis, the sweep of every layout ×
//! detector, the pruned layout's check, the pipelines comparison and the frame's figures; then the rows aggregated
//! over the frames into one [`Report`]. `gbuf report`, `gbuf demo` and `gbuf merge` run it; [`crate::report`] writes
//! what it returns.

use crate::analysis::aggregate::{aggregate, aggregate_detectors, BudgetChoice, Over};
use crate::analysis::needs;
use crate::analysis::pipelines::KnownFlip;
use crate::analysis::record::{Figure, Frame, Report};
use crate::analysis::row::Row;
use crate::analysis::sweep::{self, FlipRows, SweepConfig};
use crate::analysis::{pruned_layout, ReportInput};
use crate::error::Result;
use crate::measure::image::Viewing;
use crate::report::figures;
use crate::report::format::Attachment;
use crate::resolve::Lighting;

/// One frame's part of a report: its description, its rows, and its figures (file names prefixed as asked).
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The frame.
    pub frame: Frame,
    /// Its rows (`frame` set to the frame's input name; fronts marked within the frame).
    pub rows: Vec<Row>,
    /// Figure files.
    pub files: Vec<Attachment>,
    /// Their captions.
    pub figures: Vec<Figure>,
}

/// Runs the needs analysis and the sweep on one frame, prunes, and builds the frame's figures. With
/// `with_plots` the scatter plots of this frame are drawn (a single-frame report); `prefix` starts the figures'
/// file names.
pub fn run_frame(
    input: &ReportInput<'_>,
    cfg: &SweepConfig,
    with_plots: bool,
    prefix: &str,
    progress: sweep::Progress<'_>,
) -> Result<FrameResult> {
    let gb = input.gbuffer;
    // Wall time outside the sweep, by step (the sweep keeps its own by stage).
    let mut other = Vec::new();
    let mut clock = std::time::Instant::now();
    let mut lap = |kind: &str| {
        sweep::add_stage_time(&mut other, kind, clock.elapsed().as_secs_f64());
        clock = std::time::Instant::now();
    };
    let mut needs = needs::analyze(gb);
    if input.position_derived {
        needs.count_position_as_derivable();
    }
    let surface_maps = crate::analysis::surfaces::surface_maps(gb);
    lap("needs analysis");
    let mut out = sweep::sweep(gb, input.lights, cfg, progress)?;
    lap("sweep");
    for r in &mut out.rows {
        r.frame.clone_from(&input.name);
    }
    for d in &mut out.detectors {
        d.frame.clone_from(&input.name);
    }
    // The shading-rate figure's rule previews the lighting (none where the frame gives no positions to light).
    let r = &cfg.resolve;
    let preview = crate::resolve::LightPreview::new(gb, input.lights, r.falloff, r.brdf, cfg.viewing.tone()).ok();
    let preview = preview.as_ref().map(|p| p as &dyn crate::detect::rate::Preview);
    let (mut files, mut figures) = figures::figures(gb, preview, &out, with_plots, prefix)?;
    // What only the figures read is drawn: dropped before the pipelines, whose images are then the frame's peak
    // (the error maps, the displayed copies and FLIP map, the light counts: some 130 MB at 1080p).
    (out.maps, out.shown, out.reference_shown, out.worst_flip, out.lights_per_pixel) =
        (Vec::new(), Vec::new(), None, None, None);
    lap("figures");
    let pruned = pruned_layout(input, &needs, cfg, &out);
    lap("pruned layout");
    if let Some((p, layout)) = pruned {
        if !p.changes.is_empty() {
            if let Ok(text) = layout.spec().to_text(crate::layout::SpecSyntax::Toml) {
                files.push(Attachment { name: format!("{prefix}pruned_layout.toml"), bytes: text.into_bytes() });
            }
            // The pruned layout as shader code, when every codec it keeps has a recipe (docs/SHADERS.md).
            for lang in [
                crate::layout::shader::Lang::Glsl,
                crate::layout::shader::Lang::Hlsl,
                crate::layout::shader::Lang::Wgsl,
            ] {
                if let Ok(code) = crate::layout::shader::emit(&layout, lang) {
                    let name = format!("{prefix}pruned_layout.{}", lang.name());
                    files.push(Attachment { name, bytes: code.into_bytes() });
                }
            }
        }
        needs.pruned_layout = Some(p);
    }
    // The sweep's exact image per detector has its FLIP against the same reference already: the pipelines' adaptive
    // MSAA rows are those images, and take the numbers instead of a FLIP of their own.
    let known: Vec<KnownFlip<'_>> = out
        .exact
        .iter()
        .zip(&out.detectors)
        .filter_map(|(image, d)| {
            let e = d.aa_error.as_ref()?;
            Some(KnownFlip { image: image.as_ref()?, ldr: e.flip_ldr?, hdr: e.flip_hdr? })
        })
        .collect();
    let (pipelines, pipelines_error) = match crate::analysis::pipelines::pipelines_with(
        gb,
        input.lights,
        &crate::analysis::pipelines::PipelinesConfig { geometry: input.geometry, ..pipelines_config(cfg) },
        Some(&out.reference),
        input.single,
        &known,
    ) {
        Ok(p) => (Some(p), None),
        Err(e) => (None, Some(e.to_string())),
    };
    lap("pipelines");
    if let Some(p) = &pipelines {
        // One crop under every anti-aliasing method (a failure to draw it loses the picture, not the report).
        if let Ok((pic, (x, y, w, h))) = crate::report::pipelines::aa_crop_picture(p, &out.reference) {
            let name = format!("{prefix}aa_crops.png");
            files.push(Attachment { name: name.clone(), bytes: crate::base::picture::png_bytes(&pic)? });
            figures.push(Figure {
                file: name,
                caption: format!(
                    "Anti-aliasing: the {w}×{h} crop at ({x}, {y}) where no AA errs most, under the reference, no AA, \
                     MLAA, adaptive MSAA per detector and SSAA"
                ),
                against: None,
            });
        }
    }
    if let (Some(p), Some((det, mask))) = (&pipelines, out.masks.first()) {
        if let Some(fwd) = &p.forward_msaa {
            let (f, g) = figures::shading_figures(gb, fwd, (det, mask), prefix)?;
            files.extend(f);
            figures.extend(g);
        }
    }
    if let Some((f, g)) = figures::surfaces_figure(gb, &surface_maps, prefix)? {
        files.push(f);
        figures.push(g);
    }
    lap("figures");
    // Albedo above 1 is the data's error, not the packing's: what clamping it alone costs is said apart, beside
    // the layouts' errors that include it.
    let mut notes = input.notes.clone();
    let first = cfg.detectors.first().copied().unwrap_or(crate::detect::Detector::Lauritzen);
    // The sweep's exact image with the first detector is the baseline: lit once, not again here.
    let exact = out.exact.first().and_then(Option::as_ref);
    if let Some((n, max, e)) =
        crate::analysis::errors::albedo_clamp_error(gb, input.lights, exact, first, &cfg.detector_config, &cfg.resolve)?
    {
        notes.push(format!(
            "{n} covered albedos exceed 1 (up to {max:.3}); clamping them to [0, 1] alone — what every unorm and \
             sRGB albedo codec does — costs layout RMSE {:.5} (PSNR {:.2} dB) with `{}`: that much of each such \
             layout's error below is the data's, not the packing's",
            e.rmse,
            e.psnr_db,
            first.name()
        ));
        lap("albedo above 1");
    }
    let covered = gb.len() - gb.background_samples();
    let frame = Frame {
        input: input.name.clone(),
        width: gb.width,
        height: gb.height,
        samples: gb.samples,
        coverage: if gb.is_empty() { 0.0 } else { covered as f64 / gb.len() as f64 },
        lights: input.lights.len(),
        lights_source: input.lights_source.clone(),
        notes,
        reference: Some(out.reference_timing),
        sweep_seconds: out.seconds,
        stage_seconds: out.stage_seconds,
        other_seconds: other.into_iter().filter(|(k, _)| k != "sweep").collect(),
        needs,
        detectors: out.detectors,
        pipelines,
        pipelines_error,
        surfaces_per_pixel: Some(crate::analysis::surfaces::SurfacesPerPixel::of(gb.samples, &surface_maps)),
        fits: cfg.layouts.iter().map(|l| crate::analysis::record::LayoutFit::of(l, gb.samples)).collect(),
    };
    Ok(FrameResult { frame, rows: out.rows, files, figures })
}

/// The pipelines comparison's settings from a sweep's: its first detector, its first layout other than the lossless
/// baseline, its resolve settings, warps of 8 to 64 lanes, FLIP when the sweep computes it.
#[must_use]
pub fn pipelines_config(cfg: &SweepConfig) -> crate::analysis::pipelines::PipelinesConfig {
    let layout = cfg.layouts.iter().find(|l| l.name() != crate::analysis::LOSSLESS_BASELINE).or(cfg.layouts.first());
    crate::analysis::pipelines::PipelinesConfig {
        detector: cfg.detectors.first().copied().unwrap_or(crate::detect::Detector::Lauritzen),
        detector_config: cfg.detector_config,
        resolve: cfg.resolve,
        gbuffer_bytes: layout.map_or(20, |l| l.bytes_per_sample() as u32),
        layout: layout.map_or_else(|| "fat-20".to_string(), |l| l.name().to_string()),
        warps: vec![8, 16, 32, 64],
        viewing: (cfg.flip != FlipRows::None).then_some(cfg.viewing),
        aa_detectors: cfg.detectors.iter().copied().filter(|d| !d.is_baseline()).collect(),
        mlaa: crate::image::mlaa::MlaaConfig::default(),
        geometry: None,
        visibility_layout: crate::layout::Layout::by_name("visibility-8").expect("the built-in visibility layout"),
        compression_slots: None,
    }
}

/// How per-frame results are put together: the settings they were measured with and how to aggregate them.
#[derive(Clone, Debug, PartialEq)]
pub struct Assembly {
    /// Timing runs per stage.
    pub runs: usize,
    /// How the images were shown for FLIP.
    pub viewing: Viewing,
    /// Which rows got FLIP.
    pub flip: FlipRows,
    /// Mean or worst frame.
    pub over: Over,
    /// A byte budget to pick the winning layout for.
    pub max_bytes: Option<u32>,
    /// The lighting model the rows were lit with, and why.
    pub lighting: Option<Lighting>,
}

impl Assembly {
    /// The settings of `cfg`, aggregated by `over`; its lighting is `cfg.resolve`'s, for the reason `why`.
    #[must_use]
    pub fn of(cfg: &SweepConfig, over: Over, max_bytes: Option<u32>, why: &str) -> Self {
        Assembly {
            runs: cfg.runs.max(1),
            viewing: cfg.viewing,
            flip: cfg.flip,
            over,
            max_bytes,
            lighting: Some(Lighting::of(&cfg.resolve, why)),
        }
    }
}

/// Assembles a report from per-frame results (of one run, or read back from several `report.json` files):
/// aggregates the rows and detectors over the frames and, for more than one frame, draws the aggregate plots.
/// Returns the report and the plot files (the frames' own figures are the caller's).
pub fn assemble(
    frames: Vec<Frame>,
    rows: Vec<Row>,
    mut figures: Vec<Figure>,
    how: &Assembly,
) -> Result<(Report, Vec<Attachment>)> {
    let over = how.over;
    let aggregate_rows = aggregate(&rows, over);
    let budget = how.max_bytes.map(|b| BudgetChoice::of(&aggregate_rows, b, over));
    let detectors: Vec<_> = frames.iter().flat_map(|f| f.detectors.iter().cloned()).collect();
    let detectors = aggregate_detectors(&detectors, over);
    let mut files = Vec::new();
    if frames.len() > 1 {
        let (f, figs) = figures::aggregate_figures(&aggregate_rows, over)?;
        files = f;
        figures.splice(0..0, figs);
    }
    let rep = Report {
        frames,
        runs: how.runs,
        viewing: how.viewing,
        flip: how.flip,
        over,
        lighting: how.lighting.clone(),
        rows,
        aggregate: aggregate_rows,
        detectors,
        budget,
        figures,
    };
    Ok((rep, files))
}

/// A frame the frames loop owns while it sweeps it ([`run_frames`] holds one at a time).
#[derive(Clone, Debug)]
pub struct FrameInput {
    /// The frame's name (its path, or the scene's name).
    pub name: String,
    /// The G-buffer.
    pub gbuffer: crate::GBuffer,
    /// Its view-space lights.
    pub lights: Vec<crate::Light>,
    /// Where the lights came from.
    pub lights_source: String,
    /// The same frame with 1 sample at pixel centres (`--single`, or rendered by the demo).
    pub single: Option<crate::GBuffer>,
    /// The analytic scene it was rendered from (the demo).
    pub geometry: Option<crate::scene::SceneName>,
    /// The reader's notes every output repeats (`no-float-truth` for packed targets).
    pub notes: Vec<String>,
}

/// What the frames loop tells its caller as it goes.
#[derive(Clone, Copy, Debug)]
pub enum Event<'a> {
    /// The lighting model every frame is lit with, and why (the first frame's data chose it unless overridden).
    Lighting(&'a Lighting),
    /// A later frame whose data would choose another BRDF: it is lit as the first, since the rows aggregate.
    LightingDiffers {
        /// The frame.
        frame: &'a str,
        /// What its data would choose.
        would: &'a Lighting,
        /// What every frame is lit with.
        chosen: &'a Lighting,
    },
    /// Frame `frame` (from 0) of `count`: `done` of `total` steps, now `what`.
    Progress {
        /// The frame's index.
        frame: usize,
        /// How many frames.
        count: usize,
        /// Steps done.
        done: usize,
        /// Steps in all.
        total: usize,
        /// The step now running.
        what: &'a str,
    },
}

/// The report job over `count` frames: `next(i)` yields frame `i` (so only one is in memory at a time), each is
/// swept ([`run_frame`]) and the results assembled ([`assemble`]). Every frame is lit with one model: what `choose`
/// gives for the first frame's stored attributes (e.g. `|a| Lighting::choose(None, None, a)`: the data's choice,
/// [`Lighting::choose`]); a later frame for which it differs is announced. With more than one frame
/// the figures' files are prefixed `frameN_`. Returns the report and every figure file; `on` hears the lighting
/// choice and the progress.
pub fn run_frames<E: From<crate::Error>>(
    count: usize,
    mut next: impl FnMut(usize) -> std::result::Result<FrameInput, E>,
    cfg: &SweepConfig,
    choose: &dyn Fn(&[crate::gbuffer::Attribute]) -> Lighting,
    how: &Assembly,
    on: &mut dyn FnMut(Event<'_>),
) -> std::result::Result<(Report, Vec<Attachment>), E> {
    let mut cfg = cfg.clone();
    let mut how = how.clone();
    let (mut frames, mut rows, mut files, mut figures) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in 0..count {
        let t = std::time::Instant::now();
        let mut f = next(i)?;
        let load_seconds = t.elapsed().as_secs_f64();
        let here = choose(&f.gbuffer.attributes());
        // Positions that depth and the camera give bit for bit are not held through the report (95 MB at 1080p × 4):
        // every reader derives the same bits.
        let position_derived = f.gbuffer.position_is_derived();
        if position_derived {
            f.gbuffer.position = None;
        }
        match &how.lighting {
            Some(chosen) if i > 0 => {
                if chosen.brdf != here.brdf {
                    on(Event::LightingDiffers { frame: &f.name, would: &here, chosen });
                }
            }
            _ => {
                on(Event::Lighting(&here));
                cfg.resolve = here.apply(cfg.resolve);
                how.lighting = Some(here);
            }
        }
        let input = ReportInput {
            name: f.name.clone(),
            gbuffer: &f.gbuffer,
            lights: &f.lights,
            lights_source: f.lights_source.clone(),
            single: f.single.as_ref(),
            geometry: f.geometry,
            notes: f.notes.clone(),
            position_derived,
        };
        let prefix =
            if count > 1 { format!("frame{:0w$}_", i + 1, w = count.to_string().len()) } else { String::new() };
        let mut progress =
            |done: usize, total: usize, what: &str| on(Event::Progress { frame: i, count, done, total, what });
        let r = run_frame(&input, &cfg, count == 1, &prefix, &mut progress).map_err(|e| crate::Error::InFrame {
            frame: f.name.clone(),
            step: "report",
            source: e.into(),
        })?;
        let mut frame = r.frame;
        frame.other_seconds.insert(0, ("reading the input".to_string(), load_seconds));
        frames.push(frame);
        rows.extend(r.rows);
        files.extend(r.files);
        figures.extend(r.figures);
    }
    let (rep, plots) = assemble(frames, rows, figures, &how)?;
    files.extend(plots);
    Ok((rep, files))
}
