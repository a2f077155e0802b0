//! The `lauritzen` detector (and `combined`, which adds the ID test): Lauritzen 2010's per-pixel test.
//!
//! For every sample `i > 0` of a fully covered pixel, the sample is on the same surface as sample 0 when
//! `|z_i − z_0| ≤ s · (|∂z/∂x| + |∂z/∂y|) + slack · z_0` and `n_i · n_0 ≥ cos θ` (θ ≈ 8.1°, i.e. 0.99). The depth
//! bound is derivative-aware: MSAA samples lie less than a pixel apart on each axis, so a planar surface moves
//! less than `|∂z/∂x| + |∂z/∂y|` between them however steeply it is seen, while a silhouette jumps by more.
//!
//! The derivatives (view depth per pixel) come from a stored gradient when the caller has one
//! ([`detect_with_gradient`]); otherwise they are estimated from sample 0 of the neighbouring pixels
//! ([`neighbour_gradient`]): per axis a one-sided difference, from the side that continues the pixel's own surface.
//! At a silhouette one side of a pixel is another surface, so a central difference would add half the jump and
//! hide the edge; at a crease the side across the crease can give a difference near zero, so "the smaller one" is
//! not enough either: the side whose next difference agrees (the surface goes on) is preferred.

use super::id::IdPlanes;
use super::{depth_plane, geometric_mask, missing, Detector, DetectorConfig, EdgeMask};
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::{Vec2, Vec3};

/// A one-sided difference is *consistent* (the neighbour continues the pixel's own surface) when the next
/// difference along the same direction is within this fraction of it. Why 0.5: on a plane the second difference
/// comes from perspective only and stays under half the first difference until the plane is within about 4 pixels
/// of its vanishing line; at a crease or silhouette the next difference has the other surface's slope or the jump.
pub const CONSISTENCY: f32 = 0.5;

/// Screen-space depth derivatives at pixel (`x`, `y`), in view-depth units per pixel, estimated from sample 0 of
/// the neighbouring pixels. `depth` is the view-depth plane of `gb`.
///
/// Per axis, each side gives a one-sided difference `a = z(x±1) − z(x)` and, when the pixel beyond is usable, the
/// next one `b = z(x±2) − z(x±1)`. A side is consistent when `|b − a| ≤ CONSISTENCY · |a|` (it continues the
/// pixel's own surface); the smaller `|a|` among consistent sides is taken, else the smaller `|a|` among all
/// sides. So at a silhouette the far side (a jump) is ignored, and at a crease the side across the crease (whose
/// next difference has the other plane's slope) is too. Background and non-finite neighbours are ignored; an axis
/// without a usable neighbour gets 0 (which makes the test stricter, i.e. conservative).
#[must_use]
pub fn neighbour_gradient(gb: &GBuffer, depth: &[f32], x: u32, y: u32) -> Vec2 {
    estimate(|dx, dy| {
        let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
        if nx < 0 || ny < 0 || nx >= i64::from(gb.width) || ny >= i64::from(gb.height) {
            return f32::NAN;
        }
        let i = gb.index(nx as u32, ny as u32, 0);
        if gb.coverage[i] {
            depth[i]
        } else {
            f32::NAN
        }
    })
}

/// Sample 0's depth of every pixel (row-major), NaN where it is background or not finite: a compact plane so the
/// neighbour lookups of [`estimate`] touch 4 bytes per pixel instead of striding over the samples.
fn sample0_depths(gb: &GBuffer, depth: &[f32]) -> Vec<f32> {
    let s = gb.samples as usize;
    (0..gb.pixel_count())
        .map(|p| {
            let z = depth[p * s];
            if gb.coverage[p * s] && z.is_finite() {
                z
            } else {
                f32::NAN
            }
        })
        .collect()
}

/// The estimator of [`neighbour_gradient`] over a lookup `z(dx, dy)` of sample 0's depth at the pixel offset by
/// (dx, dy): NaN when outside the image, background or not finite; `z(0, 0)` is the pixel itself.
#[inline]
fn estimate(z: impl Fn(i64, i64) -> f32) -> Vec2 {
    let z0 = z(0, 0);
    // (|a|, consistent) for the side in direction (dx, dy); `None` when the neighbour is unusable.
    let side = |dx: i64, dy: i64| -> Option<(f32, bool)> {
        let z1 = z(dx, dy);
        let a = z1 - z0;
        if !a.is_finite() {
            return None;
        }
        let b = z(2 * dx, 2 * dy) - z1;
        // A NaN `b` (no usable pixel beyond) compares false: not consistent.
        let consistent = (b - a).abs() <= CONSISTENCY * a.abs() + 4.0 * f32::EPSILON * z0.abs();
        Some((a.abs(), consistent))
    };
    let pick = |p: Option<(f32, bool)>, q: Option<(f32, bool)>| match (p, q) {
        (Some((a, ca)), Some((b, cb))) => match (ca, cb) {
            (true, false) => a,
            (false, true) => b,
            _ => a.min(b),
        },
        (Some((a, _)), None) | (None, Some((a, _))) => a,
        (None, None) => 0.0,
    };
    Vec2::new(pick(side(-1, 0), side(1, 0)), pick(side(0, -1), side(0, 1)))
}

