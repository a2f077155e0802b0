//! The shading truth (`gbuf::measure::edges::shading_truth`) on analytic scenes lit by the resolve's reference:
//! what it must flag (silhouettes with different lighting on each side) and what it must not (one flat-lit
//! surface split into two objects at nearly equal depths, a smooth pool of light).

mod support;

use gbuf::detect::truth::object_truth;
use gbuf::light::{Light, LightKind};
use gbuf::measure::edges::{shading_truth, truth_agreement, ShadingTolerance, DEFAULT_SHADING_TOLERANCE};
use gbuf::resolve::{reference_per_sample, ResolveConfig};
use gbuf::GBuffer;
use glam::Vec3;
use support::{render, Shape, Surface};

const W: u32 = 48;
const H: u32 = 36;

fn truth(gb: &GBuffer, lights: &[Light], tol: ShadingTolerance) -> Vec<bool> {
    let radiance = reference_per_sample(gb, lights, &ResolveConfig::default()).unwrap();
    shading_truth(gb, &radiance, tol)
}

fn count(t: &[bool]) -> usize {
    t.iter().filter(|&&x| x).count()
}

/// A camera-facing plane at depth 5, split at x = 0.05 (inside a pixel column) into two objects 2 mm apart in
/// depth. Objects 1 and 9 get the same albedo from the support renderer, so only the IDs tell the halves apart.
fn split_plane() -> GBuffer {
    let left = Surface {
        keep: Some(|p| p.x < 0.05),
        ..Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -5.0) }, 1)
    };
    let right = Surface {
        keep: Some(|p| p.x >= 0.05),
        ..Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -5.002) }, 9)
    };
    render(W, H, 4, &[left, right])
}

fn directional(intensity: f32) -> Light {
    Light {
        kind: LightKind::Directional { direction: Vec3::new(0.3, -0.2, -1.0).normalize() },
        position: Vec3::ZERO,
        color: Vec3::ONE,
        intensity,
        range: f32::INFINITY,
        begin: 0.0,
    }
}

#[test]
fn a_flat_lit_plane_at_two_nearly_equal_depths_is_not_a_shading_edge() {
    let gb = split_plane();
    let ids = object_truth(&gb).unwrap();
    assert!(count(&ids) >= H as usize, "the seam is an ID edge on every row: {}", count(&ids));
    // Uniform light, and a pool of light from a point light whose brightness varies smoothly across the seam
    // (steeper than one code per pixel near its centre: the gradient term must absorb it).
    let pool = Light::point(Vec3::new(0.0, 0.0, -3.0), Vec3::ONE, 4.0, 6.0);
    for lights in [vec![directional(2.0)], vec![pool], vec![directional(0.5), pool]] {
        let t = truth(&gb, &lights, DEFAULT_SHADING_TOLERANCE);
        assert_eq!(count(&t), 0, "{lights:?}: flagged {:?}", flagged(&t));
    }
}

#[test]
fn the_gradient_term_is_what_keeps_the_pool_of_light_unflagged() {
    // Without the gradient term (sample vs sample 0 only), the smooth pool of light of the test above would be
    // an "edge" wherever it changes by more than a code step across the 0.5–0.75 px between samples.
    let gb = split_plane();
    let pool = Light::point(Vec3::new(0.0, 0.0, -3.0), Vec3::ONE, 4.0, 6.0);
    let radiance = reference_per_sample(&gb, &[pool], &ResolveConfig::default()).unwrap();
    let tol = DEFAULT_SHADING_TOLERANCE;
    let s = gb.samples as usize;
    let naive = (0..gb.pixel_count())
        .filter(|&p| {
            let d0 = tol.to_domain(radiance[p * s]);
            (1..s).any(|i| (tol.to_domain(radiance[p * s + i]) - d0).abs().max_element() > tol.threshold())
        })
        .count();
    assert!(naive > gb.pixel_count() / 10, "the pool must be steep enough to matter: {naive} naive edges");
    assert_eq!(count(&shading_truth(&gb, &radiance, tol)), 0);
}

#[test]
fn a_silhouette_between_a_lit_card_and_a_dark_wall_is_a_shading_edge() {
    // A card at depth 3 cut at x = 0.2, lit by a point light just in front of it whose range ends well before the
    // wall at depth 9: bright card, black wall.
    let card = Surface {
        keep: Some(|p| p.x < 0.2),
        ..Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -3.0) }, 1)
    };
    let wall = Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -9.0) }, 2);
    let gb = render(W, H, 4, &[card, wall]);
    let light = Light::point(Vec3::new(0.0, 0.0, -2.5), Vec3::ONE, 10.0, 2.0);
    let t = truth(&gb, &[light], DEFAULT_SHADING_TOLERANCE);
    let ids = object_truth(&gb).unwrap();
    let a = truth_agreement(&t, &ids);
    assert!(a.both >= H as usize as u64, "{a:?}");
    assert_eq!(a.only_b, 0, "every pixel straddling the lit card and the dark wall varies visibly: {a:?}");
    // A light far from both surfaces and a wall of the same albedo would not make the cut visible; here the
    // difference is large, so even a 50-code threshold finds the silhouette.
    let loud = truth(&gb, &[light], ShadingTolerance::Display { codes: 50.0, exposure: 1.0 });
    assert!(count(&loud) >= H as usize, "{}", count(&loud));
}

#[test]
fn display_tolerance_is_exposure_invariant_where_linear_is_not() {
    // Scaling every light by 100 changes an absolute linear test completely; the display test sees the same
    // picture once the exposure compensates.
    let gb = split_plane();
    let pool = Light::point(Vec3::new(0.3, 0.2, -4.0), Vec3::ONE, 6.0, 5.0);
    let bright = Light { intensity: pool.intensity * 100.0, ..pool };
    let d1 = truth(&gb, &[pool], DEFAULT_SHADING_TOLERANCE);
    let d100 = truth(&gb, &[bright], ShadingTolerance::Display { codes: 1.0, exposure: 0.01 });
    // f32 radiance, scaled: a pixel at the threshold may tip either way.
    let differ = d1.iter().zip(&d100).filter(|(a, b)| a != b).count();
    assert!(differ <= 2, "{differ} pixels changed");
    let lin = ShadingTolerance::Linear { absolute: 1.0 / 255.0 };
    let l1 = count(&truth(&gb, &[pool], lin));
    let l100 = count(&truth(&gb, &[bright], lin));
    assert!(l100 > l1 + 10, "linear test: {l1} → {l100} flagged pixels");
}

fn flagged(t: &[bool]) -> Vec<(u32, u32)> {
    (0..t.len()).filter(|&p| t[p]).map(|p| (p as u32 % W, p as u32 / W)).collect()
}
