//! How good an edge mask is: precision and recall against a ground truth, and what it costs (edge-pixel fraction
//! and per-sample shading fraction).
//!
//! Two truths: the *ID truth* ([`evaluate`]: a pixel whose samples come from different objects, or mix background
//! and surface; see [`crate::detect::truth`]) and the *shading truth* ([`shading_truth`]: a pixel whose reference
//! shading varies between its samples by more than a stated [`ShadingTolerance`], beyond the image's smooth
//! gradient), which is what per-sample shading is for. Both are compared with [`evaluate_against`];
//! [`truth_agreement`] compares two truths.

use crate::base::mask::EdgeMask;
use crate::base::picture::srgb_encode;
use crate::detect::truth::{id_truth, object_truth, TruthSource};
use crate::gbuffer::GBuffer;
use crate::image::ToneMap;
use crate::light::Light;
use crate::resolve::{reference_per_sample, ResolveConfig};
use glam::Vec3;
use rayon::prelude::*;

/// An edge mask scored against a truth. Summable counts plus the ratios derived from them.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EdgeStats {
    /// Pixels in the image.
    pub pixels: u64,
    /// Samples per pixel.
    pub samples: u32,
    /// Pixels the mask shades per sample (`shade_count > 1`).
    pub edge_pixels: u64,
    /// Pixels the truth says need per-sample shading.
    pub true_edge_pixels: u64,
    /// Flagged and truly edges.
    pub tp: u64,
    /// Flagged but not edges (wasted per-sample shading).
    pub fp: u64,
    /// Edges not flagged (aliasing left in the image).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// tp / (tp + fp); 1 when nothing is flagged (no false alarm was raised).
    pub precision: f64,
    /// tp / (tp + fn); 1 when the truth has no edge (nothing was missed).
    pub recall: f64,
    /// edge_pixels / pixels.
    pub edge_fraction: f64,
    /// true_edge_pixels / pixels.
    pub true_edge_fraction: f64,
    /// Shading evaluations / (pixels × samples): with [`evaluate`], what the mask costs on the G-buffer
    /// ([`EdgeMask::evaluated_fraction`]: covered samples only); with [`evaluate_against`], which has no coverage,
    /// what it asks for ([`EdgeMask::shading_fraction`]).
    pub shading_fraction: f64,
}

/// Scores `mask` against the object-ID truth of `gb`; `None` when `gb` has no object IDs (or the mask does not
/// match the G-buffer's size).
#[must_use]
pub fn evaluate(gb: &GBuffer, mask: &EdgeMask) -> Option<EdgeStats> {
    if mask.width != gb.width || mask.height != gb.height {
        return None;
    }
    let truth = object_truth(gb)?;
    let mut s = evaluate_against(mask, &truth);
    s.shading_fraction = mask.evaluated_fraction(&crate::detect::covered_per_pixel(gb));
    Some(s)
}

/// Scores `mask` against per-pixel truth flags (row-major). Pixels beyond the shorter of the two are ignored.
#[must_use]
pub fn evaluate_against(mask: &EdgeMask, truth: &[bool]) -> EdgeStats {
    debug_assert_eq!(mask.shade_count.len(), truth.len());
    let (mut tp, mut fp, mut fn_, mut true_edges) = (0u64, 0u64, 0u64, 0u64);
    for (&c, &t) in mask.shade_count.iter().zip(truth) {
        let e = c > 1;
        tp += u64::from(e && t);
        fp += u64::from(e && !t);
        fn_ += u64::from(!e && t);
        true_edges += u64::from(t);
    }
    let pixels = mask.shade_count.len() as u64;
    let ratio = |num: u64, den: u64, empty: f64| if den == 0 { empty } else { num as f64 / den as f64 };
    EdgeStats {
        pixels,
        samples: mask.samples,
        edge_pixels: tp + fp,
        true_edge_pixels: true_edges,
        tp,
        fp,
        fn_,
        precision: ratio(tp, tp + fp, 1.0),
        recall: ratio(tp, tp + fn_, 1.0),
        edge_fraction: mask.edge_fraction(),
        true_edge_fraction: ratio(true_edges, pixels, 0.0),
        shading_fraction: mask.shading_fraction(),
    }
}

