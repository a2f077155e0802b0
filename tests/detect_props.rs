//! Property tests of the edge detectors on random G-buffers: thresholds are monotone, counts stay in range,
//! adversarial values (NaN, ±Inf, zero normals) never panic and are flagged.

use gbuf::detect::{detect, Detector, DetectorConfig, IdSource};
use gbuf::GBuffer;
use glam::Vec3;
use proptest::prelude::*;

/// Adversarial scalars mixed into depths and normal components.
fn adversarial_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(0.0),
        Just(-0.0),
        Just(f32::MIN_POSITIVE / 4.0),
        Just(f32::MAX),
    ]
}

/// A random G-buffer: up to 4 planar "surfaces" (depth a + b·x + c·y, a unit normal, an ID); each sample picks
/// one or the background; a few values are replaced by adversarial ones when `adversarial` is set.
fn gbuffer(adversarial: bool) -> impl Strategy<Value = GBuffer> {
    (1u32..7, 1u32..6, prop::sample::select(vec![1u32, 2, 4, 8]))
        .prop_flat_map(move |(w, h, s)| {
            let n = (w * h * s) as usize;
            let surface = (0.5f32..50.0, -2.0f32..2.0, -2.0f32..2.0, -1.0f32..1.0, -1.0f32..1.0);
            let bad = if adversarial {
                prop::collection::vec((0..n, adversarial_f32()), 0..4).boxed()
            } else {
                Just(vec![]).boxed()
            };
            (Just((w, h, s)), prop::collection::vec(surface, 1..5), prop::collection::vec(0u8..6, n), bad)
        })
        .prop_map(|((w, h, s), surfaces, pick, bad)| {
            let mut gb = GBuffer::new(w, h, s).unwrap();
            let n = gb.len();
            let (mut depth, mut normal) = (vec![0.0; n], vec![Vec3::ZERO; n]);
            let (mut mat, mut obj, mut prim) = (vec![0; n], vec![0; n], vec![0; n]);
            for y in 0..h {
                for x in 0..w {
                    for si in 0..s {
                        let i = gb.index(x, y, si);
                        // Picks 4 and 5 mean "the pixel's first surface", so runs of one surface are common.
                        let k = match pick[i] as usize {
                            k if k < surfaces.len() => k,
                            4 | 5 => 0,
                            _ => continue, // background
                        };
                        let (a, b, c, nx, ny) = surfaces[k];
                        gb.coverage[i] = true;
                        depth[i] = a + b * x as f32 + c * y as f32;
                        normal[i] = Vec3::new(nx, ny, 1.0).normalize();
                        (mat[i], obj[i], prim[i]) = (k as u32 % 2, k as u32, k as u32 * 7 + x % 2);
                    }
                }
            }
            for (i, v) in bad {
                if i % 2 == 0 {
                    depth[i] = v;
                } else {
                    normal[i].x = v;
                }
            }
            gb.depth = Some(depth);
            gb.normal = Some(normal);
            gb.material_id = Some(mat);
            gb.object_id = Some(obj);
            gb.primitive_id = Some(prim);
            gb
        })
}