/// The estimated depth gradient of every pixel (row-major), as [`neighbour_gradient`] computes it; (0, 0) at
/// pixels whose sample 0 is background. Useful to inspect the estimate or to feed [`detect_with_gradient`].
pub fn neighbour_gradients(gb: &GBuffer) -> Result<Vec<Vec2>> {
    gb.validate()?;
    let depth = depth_plane(gb, Detector::Lauritzen)?;
    let mut out = Vec::with_capacity(gb.pixel_count());
    for y in 0..gb.height {
        for x in 0..gb.width {
            let covered = gb.coverage[gb.index(x, y, 0)];
            out.push(if covered { neighbour_gradient(gb, &depth, x, y) } else { Vec2::ZERO });
        }
    }
    Ok(out)
}

/// Lauritzen's test on one fully covered pixel whose samples start at `base`: are all samples on sample 0's
/// surface? Any NaN or infinity in the pixel's depths or normals answers `false` (an edge). The gradient is only
/// asked for when some depth differs by more than the slack (most pixels of a frame are flat enough not to).
#[inline]
fn same_surface(
    depth: &[f32],
    normal: &[Vec3],
    base: usize,
    samples: usize,
    gradient: impl FnOnce() -> Vec2,
    cfg: &DetectorConfig,
    min_dot: f32,
) -> bool {
    let z0 = depth[base];
    if !z0.is_finite() {
        return false;
    }
    let n0 = normal[base];
    let l0 = n0.length_squared();
    let mut max_dz = 0f32;
    for i in base + 1..base + samples {
        let ni = normal[i];
        let norms = (l0 * ni.length_squared()).sqrt();
        if !(norms > 0.0 && norms.is_finite() && n0.dot(ni) >= min_dot * norms) {
            return false;
        }
        // NaN and infinity land on "different surface", whatever the threshold.
        let dz = (depth[i] - z0).abs();
        if !dz.is_finite() {
            return false;
        }
        max_dz = max_dz.max(dz);
    }
    let slack = cfg.depth_slack * z0.abs();
    if max_dz <= slack {
        return true;
    }
    // The bound is at least the slack, so pixels decided above would pass it too. A bound that overflows to +∞
    // from finite inputs accepts everything (monotone in the thresholds); a NaN bound (non-finite gradient) is an
    // edge.
    let g = gradient();
    let bound = cfg.gradient_scale * (g.x.abs() + g.y.abs()) + slack;
    !bound.is_nan() && max_dz <= bound
}

/// Runs `lauritzen` (or `combined` when `with_ids`) with neighbour-estimated derivatives.
pub(crate) fn detect(gb: &GBuffer, cfg: &DetectorConfig, with_ids: bool) -> Result<EdgeMask> {
    run(gb, cfg, with_ids, None)
}

/// Runs `lauritzen` (or `combined` when `with_ids`) with a stored depth gradient: `gradient[p]` is (∂z/∂x, ∂z/∂y)
/// of pixel `p` (row-major) in view-depth units per pixel, as a renderer writes it from `ddx`/`ddy` of view depth.
pub fn detect_with_gradient(gb: &GBuffer, cfg: &DetectorConfig, with_ids: bool, gradient: &[Vec2]) -> Result<EdgeMask> {
    cfg.validate()?;
    gb.validate()?;
    if gradient.len() != gb.pixel_count() {
        return Err(Error::Mismatch(format!(
            "depth gradient has {} entries for {} pixels",
            gradient.len(),
            gb.pixel_count()
        )));
    }
    run(gb, cfg, with_ids, Some(gradient))
}

