//! Punctual lights in view space (glTF KHR_lights_punctual semantics, plus the begin radius of the linear
//! falloff used by the 2010 tiled-deferred demo and the ISPC `deferred` example).

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// What kind of light, with its kind-specific parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum LightKind {
    /// Omnidirectional point light.
    Point,
    /// Spot light: `direction` is the unit direction the light points (view space); cone angles in radians.
    Spot {
        /// Unit direction the spot points to.
        direction: Vec3,
        /// Angle from the axis where the falloff starts.
        inner_cone_angle: f32,
        /// Angle from the axis where the light reaches zero.
        outer_cone_angle: f32,
    },
    /// Hemisphere environment (the third light kind of the deferred-shading lectures beside point and spot): a sky
    /// of radiance `color × intensity` above the plane normal to `up` and a ground of radiance `ground ×
    /// intensity` below it, lighting every surface from every direction (no position, no range). Shaded for its
    /// diffuse part only, in closed form: a Lambertian surface with normal n receives irradiance
    /// `π·(sky·(1 + n·up)/2 + ground·(1 − n·up)/2)`. glTF has no such light; sidecars write it as
    /// `{"type": "hemisphere", "direction": up, "color": sky, "ground": [r, g, b], "intensity": k}`.
    Hemisphere {
        /// Unit "up" direction (view space).
        up: Vec3,
        /// Linear RGB colour of the ground half (scaled by the light's intensity, as `color` is).
        ground: Vec3,
    },
    /// Directional light: `direction` is the unit direction the light travels (view space).
    Directional {
        /// Unit direction of travel.
        direction: Vec3,
    },
}

/// One light, always in view space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    /// Kind and kind-specific parameters.
    pub kind: LightKind,
    /// View-space position (ignored for directional lights).
    pub position: Vec3,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Intensity (candela for point/spot, lux for directional, per glTF); 1 for ISPC-style lights.
    pub intensity: f32,
    /// Range: the distance beyond which the light contributes nothing (glTF `range`; the linear falloff's end
    /// radius). `f32::INFINITY` when unbounded.
    pub range: f32,
    /// Begin radius of the linear falloff (full intensity inside it). 0 when the source gives none.
    pub begin: f32,
}

impl Light {
    /// A point light.
    #[must_use]
    pub fn point(position: Vec3, color: Vec3, intensity: f32, range: f32) -> Self {
        Light { kind: LightKind::Point, position, color, intensity, range, begin: 0.0 }
    }

    /// Is it a directional light?
    #[must_use]
    pub fn is_directional(&self) -> bool {
        matches!(self.kind, LightKind::Directional { .. })
    }

    /// Is it a hemisphere environment ([`LightKind::Hemisphere`])?
    #[must_use]
    pub fn is_environment(&self) -> bool {
        matches!(self.kind, LightKind::Hemisphere { .. })
    }
}
