//! The pinhole camera: world ↔ view transform and the perspective projection, in the crate's one view-space
//! convention (glTF/OpenGL: +X right, +Y up, looking along −Z).
//!
//! Pixel coordinates are continuous: (0, 0) is the top-left corner of the image, pixel (x, y) covers
//! [x, x+1) × [y, y+1) and its centre is (x + 0.5, y + 0.5); +y goes **down** the image.

use glam::{Mat3, Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// A perspective camera (glTF conventions).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// World → view transform.
    pub world_to_view: Mat4,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Width / height.
    pub aspect: f32,
    /// Near plane distance (> 0).
    pub znear: f32,
    /// Far plane distance (> znear).
    pub zfar: f32,
    /// Principal point: where the optical axis meets the image, as an offset from the image centre in NDC units
    /// (+x right, +y up; ±1 = the image edge). Zero for a centred camera; a sidecar's `intrinsics` set it.
    #[serde(default)]
    pub principal: Vec2,
}

impl Camera {
    /// A camera at the world origin looking along −Z.
    #[must_use]
    pub fn identity(yfov: f32, aspect: f32, znear: f32, zfar: f32) -> Self {
        Camera { world_to_view: Mat4::IDENTITY, yfov, aspect, znear, zfar, principal: Vec2::ZERO }
    }

    /// A camera at `eye` looking at `target` with `up` (right-handed, −Z forward).
    #[must_use]
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, yfov: f32, aspect: f32, znear: f32, zfar: f32) -> Self {
        Camera {
            world_to_view: glam::camera::rh::view::look_at_mat4(eye, target, up),
            yfov,
            aspect,
            znear,
            zfar,
            principal: Vec2::ZERO,
        }
    }

    /// tan(yfov / 2).
    #[must_use]
    pub fn tan_half_fov(&self) -> f32 {
        (0.5 * self.yfov).tan()
    }

    /// View-space direction through continuous pixel coordinate `px`, scaled so that its z is −1 (so
    /// `ray * depth` is the view-space point at that depth).
    #[must_use]
    pub fn view_ray(&self, px: Vec2, width: u32, height: u32) -> Vec3 {
        self.ray_caster(width, height).ray(px)
    }

    /// [`Camera::view_ray`] for many pixels of one image: the field of view's tangent computed once (the rays are
    /// bit-identical).
    #[must_use]
    pub fn ray_caster(&self, width: u32, height: u32) -> RayCaster {
        RayCaster { t: self.tan_half_fov(), aspect: self.aspect, principal: self.principal, width, height }
    }

    /// View-space point at view depth `depth` (positive) through pixel coordinate `px`.
    #[must_use]
    pub fn view_position(&self, px: Vec2, depth: f32, width: u32, height: u32) -> Vec3 {
        self.view_ray(px, width, height) * depth
    }

    /// Continuous pixel coordinate of view-space point `p`; `None` when `p` is not in front of the camera.
    #[must_use]
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
        self.projector(width, height).project(p)
    }

    /// [`Camera::project`] for many points of one image: the field of view's tangent computed once.
    #[must_use]
    pub fn projector(&self, width: u32, height: u32) -> Projector {
        Projector { t: self.tan_half_fov(), aspect: self.aspect, principal: self.principal, width, height }
    }

    /// World-space point → view space.
    #[must_use]
    pub fn to_view_point(&self, p: Vec3) -> Vec3 {
        self.world_to_view.transform_point3(p)
    }

    /// World-space direction → view space, unit length (zero stays zero): [`Camera::normal_to_view`] normalised.
    #[must_use]
    pub fn to_view_dir(&self, d: Vec3) -> Vec3 {
        (self.normal_matrix() * d).normalize_or_zero()
    }

    /// The normal matrix: the inverse transpose of the world→view transform's linear part, so non-uniform scale
    /// keeps normals perpendicular to their surfaces. Compute it once for many normals.
    #[must_use]
    pub fn normal_matrix(&self) -> Mat3 {
        Mat3::from_mat4(self.world_to_view).inverse().transpose()
    }

    /// A world-space normal in view space through `normal_matrix` ([`Camera::normal_matrix`]), **with its length
    /// kept**: the one rule of every reader, so a zero or non-unit normal in a dump stays visible to the
    /// plausibility checks and the attribute errors (`invalid-normals`) whichever reader read it.
    #[must_use]
    pub fn normal_to_view(normal_matrix: &Mat3, n: Vec3) -> Vec3 {
        (*normal_matrix * n).normalize_or_zero() * n.length()
    }

    /// D3D-style post-projection depth in [0, 1] for view depth `d` (0 at the near plane, 1 at the far plane).
    #[must_use]
    pub fn post_projection_depth(&self, d: f32) -> f32 {
        let (n, f) = (self.znear, self.zfar);
        f * (d - n) / (d * (f - n))
    }

    /// Inverse of [`Camera::post_projection_depth`].
    #[must_use]
    pub fn view_depth_from_post_projection(&self, z: f32) -> f32 {
        let (n, f) = (self.znear, self.zfar);
        n * f / (f - z * (f - n))
    }

    /// Is the camera usable (finite, positive fov/aspect, 0 < znear < zfar, invertible transform)?
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.world_to_view.is_finite()
            && self.world_to_view.determinant().abs() > 1e-12
            && self.yfov > 0.0
            && self.yfov < std::f32::consts::PI
            && self.aspect > 0.0
            && self.aspect.is_finite()
            && self.znear > 0.0
            && self.zfar > self.znear
            && self.zfar.is_finite()
            && self.principal.is_finite()
    }
}

