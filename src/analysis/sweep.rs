//! The sweep: layouts × detectors (× culling modes) on one G-buffer with its lights.
//!
//! Input: the reference G-buffer, its lights, the lists to sweep. Output: one [`Row`] per combination with the
//! attribute errors of the layout's roundtrip, the lit image's error against the reference (lit once per sweep
//! from the unquantized G-buffer with every sample shaded), the shading fraction, the detector's precision and
//! recall against ground truth, and the measured stage times (medians of `runs` runs with their spread). A
//! combination that fails records why in `error` and the sweep goes on.
//!
//! Besides the rows it keeps what the figures need: per-pixel error maps of every layout, the edge masks of the
//! first layout, and a light-count map.

use crate::analysis::row::{mark_pareto, time_runs, Compressed, Row, Timing};
use crate::analysis::traffic::bandwidth;
use crate::detect::{self, Detector, DetectorConfig, EdgeMask};
use crate::error::Result;
use crate::gbuffer::{Attribute, GBuffer};
use crate::image::HdrImage;
use crate::layout::{Layout, LightingSource, LitFrame, PackedFrame, PreparedLighting};
use crate::light::Light;
use crate::measure;
use crate::measure::flip::FlipMap;
use crate::measure::image::{error_set, flip_many, flip_means, ErrorSet, Viewing};
use crate::resolve::{self, Culling, ResolveConfig};
use rayon::prelude::*;
use serde::Serialize;

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepConfig {
    /// Layouts (rows are grouped by layout).
    pub layouts: Vec<Layout>,
    /// Detectors.
    pub detectors: Vec<Detector>,
    /// Detector thresholds.
    pub detector_config: DetectorConfig,
    /// Culling modes to vary; empty = only `resolve.culling`.
    pub culling: Vec<Culling>,
    /// Resolve settings (BRDF, falloff, tiles, default culling).
    pub resolve: ResolveConfig,
    /// Timing runs per stage (the median and spread are reported).
    pub runs: usize,
    /// Which rows get FLIP.
    pub flip: FlipRows,
    /// How the images are shown for FLIP.
    pub viewing: Viewing,
}

crate::named_enum! {
    /// Which rows of a sweep get the perceptual error (FLIP costs about as much as a resolve at 1080p).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum FlipRows: "FLIP selection" {
        /// Where it decides: each layout's errors with the first detector (and first culling mode), and each
        /// detector's anti-aliasing error.
        #[default]
        Decisive => "decisive",
        /// Every row.
        All => "all",
        /// None (numerical errors only).
        None => "none",
    }
}

/// Per-pixel error maps of one layout (row-major; NaN = background pixel: no covered sample). Plain `f32`s, 4 bytes
/// a pixel rather than an `Option<f32>`'s 8. Only the [`HEATMAP_LAYOUTS`] layouts with the largest layout error
/// keep them, and their attribute maps are drawn once the sweep is over ([`attribute_maps`]): while each layout drew
/// its own beside its packed frame they were a tenth of the report's peak memory.
#[derive(Clone, Debug)]
pub struct ErrorMaps {
    /// Layout name.
    pub layout: String,
    /// Largest normal angle error over the pixel's covered samples, degrees.
    pub normal_deg: Option<Vec<f32>>,
    /// Largest relative depth error.
    pub depth_rel: Option<Vec<f32>>,
    /// Largest absolute albedo error (any channel).
    pub albedo_abs: Option<Vec<f32>>,
    /// Absolute image error (largest channel) of the layout's first detector row against the exact G-buffer lit
    /// with the same detector: where the layout's loss shows.
    pub image_abs: Option<Vec<f32>>,
}

/// Everything a sweep produces.
#[derive(Clone, Debug)]
pub struct SweepOutput {
    /// The rows, Pareto flags set.
    pub rows: Vec<Row>,
    /// The reference image.
    pub reference: HdrImage,
    /// Timing of the reference resolve.
    pub reference_timing: Timing,
    /// Error maps, one per layout that could be roundtripped; only the [`HEATMAP_LAYOUTS`] with the largest layout
    /// error keep their per-pixel planes.
    pub maps: Vec<ErrorMaps>,
    /// Edge masks of the first layout, per detector.
    pub masks: Vec<(String, EdgeMask)>,
    /// Lights per pixel from the first successful resolve.
    pub lights_per_pixel: Option<Vec<u32>>,
    /// Per detector (in sweep order): the anti-aliasing error of the exact G-buffer lit with it, and its shading
    /// fraction there.
    pub detectors: Vec<DetectorResult>,
    /// The exact G-buffer lit with each detector (sweep order): what layout errors are measured against.
    pub exact: Vec<Option<HdrImage>>,
    /// The LDR-FLIP map of the layout with the largest layout FLIP (first detector), with its name.
    pub worst_flip: Option<(String, FlipMap)>,
    /// Per layout (first detector), its lit image as LDR-FLIP sees it on the display (tone-mapped 8-bit sRGB,
    /// interleaved RGB): the report's A/B views. Empty without FLIP.
    pub shown: Vec<(String, Vec<u8>)>,
    /// The reference as displayed the same way (when `shown` is not empty).
    pub reference_shown: Option<Vec<u8>>,
    /// Wall time of the sweep in seconds.
    pub seconds: f64,
    /// Wall time by kind of stage (`reference`, `detectors on the exact G-buffer`, `pack/unpack`, `detect`,
    /// `resolve`, `FLIP`), in seconds, in the order first met.
    pub stage_seconds: Vec<(String, f64)>,
}

