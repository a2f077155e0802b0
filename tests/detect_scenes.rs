//! The edge detectors on analytic scenes built in code: silhouettes, creases, tessellation, grazing planes.

mod support;

use gbuf::detect::truth::{id_truth, object_truth, TruthSource};
use gbuf::detect::{detect, Detector, DetectorConfig, EdgeMask};
use gbuf::measure::edges::{evaluate, evaluate_against};
use gbuf::GBuffer;
use glam::Vec3;
use support::{flagged_columns, render, Shape, Surface};

const W: u32 = 48;
const H: u32 = 36;

fn run(gb: &GBuffer, d: Detector) -> EdgeMask {
    detect(gb, d, &DetectorConfig::default()).unwrap()
}

/// A near plane tilted 60° about the view Y axis (so its depth changes fast along x), cut off along a slanted
/// line, in front of a far wall: a silhouette whose near side has a steep depth gradient.
fn silhouette(samples: u32) -> GBuffer {
    let a = 60f32.to_radians();
    let near = Surface {
        keep: Some(|p| p.x < 0.3 + 0.3 * p.y),
        ..Surface::new(Shape::Plane { normal: Vec3::new(a.sin(), 0.0, a.cos()), point: Vec3::new(0.0, 0.0, -4.0) }, 1)
    };
    let far = Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -12.0) }, 2);
    render(W, H, samples, &[near, far])
}

#[test]
fn silhouette_is_found_exactly_by_lauritzen_depth_and_id_and_not_by_none() {
    let gb = silhouette(4);
    let truth = object_truth(&gb).unwrap();
    let true_edges = truth.iter().filter(|&&t| t).count();
    // About one pixel per row straddles the slanted cut.
    assert!(true_edges >= H as usize / 2 && true_edges <= 3 * H as usize, "{true_edges} true edge pixels");
    for d in [Detector::Lauritzen, Detector::Id, Detector::Combined] {
        let s = evaluate(&gb, &run(&gb, d)).unwrap();
        assert_eq!((s.fp, s.fn_), (0, 0), "{d}: {s:?}");
        assert_eq!(s.precision, 1.0);
        assert_eq!(s.recall, 1.0);
    }
    // The relative depth test finds the silhouette too, but also flags the steep near plane (not derivative-aware).
    let s = evaluate(&gb, &run(&gb, Detector::Depth)).unwrap();
    assert_eq!(s.recall, 1.0, "{s:?}");
    assert!(s.fp > 0, "{s:?}");
    let s = evaluate(&gb, &run(&gb, Detector::None)).unwrap();
    assert_eq!((s.tp, s.fn_ as usize, s.recall), (0, true_edges, 0.0), "{s:?}");
}

#[test]
fn parallel_planes_hide_a_silhouette_from_the_normal_test_only() {
    let near = Surface {
        keep: Some(|p| p.x < 0.3),
        ..Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -4.0) }, 1)
    };
    let far = Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -12.0) }, 2);
    let gb = render(W, H, 4, &[near, far]);
    assert_eq!(run(&gb, Detector::Normal).edge_pixels(), 0);
    let s = evaluate(&gb, &run(&gb, Detector::Lauritzen)).unwrap();
    assert_eq!((s.precision, s.recall), (1.0, 1.0), "{s:?}");
    assert!(s.tp > 0);
}

/// A big sphere filling the view, tessellated into small lat-long triangles: primitive IDs change every couple of
/// pixels while depth and (smooth-shading) normals stay continuous.
fn tessellated_sphere(samples: u32) -> GBuffer {
    fn prim(p: Vec3) -> u32 {
        let d = p - Vec3::new(0.0, 0.0, -20.0);
        let (u, v) = (d.x.atan2(d.z) / 0.01 + 1000.0, (d.y / 15.0).clamp(-1.0, 1.0).asin() / 0.01 + 1000.0);
        let (iu, iv) = (u.floor(), v.floor());
        let upper = u32::from(u - iu + (v - iv) > 1.0);
        ((iu as u32) * 4000 + iv as u32) * 2 + upper
    }
    let sphere = Surface {
        prim: Some(prim),
        ..Surface::new(Shape::Sphere { center: Vec3::new(0.0, 0.0, -20.0), radius: 15.0 }, 3)
    };
    render(W, H, samples, &[sphere])
}

