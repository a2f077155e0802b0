//! Helpers shared by the scene tests (`support::scene`, reached through `mod support;`).
#![allow(dead_code)]

use gbuf::GBuffer;
use glam::{Vec2, Vec3};

/// A renderer's normal is unit to f32 precision after normalisation; 1e-5 leaves room for the few ulps of
/// `normalize` and nothing more (a missing normalisation is off by far more).
pub const UNIT_TOL: f32 = 1e-5;
/// Position vs `Camera::view_position(px, depth)`: both are `view_ray(px) · depth`, so they agree to rounding;
/// 1e-5 relative to the distance.
pub const POSITION_REL_TOL: f32 = 1e-5;

/// Continuous pixel coordinate of plane index `i`.
pub fn sample_px(gb: &GBuffer, i: usize) -> Vec2 {
    gb.sample_px_of(i)
}

/// Checks every per-sample invariant the scenes promise; panics with the first violation.
pub fn assert_sample_invariants(gb: &GBuffer) {
    gb.validate().unwrap();
    let cam = gb.camera.expect("scenes set the camera");
    assert!(cam.is_valid());
    assert!(
        (cam.aspect - gb.width as f32 / gb.height as f32).abs() < 1e-6,
        "aspect {} for {}×{}",
        cam.aspect,
        gb.width,
        gb.height
    );
    let depth = gb.depth.as_ref().unwrap();
    let pos = gb.position.as_ref().unwrap();
    let nrm = gb.normal.as_ref().unwrap();
    let alb = gb.albedo.as_ref().unwrap();
    let ids = [gb.material_id.as_ref().unwrap(), gb.object_id.as_ref().unwrap(), gb.primitive_id.as_ref().unwrap()];
    let scalars = [
        gb.specular.as_ref().unwrap(),
        gb.specular_power.as_ref().unwrap(),
        gb.roughness.as_ref().unwrap(),
        gb.metallic.as_ref().unwrap(),
    ];
    for i in 0..gb.len() {
        if !gb.coverage[i] {
            assert_eq!((depth[i], pos[i], nrm[i], alb[i]), (0.0, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO), "background {i}");
            assert!(ids.iter().all(|p| p[i] == 0) && scalars.iter().all(|p| p[i] == 0.0), "background {i} not zero");
            continue;
        }
        let (d, p, n) = (depth[i], pos[i], nrm[i]);
        assert_eq!(d, -p.z, "sample {i}: depth {d} vs position {p}");
        assert!(d >= cam.znear * 0.999 && d <= cam.zfar, "sample {i}: depth {d} outside the clip range");
        assert!((n.length() - 1.0).abs() < UNIT_TOL, "sample {i}: |n| = {} for {n}", n.length());
        assert!(n.dot(-p) > 0.0, "sample {i}: normal {n} faces away from the eye at {p}");
        let expect = cam.view_position(sample_px(gb, i), d, gb.width, gb.height);
        assert!(
            (expect - p).length() <= POSITION_REL_TOL * p.length(),
            "sample {i}: position {p} vs camera ray {expect} (diff {})",
            (expect - p).length()
        );
        assert!(ids[0][i] > 0 && ids[1][i] > 0, "sample {i}: covered sample with ID 0");
    }
}

/// Indices of the covered samples of object `id`.
pub fn samples_of(gb: &GBuffer, id: u32) -> Vec<usize> {
    let oid = gb.object_id.as_ref().unwrap();
    (0..gb.len()).filter(|&i| gb.coverage[i] && oid[i] == id).collect()
}
