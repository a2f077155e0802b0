//! Shading less than once per pixel, measured: per SRI tile size, gbuf's G-buffer-aware shading-rate image
//! ([`crate::detect::rate`]), the lighting evaluations it leaves (against the full-rate resolve with the same edge
//! mask) and what it costs in the image, against the full-rate image and against the every-sample reference.
//!
//! Beside it, the **oracle**: from the f64 reference's error at every rate, tile by tile (the displayed
//! difference, summed), the SRI with the least error at gbuf's SRI's evaluations ([`rate::cheapest_sri`]). It is a
//! bound for generators, not a product: it needs the reference.
//!
//! The coarse image is [`resolve::resolve_coarse`]'s: one lighting evaluation per coarse pixel, edge pixels per
//! sample with the same mask. Its evaluations are the resolve's own (equal to [`rate::evaluations`]), and its time
//! is measured beside the full-rate resolve's (one run each: a machine's load shows in them).

use crate::detect::rate::{self, CoarseMode, Rate, Smoothness, Sri};
use crate::detect::{self, Detector, DetectorConfig};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::image::HdrImage;
use crate::light::Light;
use crate::measure::image::{error_set, ErrorSet, Viewing};
use crate::resolve::{self, Coarse, ResolveConfig};
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
    /// Also find, per tile size, the largest saving of gbuf's rule (its thresholds scaled by [`RULE_SCALES`]) whose
    /// LDR-FLIP against the full-rate image stays at or under this (needs `viewing`).
    pub max_flip: Option<f64>,
    /// The wave width `ffx`'s reductions run over ([`FFX_WAVE`] on AMD's GPUs; 32 on NVIDIA's).
    pub ffx_wave: u32,
    /// `ffx`'s `VarianceCutoff` ([`FFX_VARIANCE_CUTOFF`] as AMD's sample sets it).
    pub ffx_cutoff: f32,
}

/// FidelityFX VRS's `VarianceCutoff` as AMD's sample sets it.
pub const FFX_VARIANCE_CUTOFF: f32 = 0.015;

/// The wave width FidelityFX VRS's reductions run over (AMD's SDK compiles its shader for 64-wide waves).
pub const FFX_WAVE: u32 = 64;

/// The factors `--max-flip` scales the smoothness thresholds by (1: the default rule).
pub const RULE_SCALES: [f32; 9] = [0.0625, 0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0];

/// One SRI's answer.
#[derive(Clone, Debug, Serialize)]
pub struct VrsRow {
    /// The generator: `gbuffer` (gbuf's rule, its preview lit from the lights), `ffx` (FidelityFX VRS's on the
    /// full-rate image), `gbuffer-prev` (gbuf's rule, its preview the full-rate image as a previous frame), `oracle`
    /// (the least error against the reference at `gbuffer`'s evaluations) or `gbuffer-max-flip`.
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
    /// The coarse resolve's wall time (ms).
    pub resolve_ms: f64,
    /// Its light loop's: the work lists shaded against their lights (ms; the work lists' reading of the G-buffer
    /// and the culling are in `resolve_ms` only).
    pub shade_ms: f64,
    /// The time the generator took to make the SRI (ms, wall, rayon's threads; `None` for the oracle, which is no
    /// generator).
    pub sri_ms: Option<f64>,
    /// For `gbuffer-max-flip`: the factor the rule's thresholds were scaled by.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rule_scale: Option<f32>,
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
    /// The full-rate resolve's wall time (ms).
    pub full_rate_resolve_ms: f64,
    /// Its light loop's: the work lists shaded against their lights (ms; the work lists' reading of the G-buffer
    /// and the culling are in `resolve_ms` only).
    pub full_rate_shade_ms: f64,
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
    /// The full-rate image (what `ffx` sees as "the previous frame").
    #[serde(skip)]
    pub full_rate: HdrImage,
}