/// When does a pixel's shading vary enough between its samples to need per-sample shading? The stated tolerance
/// of [`shading_truth`]: a comparison domain and a threshold in it.
///
/// The default, [`DEFAULT_SHADING_TOLERANCE`], works in the displayed domain: one 8-bit code step of the PNG the
/// resolve writes at its defaults. An HDR difference matters exactly when it would change what is shown; one sRGB
/// code step is about one just-noticeable difference for mid tones; and the tone map makes the test relative to the
/// pixel's brightness (0.05 is many codes in a dark corner and less than one on a highlight of 20), which an
/// absolute linear threshold cannot do. At 1/255 absolute in linear radiance, 43% of the room's pixels were
/// "edges".
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "domain", rename_all = "kebab-case")]
pub enum ShadingTolerance {
    /// Displayed domain: per channel, `display(x) = 255 · srgb(reinhard(exposure · x))` — the tone map and sRGB
    /// encoding of `gbuf resolve --png` at its defaults, before rounding — and a threshold of `codes` code steps
    /// (continuous: a 0.3-code difference that happens to straddle a rounding boundary is not an edge).
    /// CLI spelling: `display:CODES`, or just `CODES`.
    Display {
        /// Threshold in 8-bit code steps.
        codes: f32,
        /// Exposure applied before the Reinhard tone map `y = x / (1 + x)`.
        exposure: f32,
    },
    /// Linear radiance with an absolute threshold. CLI spelling: `linear:X`. Not scale-invariant; kept to compare
    /// with older numbers.
    Linear {
        /// Threshold in linear radiance units.
        absolute: f32,
    },
}

/// The default shading tolerance: more than one 8-bit code step of the default PNG (Reinhard, exposure 1, sRGB).
pub const DEFAULT_SHADING_TOLERANCE: ShadingTolerance = ShadingTolerance::Display { codes: 1.0, exposure: 1.0 };

impl Default for ShadingTolerance {
    fn default() -> Self {
        DEFAULT_SHADING_TOLERANCE
    }
}

impl ShadingTolerance {
    /// Parses the CLI spelling: `CODES` or `display:CODES` (display domain, exposure 1), or `linear:X`.
    /// Thresholds must be finite and ≥ 0.
    pub fn parse(s: &str) -> Result<Self, String> {
        let (domain, value) = match s.split_once(':') {
            Some((d, v)) => (d.trim(), v.trim()),
            None => ("display", s.trim()),
        };
        let x: f32 = value.parse().map_err(|_| {
            format!("shading tolerance {s:?}: {value:?} is not a number (want CODES, display:CODES or linear:X)")
        })?;
        if !(x.is_finite() && x >= 0.0) {
            return Err(format!("shading tolerance {s:?}: the threshold must be finite and ≥ 0"));
        }
        match domain {
            "display" => Ok(ShadingTolerance::Display { codes: x, exposure: 1.0 }),
            "linear" => Ok(ShadingTolerance::Linear { absolute: x }),
            _ => Err(format!("shading tolerance {s:?}: unknown domain {domain:?}; known: display, linear")),
        }
    }

    /// Checks the numbers (finite, threshold ≥ 0, exposure > 0).
    pub fn validate(&self) -> crate::Result<()> {
        let ok = match *self {
            ShadingTolerance::Display { codes, exposure } => {
                codes.is_finite() && codes >= 0.0 && exposure.is_finite() && exposure > 0.0
            }
            ShadingTolerance::Linear { absolute } => absolute.is_finite() && absolute >= 0.0,
        };
        if ok {
            Ok(())
        } else {
            Err(crate::Error::Argument(format!(
                "invalid shading tolerance {self:?}: thresholds must be finite and ≥ 0, exposure > 0"
            )))
        }
    }

    /// Linear radiance → the comparison domain (per channel). Non-finite input stays non-finite so that it is
    /// caught as a difference.
    #[must_use]
    pub fn to_domain(&self, radiance: Vec3) -> Vec3 {
        match *self {
            ShadingTolerance::Display { exposure, .. } if radiance.is_finite() => {
                let tone = ToneMap::Reinhard { exposure };
                radiance.to_array().map(|x| 255.0 * srgb_encode(tone.apply(x))).into()
            }
            _ => radiance,
        }
    }

    /// The threshold in the comparison domain.
    #[must_use]
    pub fn threshold(&self) -> f32 {
        match *self {
            ShadingTolerance::Display { codes, .. } => codes,
            ShadingTolerance::Linear { absolute } => absolute,
        }
    }
}

impl std::fmt::Display for ShadingTolerance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let rule = "beyond the pixel's smooth gradient";
        match *self {
            ShadingTolerance::Display { codes, exposure } => {
                write!(f, "> {codes} 8-bit code step(s) after Reinhard (exposure {exposure}) + sRGB, {rule}")
            }
            ShadingTolerance::Linear { absolute } => write!(f, "> {absolute} linear radiance, {rule}"),
        }
    }
}