/// A detector on the exact G-buffer: what its anti-aliasing costs in error and in shading.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct DetectorResult {
    /// The frame.
    #[serde(default)]
    pub frame: String,
    /// Detector name.
    pub detector: String,
    /// Shaded samples / all samples on the exact G-buffer.
    pub shading_fraction: Option<f64>,
    /// Fraction of pixels shaded per sample.
    pub edge_fraction: Option<f64>,
    /// The exact G-buffer lit with this detector against the every-sample reference.
    pub aa_error: Option<ErrorSet>,
    /// Light-fragment pairs of a quad-culled resolve with this detector's mask.
    pub quad_light_fragments: Option<u64>,
    /// On the front of anti-aliasing error against shading fraction (among this frame's detectors).
    pub on_front: bool,
    /// Why a number is missing.
    pub error: Option<String>,
}

/// Progress callback: (done, total, what is running).
pub type Progress<'a> = &'a mut dyn FnMut(usize, usize, &str);

/// The per-pixel maximum of `f(i)` over the covered samples of each pixel of `band` (a band's samples `i`; NaN
/// where none is covered), into `out` (the band's pixels of a frame-sized map).
fn per_pixel(band: &GBuffer, out: &mut [f32], f: impl Fn(usize) -> f32 + Sync) {
    let s = band.samples as usize;
    out.par_iter_mut().enumerate().for_each(|(p, o)| {
        *o = (p * s..(p + 1) * s).filter(|&i| band.coverage[i]).map(&f).fold(f32::NAN, f32::max);
    });
}

/// The error maps of `test`, a band of `reference`'s rows starting at pixel `first_pixel` (the whole frame at 0),
/// into `maps` (frame-sized maps created when both G-buffers have the attribute).
fn error_maps_into(reference: &GBuffer, test: &GBuffer, first_pixel: usize, maps: &mut ErrorMaps) {
    fn map(m: &mut Option<Vec<f32>>, n: usize, px: std::ops::Range<usize>) -> &mut [f32] {
        &mut m.get_or_insert_with(|| vec![f32::NAN; n])[px]
    }
    let (n, s) = (reference.pixel_count(), reference.samples as usize);
    let px = first_pixel..first_pixel + test.pixel_count();
    let base = first_pixel * s;
    if let (Some(a), Some(b)) = (reference.normal.as_deref(), test.normal.as_deref()) {
        per_pixel(test, map(&mut maps.normal_deg, n, px.clone()), |i| {
            // 2·atan2(|a−b|, |a+b|) of the unit vectors: exact for small angles, where acos of the dot product
            // loses ~0.02° to f32 rounding (the rows' angles come from measure::gbuffer::angle_deg, in f64).
            let (u, v) = (a[base + i].normalize_or_zero(), b[i].normalize_or_zero());
            if u == glam::Vec3::ZERO || v == glam::Vec3::ZERO {
                if u == v {
                    0.0
                } else {
                    180.0
                }
            } else {
                (2.0 * (u - v).length().atan2((u + v).length())).to_degrees()
            }
        });
    }
    if let (Some(a), Some(b)) = (reference.depth.as_deref(), test.depth.as_deref()) {
        per_pixel(test, map(&mut maps.depth_rel, n, px.clone()), |i| {
            let a = a[base + i];
            ((b[i] - a) / a.abs().max(f32::MIN_POSITIVE)).abs()
        });
    }
    if let (Some(a), Some(b)) = (reference.albedo.as_deref(), test.albedo.as_deref()) {
        per_pixel(test, map(&mut maps.albedo_abs, n, px), |i| (b[i] - a[base + i]).abs().max_element());
    }
}

fn image_abs(reference: &HdrImage, test: &HdrImage) -> Vec<f32> {
    reference.rgb.par_iter().zip(&test.rgb).map(|(a, b)| (*b - *a).abs().max_element()).collect()
}