fn run(gb: &GBuffer, cfg: &DetectorConfig, with_ids: bool, gradient: Option<&[Vec2]>) -> Result<EdgeMask> {
    let detector = if with_ids { Detector::Combined } else { Detector::Lauritzen };
    let depth = depth_plane(gb, detector)?;
    let normal = gb.normal.as_deref().ok_or_else(|| missing(gb, detector, "depth (or position) and normal"))?;
    // `combined` uses IDs when the G-buffer has them and falls back to `lauritzen` alone otherwise.
    let ids = if with_ids { IdPlanes::resolve(gb, cfg.ids) } else { None };
    let (s, w, h) = (gb.samples as usize, i64::from(gb.width), i64::from(gb.height));
    let min_dot = cfg.min_normal_dot();
    let z0s = if gradient.is_none() { sample0_depths(gb, &depth) } else { Vec::new() };
    Ok(geometric_mask(gb, |x, y, base| {
        let p = y as usize * gb.width as usize + x as usize;
        let g = || match gradient {
            Some(g) => g[p],
            None => estimate(|dx, dy| {
                let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    f32::NAN
                } else {
                    z0s[(ny * w + nx) as usize]
                }
            }),
        };
        ids.as_ref().is_none_or(|ids| ids.same(base, s)) && same_surface(&depth, normal, base, s, g, cfg, min_dot)
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w × h × s` buffer, fully covered, facing the camera at depth `z`.
    fn flat(w: u32, h: u32, s: u32, z: f32) -> GBuffer {
        let mut gb = GBuffer::new(w, h, s).unwrap();
        gb.coverage.fill(true);
        gb.depth = Some(vec![z; gb.len()]);
        gb.normal = Some(vec![Vec3::Z; gb.len()]);
        gb
    }

    #[test]
    fn one_sided_difference_follows_the_pixels_own_surface() {
        let mut gb = flat(3, 1, 1, 0.0);
        gb.depth = Some(vec![1.0, 1.1, 9.0]);
        let d = gb.depth.clone().unwrap();
        let g = neighbour_gradient(&gb, &d, 1, 0);
        assert!((g.x - 0.1).abs() < 1e-6 && g.y == 0.0, "{g}");
        // Background neighbours are ignored.
        gb.coverage[0] = false;
        let g = neighbour_gradient(&gb, &d, 1, 0);
        assert!((g.x - 7.9).abs() < 1e-5, "{g}");
        // A ridge at pixel 3: pixel 2's right neighbour differs by 0.05, but the surface turns there; the left
        // side (slope 0.2 twice) continues pixel 2's plane and wins.
        let mut gb = flat(6, 1, 1, 0.0);
        gb.depth = Some(vec![1.0, 1.2, 1.4, 1.45, 1.25, 1.05]);
        let d = gb.depth.clone().unwrap();
        let g = neighbour_gradient(&gb, &d, 2, 0);
        assert!((g.x - 0.2).abs() < 1e-5, "{g}");
    }

    #[test]
    fn flat_plane_has_no_edges_and_a_step_does() {
        let gb = flat(4, 4, 4, 5.0);
        let m = detect(&gb, &DetectorConfig::default(), false).unwrap();
        assert_eq!(m.edge_pixels(), 0);
        let mut gb = gb;
        let i = gb.index(2, 2, 3);
        gb.depth.as_mut().unwrap()[i] = 5.5;
        let m = detect(&gb, &DetectorConfig::default(), false).unwrap();
        assert_eq!(m.edges().iter().filter(|&&e| e).count(), 1);
        assert!(m.is_edge(2 * 4 + 2));
    }

    #[test]
    fn non_finite_input_is_an_edge_not_a_panic() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut gb = flat(3, 3, 4, 2.0);
            let i = gb.index(1, 1, 0);
            gb.depth.as_mut().unwrap()[i] = bad;
            let j = gb.index(0, 0, 2);
            gb.normal.as_mut().unwrap()[j] = Vec3::splat(bad);
            let m = detect(&gb, &DetectorConfig::default(), false).unwrap();
            assert!(m.is_edge(4) && m.is_edge(0), "{bad}: {:?}", m.shade_count);
            assert_eq!(m.edge_pixels(), 2, "{bad}: {:?}", m.shade_count);
        }
    }

    #[test]
    fn stored_gradient_is_used_and_checked() {
        let mut gb = flat(2, 1, 2, 4.0);
        let i = gb.index(0, 0, 1);
        gb.depth.as_mut().unwrap()[i] = 4.3;
        let cfg = DetectorConfig::default();
        assert!(detect_with_gradient(&gb, &cfg, false, &[Vec2::ZERO; 2]).unwrap().is_edge(0));
        assert!(!detect_with_gradient(&gb, &cfg, false, &[Vec2::new(0.2, 0.2); 2]).unwrap().is_edge(0));
        assert!(detect_with_gradient(&gb, &cfg, false, &[Vec2::ZERO; 3]).is_err());
        let g = neighbour_gradients(&gb).unwrap();
        assert_eq!(g, vec![Vec2::ZERO; 2]);
    }

    #[test]
    fn stored_estimate_and_inline_estimate_agree() {
        // A bumpy buffer with background holes: feeding the per-pixel estimate back as a stored gradient must give
        // the same mask as the inline path.
        let mut rng = crate::base::rng::SplitMix64::new(9);
        let mut gb = flat(17, 11, 4, 1.0);
        for i in 0..gb.len() {
            let p = i / 4;
            gb.depth.as_mut().unwrap()[i] = 3.0 + 0.05 * (p % 17) as f32 + rng.range_f32(0.0, 0.06);
            gb.coverage[i] = rng.next_f32() > 0.03;
        }
        let cfg = DetectorConfig::default();
        let inline = detect(&gb, &cfg, false).unwrap();
        let stored = detect_with_gradient(&gb, &cfg, false, &neighbour_gradients(&gb).unwrap()).unwrap();
        assert_eq!(inline, stored);
        assert!(inline.edge_pixels() > 0 && inline.edge_pixels() < gb.pixel_count());
    }
}
