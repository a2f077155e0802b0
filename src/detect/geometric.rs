//! The single-attribute geometric detectors: `depth` (relative plus absolute depth difference) and `normal`
//! (angle between normals).
//!
//! Both compare every sample against sample 0 of the same pixel. `depth` is not derivative-aware: a plane seen at a
//! grazing angle moves more than `relative · z` per pixel and is flagged, which is exactly the weakness Lauritzen's
//! derivative test removes. `normal` misses silhouettes between parallel surfaces (a box in front of a wall) and
//! finds creases the depth tests miss.

use super::{depth_plane, geometric_mask, missing, Detector, DetectorConfig, EdgeMask};
use crate::error::Result;
use crate::gbuffer::GBuffer;

/// Runs the `depth` detector: a sample is on another surface when
/// `|z_i − z_0| > depth_absolute + depth_relative · z_0`.
pub(crate) fn detect_depth(gb: &GBuffer, cfg: &DetectorConfig) -> Result<EdgeMask> {
    let depth = depth_plane(gb, Detector::Depth)?;
    let s = gb.samples as usize;
    Ok(geometric_mask(gb, |_, _, base| {
        let z0 = depth[base];
        let bound = cfg.depth_absolute + cfg.depth_relative * z0.abs();
        // Non-finite depths (and differences that overflow) are edges whatever the threshold; a bound that
        // overflows to +∞ accepts every finite difference, which keeps the test monotone.
        z0.is_finite()
            && depth[base + 1..base + s].iter().all(|&z| {
                let dz = (z - z0).abs();
                dz.is_finite() && dz <= bound
            })
    }))
}

/// Runs the `normal` detector: a sample is on another surface when its normal is more than
/// `normal_angle_deg` away from sample 0's (zero-length or non-finite normals count as different).
pub(crate) fn detect_normal(gb: &GBuffer, cfg: &DetectorConfig) -> Result<EdgeMask> {
    let normal = gb.normal.as_deref().ok_or_else(|| missing(gb, Detector::Normal, "normal"))?;
    let s = gb.samples as usize;
    let min_dot = cfg.min_normal_dot();
    Ok(geometric_mask(gb, |_, _, base| {
        let n0 = normal[base];
        let l0 = n0.length_squared();
        normal[base + 1..base + s].iter().all(|&n| {
            let norms = (l0 * n.length_squared()).sqrt();
            norms > 0.0 && norms.is_finite() && n0.dot(n) >= min_dot * norms
        })
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn one_pixel(depths: [f32; 2], normals: [Vec3; 2]) -> GBuffer {
        let mut gb = GBuffer::new(1, 1, 2).unwrap();
        gb.coverage.fill(true);
        gb.depth = Some(depths.to_vec());
        gb.normal = Some(normals.to_vec());
        gb
    }

    #[test]
    fn depth_threshold_is_relative_plus_absolute() {
        let gb = one_pixel([10.0, 10.15], [Vec3::Z; 2]);
        let edge = |relative, absolute| {
            let cfg = DetectorConfig { depth_relative: relative, depth_absolute: absolute, ..Default::default() };
            detect_depth(&gb, &cfg).unwrap().is_edge(0)
        };
        assert!(edge(0.01, 0.0)); // 0.15 > 0.1
        assert!(!edge(0.02, 0.0)); // 0.15 ≤ 0.2
        assert!(!edge(0.01, 0.06)); // 0.15 ≤ 0.16
    }

    #[test]
    fn normal_threshold_is_an_angle() {
        let tilted = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
        let edge = |deg, threshold| {
            let gb = one_pixel([1.0; 2], [Vec3::Z, tilted(deg)]);
            detect_normal(&gb, &DetectorConfig { normal_angle_deg: threshold, ..Default::default() })
                .unwrap()
                .is_edge(0)
        };
        assert!(edge(10.0, 8.0) && !edge(6.0, 8.0) && !edge(10.0, 12.0));
        // Non-unit normals are compared by angle, not by raw dot product.
        let gb = one_pixel([1.0; 2], [Vec3::Z * 0.5, Vec3::Z * 3.0]);
        assert!(!detect_normal(&gb, &DetectorConfig::default()).unwrap().is_edge(0));
        let gb = one_pixel([1.0; 2], [Vec3::Z, Vec3::ZERO]);
        assert!(detect_normal(&gb, &DetectorConfig::default()).unwrap().is_edge(0));
    }
}
