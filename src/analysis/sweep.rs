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

use crate::analysis::row::{mark_pareto, time_runs, Row, Timing};
use crate::detect::{self, Detector, DetectorConfig, EdgeMask};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::image::HdrImage;
use crate::layout::Layout;
use crate::light::Light;
use crate::measure;
use crate::resolve::{self, Culling, ResolveConfig};

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
}

/// Per-pixel error maps of one layout (row-major; `None` = background pixel).
#[derive(Clone, Debug)]
pub struct ErrorMaps {
    /// Layout name.
    pub layout: String,
    /// Largest normal angle error over the pixel's covered samples, degrees.
    pub normal_deg: Option<Vec<Option<f32>>>,
    /// Largest relative depth error.
    pub depth_rel: Option<Vec<Option<f32>>>,
    /// Largest absolute albedo error (any channel).
    pub albedo_abs: Option<Vec<Option<f32>>>,
    /// Absolute image error (largest channel) of the layout's first detector row.
    pub image_abs: Option<Vec<Option<f32>>>,
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
    /// Error maps, one per layout that could be roundtripped.
    pub maps: Vec<ErrorMaps>,
    /// Edge masks of the first layout, per detector.
    pub masks: Vec<(String, EdgeMask)>,
    /// Lights per pixel from the first successful resolve.
    pub lights_per_pixel: Option<Vec<u32>>,
    /// Wall time of the sweep in seconds.
    pub seconds: f64,
}

/// Progress callback: (done, total, what is running).
pub type Progress<'a> = &'a mut dyn FnMut(usize, usize, &str);

fn per_pixel(gb: &GBuffer, f: impl Fn(usize) -> f32) -> Vec<Option<f32>> {
    let s = gb.samples as usize;
    (0..gb.pixel_count())
        .map(|p| {
            (p * s..(p + 1) * s)
                .filter(|&i| gb.coverage[i])
                .map(&f)
                .fold(None, |a: Option<f32>, v| Some(a.map_or(v, |a| a.max(v))))
        })
        .collect()
}

/// Per-pixel error maps of `test` against `reference`.
#[must_use]
pub fn error_maps(layout: &str, reference: &GBuffer, test: &GBuffer) -> ErrorMaps {
    let normal_deg = match (reference.normal.as_deref(), test.normal.as_deref()) {
        (Some(a), Some(b)) => Some(per_pixel(reference, |i| a[i].dot(b[i]).clamp(-1.0, 1.0).acos().to_degrees())),
        _ => None,
    };
    let depth_rel = match (reference.depth.as_deref(), test.depth.as_deref()) {
        (Some(a), Some(b)) => Some(per_pixel(reference, |i| ((b[i] - a[i]) / a[i].abs().max(f32::MIN_POSITIVE)).abs())),
        _ => None,
    };
    let albedo_abs = match (reference.albedo.as_deref(), test.albedo.as_deref()) {
        (Some(a), Some(b)) => Some(per_pixel(reference, |i| (b[i] - a[i]).abs().max_element())),
        _ => None,
    };
    ErrorMaps { layout: layout.to_string(), normal_deg, depth_rel, albedo_abs, image_abs: None }
}

fn image_abs(reference: &HdrImage, test: &HdrImage) -> Vec<Option<f32>> {
    reference.rgb.iter().zip(&test.rgb).map(|(a, b)| Some((*b - *a).abs().max_element())).collect()
}

