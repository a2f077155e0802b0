//! Stiff and extreme inputs: never a NaN or Inf out, never a panic, sanitised values counted.

use gbuf::image::HdrImage;
use gbuf::light::{Light, LightKind};
use gbuf::resolve::{
    fixture, reference, reference_per_sample, resolve, Brdf, Culling, Falloff, ResolveConfig, Schedule,
};
use gbuf::GBuffer;
use glam::Vec3;

fn all_configs() -> Vec<ResolveConfig> {
    let mut v = Vec::new();
    for culling in Culling::ALL {
        for brdf in Brdf::ALL {
            for falloff in Falloff::ALL {
                for schedule in Schedule::ALL {
                    v.push(ResolveConfig { culling, brdf, falloff, schedule, ..Default::default() });
                }
            }
        }
    }
    v
}

fn assert_finite(img: &HdrImage, what: &str) {
    for (i, c) in img.rgb.iter().enumerate() {
        assert!(c.is_finite() && c.min_element() >= 0.0, "{what}: pixel {i} = {c}");
    }
}

/// Runs every configuration plus the reference; checks finiteness; returns the default config's result.
fn run_everything(gb: &GBuffer, lights: &[Light], what: &str) -> gbuf::resolve::Resolved {
    let mask = gbuf::detect::baselines::ssaa(gb);
    for c in all_configs() {
        let r = resolve(gb, lights, &mask, &c).unwrap_or_else(|e| panic!("{what} {c:?}: {e}"));
        assert_finite(&r.image, &format!("{what} {c:?}"));
        assert_eq!(r.stats.sanitized.output, 0, "{what}: output had to be sanitised");
        let reference = reference(gb, lights, &c).unwrap();
        assert_finite(&reference, &format!("{what} reference {c:?}"));
    }
    resolve(gb, lights, &mask, &ResolveConfig::default()).unwrap()
}

#[test]
fn light_on_the_surface_and_begin_equal_end() {
    let gb = fixture::spheres(24, 16, 2).unwrap();
    let pos = gb.position.as_ref().unwrap();
    let i = gb.coverage.iter().position(|&c| c).unwrap();
    let mut on_surface = Light::point(pos[i], Vec3::ONE, 1.0, 2.0);
    on_surface.begin = 2.0; // begin = end
    let mut zero_width = Light::point(pos[i] + Vec3::Y * 0.1, Vec3::ONE, 1.0, 1.0);
    zero_width.begin = 1.0;
    let r = run_everything(&gb, &[on_surface, zero_width], "distance 0");
    assert!(r.image.rgb.iter().any(|c| c.max_element() > 0.0), "the lights lit nothing");
}

#[test]
fn specular_power_and_roughness_extremes() {
    for (power, roughness) in [(0.0, 0.0), (1e4, 1.0), (0.0, 1.0), (1e4, 0.0), (1e9, 0.5)] {
        let mut gb = fixture::spheres(20, 12, 1).unwrap();
        let n = gb.len();
        gb.specular_power = Some(vec![power; n]);
        gb.roughness = Some(vec![roughness; n]);
        gb.specular = Some(vec![1.0; n]);
        let lights = fixture::lights_on_surfaces(&gb, 20, 3.0, 7);
        let r = run_everything(&gb, &lights, &format!("power {power} roughness {roughness}"));
        if power > 1e6 {
            assert!(r.stats.sanitized.specular_power > 0, "power {power} was not counted as clamped");
        }
    }
}

#[test]
fn zero_lights_give_black_and_no_surface_gives_black() {
    let gb = fixture::spheres(20, 12, 4).unwrap();
    let r = run_everything(&gb, &[], "no lights");
    assert!(r.image.rgb.iter().all(|c| *c == Vec3::ZERO));
    assert_eq!(r.stats.light_pairs_tested, 0);

    let empty = GBuffer::new(19, 7, 4).unwrap(); // all background, no attributes at all
    let lights = vec![Light::point(Vec3::new(0.0, 0.0, -2.0), Vec3::ONE, 1.0, 5.0)];
    let r = run_everything(&empty, &lights, "no surface");
    assert!(r.image.rgb.iter().all(|c| *c == Vec3::ZERO));
    assert_eq!(r.stats.shading_evaluations, 0);
    assert_eq!(r.image.rgb.len(), 19 * 7);
    let per_sample = reference_per_sample(&empty, &lights, &ResolveConfig::default()).unwrap();
    assert_eq!(per_sample.len(), empty.len());
}

#[test]
fn hundred_thousand_lights() {
    let gb = fixture::spheres(16, 10, 1).unwrap();
    let lights = fixture::lights_on_surfaces(&gb, 100_000, 0.5, 3);
    for culling in [Culling::Tiled, Culling::Clustered, Culling::Quad] {
        let c = ResolveConfig { culling, ..Default::default() };
        let r = resolve(&gb, &lights, &gbuf::detect::baselines::none(&gb), &c).unwrap();
        assert_finite(&r.image, "100k lights");
        assert_eq!(r.stats.lights, 100_000);
        assert!(r.stats.light_pairs_lit > 0);
    }
}

#[test]
fn nan_and_inf_in_the_gbuffer_are_sanitised_and_counted() {
    let mut gb = fixture::spheres(24, 16, 4).unwrap();
    let mut lights = fixture::lights_on_surfaces(&gb, 30, 3.0, 1);
    let covered: Vec<usize> = (0..gb.len()).filter(|&i| gb.coverage[i]).collect();
    let (a, b, c, d) = (covered[3], covered[50], covered[100], covered[200]);
    gb.normal.as_mut().unwrap()[a] = Vec3::new(f32::NAN, 0.0, 0.0);
    gb.albedo.as_mut().unwrap()[b] = Vec3::new(f32::INFINITY, 0.5, f32::NEG_INFINITY);
    gb.position.as_mut().unwrap()[c] = Vec3::new(0.0, f32::NAN, -3.0);
    gb.specular_power.as_mut().unwrap()[d] = f32::INFINITY;
    gb.depth.as_mut().unwrap()[d] = f32::NAN; // ignored: the position plane wins
    lights.push(Light::point(Vec3::new(f32::NAN, 0.0, -1.0), Vec3::ONE, 1.0, 2.0));
    lights.push(Light { kind: LightKind::Directional { direction: Vec3::ZERO }, ..lights[0] });
    let r = run_everything(&gb, &lights, "nan");
    let s = r.stats.sanitized;
    assert_eq!((s.normal, s.albedo, s.position, s.specular_power, s.lights), (1, 1, 1, 1, 2), "{s:?}");
    assert_eq!(r.stats.lights, 30);
}

#[test]
fn bad_arguments_are_errors_not_panics() {
    let gb = fixture::spheres(8, 8, 1).unwrap();
    let wrong = gbuf::detect::baselines::ssaa(&fixture::spheres(4, 8, 1).unwrap());
    assert!(resolve(&gb, &[], &wrong, &ResolveConfig::default()).is_err());
    let bad = ResolveConfig { tile_size: 0, ..Default::default() };
    assert!(resolve(&gb, &[], &gbuf::detect::baselines::ssaa(&gb), &bad).is_err());
    let mut no_pos = gb.clone();
    no_pos.position = None;
    no_pos.camera = None;
    let e = resolve(&no_pos, &[], &gbuf::detect::baselines::ssaa(&gb), &ResolveConfig::default()).unwrap_err();
    assert!(e.to_string().contains("position"), "{e}");
}