#[test]
fn smooth_tessellated_surface_is_an_edge_only_for_forward_msaa() {
    let gb = tessellated_sphere(4);
    assert!(gb.coverage.iter().all(|&c| c), "the sphere must fill the view");
    let prim_truth = id_truth(&gb, TruthSource::Primitive).unwrap();
    let prim_edges = prim_truth.iter().filter(|&&t| t).count();
    assert!(prim_edges > gb.pixel_count() / 5, "the tessellation is too coarse: {prim_edges} pixels");
    for d in [Detector::Lauritzen, Detector::Depth, Detector::Normal, Detector::Id, Detector::Combined] {
        assert_eq!(run(&gb, d).edge_pixels(), 0, "{d} flags a smooth surface");
    }
    let fwd = run(&gb, Detector::ForwardMsaa);
    assert_eq!(fwd.edges(), prim_truth, "forward MSAA shades exactly the pixels spanning triangles");
    assert!(fwd.shading_fraction() > 0.25 + 0.2 * 0.25, "{}", fwd.shading_fraction());
    assert!(fwd.shade_count.iter().all(|&c| (1..=4).contains(&c)));
}

/// A ridge: two planes meeting along the view-space line x = 0.1, z = −6, normals ±`half_angle` about Y. Depth is
/// continuous across the ridge; only the normal jumps.
fn crease(half_angle_deg: f32) -> GBuffer {
    let a = half_angle_deg.to_radians();
    let p = Vec3::new(0.1, 0.0, -6.0);
    let left = Surface {
        keep: Some(|p| p.x < 0.1),
        ..Surface::new(Shape::Plane { normal: Vec3::new(-a.sin(), 0.0, a.cos()), point: p }, 1)
    };
    let right = Surface {
        keep: Some(|p| p.x >= 0.1),
        ..Surface::new(Shape::Plane { normal: Vec3::new(a.sin(), 0.0, a.cos()), point: p }, 1)
    };
    render(W, H, 4, &[left, right])
}

/// Pixels (row-major) whose samples lie on both sides of view x = 0.1.
fn straddles_ridge(gb: &GBuffer) -> Vec<bool> {
    let pos = gb.position.as_ref().unwrap();
    let s = gb.samples as usize;
    (0..gb.pixel_count())
        .map(|p| {
            let left = pos[p * s..p * s + s].iter().filter(|q| q.x < 0.1).count();
            left != 0 && left != s
        })
        .collect()
}

#[test]
fn crease_over_eight_degrees_is_found_by_normal_and_lauritzen() {
    let gb = crease(10.0); // 20° between the two normals
    let truth = straddles_ridge(&gb);
    assert!(truth.iter().filter(|&&t| t).count() >= H as usize);
    for d in [Detector::Normal, Detector::Lauritzen, Detector::Combined] {
        let s = evaluate_against(&run(&gb, d), &truth);
        assert_eq!((s.fp, s.fn_), (0, 0), "{d}: {s:?}");
    }
    // One object, continuous depth: the ID and depth tests see nothing.
    assert_eq!(run(&gb, Detector::Id).edge_pixels(), 0);
    assert_eq!(run(&gb, Detector::Depth).edge_pixels(), 0);
    assert_eq!(object_truth(&gb).unwrap().iter().filter(|&&t| t).count(), 0);
    // A crease under the threshold (3° each side, 6° in all) is not an edge.
    let gentle = crease(3.0);
    assert_eq!(run(&gentle, Detector::Normal).edge_pixels(), 0);
    assert_eq!(run(&gentle, Detector::Lauritzen).edge_pixels(), 0);
}

