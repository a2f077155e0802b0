//! Shading less than once per pixel, measured: per SRI tile size, gbuf's G-buffer-aware shading-rate image
//! ([`crate::detect::rate`]), the lighting evaluations it leaves (against the full-rate resolve with the same edge
//! mask) and what it costs in the image, against the full-rate image and against the every-sample reference.
//!
//! The coarse image is the resolve of [`rate::coarse_gbuffer`]: the frame whose shared pixels carry their coarse
//! pixel's representative surface, lit with the same mask. It is the image a coarse-shading resolve gives; the
//! evaluations are counted by [`rate::evaluations`] (this resolve still evaluates every pixel, so the time it
//! saves is not measured here).

use crate::detect::rate::{self, CoarseMode, Rate, Smoothness, Sri};
use crate::detect::{self, Detector, DetectorConfig};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::image::HdrImage;
use crate::light::Light;
use crate::measure::image::{error_set, ErrorSet, Viewing};
use crate::resolve::{self, ResolveConfig};
use serde::Serialize;

/// What to measure.
#[derive(Clone, Debug)]
pub struct VrsConfig {
    /// SRI tile sizes (8, 16, 32).
    pub tiles: Vec<u32>,
    /// Allow the rates beyond 2 × 2.
    pub extra_rates: bool,
    /// How a coarse pixel's evaluation reaches its pixels.
    pub mode: CoarseMode,
    /// The edge detector whose pixels stay per sample.
    pub detector: Detector,
    /// Its thresholds.
    pub detector_config: DetectorConfig,
    /// Lighting.
    pub resolve: ResolveConfig,
    /// FLIP's viewing conditions (`None`: numerical errors only).
    pub viewing: Option<Viewing>,
    /// gbuf's smoothness rule (its `broadcast` follows `mode`).
    pub rule: Smoothness,
}

/// One SRI's answer.
#[derive(Clone, Debug, Serialize)]
pub struct VrsRow {
    /// The generator (`gbuffer`).
    pub generator: String,
    /// Tile size in pixels.
    pub tile: u32,
    /// Tiles per rate (`1x1`, `1x2`, …; rates no tile has are left out).
    pub rates: Vec<(String, usize)>,
    /// Lighting evaluations.
    pub evaluations: u64,
    /// Evaluations per pixel.
    pub evaluations_per_pixel: f64,
    /// Fraction of the full-rate resolve's evaluations saved.
    pub saved: f64,
    /// The coarse image against the full-rate image.
    pub vs_full_rate: ErrorSet,
    /// The coarse image against the every-sample reference.
    pub vs_reference: ErrorSet,
}

/// Everything [`vrs`] measures.
#[derive(Clone, Debug, Serialize)]
pub struct VrsOutput {
    /// The coarse-pixel mode (`broadcast` or `lighting`).
    pub mode: String,
    /// The edge detector.
    pub detector: String,
    /// Whether the rates beyond 2 × 2 were allowed.
    pub extra_rates: bool,
    /// The full-rate resolve's evaluations (the mask's) and per pixel.
    pub full_rate_evaluations: u64,
    /// Per pixel.
    pub full_rate_evaluations_per_pixel: f64,
    /// The full-rate image against the reference (what the detector alone costs).
    pub full_rate_vs_reference: ErrorSet,
    /// One row per tile size.
    pub rows: Vec<VrsRow>,
    /// The SRIs, in row order.
    #[serde(skip)]
    pub sris: Vec<Sri>,
    /// The coarse images, in row order.
    #[serde(skip)]
    pub images: Vec<HdrImage>,
}

/// Measures gbuf's SRI on `gb` lit by `lights` (view space) at each tile size of `cfg`.
pub fn vrs(gb: &GBuffer, lights: &[Light], cfg: &VrsConfig) -> Result<VrsOutput> {
    let mask = detect::detect(gb, cfg.detector, &cfg.detector_config)?;
    let full = resolve::resolve(gb, lights, &mask, &cfg.resolve)?.image;
    let reference = resolve::reference(gb, lights, &cfg.resolve)?;
    resolve::check_meaningful(gb, lights, &reference)?;
    let v = cfg.viewing.as_ref();
    let pixels = gb.pixel_count().max(1) as f64;
    let full_evals = mask.evaluations(&detect::covered_per_pixel(gb));
    let rule = Smoothness { broadcast: cfg.mode == CoarseMode::Broadcast, ..cfg.rule };
    let mut out = VrsOutput {
        mode: match cfg.mode {
            CoarseMode::Broadcast => "broadcast",
            CoarseMode::Lighting => "lighting",
        }
        .to_string(),
        detector: cfg.detector.name().to_string(),
        extra_rates: cfg.extra_rates,
        full_rate_evaluations: full_evals,
        full_rate_evaluations_per_pixel: full_evals as f64 / pixels,
        full_rate_vs_reference: error_set(&reference, &full, v),
        rows: Vec::new(),
        sris: Vec::new(),
        images: Vec::new(),
    };
    for &tile in &cfg.tiles {
        let sri = rate::gbuffer_sri(gb, &mask, tile, cfg.extra_rates, &rule)?;
        let coarse = rate::coarse_gbuffer(gb, &mask, &sri, cfg.mode);
        let image = resolve::resolve(&coarse, lights, &mask, &cfg.resolve)?.image;
        let evaluations = rate::evaluations(gb, &mask, &sri);
        let rates = Rate::ALL
            .iter()
            .zip(sri.histogram())
            .filter(|(_, n)| *n > 0)
            .map(|(r, n)| (r.name().to_string(), n))
            .collect();
        out.rows.push(VrsRow {
            generator: "gbuffer".into(),
            tile,
            rates,
            evaluations,
            evaluations_per_pixel: evaluations as f64 / pixels,
            saved: if full_evals == 0 { 0.0 } else { 1.0 - evaluations as f64 / full_evals as f64 },
            vs_full_rate: error_set(&full, &image, v),
            vs_reference: error_set(&reference, &image, v),
        });
        out.sris.push(sri);
        out.images.push(image);
    }
    Ok(out)
}