/// The shading truth: per pixel (row-major), does some sample's reference shading differ from the pixel's
/// sample-0 shading by more than `tolerance`, beyond what the image's smooth gradient accounts for?
///
/// In `tolerance`'s domain (see [`ShadingTolerance::to_domain`]), with `d_i` sample `i`'s value, `k` sample 0 (or
/// the first covered sample when sample 0 is background: the one the resolve shades for a non-edge pixel) and
/// `o_i` the sample offsets in pixels, a pixel is an edge when for some sample and channel
///
/// ```text
/// |d_i − d_k| > |∂d/∂x| · |o_i.x − o_k.x| + |∂d/∂y| · |o_i.y − o_k.y| + threshold
/// ```
///
/// — Lauritzen's depth test, applied to what is displayed. The derivatives are the smaller one-sided differences of
/// sample 0's value between the pixel and its left/right (up/down) neighbours, so they come from the smooth side at
/// a silhouette; a neighbour whose sample 0 is background does not count; with no usable neighbour the derivative
/// is 0. Without the gradient term, a smooth gradient steeper than ~2.5 codes per pixel (a lit sphere, the pool of
/// light under a lamp) would be an "edge" only because sample 0 sits 0.4 px off the pixel centre; shading such a
/// pixel per sample moves the value to the centre's, it removes no aliasing.
///
/// `per_sample_radiance` is in the G-buffer's plane order (`(y * width + x) * samples + s`), e.g. from
/// [`crate::resolve::reference_per_sample`]; background samples should hold 0 (black sky, as the reference has
/// them). Pixels with no covered sample are never edges. Non-finite radiance among a pixel's samples, and samples
/// missing from a too-short slice, count as differing (conservative).
#[must_use]
pub fn shading_truth(gb: &GBuffer, per_sample_radiance: &[Vec3], tolerance: ShadingTolerance) -> Vec<bool> {
    let (w, h, s) = (gb.width as usize, gb.height as usize, gb.samples as usize);
    let mut out = vec![false; gb.pixel_count()];
    if w == 0 || s == 0 || gb.coverage.len() != gb.len() || gb.sample_positions.len() != s {
        debug_assert!(gb.pixel_count() == 0, "inconsistent G-buffer reached shading_truth");
        return out;
    }
    // Every sample in the comparison domain, once (the sRGB curve is the costly part).
    let domain: Vec<Vec3> = per_sample_radiance.par_iter().map(|&r| tolerance.to_domain(r)).collect();
    let value = |i: usize| domain.get(i).copied();
    // Sample 0's value per pixel, where sample 0 is covered and finite: the neighbours' side of the gradient.
    let s0: Vec<Option<Vec3>> =
        (0..w * h).into_par_iter().map(|p| value(p * s).filter(|v| gb.coverage[p * s] && v.is_finite())).collect();
    let threshold = tolerance.threshold();
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, edge) in row.iter_mut().enumerate() {
            let p = y * w + x;
            let base = p * s;
            let Some(k) = gb.coverage[base..base + s].iter().position(|&c| c) else { continue };
            // Every sample present and finite, else conservative.
            if (base..base + s).any(|i| !value(i).is_some_and(|v| v.is_finite())) {
                *edge = true;
                continue;
            }
            let here = s0[p];
            let slope = |prev: Option<usize>, next: Option<usize>| {
                let side = |q: Option<usize>| Some((here? - s0[q?]?).abs());
                match (side(prev), side(next)) {
                    (Some(a), Some(b)) => a.min(b),
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => Vec3::ZERO,
                }
            };
            let dx = slope((x > 0).then(|| p - 1), (x + 1 < w).then_some(p + 1));
            let dy = slope((y > 0).then(|| p - w), (y + 1 < h).then_some(p + w));
            let (dk, ok) = (value(base + k).unwrap_or_default(), gb.sample_positions[k]);
            *edge = gb.sample_positions.iter().enumerate().any(|(i, &o)| {
                let d = value(base + i).unwrap_or_default();
                let off = (o - ok).abs();
                let bound = dx * off.x + dy * off.y + Vec3::splat(threshold);
                (d - dk).abs().cmpgt(bound).any()
            });
        }
    });
    out
}