/// [`Camera::view_ray`] with its per-camera constants precomputed ([`Camera::ray_caster`]); the same arithmetic, so
/// the same rays bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct RayCaster {
    t: f32,
    aspect: f32,
    principal: Vec2,
    width: u32,
    height: u32,
}

impl RayCaster {
    /// View-space direction through continuous pixel coordinate `px`, with z = −1 ([`Camera::view_ray`]).
    #[inline]
    #[must_use]
    pub fn ray(&self, px: Vec2) -> Vec3 {
        let ndc_x = px.x / self.width as f32 * 2.0 - 1.0 - self.principal.x;
        let ndc_y = 1.0 - px.y / self.height as f32 * 2.0 - self.principal.y;
        Vec3::new(ndc_x * self.t * self.aspect, ndc_y * self.t, -1.0)
    }
}

/// [`Camera::project`] with its per-camera constants precomputed ([`Camera::projector`]); the same arithmetic, so the
/// same results bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct Projector {
    t: f32,
    aspect: f32,
    principal: Vec2,
    width: u32,
    height: u32,
}

impl Projector {
    /// Continuous pixel coordinate of view-space point `p`; `None` when `p` is not in front of the camera.
    #[must_use]
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        if p.z >= 0.0 || !p.is_finite() {
            return None;
        }
        let t = self.t;
        let ndc_x = p.x / (-p.z * t * self.aspect) + self.principal.x;
        let ndc_y = p.y / (-p.z * t) + self.principal.y;
        Some(Vec2::new((ndc_x + 1.0) * 0.5 * self.width as f32, (1.0 - ndc_y) * 0.5 * self.height as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_inverts_view_position() {
        let cam = Camera::identity(0.8, 16.0 / 9.0, 0.1, 100.0);
        for &(x, y, d) in &[(0.5, 0.5, 1.0), (100.25, 7.5, 33.0), (1919.5, 1079.5, 0.2)] {
            let px = Vec2::new(x, y);
            let p = cam.view_position(px, d, 1920, 1080);
            assert!((-p.z - d).abs() < 1e-5 * d);
            let back = cam.project(p, 1920, 1080).unwrap();
            assert!((back - px).length() < 1e-2, "{px} -> {p} -> {back}");
        }
        assert!(cam.project(Vec3::new(0.0, 0.0, 1.0), 10, 10).is_none());
    }

    #[test]
    fn post_projection_depth_round_trips() {
        let cam = Camera::identity(0.8, 1.0, 0.5, 500.0);
        assert!(cam.post_projection_depth(0.5).abs() < 1e-6);
        assert!((cam.post_projection_depth(500.0) - 1.0).abs() < 1e-6);
        let d = 37.0;
        let z = cam.post_projection_depth(d);
        assert!((cam.view_depth_from_post_projection(z) - d).abs() < 1e-3);
    }

    #[test]
    fn an_infinite_far_plane_is_not_usable() {
        // Its post-projection depth is NaN, and a canonical EXR stores it as JSON null, which no reader takes
        // (found by fuzz/fuzz_targets/canonical_struct.rs; input in fuzz/regressions/canonical_struct/).
        let cam = Camera::identity(0.8, 1.0, 0.1, f32::INFINITY);
        assert!(cam.post_projection_depth(1.0).is_nan());
        assert!(!cam.is_valid());
    }
}