/// Measures gbuf's SRI on `gb` lit by `lights` (view space) at each tile size of `cfg`.
pub fn vrs(gb: &GBuffer, lights: &[Light], cfg: &VrsConfig) -> Result<VrsOutput> {
    let mask = detect::detect(gb, cfg.detector, &cfg.detector_config)?;
    let full = resolve::resolve(gb, lights, &mask, &cfg.resolve)?;
    let (full_ms, full_shade_ms) = (full.stats.ms.total, shade_ms(&full.stats));
    let full = full.image;
    let reference = resolve::reference(gb, lights, &cfg.resolve)?;
    resolve::check_meaningful(gb, lights, &reference)?;
    let v = cfg.viewing.as_ref();
    let pixels = gb.pixel_count().max(1) as f64;
    let full_evals = mask.evaluations(&detect::covered_per_pixel(gb));
    let rule = Smoothness { broadcast: cfg.mode == CoarseMode::Broadcast, ..cfg.rule };
    let tone = cfg.viewing.as_ref().map_or_else(Default::default, Viewing::tone);
    let preview = resolve::LightPreview::new(gb, lights, cfg.resolve.falloff, cfg.resolve.brdf, tone)?;
    let lit: Option<&dyn rate::Preview> = Some(&preview);
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
        full_rate_resolve_ms: full_ms,
        full_rate_shade_ms: full_shade_ms,
        full_rate_vs_reference: error_set(&reference, &full, v),
        rows: Vec::new(),
        sris: Vec::new(),
        images: Vec::new(),
        full_rate: HdrImage::default(),
    };
    // The frame coarse at each rate everywhere: a tile's image under any SRI is its image under its own rate
    // everywhere (coarse pixels never cross tiles, and every tile size is a multiple of the widest coarse pixel).
    let rates: Vec<Rate> = Rate::ALL.into_iter().filter(|r| r.allowed(gb.samples, cfg.extra_rates)).collect();
    let mut uniform = Vec::with_capacity(rates.len());
    for &r in &rates {
        let image = if r == Rate::R1x1 {
            full.clone()
        } else {
            let sri = Sri::uniform(gb.width, gb.height, 8, r);
            resolve::resolve_coarse(gb, lights, &mask, Coarse { sri: &sri, mode: cfg.mode }, &cfg.resolve)?.image
        };
        uniform.push(displayed_errors(&image, &reference));
    }
    // One SRI's row: its coarse image, evaluations and errors.
    let measure = |generator: &str,
                   tile: u32,
                   (sri, sri_ms): (&Sri, Option<f64>),
                   scale: Option<f32>|
     -> Result<(VrsRow, HdrImage)> {
        let coarse = resolve::resolve_coarse(gb, lights, &mask, Coarse { sri, mode: cfg.mode }, &cfg.resolve)?;
        let evaluations = coarse.stats.shading_evaluations;
        let (resolve_ms, shade_ms) = (coarse.stats.ms.total, shade_ms(&coarse.stats));
        let image = coarse.image;
        let row = VrsRow {
            generator: generator.into(),
            tile,
            rates: histogram(sri),
            evaluations,
            evaluations_per_pixel: evaluations as f64 / pixels,
            saved: if full_evals == 0 { 0.0 } else { 1.0 - evaluations as f64 / full_evals as f64 },
            vs_full_rate: error_set(&full, &image, v),
            vs_reference: error_set(&reference, &image, v),
            resolve_ms,
            shade_ms,
            sri_ms,
            rule_scale: scale,
        };
        Ok((row, image))
    };
    let push = |out: &mut VrsOutput, (row, image): (VrsRow, HdrImage), sri: Sri| {
        out.rows.push(row);
        out.images.push(image);
        out.sris.push(sri);
    };
    for &tile in &cfg.tiles {
        let (sri, ms) = timed(|| rate::gbuffer_sri(gb, lit, &mask, tile, cfg.extra_rates, &rule))?;
        let measured = measure("gbuffer", tile, (&sri, Some(ms)), None)?;
        let budget = measured.0.evaluations;
        push(&mut out, measured, sri.clone());
        // FidelityFX VRS's rule on the full-rate image as "the previous frame" (a static camera).
        // (At 8× MSAA and beyond the hardware clamps its 2 × 2 tiles.)
        // With the additional rates it is AMD's build of the pass that has them.
        let (ffx, ms) = timed(|| rate::ffx_sri(&full, tile, cfg.ffx_cutoff, cfg.ffx_wave, cfg.extra_rates))?;
        let ffx = ffx.clamped(gb.samples, cfg.extra_rates);
        push(&mut out, measure("ffx", tile, (&ffx, Some(ms)), None)?, ffx);
        // gbuf's rule with what `ffx` reads as its preview: the full-rate image as a static camera's previous frame
        // (a renderer's last frame), instead of the lights.
        if rule.preview > 0.0 {
            let (prev, ms) = timed(|| {
                let shown = resolve::ImagePreview::new(&full, tone);
                rate::gbuffer_sri(gb, Some(&shown), &mask, tile, cfg.extra_rates, &rule)
            })?;
            push(&mut out, measure("gbuffer-prev", tile, (&prev, Some(ms)), None)?, prev);
        }
        // The oracle at gbuf's budget: per tile the rates' errors against the reference and their evaluations.
        let tiles = sri.rates.len();
        let (mut error, mut evals) = (vec![Vec::new(); tiles], vec![Vec::new(); tiles]);
        for (k, &r) in rates.iter().enumerate() {
            let at = Sri::uniform(gb.width, gb.height, tile, r);
            let per_tile = tile_sums(&uniform[k], gb.width, gb.height, tile);
            for (t, n) in rate::tile_evaluations(gb, &mask, &at).into_iter().enumerate() {
                evals[t].push(n);
                error[t].push(per_tile[t]);
            }
        }
        let objective = |s: &Sri| -> f64 {
            s.rates.iter().enumerate().map(|(t, r)| error[t][rates.iter().position(|x| x == r).expect("a rate")]).sum()
        };
        // gbuf's own SRI is a candidate: the oracle is never worse than it at its budget.
        let oracle = rate::cheapest_sri(&sri, &rates, &error, &evals, budget)
            .filter(|o| objective(o) <= objective(&sri))
            .unwrap_or_else(|| sri.clone());
        push(&mut out, measure("oracle", tile, (&oracle, None), None)?, oracle);
        if let (Some(max), Some(_)) = (cfg.max_flip, v) {
            // The rule's thresholds scaled from strict to loose; the most evaluations saved within the FLIP bound.
            let mut best: Option<((VrsRow, HdrImage), Sri)> = None;
            for scale in RULE_SCALES {
                let r = Smoothness {
                    depth_relative: rule.depth_relative * scale,
                    normal_deg: rule.normal_deg * scale,
                    albedo: rule.albedo * scale,
                    lobe: rule.lobe * scale,
                    preview: rule.preview * scale,
                    ..rule
                };
                let (s, ms) = timed(|| rate::gbuffer_sri(gb, lit, &mask, tile, cfg.extra_rates, &r))?;
                if best.as_ref().is_some_and(|b| b.0 .0.evaluations <= rate::evaluations(gb, &mask, &s)) {
                    continue;
                }
                let m = measure("gbuffer-max-flip", tile, (&s, Some(ms)), Some(scale))?;
                if m.0.vs_full_rate.flip_ldr.is_some_and(|f| f <= max) {
                    best = Some((m, s));
                }
            }
            if let Some((m, s)) = best {
                push(&mut out, m, s);
            }
        }
    }
    out.full_rate = full;
    Ok(out)
}