/// Each detector on the exact G-buffer: the mask, the image (what layouts are compared with for their layout
/// error), its anti-aliasing error against the reference and the quad schedule's light-fragment pairs.
fn detector_results(
    gb: &GBuffer,
    lights: &[Light],
    cfg: &SweepConfig,
    reference: &HdrImage,
) -> (Vec<Option<HdrImage>>, Vec<DetectorResult>) {
    let mut images = Vec::new();
    let mut results = Vec::new();
    for &d in &cfg.detectors {
        let mut r = DetectorResult {
            frame: String::new(),
            detector: d.name().to_string(),
            shading_fraction: None,
            edge_fraction: None,
            aa_error: None,
            quad_light_fragments: None,
            on_front: false,
            error: None,
        };
        let lit = detect::detect(gb, d, &cfg.detector_config).and_then(|mask| {
            let res = resolve::resolve(gb, lights, &mask, &cfg.resolve)?;
            let quad = if cfg.resolve.culling == Culling::Quad {
                res.stats.light_pairs_tested
            } else {
                let q = ResolveConfig { culling: Culling::Quad, ..cfg.resolve };
                resolve::resolve(gb, lights, &mask, &q)?.stats.light_pairs_tested
            };
            Ok((mask, res, quad))
        });
        match lit {
            Ok((mask, res, quad)) => {
                r.shading_fraction = Some(mask.evaluated_fraction(&detect::covered_per_pixel(gb)));
                r.edge_fraction = Some(mask.edge_fraction());
                r.aa_error = Some(error_set(reference, &res.image, None));
                r.quad_light_fragments = Some(quad);
                images.push(Some(res.image));
            }
            Err(e) => {
                r.error = Some(format!("exact G-buffer with {}: {e}", d.name()));
                images.push(None);
            }
        }
        results.push(r);
    }
    // Their FLIP against the reference comes with the first batch of rows' images ([`flush_flip`]).
    mark_detector_front(&mut results);
    (images, results)
}

/// Marks the detectors on the front of anti-aliasing error (RMSE) against the shading they cost.
fn mark_detector_front(results: &mut [DetectorResult]) {
    let pts: Vec<(f64, f64)> = results
        .iter()
        .map(|r| (r.shading_fraction.unwrap_or(f64::NAN), r.aa_error.map_or(f64::NAN, |e| e.rmse)))
        .collect();
    for (r, on) in results.iter_mut().zip(crate::analysis::pareto::front(&pts)) {
        r.on_front = on;
    }
}

