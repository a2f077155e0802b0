//! The hemisphere environment light (issue 15, part 6): the third light kind of the deferred-shading lectures beside
//! point and spot. Checked against its closed form on surfaces facing up, down and sideways for every BRDF, against
//! the f64 reference together with point lights, bit for bit across culling methods, MSAA schedules and the light
//! pre-pass's composition, and through the sidecar (world-space up, refusals).

use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::io::Sidecar;
use gbuf::light::{Light, LightKind};
use gbuf::resolve::{reference, resolve, Brdf, Culling, MsaaSchedule, ResolveConfig, Schedule};
use gbuf::scene::{default_lights, render, SceneName};
use gbuf::GBuffer;
use glam::Vec3;
use std::f32::consts::PI;
use std::path::Path;

fn hemisphere(up: Vec3, sky: Vec3, ground: Vec3, intensity: f32) -> Light {
    Light {
        kind: LightKind::Hemisphere { up, ground },
        position: Vec3::ZERO,
        color: sky,
        intensity,
        range: f32::INFINITY,
        begin: 0.0,
    }
}

/// Three pixels in front of the camera whose normals face up (+y), down and sideways (+z, towards the eye).
fn three_normals() -> GBuffer {
    let mut gb = GBuffer::new(3, 1, 1).unwrap();
    let pos: Vec<Vec3> = (0..3).map(|x| Vec3::new(x as f32 - 1.0, 0.0, -5.0)).collect();
    gb.depth = Some(pos.iter().map(|p| -p.z).collect());
    gb.position = Some(pos);
    gb.normal = Some(vec![Vec3::Y, -Vec3::Y, Vec3::Z]);
    gb.albedo = Some(vec![Vec3::new(0.8, 0.5, 0.2); 3]);
    gb.specular = Some(vec![1.0; 3]);
    gb.specular_power = Some(vec![32.0; 3]);
    gb.roughness = Some(vec![0.5; 3]);
    gb.metallic = Some(vec![0.25; 3]);
    gb.coverage = vec![true; 3];
    gb
}

#[test]
fn closed_form_on_up_down_and_sideways_normals_for_every_brdf() {
    let gb = three_normals();
    let (sky, ground) = (Vec3::new(0.6, 0.7, 1.0), Vec3::new(0.3, 0.2, 0.1));
    let lights = [hemisphere(Vec3::Y, sky, ground, 2.0)];
    let mask = detect(&gb, Detector::None, &DetectorConfig::default()).unwrap();
    let albedo = Vec3::new(0.8, 0.5, 0.2);
    for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
        let k = match brdf {
            Brdf::Lambert => albedo,
            Brdf::BlinnPhong => albedo * PI,
            Brdf::Ggx => {
                let f0 = Vec3::splat(0.04).lerp(albedo, 0.25);
                albedo * 0.75 * (Vec3::ONE - f0)
            }
        };
        // Up: the sky only; down: the ground only; sideways: their mean.
        let want = [k * sky * 2.0, k * ground * 2.0, k * (sky + ground)];
        let cfg = ResolveConfig { brdf, ..ResolveConfig::default() };
        let got = resolve(&gb, &lights, &mask, &cfg).unwrap().image.rgb;
        let reference = reference(&gb, &lights, &cfg).unwrap().rgb;
        for i in 0..3 {
            for (name, img) in [("resolve", &got), ("reference", &reference)] {
                let err = (img[i] - want[i]).abs().max_element() / want[i].max_element();
                assert!(err < 1e-6, "{brdf:?} {name} pixel {i}: {} against {}", img[i], want[i]);
            }
        }
    }
    // An environment with a zero up vector or a negative ground is dropped, like any unusable light.
    for bad in [hemisphere(Vec3::ZERO, sky, ground, 1.0), hemisphere(Vec3::Y, sky, -ground, 1.0)] {
        let img = resolve(&gb, &[bad], &mask, &ResolveConfig::default()).unwrap();
        assert!(img.image.rgb.iter().all(|c| *c == Vec3::ZERO) && img.stats.sanitized.lights == 1);
    }
}