/// `f`'s result and its wall time (ms).
fn timed<T>(f: impl FnOnce() -> Result<T>) -> Result<(T, f64)> {
    let t = std::time::Instant::now();
    let v = f()?;
    Ok((v, t.elapsed().as_secs_f64() * 1e3))
}

/// A resolve's light loop: its work lists shaded against their lights (ms).
fn shade_ms(stats: &resolve::ResolveStats) -> f64 {
    stats.ms.shade
}

/// Tiles per rate of `sri` (rates no tile has are left out).
fn histogram(sri: &Sri) -> Vec<(String, usize)> {
    Rate::ALL.iter().zip(sri.histogram()).filter(|(_, n)| *n > 0).map(|(r, n)| (r.name().to_string(), n)).collect()
}

/// Per pixel, the squared difference of `image` and `reference` as displayed (the default tone map, summed over
/// the channels): what the oracle minimises.
fn displayed_errors(image: &HdrImage, reference: &HdrImage) -> Vec<f64> {
    let tone = crate::image::ToneMap::default();
    image
        .rgb
        .iter()
        .zip(&reference.rgb)
        .map(|(a, b)| (0..3).map(|c| f64::from(tone.apply(a[c]) - tone.apply(b[c])).powi(2)).sum::<f64>())
        .collect()
}

/// `per_pixel` summed over each `tile × tile` tile (row-major).
fn tile_sums(per_pixel: &[f64], width: u32, height: u32, tile: u32) -> Vec<f64> {
    let cols = width.div_ceil(tile);
    let mut out = vec![0.0; (cols * height.div_ceil(tile)) as usize];
    for (p, e) in per_pixel.iter().enumerate() {
        let (x, y) = (p as u32 % width, p as u32 / width);
        out[((y / tile) * cols + x / tile) as usize] += e;
    }
    out
}