/// Runs the sweep. `lights` are in view space. The reference is computed once.
pub fn sweep(gb: &GBuffer, lights: &[Light], cfg: &SweepConfig, outer: Progress<'_>) -> Result<SweepOutput> {
    let start = std::time::Instant::now();
    let mut clock = StageClock::default();
    // Each step names its stage as a value: the clock times the stage, the caller's progress gets the text.
    let mut progress = |done: usize, total: usize, stage: Option<Stage>, subject: Option<&str>| {
        clock.enter(stage);
        let what = match (subject, stage) {
            (Some(s), Some(st)) => format!("{s}: {}", st.name()),
            (None, Some(st)) => st.name().to_string(),
            (_, None) => "done".to_string(),
        };
        outer(done, total, &what);
    };
    let cullings: Vec<Option<Culling>> =
        if cfg.culling.is_empty() { vec![None] } else { cfg.culling.iter().copied().map(Some).collect() };
    let per_layout = cfg.detectors.len() * cullings.len();
    let total = 2 + cfg.layouts.len() * (1 + per_layout);
    let mut done = 0;
    progress(done, total, Some(Stage::Reference), None);
    let (reference, reference_timing) = time_runs(1, || resolve::reference(gb, lights, &cfg.resolve))?;
    resolve::check_meaningful(gb, lights, &reference)?;
    done += 1;
    progress(done, total, Some(Stage::Detectors), None);
    // The resolve is bit-identical across culling modes, so one exact image per detector serves every culling.
    let (exact, mut detectors) = detector_results(gb, lights, cfg, &reference);
    done += 1;

    let mut rows = Vec::new();
    let mut maps = Vec::new();
    let mut masks = Vec::new();
    let mut lights_per_pixel = None;
    let against = FlipAgainst { reference: &reference, exact: &exact, viewing: &cfg.viewing };
    // The detectors' exact images wait for the first batch too (the reference filtered once for both).
    let mut flips = FlipQueue { detectors_waiting: cfg.flip != FlipRows::None, ..FlipQueue::default() };
    // Layouts keep the coverage: one count of covered samples serves every row's shading fraction.
    let covered = detect::covered_per_pixel(gb);
    for (li, layout) in cfg.layouts.iter().enumerate() {
        let bytes = layout.bytes_per_sample() as u32;
        // What the targets occupy in memory (AFRC targets at their fixed rate): the traffic's bytes.
        let stored = layout.stored_bytes_per_sample();
        let base = Row {
            layout: layout.name().to_string(),
            bytes_per_sample: bytes,
            footprint_bytes: layout.footprint_bytes(gb.width, gb.height, gb.samples),
            bandwidth_mb: bandwidth(gb, stored, None),
            decode_ops_per_sample: Some(layout.decode_ops_per_sample()),
            ..Default::default()
        };
        // A layout that cannot be packed or measured gives each of its rows the reason.
        let fail_layout = |rows: &mut Vec<Row>, e: &crate::error::Error| {
            for d in &cfg.detectors {
                for c in &cullings {
                    rows.push(Row {
                        detector: d.name().to_string(),
                        culling: c.map(|c| c.name().to_string()),
                        error: Some(format!("roundtrip failed: {e}")),
                        ..base.clone()
                    });
                }
            }
        };
        progress(done, total, Some(Stage::PackUnpack), Some(layout.name()));
        let prepared = layout.prepare_lighting(gb, cfg.runs, resolve::TIMING_STRIDE);
        done += 1;
        let prepared = match prepared {
            Ok(v) => v,
            Err(e) => {
                fail_layout(&mut rows, &e);
                done += per_layout;
                continue;
            }
        };
        let mut attr_row = base.clone();
        progress(done, total, Some(Stage::Compression), Some(layout.name()));
        attr_row.compressed = compressed_row(layout, gb, &prepared);
        progress(done, total, Some(Stage::PackUnpack), Some(layout.name()));
        // What the detectors and the resolve read: the packed targets band by band, or whole planes (the input
        // itself, or the lighting copy).
        let (frame, planes) = match prepared.frame(layout, gb) {
            Ok(LitFrame::Packed(f)) => (Some(f), None),
            Ok(LitFrame::Planes(d)) => (None, Some(d)),
            Err(e) => {
                fail_layout(&mut rows, &e);
                done += per_layout;
                continue;
            }
        };
        // The attribute errors and maps: against the decoded bands of a packed frame (the decode timed there), or
        // against the whole planes.
        let measured = match (&frame, planes) {
            (Some(f), _) => band_pass(f, gb, cfg.runs),
            (None, Some(d)) => Ok(whole_pass(gb, d, prepared.decode_ms.clone())),
            (None, None) => unreachable!("a layout's input is packed or planes"),
        };
        let (attribute_errors, derived, decode_ms) = match measured {
            Ok(m) => m,
            Err(e) => {
                fail_layout(&mut rows, &e);
                done += per_layout;
                continue;
            }
        };
        let timing = |ms: Vec<f64>| Timing::from_ms(ms).expect("at least one run");
        attr_row.packed_resolve = frame.is_some();
        attr_row.set_timing("encode", timing(prepared.encode_ms.clone()));
        attr_row.set_timing("decode", timing(decode_ms));
        if let Some(ms) = prepared.table_ms {
            attr_row.set_timing("material_table", timing(vec![ms]));
        }
        fill_attribute_errors(&mut attr_row, attribute_errors, derived);
        let mut lmaps = ErrorMaps {
            layout: layout.name().to_string(),
            normal_deg: None,
            depth_rel: None,
            albedo_abs: None,
            image_abs: None,
        };

        for (di, &det) in cfg.detectors.iter().enumerate() {
            progress(done, total, Some(Stage::Detect), Some(&format!("{} × {}", layout.name(), det.name())));
            let mut row = Row { detector: det.name().to_string(), ..attr_row.clone() };
            row.aa_error = detectors[di].aa_error;
            row.bandwidth_mb = bandwidth(gb, stored, detectors[di].quad_light_fragments);
            // Packed: the whole frame once, then sampled estimates (see `time_sampled_runs`).
            let detected = match (&frame, planes) {
                (Some(f), _) => time_sampled_runs(
                    cfg.runs,
                    || detect::detect_packed(f, det, &cfg.detector_config),
                    || detect::time_packed_sampled(f, det, &cfg.detector_config, resolve::TIMING_STRIDE),
                ),
                (None, Some(d)) => time_runs(cfg.runs, || detect::detect(d, det, &cfg.detector_config)),
                (None, None) => unreachable!("a layout's input is packed or planes"),
            };
            let mask = match detected {
                Ok((m, t)) => {
                    row.set_timing("detect", t);
                    m
                }
                Err(e) => {
                    for c in &cullings {
                        rows.push(Row {
                            culling: c.map(|c| c.name().to_string()),
                            error: Some(format!("detector failed: {e}")),
                            ..row.clone()
                        });
                    }
                    done += cullings.len();
                    continue;
                }
            };
            row.shading_fraction = Some(mask.evaluated_fraction(&covered));
            row.edge_fraction = Some(mask.edge_fraction());
            match measure::edges::evaluate(gb, &mask) {
                Some(s) => {
                    row.precision = Some(s.precision);
                    row.recall = Some(s.recall);
                }
                None => row.add_note("no object IDs: no ground truth for precision/recall"),
            }
            for (ci, &c) in cullings.iter().enumerate() {
                progress(done, total, Some(Stage::Resolve), Some(&format!("{} × {}", layout.name(), det.name())));
                let mut rcfg = cfg.resolve;
                let mut r = row.clone();
                if let Some(c) = c {
                    rcfg.culling = c;
                    r.culling = Some(c.name().to_string());
                }
                let decisive = di == 0 && ci == 0;
                let flip = match cfg.flip {
                    FlipRows::All => true,
                    FlipRows::Decisive => decisive,
                    FlipRows::None => false,
                };
                let input: resolve::ResolveInput<'_> = match (&frame, planes) {
                    (Some(f), _) => f.into(),
                    (None, Some(d)) => d.into(),
                    (None, None) => unreachable!("a layout's input is packed or planes"),
                };
                let resolved = if frame.is_some() {
                    time_sampled_runs(
                        cfg.runs,
                        || resolve::resolve(input, lights, &mask, &rcfg),
                        || resolve::time_sampled(input, lights, &mask, &rcfg),
                    )
                } else {
                    time_runs(cfg.runs, || resolve::resolve(input, lights, &mask, &rcfg))
                };
                match resolved {
                    Ok((res, t)) => {
                        r.set_timing("resolve", t);
                        if c == Some(Culling::Quad) {
                            r.bandwidth_mb = bandwidth(gb, stored, Some(res.stats.light_pairs_tested));
                        }
                        r.total_error = Some(error_set(&reference, &res.image, None));
                        if let Some(x) = exact[di].as_ref() {
                            let e = ErrorSet::numeric(&measure::image::compare(x, &res.image));
                            r.layout_error = Some(e);
                            if e.rmse == 0.0 {
                                r.add_note("image identical to the exact G-buffer's (layout error 0)");
                            }
                        } else {
                            r.add_note("the exact G-buffer could not be lit with this detector: no layout error");
                        }
                        if lmaps.image_abs.is_none() {
                            if let Some(x) = exact[di].as_ref() {
                                lmaps.image_abs = Some(image_abs(x, &res.image));
                            }
                        }
                        if lights_per_pixel.is_none() {
                            lights_per_pixel = Some(res.lights_per_pixel.clone());
                        }
                        if flip {
                            flips.pending.push(PendingFlip {
                                row: rows.len(),
                                detector: di,
                                decisive,
                                image: res.image,
                            });
                        }
                    }
                    Err(e) => r.error = Some(format!("resolve failed: {e}")),
                }
                rows.push(r);
                done += 1;
            }
            if li == 0 {
                masks.push((det.name().to_string(), mask));
            }
        }
        maps.push(lmaps);
        keep_worst_maps(&mut maps, &rows);
        // FLIP runs between layouts, once this one's packed frame or lighting copy is gone: the batch's images, their
        // displayed copies and maps then never share the memory with it.
        drop(frame);
        drop(prepared);
        if flips.pending.len() >= FLIP_BATCH {
            progress(done, total, Some(Stage::Flip), None);
            flips.flush(&mut rows, &against, &mut detectors);
        }
    }
    if !flips.pending.is_empty() || flips.detectors_waiting {
        progress(done, total, Some(Stage::Flip), None);
        flips.flush(&mut rows, &against, &mut detectors);
    }
    let FlipQueue { worst: worst_flip, shown, .. } = flips;
    // The kept layouts' attribute maps, now that no packed frame or waiting image shares the memory with them.
    progress(done, total, Some(Stage::Maps), None);
    for i in worst_maps(&maps, &rows) {
        if let Some(layout) = cfg.layouts.iter().find(|l| l.name() == maps[i].layout) {
            attribute_maps(gb, layout, &mut maps[i])?;
        }
    }
    // Rows took their detector's anti-aliasing error when made, before its FLIP was measured.
    for r in rows.iter_mut().filter(|r| r.aa_error.is_some()) {
        if let Some(d) = detectors.iter().find(|d| d.detector == r.detector) {
            r.aa_error = d.aa_error;
        }
    }
    progress(total, total, None, None);
    mark_pareto(&mut rows);
    let reference_shown = (!shown.is_empty()).then(|| reference.to_srgb8(cfg.viewing.tone()));
    Ok(SweepOutput {
        rows,
        reference,
        reference_timing,
        maps,
        masks,
        lights_per_pixel,
        detectors,
        exact,
        worst_flip,
        reference_shown,
        shown,
        seconds: start.elapsed().as_secs_f64(),
        stage_seconds: clock.seconds,
    })
}