/// How two per-pixel truths (e.g. the shading truth and the ID truth) agree.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct TruthAgreement {
    /// Pixels flagged by both.
    pub both: u64,
    /// Pixels flagged by `a` only.
    pub only_a: u64,
    /// Pixels flagged by `b` only.
    pub only_b: u64,
    /// `both / (both + only_b)`: the share of `b`'s edges that `a` flags too (1 when `b` has none).
    pub b_covered_by_a: f64,
    /// `both / (both + only_a)`: the share of `a`'s edges that `b` flags too (1 when `a` has none).
    pub a_covered_by_b: f64,
}

/// Compares two per-pixel truths of the same length (pixels beyond the shorter are ignored).
#[must_use]
pub fn truth_agreement(a: &[bool], b: &[bool]) -> TruthAgreement {
    let (mut both, mut only_a, mut only_b) = (0u64, 0u64, 0u64);
    for (&x, &y) in a.iter().zip(b) {
        both += u64::from(x && y);
        only_a += u64::from(x && !y);
        only_b += u64::from(!x && y);
    }
    let ratio = |n: u64, d: u64| if d == 0 { 1.0 } else { n as f64 / d as f64 };
    TruthAgreement {
        both,
        only_a,
        only_b,
        b_covered_by_a: ratio(both, both + only_b),
        a_covered_by_b: ratio(both, both + only_a),
    }
}

/// Fraction of `true` flags (0 for an empty slice): the true-edge fraction of a truth.
#[must_use]
pub fn true_fraction(t: &[bool]) -> f64 {
    if t.is_empty() {
        0.0
    } else {
        t.iter().filter(|&&e| e).count() as f64 / t.len() as f64
    }
}

/// The truths an edge mask is scored against, each `None` when the G-buffer cannot give it.
#[derive(Clone, Debug, Default)]
pub struct Truths {
    /// The object-ID truth ([`object_truth`]); needs object IDs.
    pub ids: Option<Vec<bool>>,
    /// The primitive-ID truth (the rate forward MSAA shades at); needs primitive IDs.
    pub primitives: Option<Vec<bool>>,
    /// The shading truth ([`shading_truth`]); needs lights.
    pub shading: Option<Vec<bool>>,
    /// Covered samples per pixel ([`crate::detect::covered_per_pixel`]): what a mask costs.
    pub covered: Vec<u8>,
}

impl Truths {
    /// Every truth `gb` can give: the ID truths from its IDs, and with (non-empty) `lights` the shading truth of the
    /// per-sample reference shading under `cfg` (its BRDF and falloff).
    pub fn of(
        gb: &GBuffer,
        lights: Option<&[Light]>,
        cfg: &ResolveConfig,
        tolerance: ShadingTolerance,
    ) -> crate::Result<Truths> {
        let shading = match lights {
            Some(lights) if !lights.is_empty() => {
                let radiance = reference_per_sample(gb, lights, cfg)?;
                Some(shading_truth(gb, &radiance, tolerance))
            }
            _ => None,
        };
        Ok(Truths {
            ids: object_truth(gb),
            primitives: id_truth(gb, TruthSource::Primitive),
            shading,
            covered: crate::detect::covered_per_pixel(gb),
        })
    }

    /// Scores `mask` against every truth there is.
    #[must_use]
    pub fn score(&self, mask: &EdgeMask) -> MaskScores {
        let scores = |t: &Option<Vec<bool>>| t.as_deref().map(|t| Scores::from(evaluate_against(mask, t)));
        MaskScores {
            edge_fraction: mask.edge_fraction(),
            shading_fraction: mask.evaluated_fraction(&self.covered),
            ids: scores(&self.ids),
            shading: scores(&self.shading),
            primitive: scores(&self.primitives),
        }
    }
}

/// The truth-dependent part of [`EdgeStats`]: what a detector's row reports per truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Scores {
    /// See [`EdgeStats::precision`].
    pub precision: f64,
    /// See [`EdgeStats::recall`].
    pub recall: f64,
    /// See [`EdgeStats::tp`].
    pub tp: u64,
    /// See [`EdgeStats::fp`].
    pub fp: u64,
    /// See [`EdgeStats::fn_`].
    #[serde(rename = "fn")]
    pub fn_: u64,
}

impl From<EdgeStats> for Scores {
    fn from(s: EdgeStats) -> Scores {
        Scores { precision: s.precision, recall: s.recall, tp: s.tp, fp: s.fp, fn_: s.fn_ }
    }
}