/// A random configuration and a second one with every numeric threshold at least as large.
fn config_pair() -> impl Strategy<Value = (DetectorConfig, DetectorConfig)> {
    let one = (0.0f32..3.0, 0.0f32..0.01, 0.0f32..0.2, 0.0f32..1.0, 0.0f32..90.0);
    (one.clone(), one, prop::sample::select(IdSource::ALL.to_vec())).prop_map(|(a, d, ids)| {
        let lo = DetectorConfig {
            gradient_scale: a.0,
            depth_slack: a.1,
            depth_relative: a.2,
            depth_absolute: a.3,
            normal_angle_deg: a.4,
            ids,
        };
        let hi = DetectorConfig {
            gradient_scale: a.0 + d.0,
            depth_slack: a.1 + d.1,
            depth_relative: a.2 + d.2,
            depth_absolute: a.3 + d.3,
            normal_angle_deg: (a.4 + d.4).min(180.0),
            ids,
        };
        (lo, hi)
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn raising_a_threshold_never_adds_edges(gb in gbuffer(true), (lo, hi) in config_pair()) {
        for d in [Detector::Lauritzen, Detector::Depth, Detector::Normal, Detector::Id, Detector::Combined] {
            let a = detect(&gb, d, &lo).unwrap();
            let b = detect(&gb, d, &hi).unwrap();
            for p in 0..gb.pixel_count() {
                prop_assert!(!b.is_edge(p) || a.is_edge(p), "{d}: pixel {p} is an edge only at the higher threshold");
            }
        }
    }

    #[test]
    fn counts_are_in_range_and_respect_coverage(gb in gbuffer(true)) {
        let s = gb.samples as usize;
        let cfg = DetectorConfig::default();
        let ssaa = detect(&gb, Detector::Ssaa, &cfg).unwrap();
        let none = detect(&gb, Detector::None, &cfg).unwrap();
        for d in Detector::ALL {
            let m = detect(&gb, d, &cfg).unwrap();
            prop_assert_eq!(m.shade_count.len(), gb.pixel_count());
            for p in 0..gb.pixel_count() {
                let covered = gb.coverage[p * s..p * s + s].iter().filter(|&&c| c).count();
                let c = m.shade_count[p];
                prop_assert_eq!(c == 0, covered == 0, "{}: pixel {} count {} covered {}", d, p, c, covered);
                prop_assert!(none.shade_count[p] <= c && c <= ssaa.shade_count[p], "{d}: pixel {p} count {c}");
                if !d.is_baseline() && covered != 0 && covered != s {
                    prop_assert!(m.is_edge(p), "{d}: mixed pixel {p} not an edge");
                }
            }
        }
    }

    #[test]
    fn non_finite_values_in_a_covered_pixel_make_it_an_edge(
        gb in gbuffer(false),
        which in 0usize..1000,
        bad in prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)],
    ) {
        if gb.samples == 1 {
            return Ok(()); // one sample: never an edge (tested elsewhere); not a reject, which would abort long runs
        }
        // Make one pixel a flat, fully covered surface, then spoil one of its samples.
        let mut gb = gb;
        let s = gb.samples as usize;
        let i = which % gb.len();
        let p = i / s;
        for j in p * s..p * s + s {
            gb.coverage[j] = true;
            gb.depth.as_mut().unwrap()[j] = 1.0;
            gb.normal.as_mut().unwrap()[j] = Vec3::Z;
            gb.material_id.as_mut().unwrap()[j] = 0;
            gb.object_id.as_mut().unwrap()[j] = 0;
        }
        for d in [Detector::Lauritzen, Detector::Depth, Detector::Normal, Detector::Combined] {
            prop_assert!(!detect(&gb, d, &DetectorConfig::default()).unwrap().is_edge(p), "{d}: flat pixel flagged");
        }
        gb.depth.as_mut().unwrap()[i] = bad;
        for d in [Detector::Lauritzen, Detector::Depth, Detector::Combined] {
            let m = detect(&gb, d, &DetectorConfig::default()).unwrap();
            prop_assert!(m.is_edge(p), "{d}: depth {bad} at sample {i} not flagged");
        }
        gb.depth.as_mut().unwrap()[i] = 1.0;
        gb.normal.as_mut().unwrap()[i] = Vec3::new(bad, 0.0, 1.0);
        for d in [Detector::Lauritzen, Detector::Normal, Detector::Combined] {
            let m = detect(&gb, d, &DetectorConfig::default()).unwrap();
            prop_assert!(m.is_edge(p), "{d}: normal x = {bad} at sample {i} not flagged");
        }
    }
}

#[test]
fn every_threshold_is_monotone_on_a_deterministic_sweep() {
    // A fixed random buffer and a dense sweep of each threshold alone: the edge count never rises.
    let mut rng = gbuf::base::rng::SplitMix64::new(4);
    let (w, h, s) = (24u32, 16u32, 4u32);
    let mut gb = GBuffer::new(w, h, s).unwrap();
    gb.coverage.fill(true);
    let n = gb.len();
    let depth: Vec<f32> = (0..n).map(|i| 5.0 + 0.01 * (i / 4) as f32 + rng.range_f32(0.0, 0.3)).collect();
    let normal: Vec<Vec3> =
        (0..n).map(|_| Vec3::new(rng.range_f32(-0.3, 0.3), rng.range_f32(-0.3, 0.3), 1.0).normalize()).collect();
    gb.depth = Some(depth);
    gb.normal = Some(normal);
    type Set = fn(&mut DetectorConfig, f32);
    let sweeps: [(Detector, Set, f32); 5] = [
        (Detector::Lauritzen, |c, v| c.gradient_scale = v, 4.0),
        (Detector::Lauritzen, |c, v| c.depth_slack = v, 0.05),
        (Detector::Depth, |c, v| c.depth_relative = v, 0.1),
        (Detector::Depth, |c, v| c.depth_absolute = v, 0.5),
        (Detector::Normal, |c, v| c.normal_angle_deg = v, 60.0),
    ];
    for (d, set, max) in sweeps {
        let mut last = usize::MAX;
        let mut first = None;
        for k in 0..=40 {
            let mut cfg = DetectorConfig { normal_angle_deg: 180.0, ..Default::default() };
            set(&mut cfg, max * k as f32 / 40.0);
            let e = detect(&gb, d, &cfg).unwrap().edge_pixels();
            assert!(e <= last, "{d}: {e} edges after {last} at step {k}");
            first.get_or_insert(e);
            last = e;
        }
        // The sweep must actually move: otherwise it proves nothing.
        assert!(first.unwrap() > last, "{d}: sweep from {first:?} to {last} did not change anything");
    }
}