/// A layout's bytes after the framebuffer-compression models and the tiled traffic with them: from its packed frame,
/// or packed a band at a time when it is lit from the input or a decoded copy. `None` when it cannot be packed (the
/// row says why elsewhere).
fn compressed_row(layout: &Layout, gb: &GBuffer, prepared: &PreparedLighting) -> Option<Compressed> {
    use crate::layout::compression;
    let mut targets = match &prepared.source {
        LightingSource::Packed(p) => compression::compressed_models(p),
        LightingSource::Input | LightingSource::Copy(_) => compression::compressed_models_of(layout, gb).ok()?,
    };
    compression::fixed_rate(&mut targets, layout);
    let bytes = compression::bytes_per_sample(&targets, gb.len() as u64);
    Some(Compressed { bytes_per_sample: bytes, tiled_mb: bytes.map(|b| bandwidth(gb, b, None).tiled) })
}

/// Adds `s` seconds to `kind` in `stages` (appended when new, so the kinds stay in the order first met).
pub fn add_stage_time(stages: &mut Vec<(String, f64)>, kind: &str, s: f64) {
    match stages.iter_mut().find(|(k, _)| k == kind) {
        Some((_, t)) => *t += s,
        None => stages.push((kind.to_string(), s)),
    }
}

crate::named_enum! {
    /// A stage of the sweep, as its wall time is reported (`Frame::stage_seconds`) and its progress shown.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Stage: "sweep stage" {
        /// The every-sample f64 reference.
        Reference => "reference",
        /// Each detector on the exact G-buffer.
        Detectors => "detectors on the exact G-buffer",
        /// A layout's pack and unpack (timed runs included).
        PackUnpack => "pack/unpack",
        /// A layout's bytes under the framebuffer-compression models.
        Compression => "compression models",
        /// A detector on a decoded G-buffer.
        Detect => "detect",
        /// The resolve of a decoded G-buffer.
        Resolve => "resolve",
        /// A batch of FLIPs.
        Flip => "FLIP",
        /// The kept layouts' attribute error maps, drawn after the layouts.
        Maps => "error maps",
    }
}