/// One mask scored against every [`Truths`]: its cost and, per truth there is, its scores. Serialised with the
/// ID-truth scores inline (`precision`, `recall`, …) and the others under `shading` and `primitive`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct MaskScores {
    /// See [`EdgeMask::edge_fraction`].
    pub edge_fraction: f64,
    /// See [`EdgeMask::shading_fraction`].
    pub shading_fraction: f64,
    /// Against the object-ID truth.
    #[serde(flatten)]
    pub ids: Option<Scores>,
    /// Against the shading truth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shading: Option<Scores>,
    /// Against the primitive-ID truth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub primitive: Option<Scores>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_built_confusion_matrix() {
        // 6 pixels: flagged = [y, y, n, n, y, n], truth = [y, n, y, n, y, y].
        let mask = EdgeMask { width: 3, height: 2, samples: 4, shade_count: vec![4, 4, 1, 0, 2, 1] };
        let truth = [true, false, true, false, true, true];
        let s = evaluate_against(&mask, &truth);
        assert_eq!((s.tp, s.fp, s.fn_, s.edge_pixels, s.true_edge_pixels), (2, 1, 2, 3, 4));
        assert!((s.precision - 2.0 / 3.0).abs() < 1e-12, "{}", s.precision);
        assert!((s.recall - 0.5).abs() < 1e-12, "{}", s.recall);
        assert!((s.edge_fraction - 0.5).abs() < 1e-12);
        assert!((s.true_edge_fraction - 4.0 / 6.0).abs() < 1e-12);
        assert!((s.shading_fraction - 12.0 / 24.0).abs() < 1e-12);
        let json = serde_json::to_value(s).unwrap();
        assert_eq!(json["fn"], 2);
    }

    #[test]
    fn empty_cases_are_defined() {
        let mask = EdgeMask { width: 2, height: 1, samples: 2, shade_count: vec![1, 1] };
        let s = evaluate_against(&mask, &[false, false]);
        assert_eq!((s.precision, s.recall), (1.0, 1.0));
    }

    #[test]
    fn evaluate_needs_object_ids() {
        let mut gb = GBuffer::new(2, 1, 2).unwrap();
        gb.coverage.fill(true);
        let mask = EdgeMask::filled(2, 1, 2, 1);
        assert_eq!(evaluate(&gb, &mask), None);
        gb.object_id = Some(vec![1, 1, 1, 2]);
        let s = evaluate(&gb, &mask).unwrap();
        assert_eq!((s.tp, s.fn_), (0, 1));
        assert_eq!(evaluate(&gb, &EdgeMask::filled(3, 1, 2, 1)), None);
    }

    /// A 3×1 image, 2 samples per pixel at offsets ±(¼, ¼): 0.5 px apart in x and in y.
    fn row_of_three() -> GBuffer {
        let mut gb = GBuffer::new(3, 1, 2).unwrap();
        gb.coverage.fill(true);
        gb
    }

    #[test]
    fn a_sample_differing_beyond_the_threshold_is_an_edge() {
        let gb = row_of_three();
        let lin = |x| ShadingTolerance::Linear { absolute: x };
        let flat = Vec3::splat(0.5);
        // Pixel 1's second sample is 0.02 brighter in blue; its neighbours are flat (no gradient to discount).
        let r = [flat, flat, flat, Vec3::new(0.5, 0.5, 0.52), flat, flat];
        assert_eq!(shading_truth(&gb, &r, lin(0.01)), vec![false, true, false]);
        assert_eq!(shading_truth(&gb, &r, lin(0.03)), vec![false, false, false]);
        // Display domain: 0.5 → 0.52 is 0.02/(1.5·1.52)·255·srgb′(1/3) ≈ 1.9 codes.
        let disp = |c| ShadingTolerance::Display { codes: c, exposure: 1.0 };
        assert_eq!(shading_truth(&gb, &r, disp(1.5)), vec![false, true, false]);
        assert_eq!(shading_truth(&gb, &r, disp(2.5)), vec![false, false, false]);
    }

    #[test]
    fn a_smooth_ramp_is_discounted_but_a_step_is_not() {
        let gb = row_of_three();
        let lin = ShadingTolerance::Linear { absolute: 0.01 };
        // A ramp of 1 per pixel: samples 0.5 px apart differ by 0.5, exactly what the gradient accounts for.
        let ramp: Vec<Vec3> = (0..6).map(|i| Vec3::splat(i as f32 * 0.5)).collect();
        assert_eq!(shading_truth(&gb, &ramp, lin), vec![false, false, false]);
        // A step inside pixel 1 (its second sample jumps by 5) with flat neighbours on both sides.
        let mut step = vec![Vec3::ZERO; 6];
        step[3] = Vec3::splat(5.0);
        step[4] = Vec3::splat(5.0);
        step[5] = Vec3::splat(5.0);
        assert_eq!(shading_truth(&gb, &step, lin), vec![false, true, false]);
        // The gradient is the smaller one-sided difference: pixel 1 next to a jump on its left only is still
        // measured against its flat right side.
        let mut one_sided = vec![Vec3::ZERO; 6];
        one_sided[2] = Vec3::splat(5.0);
        one_sided[3] = Vec3::splat(5.1);
        one_sided[4] = Vec3::splat(5.0);
        one_sided[5] = Vec3::splat(5.0);
        assert_eq!(shading_truth(&gb, &one_sided, lin), vec![false, true, false]);
    }

    #[test]
    fn background_samples_and_bad_values() {
        let mut gb = row_of_three();
        // Pixel 0: half background (black) beside a lit sample: an edge. Pixel 2: empty, NaN ignored.
        gb.coverage = vec![false, true, true, true, false, false];
        let lin = ShadingTolerance::Linear { absolute: 0.01 };
        let r = [Vec3::ZERO, Vec3::ONE, Vec3::ONE, Vec3::ONE, Vec3::ZERO, Vec3::NAN];
        assert_eq!(shading_truth(&gb, &r, lin), vec![true, false, false]);
        // A NaN among covered samples, and samples missing from a short slice, count as differing.
        let mut bad = r;
        bad[3] = Vec3::new(f32::NAN, 1.0, 1.0);
        assert_eq!(shading_truth(&gb, &bad, lin), vec![true, true, false]);
        assert_eq!(shading_truth(&gb, &r[..3], lin), vec![true, true, false]);
    }

    #[test]
    fn display_domain_is_relative_to_brightness() {
        let t = DEFAULT_SHADING_TOLERANCE;
        let step = |a: f32, b: f32| (t.to_domain(Vec3::splat(b)) - t.to_domain(Vec3::splat(a))).max_element();
        // The same linear step of 0.05 is many codes in the dark and less than one on a bright highlight.
        assert!(step(0.05, 0.10) > 10.0, "{}", step(0.05, 0.10));
        assert!(step(20.0, 20.05) < 0.1, "{}", step(20.0, 20.05));
        assert_eq!(t.to_domain(Vec3::ZERO), Vec3::ZERO);
        assert!((t.to_domain(Vec3::splat(1e30)).x - 255.0).abs() < 1e-3);
        assert!(!t.to_domain(Vec3::NAN).is_finite(), "NaN must stay visible to the truth");
        // Exposure scales what "dark" means.
        let bright = ShadingTolerance::Display { codes: 1.0, exposure: 100.0 };
        assert_eq!(bright.to_domain(Vec3::splat(0.01)), t.to_domain(Vec3::splat(1.0)));
    }

    #[test]
    fn tolerance_spellings_parse_and_bad_ones_are_refused() {
        assert_eq!(ShadingTolerance::parse("1"), Ok(DEFAULT_SHADING_TOLERANCE));
        assert_eq!(ShadingTolerance::parse("display:2.5"), Ok(ShadingTolerance::Display { codes: 2.5, exposure: 1.0 }));
        assert_eq!(ShadingTolerance::parse("linear:0.01"), Ok(ShadingTolerance::Linear { absolute: 0.01 }));
        for bad in ["", "x", "linear:", "log:1", "-1", "display:nan", "linear:inf"] {
            let e = ShadingTolerance::parse(bad).unwrap_err();
            assert!(e.contains("shading tolerance"), "{bad}: {e}");
        }
        assert!(ShadingTolerance::Display { codes: 1.0, exposure: 0.0 }.validate().is_err());
        assert!(DEFAULT_SHADING_TOLERANCE.validate().is_ok());
        assert!(DEFAULT_SHADING_TOLERANCE.to_string().contains("8-bit code"));
    }

    #[test]
    fn agreement_counts() {
        let a = [true, true, false, false, true];
        let b = [true, false, true, false, true];
        let g = truth_agreement(&a, &b);
        assert_eq!((g.both, g.only_a, g.only_b), (2, 1, 1));
        assert!((g.b_covered_by_a - 2.0 / 3.0).abs() < 1e-12 && (g.a_covered_by_b - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(truth_agreement(&[false], &[false]).b_covered_by_a, 1.0);
    }
}