#[test]
fn with_point_lights_it_matches_the_reference_and_is_bit_identical_across_culling_and_schedules() {
    let gb = render(SceneName::Room, 96, 54, 4).unwrap();
    let mut lights = default_lights(SceneName::Room, &gb);
    let up = gb.camera.unwrap().to_view_dir(Vec3::Y);
    lights.push(hemisphere(up, Vec3::new(0.2, 0.25, 0.35), Vec3::new(0.05, 0.04, 0.03), 1.0));
    let mask = detect(&gb, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
        let base = ResolveConfig { brdf, ..ResolveConfig::default() };
        let first = resolve(&gb, &lights, &mask, &base).unwrap().image;
        let without = resolve(&gb, &lights[..lights.len() - 1], &mask, &base).unwrap().image;
        assert!(first.rgb.iter().zip(&without.rgb).filter(|(a, b)| a != b).count() > first.rgb.len() / 2);
        for culling in [Culling::None, Culling::Tiled, Culling::Quad, Culling::Clustered] {
            for msaa in [MsaaSchedule::Packed, MsaaSchedule::PerPixel, MsaaSchedule::TwoPass] {
                if culling == Culling::Clustered && msaa != MsaaSchedule::Packed {
                    continue;
                }
                let cfg = ResolveConfig { culling, msaa, ..base };
                let img = resolve(&gb, &lights, &mask, &cfg).unwrap().image;
                assert!(img.rgb == first.rgb, "{brdf:?} {culling:?} {msaa:?}: image differs");
            }
        }
        // Against the f64 reference, where every pixel is shaded per sample.
        let ssaa = detect(&gb, Detector::Ssaa, &DetectorConfig::default()).unwrap();
        let img = resolve(&gb, &lights, &ssaa, &base).unwrap().image;
        let r = reference(&gb, &lights, &base).unwrap();
        let (num, den) = img.rgb.iter().zip(&r.rgb).fold((0.0f64, 0.0f64), |(n, d), (a, b)| {
            (n + f64::from((*a - *b).length_squared()), d + f64::from(b.length_squared()))
        });
        assert!(num / den < 1e-8, "{brdf:?}: relative MSE against the reference {}", num / den);
    }
    // The light pre-pass adds the environment to its composed colour as deferred does: with the environment alone
    // (no light in the pre-pass buffers) the two images are equal.
    let env_only = [lights[lights.len() - 1]];
    for brdf in [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx] {
        let deferred = ResolveConfig { brdf, ..ResolveConfig::default() };
        let prepass = ResolveConfig { schedule: Schedule::LightPrepass, ..deferred };
        let a = resolve(&gb, &env_only, &mask, &deferred).unwrap().image;
        let b = resolve(&gb, &env_only, &mask, &prepass).unwrap().image;
        let worst = a.rgb.iter().zip(&b.rgb).map(|(x, y)| (*x - *y).abs().max_element()).fold(0.0f32, f32::max);
        assert!(worst < 1e-6, "{brdf:?}: pre-pass and deferred differ by {worst} with the environment alone");
    }
}

#[test]
fn sidecars_read_the_hemisphere_light_in_world_space_and_refuse_bad_ones() {
    let path = Path::new("scene.json");
    let camera = r#""camera": {"world_to_view": [[1,0,0,0],[0,0,1,0],[0,-1,0,0],[0,0,0,1]], "yfov": 0.8,
        "aspect": 1.5, "znear": 0.1, "zfar": 100}"#;
    let text = format!(
        r#"{{ {camera}, "lights": [{{"type": "hemisphere", "direction": [0, 0, 1], "color": [0.5, 0.6, 0.9],
            "ground": [0.2, 0.1, 0.05], "intensity": 2}}] }}"#
    );
    let side = Sidecar::parse(&text, path).unwrap();
    let lights = side.view_lights(None, path).unwrap();
    let LightKind::Hemisphere { up, ground } = lights[0].kind else { panic!("{:?}", lights[0]) };
    // World +z is the camera's +y (row-major matrix: its second row is (0, 0, 1)): up in view space.
    assert!((up - Vec3::Y).length() < 1e-6, "{up}");
    assert_eq!(
        (ground, lights[0].color, lights[0].intensity),
        (Vec3::new(0.2, 0.1, 0.05), Vec3::new(0.5, 0.6, 0.9), 2.0)
    );
    // Written back by the scene writer and read again: the same light.
    let entry = gbuf::scene::sidecar_light(&lights[0]);
    assert_eq!(entry.kind, "hemisphere");
    assert_eq!(entry.ground, Some([0.2, 0.1, 0.05]));
    for (bad, what) in [
        (r#"{"type": "hemisphere", "color": [1, 1, 1]}"#, "needs \"direction\""),
        (r#"{"type": "hemisphere", "direction": [0, 1, 0], "ground": [0, -1, 0]}"#, "ground colour"),
        (r#"{"type": "hemisphere", "direction": [0, 0, 0]}"#, "direction is zero"),
    ] {
        let text = format!(r#"{{ "lights_space": "view", "lights": [{bad}] }}"#);
        let e = Sidecar::parse(&text, path).and_then(|s| s.view_lights(None, path)).unwrap_err().to_string();
        assert!(e.contains("scene.json") && e.contains("light 0") && e.contains(what), "{e}");
    }
}
