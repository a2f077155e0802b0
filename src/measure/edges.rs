//! How good an edge mask is: precision and recall against a ground truth, and what it costs (edge-pixel fraction
//! and per-sample shading fraction).
//!
//! Two truths: the *ID truth* ([`evaluate`]: a pixel whose samples come from different objects, or mix background
//! and surface; see [`crate::detect::truth`]) and the *shading truth* ([`shading_truth`]: a pixel whose reference
//! shading varies between its samples by more than a tolerance), which is what per-sample shading is for.
//! Both are compared with [`evaluate_against`].

use crate::detect::truth::object_truth;
use crate::detect::EdgeMask;
use crate::gbuffer::GBuffer;
use glam::Vec3;

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
    /// Shading evaluations / (pixels × samples), from the mask's shade counts.
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
    Some(evaluate_against(mask, &truth))
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

/// A reasonable default tolerance for [`shading_truth`] on radiance in [0, 1]-ish units: 1/255, one 8-bit display
/// step, so a pixel is a shading edge when per-sample shading would change a displayed value.
pub const DEFAULT_SHADING_TOLERANCE: f32 = 1.0 / 255.0;

/// The shading truth: per pixel (row-major), does some sample's reference radiance differ from sample 0's by more
/// than `tolerance` in some channel? `per_sample_radiance` is in the G-buffer's plane order
/// (`(y * width + x) * samples + s`), e.g. from the resolve's per-sample reference. Background samples take
/// whatever radiance the reference gives them. Non-finite radiance, and samples missing from a too-short slice,
/// count as differing (conservative).
#[must_use]
pub fn shading_truth(gb: &GBuffer, per_sample_radiance: &[Vec3], tolerance: f32) -> Vec<bool> {
    let s = gb.samples as usize;
    (0..gb.pixel_count())
        .map(|p| {
            let Some(px) = per_sample_radiance.get(p * s..p * s + s) else {
                return true;
            };
            let r0 = px[0];
            // `!(d <= tol)` per channel so that NaN counts as a difference (`max_element` would drop a NaN).
            let tol = Vec3::splat(tolerance);
            px.iter().any(|r| !(*r - r0).abs().cmple(tol).all())
        })
        .collect()
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

    #[test]
    fn shading_truth_uses_the_tolerance_and_is_conservative() {
        let gb = GBuffer::new(3, 1, 2).unwrap();
        let r = [
            Vec3::splat(0.5),
            Vec3::new(0.5, 0.5, 0.52), // differs by 0.02
            Vec3::ONE,
            Vec3::ONE,
            Vec3::ZERO,
            Vec3::new(f32::NAN, 0.0, 0.0),
        ];
        assert_eq!(shading_truth(&gb, &r, 0.01), vec![true, false, true]);
        assert_eq!(shading_truth(&gb, &r, 0.05), vec![false, false, true]);
        assert_eq!(shading_truth(&gb, &r[..4], 0.05), vec![false, false, true]);
    }
}