/// Runs the sweep. `lights` are in view space. The reference is computed once.
pub fn sweep(gb: &GBuffer, lights: &[Light], cfg: &SweepConfig, progress: Progress<'_>) -> Result<SweepOutput> {
    let start = std::time::Instant::now();
    let cullings: Vec<Option<Culling>> =
        if cfg.culling.is_empty() { vec![None] } else { cfg.culling.iter().copied().map(Some).collect() };
    let per_layout = cfg.detectors.len() * cullings.len();
    let total = 1 + cfg.layouts.len() * (1 + per_layout);
    let mut done = 0;
    progress(done, total, "reference");
    let (reference, reference_timing) = time_runs(1, || resolve::reference(gb, lights, &cfg.resolve))?;
    // Each detector on the exact G-buffer: what the layouts' images are compared with for `layout_rmse`.
    let exact: Vec<Option<HdrImage>> = cfg
        .detectors
        .iter()
        .map(|&d| {
            let mask = detect::detect(gb, d, &cfg.detector_config).ok()?;
            resolve::resolve(gb, lights, &mask, &cfg.resolve).ok().map(|r| r.image)
        })
        .collect();
    done += 1;

    let mut rows = Vec::new();
    let mut maps = Vec::new();
    let mut masks = Vec::new();
    let mut lights_per_pixel = None;
    for (li, layout) in cfg.layouts.iter().enumerate() {
        let bytes = layout.bytes_per_sample() as u32;
        let base = Row {
            layout: layout.name().to_string(),
            bytes_per_sample: bytes,
            footprint_bytes: layout.footprint_bytes(gb.width, gb.height, gb.samples),
            ..Default::default()
        };
        progress(done, total, &format!("{}: pack/unpack", layout.name()));
        let packed = time_runs(cfg.runs, || layout.pack(gb));
        let decoded =
            packed.and_then(|(p, te)| time_runs(cfg.runs, || layout.unpack(&p, gb)).map(|(d, td)| (d, te, td)));
        done += 1;
        let (decoded, te, td) = match decoded {
            Ok(v) => v,
            Err(e) => {
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
                done += per_layout;
                continue;
            }
        };
        let mut attr_row = base.clone();
        attr_row.set_timing("encode", te);
        attr_row.set_timing("decode", td);
        fill_attribute_errors(&mut attr_row, gb, &decoded);
        let mut lmaps = error_maps(layout.name(), gb, &decoded);

        for (di, &det) in cfg.detectors.iter().enumerate() {
            progress(done, total, &format!("{} × {}: detect", layout.name(), det.name()));
            let mut row = Row { detector: det.name().to_string(), ..attr_row.clone() };
            let mask = match time_runs(cfg.runs, || detect::detect(&decoded, det, &cfg.detector_config)) {
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
            row.shading_fraction = Some(mask.shading_fraction());
            row.edge_fraction = Some(mask.edge_fraction());
            match measure::edges::evaluate(gb, &mask) {
                Some(s) => {
                    row.precision = Some(s.precision);
                    row.recall = Some(s.recall);
                }
                None => row.add_note("no object IDs: no ground truth for precision/recall"),
            }
            for &c in &cullings {
                progress(done, total, &format!("{} × {}: resolve", layout.name(), det.name()));
                let mut rcfg = cfg.resolve;
                let mut r = row.clone();
                if let Some(c) = c {
                    rcfg.culling = c;
                    r.culling = Some(c.name().to_string());
                }
                match time_runs(cfg.runs, || resolve::resolve(&decoded, lights, &mask, &rcfg)) {
                    Ok((res, t)) => {
                        r.set_timing("resolve", t);
                        let e = measure::image::compare(&reference, &res.image);
                        r.rmse = Some(e.rmse);
                        r.psnr_db = Some(e.psnr_db);
                        r.max_abs = Some(e.max_abs);
                        r.rel_mse = Some(e.rel_mse);
                        r.layout_rmse = exact[di].as_ref().map(|x| measure::image::compare(x, &res.image).rmse);
                        if e.rmse == 0.0 {
                            r.add_note("image identical to the reference (PSNR infinite)");
                        }
                        if lmaps.image_abs.is_none() {
                            lmaps.image_abs = Some(image_abs(&reference, &res.image));
                        }
                        if lights_per_pixel.is_none() {
                            lights_per_pixel = Some(res.lights_per_pixel.clone());
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
    }
    progress(total, total, "done");
    mark_pareto(&mut rows);
    Ok(SweepOutput {
        rows,
        reference,
        reference_timing,
        maps,
        masks,
        lights_per_pixel,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Copies the roundtrip's attribute errors into a row.
fn fill_attribute_errors(row: &mut Row, reference: &GBuffer, decoded: &GBuffer) {
    let e = match measure::gbuffer::compare(reference, decoded) {
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
    if !e.missing.is_empty() {
        row.add_note(format!("not stored by the layout: {}", e.missing.join(", ")));
    }
}