/// Wall time per stage: the time from entering one stage to entering the next (or the end, `None`).
#[derive(Default)]
struct StageClock {
    current: Option<(Stage, std::time::Instant)>,
    seconds: Vec<(String, f64)>,
}

impl StageClock {
    fn enter(&mut self, stage: Option<Stage>) {
        let now = std::time::Instant::now();
        if let Some((kind, since)) = self.current.take() {
            add_stage_time(&mut self.seconds, kind.name(), now.duration_since(since).as_secs_f64());
        }
        self.current = stage.map(|s| (s, now));
    }
}

/// How many layouts keep their per-pixel error maps: those with the largest layout error (the report draws their
/// heatmaps). A map of a 1080p frame is 17 MB per attribute; keeping every layout's held half a GB.
pub const HEATMAP_LAYOUTS: usize = 2;

/// Drops the per-pixel planes of every layout but the [`HEATMAP_LAYOUTS`] with the largest best layout RMSE (over
/// their rows); the entries stay, empty.
fn keep_worst_maps(maps: &mut [ErrorMaps], rows: &[Row]) {
    let kept = worst_maps(maps, rows);
    for (_, m) in maps.iter_mut().enumerate().filter(|(i, _)| !kept.contains(i)) {
        (m.normal_deg, m.depth_rel, m.albedo_abs, m.image_abs) = (None, None, None, None);
    }
}

/// The indices of the (at most) [`HEATMAP_LAYOUTS`] maps whose layouts have the largest best layout RMSE over their
/// rows, among those with a finite one.
fn worst_maps(maps: &[ErrorMaps], rows: &[Row]) -> Vec<usize> {
    let best = |m: &ErrorMaps| {
        rows.iter().filter(|r| r.layout == m.layout).filter_map(Row::layout_rmse).fold(f64::NAN, f64::min)
    };
    let mut order: Vec<(usize, f64)> = maps.iter().enumerate().map(|(i, m)| (i, best(m))).collect();
    // Largest first; layouts without a finite error last (the report draws none for them).
    order.sort_by(|a, b| match (a.1.is_finite(), b.1.is_finite()) {
        (true, true) => b.1.total_cmp(&a.1),
        (x, y) => y.cmp(&x),
    });
    order.into_iter().take(HEATMAP_LAYOUTS).filter(|(_, e)| e.is_finite()).map(|(i, _)| i).collect()
}

/// Rows whose images wait for FLIP, batched so that each reference is filtered once per batch, not once per row.
/// Four, not eight: the waiting images (25 MB each at 1080p) were the sweep's peak, the report's since the
/// pipelines section frees its images early; a second batch filters the references once more.
const FLIP_BATCH: usize = 4;

/// A row's image waiting for FLIP: against the reference (total error) and the exact G-buffer lit with its
/// detector (layout error).
struct PendingFlip {
    row: usize,
    detector: usize,
    decisive: bool,
    image: HdrImage,
}

/// What the pending rows' images are compared with: the reference, each detector's exact image, and how images are
/// viewed.
struct FlipAgainst<'a> {
    reference: &'a HdrImage,
    exact: &'a [Option<HdrImage>],
    viewing: &'a Viewing,
}

/// The sweep's FLIP state: the rows' images waiting for a batch, whether the detectors' exact images still wait for
/// one, and what the batches keep for the figures.
#[derive(Default)]
struct FlipQueue {
    pending: Vec<PendingFlip>,
    detectors_waiting: bool,
    /// The decisive row with the largest layout LDR-FLIP, and its map (the first on ties, in row order).
    worst: Option<(String, FlipMap)>,
    /// The decisive rows' images as displayed.
    shown: Vec<(String, Vec<u8>)>,
}

