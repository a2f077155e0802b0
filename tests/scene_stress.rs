//! The `stress` scene holds every extreme its module doc promises.

mod support;

use gbuf::scene::{objects, render, stress, SceneName};
use gbuf::GBuffer;
use glam::Vec3;
use support::{assert_sample_invariants, samples_of};

fn id(name: &str) -> u32 {
    objects(SceneName::Stress, 1, 1).into_iter().find(|o| o.name == name).unwrap().object_id
}

fn covered_normals(gb: &GBuffer) -> Vec<Vec3> {
    let n = gb.normal.as_ref().unwrap();
    (0..gb.len()).filter(|&i| gb.coverage[i]).map(|i| n[i]).collect()
}

#[test]
fn invariants_hold_at_every_msaa_count() {
    for s in [1, 2, 4, 8, 16] {
        assert_sample_invariants(&render(SceneName::Stress, 192, 108, s).unwrap());
    }
}

#[test]
fn normals_at_and_near_the_view_axis_and_on_the_axes() {
    let gb = render(SceneName::Stress, 320, 180, 4).unwrap();
    let normals = covered_normals(&gb);
    let has = |f: &dyn Fn(Vec3) -> bool| normals.iter().any(|&n| f(n));
    assert!(has(&|n| n == Vec3::Z), "no normal exactly +Z");
    assert!(
        has(&|n| n.z == 1.0 && n.x != 0.0 && n.truncate().length() <= 1e-7),
        "no normal within 1e-7 rad of +Z (but not on it)"
    );
    assert!(has(&|n| n.z == 1.0 - f32::EPSILON / 2.0), "no normal with z one ulp below 1");
    assert!(has(&|n| n.z == 1.0 && n.x != 0.0 && n.x.abs() < f32::MIN_POSITIVE), "no subnormal component");
    for axis in [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y] {
        assert!(has(&|n| n == axis), "no normal exactly {axis}");
    }
    // Nearly edge-on: the normal almost perpendicular to the ray (|cos| < 0.1).
    let pos = gb.position.as_ref().unwrap();
    let n = gb.normal.as_ref().unwrap();
    let edge_on = samples_of(&gb, id("edge-on"));
    assert!(!edge_on.is_empty(), "edge-on sliver not hit");
    for i in edge_on {
        let c = n[i].dot(-pos[i].normalize());
        assert!(c > 0.0 && c < 0.1, "edge-on sample with cos {c}");
    }
}

#[test]
fn depth_reaches_both_clip_planes() {
    let gb = render(SceneName::Stress, 320, 180, 4).unwrap();
    let cam = gb.camera.unwrap();
    assert_eq!((cam.znear, cam.zfar), (stress::ZNEAR, stress::ZFAR));
    let d = gb.depth.as_ref().unwrap();
    let covered: Vec<f32> = (0..gb.len()).filter(|&i| gb.coverage[i]).map(|i| d[i]).collect();
    let max = covered.iter().copied().fold(0.0, f32::max);
    let min = covered.iter().copied().fold(f32::INFINITY, f32::min);
    assert!(max > 0.99 * cam.zfar && max <= cam.zfar, "farthest depth {max}");
    assert!(min <= 1.01 * cam.znear && min >= 0.999 * cam.znear, "nearest depth {min}");
}

#[test]
fn subpixel_geometry_is_hit_by_some_samples_only() {
    let gb4 = render(SceneName::Stress, 320, 180, 4).unwrap();
    let gb1 = render(SceneName::Stress, 320, 180, 1).unwrap();
    let oid = gb4.object_id.as_ref().unwrap();
    for name in ["subpixel-bar", "subpixel-hbar"] {
        let target = id(name);
        let mut partial = 0;
        for p in 0..gb4.pixel_count() {
            let hits = (0..4).filter(|&k| gb4.coverage[p * 4 + k] && oid[p * 4 + k] == target).count();
            assert!(hits < 4, "{name} covers a whole pixel");
            partial += usize::from(hits > 0);
        }
        assert!(partial >= 10, "{name}: {partial} partially covered pixels");
    }
    // The 0.3 px dot sits on a pixel centre: the 1× centre sample sees it, no 4× sample does.
    assert_eq!(samples_of(&gb1, id("subpixel-dot")).len(), 1);
    assert!(samples_of(&gb4, id("subpixel-dot")).is_empty());
}

#[test]
fn background_almost_everywhere_and_extreme_values_present() {
    let gb = render(SceneName::Stress, 320, 180, 4).unwrap();
    let covered = gb.coverage.iter().filter(|c| **c).count() as f64 / gb.len() as f64;
    assert!(covered > 0.005 && covered < 0.05, "covered fraction {covered}");
    let cov: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
    let scalar_has = |p: &Option<Vec<f32>>, v: f32| cov.iter().any(|&i| p.as_ref().unwrap()[i] == v);
    for (name, plane, lo, hi) in [
        ("specular", &gb.specular, 0.0, 1.0),
        ("specular_power", &gb.specular_power, 0.0, 1e4),
        ("roughness", &gb.roughness, 0.0, 1.0),
        ("metallic", &gb.metallic, 0.0, 1.0),
    ] {
        assert!(scalar_has(plane, lo) && scalar_has(plane, hi), "{name} lacks {lo} or {hi}");
    }
    let alb = gb.albedo.as_ref().unwrap();
    assert!(cov.iter().any(|&i| alb[i] == Vec3::ZERO) && cov.iter().any(|&i| alb[i] == Vec3::ONE));
    let oid = gb.object_id.as_ref().unwrap();
    let mid = gb.material_id.as_ref().unwrap();
    assert!(cov.iter().any(|&i| oid[i] > u32::from(u16::MAX)), "no object ID beyond 16 bits");
    assert!(cov.iter().any(|&i| mid[i] > u32::from(u8::MAX)), "no material ID beyond 8 bits");
}

#[test]
fn stress_is_deterministic() {
    assert!(render(SceneName::Stress, 100, 60, 8).unwrap() == render(SceneName::Stress, 100, 60, 8).unwrap());
}
