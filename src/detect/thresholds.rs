//! The thresholds of every edge detector, in one configuration value.
//!
//! Every threshold is monotone: raising it never adds edges (a property test checks it). The defaults follow
//! Lauritzen's 2010 deferred-MSAA demo (depth compared against the screen-space depth derivatives, normals
//! against `n_i · n_0 < 0.99`, i.e. about 8.1°).

use crate::error::{Error, Result};

/// `acos(0.99)` in degrees: the normal threshold of Lauritzen's demo (`dot(n_i, n_0) < 0.99`).
pub const LAURITZEN_NORMAL_ANGLE_DEG: f32 = 8.109_614;

/// Default relative slack of the derivative test, as a fraction of `z_0`. Why: a camera-facing plane has zero
/// depth derivatives, so the bare test `|Δz| > 0` would flag f32 rounding and the quantisation of a packed depth
/// (a 24-bit post-projection depth resolves about 1e-5 of the view depth at mid range).
pub const DEFAULT_DEPTH_SLACK: f32 = 1e-4;

/// Default relative threshold of the `depth` detector: samples more than 2 % of the view depth apart are on
/// different surfaces. Flags slopes steeper than about 2 % of the depth per pixel (grazing floors far away).
pub const DEFAULT_DEPTH_RELATIVE: f32 = 0.02;

/// Which integer IDs the `id` detector compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IdSource {
    /// Material IDs only (what a real G-buffer stores).
    Material,
    /// Object IDs only.
    Object,
    /// Whichever of the two are present; a pixel is an edge when either differs.
    #[default]
    Either,
}

crate::named!(IdSource: "ID choice" { Material => "material", Object => "object", Either => "either" });

/// The thresholds of every detector. Raising any of the numeric thresholds never adds edges.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DetectorConfig {
    /// `lauritzen`: sample `i` is on another surface when `|z_i − z_0| > gradient_scale · (|∂z/∂x| + |∂z/∂y|)
    /// + depth_slack · z_0`. 1.0 is Lauritzen's test.
    pub gradient_scale: f32,
    /// `lauritzen`: relative slack added to the derivative bound (see `DEFAULT_DEPTH_SLACK`).
    pub depth_slack: f32,
    /// `depth`: sample `i` is on another surface when `|z_i − z_0| > depth_absolute + depth_relative · z_0`.
    pub depth_relative: f32,
    /// `depth`: absolute part of the threshold, in view-space units (0 by default: purely relative).
    pub depth_absolute: f32,
    /// `normal` and `lauritzen`: samples whose normals differ by more than this angle (degrees) are on
    /// different surfaces.
    pub normal_angle_deg: f32,
    /// `id` and `combined`: which IDs to compare.
    pub ids: IdSource,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            gradient_scale: 1.0,
            depth_slack: DEFAULT_DEPTH_SLACK,
            depth_relative: DEFAULT_DEPTH_RELATIVE,
            depth_absolute: 0.0,
            normal_angle_deg: LAURITZEN_NORMAL_ANGLE_DEG,
            ids: IdSource::Either,
        }
    }
}

impl DetectorConfig {
    /// Refuses negative or non-finite thresholds (an angle is also capped at 180°).
    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("gradient_scale", self.gradient_scale),
            ("depth_slack", self.depth_slack),
            ("depth_relative", self.depth_relative),
            ("depth_absolute", self.depth_absolute),
            ("normal_angle_deg", self.normal_angle_deg),
        ];
        for (name, v) in checks {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::Argument(format!("detector threshold {name} = {v} must be finite and ≥ 0")));
            }
        }
        if self.normal_angle_deg > 180.0 {
            return Err(Error::Argument(format!(
                "detector threshold normal_angle_deg = {} must be at most 180",
                self.normal_angle_deg
            )));
        }
        Ok(())
    }

    /// The cosine of the normal threshold: samples with `n_i · n_0 < min_normal_dot · |n_i| |n_0|` differ.
    #[must_use]
    pub fn min_normal_dot(&self) -> f32 {
        self.normal_angle_deg.to_radians().cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_normal_threshold_is_lauritzens_dot() {
        let c = DetectorConfig::default();
        assert!((c.min_normal_dot() - 0.99).abs() < 1e-6, "{}", c.min_normal_dot());
        c.validate().unwrap();
    }

    #[test]
    fn bad_thresholds_are_refused() {
        let bad = [
            DetectorConfig { gradient_scale: -1.0, ..Default::default() },
            DetectorConfig { depth_relative: f32::NAN, ..Default::default() },
            DetectorConfig { depth_absolute: f32::INFINITY, ..Default::default() },
            DetectorConfig { normal_angle_deg: 181.0, ..Default::default() },
        ];
        for c in bad {
            assert!(c.validate().is_err(), "{c:?}");
        }
    }

    #[test]
    fn id_source_names_round_trip() {
        for i in IdSource::ALL {
            assert_eq!(IdSource::from_name(i.name()), Some(i));
        }
        assert_eq!(IdSource::from_name("both"), None);
    }
}