impl FlipQueue {
    /// FLIP of the pending rows' images: all of them against the reference in one batch (with the detectors' exact
    /// images while they wait, their anti-aliasing FLIP then set), then per detector against that detector's exact
    /// image. A lossless layout's image, equal to its detector's exact image, costs the batch almost nothing: every
    /// window is equal to an earlier test's, whose errors it takes.
    fn flush(&mut self, rows: &mut [Row], against: &FlipAgainst<'_>, detectors: &mut [DetectorResult]) {
        let FlipQueue { pending, detectors_waiting, worst, shown } = self;
        let FlipAgainst { reference, exact, viewing } = *against;
        for p in pending.iter().filter(|p| p.decisive) {
            shown.push((rows[p.row].layout.clone(), p.image.to_srgb8(viewing.tone())));
        }
        let set = |e: &mut Option<ErrorSet>, f: Option<(FlipMap, f64)>| -> Option<FlipMap> {
            let (e, (map, hdr)) = (e.as_mut()?, f?);
            e.flip_ldr = Some(map.mean);
            e.flip_hdr = Some(hdr);
            Some(map)
        };
        let put = |e: Option<&mut ErrorSet>, f: Option<(f64, f64)>| {
            if let (Some(e), Some((ldr, hdr))) = (e, f) {
                (e.flip_ldr, e.flip_hdr) = (Some(ldr), Some(hdr));
            }
        };
        // Against the reference only the means are wanted: no maps.
        let lit: Vec<usize> =
            if *detectors_waiting { (0..exact.len()).filter(|&d| exact[d].is_some()).collect() } else { Vec::new() };
        let images: Vec<&HdrImage> =
            lit.iter().filter_map(|&d| exact[d].as_ref()).chain(pending.iter().map(|p| &p.image)).collect();
        let measured = if images.is_empty() { Vec::new() } else { flip_means(reference, &images, viewing) };
        let (of_detectors, of_rows) = measured.split_at(measured.len().min(lit.len()));
        for (&d, &f) in lit.iter().zip(of_detectors) {
            put(detectors[d].aa_error.as_mut(), f);
        }
        *detectors_waiting = false;
        for (p, &f) in pending.iter().zip(of_rows) {
            put(rows[p.row].total_error.as_mut(), f);
        }
        let mut layout_maps: Vec<Option<FlipMap>> = pending.iter().map(|_| None).collect();
        for (d, x) in exact.iter().enumerate() {
            let Some(x) = x else { continue };
            let group: Vec<usize> = (0..pending.len()).filter(|&i| pending[i].detector == d).collect();
            if group.is_empty() {
                continue;
            }
            let images: Vec<&HdrImage> = group.iter().map(|&i| &pending[i].image).collect();
            for (&i, f) in group.iter().zip(flip_many(x, &images, viewing)) {
                layout_maps[i] = set(&mut rows[pending[i].row].layout_error, f);
            }
        }
        for (p, map) in pending.iter().zip(layout_maps) {
            if let Some(map) = map.filter(|_| p.decisive) {
                if worst.as_ref().is_none_or(|(_, w)| map.mean > w.mean) {
                    *worst = Some((rows[p.row].layout.clone(), map));
                }
            }
        }
        pending.clear();
    }
}

/// Copies the roundtrip's attribute errors into a row (`derived`: the lighting derives positions from the stored
/// depth and the camera, so a layout without positions is not missing them).
fn fill_attribute_errors(row: &mut Row, errors: Result<measure::gbuffer::AttributeErrors>, derived: bool) {
    let e = match errors {
        Ok(e) => e,
        Err(err) => {
            row.add_note(format!("attribute errors not computed: {err}"));
            return;
        }
    };
    row.normal_mean_deg = e.normal.as_ref().map(|n| n.mean_deg);
    row.normal_p95_deg = e.normal.as_ref().map(|n| n.p95_deg);
    row.normal_max_deg = e.normal.as_ref().map(|n| n.max_deg);
    row.depth_rel_mean = e.depth.as_ref().map(|d| d.rel_mean);
    row.depth_rel_max = e.depth.as_ref().map(|d| d.rel_max);
    row.albedo_max_abs = e.albedo.as_ref().map(|a| a.max_abs);
    // Specular power is an exponent (1..4096): its absolute error is not comparable with the [0, 1] scalars.
    row.scalar_max_abs =
        e.scalars.iter().filter(|s| s.attribute != "specular_power").map(|s| s.max_abs).reduce(f64::max);
    let derived = |m: &String| m == Attribute::Position.name() && derived;
    let missing: Vec<&str> = e.missing.iter().filter(|m| !derived(m)).map(String::as_str).collect();
    if !missing.is_empty() {
        row.add_note(format!("not stored by the layout: {}", missing.join(", ")));
    }
}

/// [`time_runs`] whose runs after the first are estimates: `whole` once (its result and time), then `runs − 1`
/// times `sample`, which times a systematic sample of the frame (every [`resolve::TIMING_STRIDE`]-th band) and
/// returns the scaled time in ms. A report times eight layouts × three detectors: the sampled runs keep the
/// spread of several runs for an eighth of their cost.
fn time_sampled_runs<T>(
    runs: usize,
    whole: impl FnOnce() -> Result<T>,
    mut sample: impl FnMut() -> Result<f64>,
) -> Result<(T, Timing)> {
    let t = std::time::Instant::now();
    let v = whole()?;
    let mut ms = vec![t.elapsed().as_secs_f64() * 1e3];
    for _ in 1..runs.max(1) {
        ms.push(sample()?);
    }
    Ok((v, Timing::from_ms(ms).expect("at least one run")))
}

/// Rows per band of [`band_pass`]: two bands of every plane are alive (the one measured, the next decoded), 18 MB
/// at 1080p × 4 (64 rows held 72 MB at the report's peak; the statistics do not depend on the band size).
const BAND_ROWS: u32 = 16;

/// A layout's attribute errors, whether positions are derived from depth, and each run's decode time (ms).
type Measured = (Result<measure::gbuffer::AttributeErrors>, bool, Vec<f64>);