mod shading_truth_props {
    use gbuf::measure::edges::{shading_truth, ShadingTolerance};
    use gbuf::GBuffer;
    use glam::{Vec2, Vec3};
    use proptest::prelude::*;

    /// Radiance of every sample from `f(x, y)` at the sample's position in pixels, every sample covered.
    fn sampled(w: u32, h: u32, s: u32, f: impl Fn(Vec2) -> Vec3) -> (GBuffer, Vec<Vec3>) {
        let mut gb = GBuffer::new(w, h, s).unwrap();
        gb.coverage.fill(true);
        let mut r = vec![Vec3::ZERO; gb.len()];
        for y in 0..h {
            for x in 0..w {
                for k in 0..s {
                    let o = gb.sample_positions[k as usize];
                    r[gb.index(x, y, k)] = f(Vec2::new(x as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y));
                }
            }
        }
        (gb, r)
    }

    fn size() -> impl Strategy<Value = (u32, u32, u32)> {
        (1u32..9, 1u32..7, prop::sample::select(vec![2u32, 4, 8, 16]))
    }

    proptest! {
        /// A linear field is never a shading edge in the linear domain, however steep: the neighbours' one-sided
        /// differences are its exact slopes, and they bound every sample's difference from sample 0. (Needs a
        /// neighbour in each direction: in a 1-pixel-wide image the slope across it is unknown and taken as 0.)
        #[test]
        fn linear_fields_are_never_edges(
            (w, h, s) in size(),
            a in prop::array::uniform3(-10.0f32..10.0),
            b in prop::array::uniform3(-5.0f32..5.0),
            c in prop::array::uniform3(-5.0f32..5.0),
        ) {
            prop_assume!(w >= 2 && h >= 2);
            let (a, b, c) = (Vec3::from(a), Vec3::from(b), Vec3::from(c));
            let (gb, r) = sampled(w, h, s, |p| a + b * p.x + c * p.y);
            // f32 rounding of values up to ~100: a threshold far below any real edge but above the rounding.
            let t = shading_truth(&gb, &r, ShadingTolerance::Linear { absolute: 1e-3 });
            prop_assert!(t.iter().all(|&e| !e), "{t:?}");
        }

        /// A vertical step of height `jump` inside pixel column `col` (at fraction `at` of the pixel, strictly
        /// between two sample columns) is a shading edge exactly in that column, on every row, with flat
        /// neighbours on both sides.
        #[test]
        fn a_step_inside_a_column_is_an_edge_on_every_row_and_nowhere_else(
            (w, h, s) in size(),
            col_pick in 0u32..100,
            jump in 0.1f32..100.0,
            base in 0.0f32..10.0,
        ) {
            prop_assume!(w >= 3);
            let col = 1 + col_pick % (w - 2);
            let gb0 = GBuffer::new(w, h, s).unwrap();
            // The step sits halfway between the two sample columns nearest the pixel centre on either side of it.
            let mut xs: Vec<f32> = gb0.sample_positions.iter().map(|o| o.x).collect();
            xs.sort_by(f32::total_cmp);
            xs.dedup();
            prop_assume!(xs.len() >= 2);
            let mid = xs.len() / 2;
            let at = 0.5 + 0.5 * (xs[mid - 1] + xs[mid]);
            let edge_x = col as f32 + at;
            let (gb, r) = sampled(w, h, s, |p| Vec3::splat(if p.x < edge_x { base } else { base + jump }));
            let t = shading_truth(&gb, &r, ShadingTolerance::Linear { absolute: 0.05 });
            for y in 0..h {
                for x in 0..w {
                    prop_assert_eq!(t[(y * w + x) as usize], x == col, "pixel ({}, {}) with the step in column {}", x, y, col);
                }
            }
        }
    }
}