#[test]
fn grazing_plane_is_flagged_by_depth_threshold_but_not_by_lauritzen() {
    // A wall turned 57° about Y: at the right edge of the view it is seen at about 80° from its normal.
    let a = 57f32.to_radians();
    let wall =
        Surface::new(Shape::Plane { normal: Vec3::new(a.sin(), 0.0, a.cos()), point: Vec3::new(0.0, 0.0, -5.0) }, 1);
    let gb = render(W, H, 4, &[wall]);
    assert!(gb.coverage.iter().all(|&c| c));
    let depth = run(&gb, Detector::Depth);
    let cols = flagged_columns(&depth, H / 2);
    assert!(cols.len() >= 4, "the relative depth test should flag the grazing side: {cols:?}");
    // Absolute thresholds are worse still: 0.05 view units flags even more of it.
    let abs = detect(
        &gb,
        Detector::Depth,
        &DetectorConfig { depth_relative: 0.0, depth_absolute: 0.05, ..Default::default() },
    )
    .unwrap();
    assert!(abs.edge_pixels() >= depth.edge_pixels() / 2, "{} vs {}", abs.edge_pixels(), depth.edge_pixels());
    assert_eq!(run(&gb, Detector::Lauritzen).edge_pixels(), 0, "lauritzen is derivative-aware");
}

#[test]
fn ssaa_and_none_bound_the_shading_fraction() {
    for samples in [2, 4, 8] {
        let gb = silhouette(samples);
        assert!(gb.coverage.iter().all(|&c| c));
        let ssaa = run(&gb, Detector::Ssaa);
        let none = run(&gb, Detector::None);
        assert_eq!(ssaa.shading_fraction(), 1.0);
        assert_eq!(ssaa.edge_fraction(), 1.0);
        assert_eq!(none.shading_fraction(), 1.0 / f64::from(samples));
        assert_eq!(none.edge_pixels(), 0);
        let l = run(&gb, Detector::Lauritzen).shading_fraction();
        assert!(l > none.shading_fraction() && l < 1.0, "{samples}x: {l}");
    }
}

#[test]
fn single_sample_buffers_have_no_edges() {
    let gb = silhouette(1);
    for d in Detector::ALL {
        let m = run(&gb, d);
        assert_eq!(m.edge_pixels(), 0, "{d}");
        assert_eq!(m.shading_fraction(), 1.0, "{d}");
    }
}

#[test]
fn background_and_surface_mix_is_an_edge_and_empty_pixels_cost_nothing() {
    let sphere = Surface::new(Shape::Sphere { center: Vec3::new(0.0, 0.0, -10.0), radius: 2.0 }, 5);
    let gb = render(W, H, 4, &[sphere]);
    let s = gb.samples as usize;
    let mixed: Vec<bool> = (0..gb.pixel_count())
        .map(|p| {
            let n = gb.coverage[p * s..p * s + s].iter().filter(|&&c| c).count();
            n != 0 && n != s
        })
        .collect();
    assert!(mixed.iter().any(|&m| m));
    for d in [Detector::Lauritzen, Detector::Depth, Detector::Normal, Detector::Id, Detector::Combined] {
        let m = run(&gb, d);
        for (p, &mx) in mixed.iter().enumerate() {
            if mx {
                assert!(m.is_edge(p), "{d}: mixed pixel {p} not flagged");
            }
            if gb.coverage[p * s..p * s + s].iter().all(|&c| !c) {
                assert_eq!(m.shade_count[p], 0, "{d}: empty pixel {p}");
            }
        }
    }
    // Hardware MSAA does not shade the background: a half-covered pixel on one triangle costs one evaluation.
    let fwd = run(&gb, Detector::ForwardMsaa);
    assert!(mixed.iter().zip(&fwd.shade_count).all(|(&m, &c)| !m || c == 1));
}

#[test]
fn hand_built_precision_and_recall() {
    // 4 pixels × 2 samples: 0 two objects, 1 two depths on one object, 2 one flat surface, 3 two objects at one depth.
    let mut gb = GBuffer::new(4, 1, 2).unwrap();
    gb.coverage.fill(true);
    gb.depth = Some(vec![1.0, 3.0, 1.0, 3.0, 1.0, 1.0, 1.0, 1.0]);
    gb.object_id = Some(vec![1, 2, 1, 1, 1, 1, 1, 2]);
    let m = run(&gb, Detector::Depth);
    assert_eq!(m.edges(), vec![true, true, false, false]);
    let s = evaluate(&gb, &m).unwrap();
    assert_eq!((s.tp, s.fp, s.fn_), (1, 1, 1));
    assert_eq!((s.precision, s.recall), (0.5, 0.5));
    assert_eq!((s.edge_fraction, s.true_edge_fraction), (0.5, 0.5));
    assert_eq!(s.shading_fraction, (2.0 + 2.0 + 1.0 + 1.0) / 8.0);
}