/// The attribute errors and decode times of a packed frame, decoded band by band against the input `gb` (the first
/// run of the decode also measures; `runs − 1` more decode every band again, timed only). In the first run each band
/// is decoded while the one before it is measured: the statistics are carried from band to band in sample order (the
/// numbers are `compare`'s bit for bit), so the measuring itself stays in order. The error maps are drawn after the
/// sweep for the layouts that keep them ([`attribute_maps`]).
fn band_pass(frame: &PackedFrame<'_>, gb: &GBuffer, runs: usize) -> Result<Measured> {
    let mut compare = measure::gbuffer::CompareBands::new(gb)?;
    let mut compared: Result<()> = Ok(());
    let mut decode_ms = Vec::new();
    let row = gb.width as usize * gb.samples as usize;
    let mut derived = false;
    let bands = gb.height.div_ceil(BAND_ROWS).max(1);
    let rows_of = |b: u32| b * BAND_ROWS..((b + 1) * BAND_ROWS).min(gb.height);
    let timed_decode = |b: u32, out: &mut GBuffer| -> Result<std::time::Duration> {
        let t = std::time::Instant::now();
        frame.decode_rows(rows_of(b), out)?;
        Ok(t.elapsed())
    };
    let (mut band, mut next) = (GBuffer::default(), GBuffer::default());
    let mut dec = timed_decode(0, &mut band)?;
    for b in 0..bands {
        let start = rows_of(b).start as usize * row;
        let (decoded, ()) = rayon::join(
            || if b + 1 < bands { timed_decode(b + 1, &mut next) } else { Ok(std::time::Duration::ZERO) },
            || {
                if compared.is_ok() {
                    compared = compare.add(start, &band);
                }
                derived = band.derives_position();
            },
        );
        dec += decoded?;
        std::mem::swap(&mut band, &mut next);
    }
    decode_ms.push(dec.as_secs_f64() * 1e3);
    // The other runs time every TIMING_STRIDE-th band, scaled.
    let stride = resolve::TIMING_STRIDE;
    for _ in 1..runs.max(1) {
        let mut dec = std::time::Duration::ZERO;
        for b in (0..bands).step_by(stride as usize) {
            dec += timed_decode(b, &mut band)?;
        }
        decode_ms.push(dec.as_secs_f64() * 1e3 * f64::from(bands) / f64::from(bands.div_ceil(stride)));
    }
    let errors = compared.map(|()| compare.finish());
    Ok((errors, derived, decode_ms))
}

/// [`band_pass`] for a whole decoded G-buffer (`decode_ms`: its decode times, measured when it was made).
fn whole_pass(gb: &GBuffer, decoded: &GBuffer, decode_ms: Vec<f64>) -> Measured {
    let errors = measure::gbuffer::compare(gb, decoded);
    let derived = decoded.derives_position();
    (errors, derived, decode_ms)
}

/// The per-pixel attribute error maps (normal, depth, albedo) of `layout`'s roundtrip of `gb` into `maps`: the frame
/// packed and decoded band by band as the lighting reads it ([`Layout::each_roundtrip_band`]), each band measured
/// against the input. The sweep draws them only for the layouts that keep their maps, once it is over: the maps
/// (8 MB a plane at 1080p) and the bands they were drawn from were a tenth of the report's peak when every layout
/// drew its own while its packed frame was alive.
pub fn attribute_maps(gb: &GBuffer, layout: &Layout, maps: &mut ErrorMaps) -> Result<()> {
    let only = [Attribute::Normal, Attribute::Depth, Attribute::Albedo];
    let row_px = gb.width as usize;
    layout.each_roundtrip_band(gb, 1, Some(&only), |rows, band| {
        error_maps_into(gb, band, rows.start as usize * row_px, maps);
        Ok(true)
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The maps drawn after the sweep, band by band from the packed frame, are those of the whole decoded copy the
    /// lighting reads, bit for bit (NaN exactly where the other is).
    #[test]
    fn attribute_maps_are_the_whole_roundtrips_maps() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 300, 200, 4).unwrap();
        for name in ["fat-20", "lauritzen-15", "minimal-8"] {
            let layout = Layout::by_name(name).unwrap();
            let empty = || ErrorMaps {
                layout: name.into(),
                normal_deg: None,
                depth_rel: None,
                albedo_abs: None,
                image_abs: None,
            };
            let mut banded = empty();
            attribute_maps(&gb, &layout, &mut banded).unwrap();
            let mut whole = empty();
            error_maps_into(&gb, &layout.roundtrip_for_lighting(&gb, 1).unwrap().decoded, 0, &mut whole);
            let bits = |m: &Option<Vec<f32>>| m.as_ref().map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>());
            for (a, b) in [
                (&banded.normal_deg, &whole.normal_deg),
                (&banded.depth_rel, &whole.depth_rel),
                (&banded.albedo_abs, &whole.albedo_abs),
            ] {
                assert!(a.is_some(), "{name}");
                assert_eq!(bits(a), bits(b), "{name}");
            }
        }
    }
}
