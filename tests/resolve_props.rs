//! Properties of the resolve: agreement with the f64 reference, independence from culling, tile size and thread
//! count, and the schedule's bookkeeping.

use gbuf::image::HdrImage;
use gbuf::light::{Light, LightKind};
use gbuf::measure::image::compare;
use gbuf::resolve::{fixture, reference, resolve, Brdf, Culling, Falloff, ResolveConfig, Schedule};
use gbuf::GBuffer;
use glam::Vec3;
use proptest::prelude::*;

/// The f32 kernel (fast pow, f32 sums) against the f64 reference, every sample shaded: relative MSE bound.
/// Measured values are around 1e-12..1e-10; the bound leaves room for other CPUs' vector widths.
const KERNEL_VS_REFERENCE_REL_MSE: f64 = 1e-8;

fn cfg(culling: Culling, brdf: Brdf, falloff: Falloff) -> ResolveConfig {
    ResolveConfig { culling, brdf, falloff, ..Default::default() }
}

fn mixed_lights(gb: &GBuffer, seed: u64) -> Vec<Light> {
    let mut lights = fixture::lights_on_surfaces(gb, 60, 3.0, seed);
    lights.push(Light {
        kind: LightKind::Spot {
            direction: Vec3::new(0.0, -1.0, -0.3).normalize(),
            inner_cone_angle: 0.3,
            outer_cone_angle: 0.6,
        },
        ..Light::point(Vec3::new(0.0, 3.0, -7.0), Vec3::new(1.0, 0.9, 0.7), 20.0, 12.0)
    });
    lights.push(Light {
        kind: LightKind::Directional { direction: Vec3::new(0.3, -1.0, -0.5).normalize() },
        ..Light::point(Vec3::ZERO, Vec3::new(0.2, 0.2, 0.3), 1.0, f32::INFINITY)
    });
    // An unbounded point light (glTF without range).
    lights.push(Light::point(Vec3::new(-1.0, 1.0, -4.0), Vec3::ONE, 2.0, f32::INFINITY));
    lights
}

fn assert_bit_identical(a: &HdrImage, b: &HdrImage, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (x, y)) in a.rgb.iter().zip(&b.rgb).enumerate() {
        assert!(x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits), "{what}: pixel {i}: {x} vs {y}");
    }
}

#[test]
fn kernel_matches_the_f64_reference_for_every_brdf_and_falloff() {
    let gb = fixture::spheres(40, 24, 4).unwrap();
    let lights = mixed_lights(&gb, 5);
    let mask = gbuf::detect::baselines::ssaa(&gb);
    for brdf in Brdf::ALL {
        for falloff in Falloff::ALL {
            let c = cfg(Culling::None, brdf, falloff);
            let r = resolve(&gb, &lights, &mask, &c).unwrap();
            let reference = reference(&gb, &lights, &c).unwrap();
            let e = compare(&reference, &r.image);
            assert!(e.rel_mse < KERNEL_VS_REFERENCE_REL_MSE, "{brdf}/{falloff}: {e:?}");
            assert!(e.peak > 0.0 && reference.rgb.iter().any(|c| c.max_element() > 0.0), "{brdf}/{falloff} is black");
            assert_eq!(r.stats.shading_fraction, gb.len() as f64 / gb.len() as f64 * covered_fraction(&gb));
        }
    }
}

fn covered_fraction(gb: &GBuffer) -> f64 {
    gb.coverage.iter().filter(|&&c| c).count() as f64 / gb.len() as f64
}

#[test]
fn every_culling_gives_the_same_image_bit_for_bit() {
    let gb = fixture::spheres(53, 29, 4).unwrap();
    let lights = mixed_lights(&gb, 11);
    let mask = gbuf::detect::baselines::ssaa(&gb);
    for brdf in Brdf::ALL {
        for falloff in Falloff::ALL {
            for schedule in Schedule::ALL {
                let base = ResolveConfig { schedule, ..cfg(Culling::None, brdf, falloff) };
                let none = resolve(&gb, &lights, &mask, &base).unwrap();
                for &culling in &Culling::ALL[1..] {
                    let r = resolve(&gb, &lights, &mask, &ResolveConfig { culling, ..base }).unwrap();
                    assert_bit_identical(&none.image, &r.image, &format!("{culling} {brdf}/{falloff}/{schedule}"));
                    assert!(r.stats.light_pairs_tested < none.stats.light_pairs_tested, "{culling} culled nothing");
                    assert_eq!(r.stats.light_pairs_lit, none.stats.light_pairs_lit, "{culling}");
                }
            }
        }
    }
}

#[test]
fn tile_size_and_thread_count_do_not_change_the_image() {
    let gb = fixture::spheres(45, 31, 2).unwrap();
    let lights = mixed_lights(&gb, 2);
    let mask = gbuf::detect::baselines::ssaa(&gb);
    let base = ResolveConfig::default();
    let want = resolve(&gb, &lights, &mask, &base).unwrap();
    for tile_size in [1, 5, 8, 32, 64] {
        for culling in Culling::ALL {
            let c = ResolveConfig { tile_size, culling, ..base };
            let r = resolve(&gb, &lights, &mask, &c).unwrap();
            assert_bit_identical(&want.image, &r.image, &format!("tile {tile_size} {culling}"));
        }
    }
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let r = pool.install(|| resolve(&gb, &lights, &mask, &base)).unwrap();
        assert_bit_identical(&want.image, &r.image, &format!("{threads} threads"));
        assert_eq!(r.stats.light_pairs_tested, want.stats.light_pairs_tested);
    }
}

#[test]
fn non_edge_pixels_are_shaded_once_and_edge_pixels_per_sample() {
    let gb = fixture::spheres(32, 20, 4).unwrap();
    let lights = fixture::lights_on_surfaces(&gb, 30, 3.0, 4);
    let c = ResolveConfig::default();
    let once = resolve(&gb, &lights, &gbuf::detect::baselines::none(&gb), &c).unwrap();
    let all = resolve(&gb, &lights, &gbuf::detect::baselines::ssaa(&gb), &c).unwrap();
    let pixels_covered = gb.coverage.chunks(4).filter(|p| p.iter().any(|&c| c)).count() as u64;
    assert_eq!(once.stats.shading_evaluations, pixels_covered);
    assert_eq!(once.stats.edge_fraction, 0.0);
    assert_eq!(all.stats.shading_evaluations, gb.coverage.iter().filter(|&&c| c).count() as u64);
    // A mask flagging a single pixel: exactly that pixel differs from `once`, and it equals `all` there.
    let mut mask = gbuf::detect::baselines::none(&gb);
    let p = (0..gb.pixel_count())
        .find(|&p| {
            let s = &gb.coverage[p * 4..p * 4 + 4];
            s.iter().all(|&c| c) && (all.image.rgb[p] - once.image.rgb[p]).abs().max_element() > 1e-6
        })
        .expect("some fully covered pixel whose samples differ");
    mask.shade_count[p] = 4;
    let mixed = resolve(&gb, &lights, &mask, &c).unwrap();
    assert_eq!(mixed.stats.shading_evaluations, pixels_covered + 3);
    for q in 0..gb.pixel_count() {
        let want = if q == p { all.image.rgb[q] } else { once.image.rgb[q] };
        assert!((mixed.image.rgb[q] - want).abs().max_element() <= 1e-6 * want.max_element().max(1.0), "pixel {q}");
    }
    assert!(mixed.lights_per_pixel[p] > once.lights_per_pixel[p]);
}

#[test]
fn last_rows_and_columns_are_shaded_when_the_size_is_not_a_tile_multiple() {
    let gb = fixture::spheres(37, 19, 1).unwrap();
    let lights = vec![Light::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE, 50.0, f32::INFINITY)];
    let r = resolve(&gb, &lights, &gbuf::detect::baselines::none(&gb), &ResolveConfig::default()).unwrap();
    let (w, h) = (gb.width as usize, gb.height as usize);
    for x in 0..w {
        let p = (h - 1) * w + x;
        assert!(r.image.rgb[p].max_element() > 0.0, "bottom row pixel {x} not shaded");
    }
    for y in 0..h {
        let p = y * w + w - 1;
        if gb.coverage[p] {
            assert!(r.image.rgb[p].max_element() > 0.0, "right column pixel {y} not shaded");
        }
    }
    assert_eq!(r.stats.tiles, 3 * 2);
}

/// The sampled timing run holds only its bands (every `TIMING_STRIDE`-th): frames whose last sampled band is
/// partial, whole, or the only one, light without running past the outputs.
#[test]
fn sampled_timing_runs_fit_their_bands() {
    let lights = vec![Light::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE, 50.0, f32::INFINITY)];
    let cfg = ResolveConfig::default();
    let stride = gbuf::resolve::TIMING_STRIDE;
    for h in [7, 8 * cfg.tile_size + 5, 9 * cfg.tile_size, 17 * cfg.tile_size + 1] {
        let gb = fixture::spheres(37, h, 1).unwrap();
        let mask = gbuf::detect::baselines::none(&gb);
        let ms = gbuf::resolve::time_sampled(&gb, &lights, &mask, &cfg).unwrap();
        assert!(ms.is_finite() && ms > 0.0, "height {h} (stride {stride}): {ms} ms");
    }
}

fn arb_light() -> impl Strategy<Value = Light> {
    (
        (-6.0f32..6.0, -2.0f32..4.0, -22.0f32..1.0),
        0.05f32..8.0,
        0.0f32..1.2,
        0u8..4,
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
        (0.0f32..0.8, 0.0f32..0.8),
    )
        .prop_map(|((x, y, z), range, begin_frac, kind, (dx, dy, dz), (a, b))| {
            let dir = Vec3::new(dx, dy, dz).try_normalize().unwrap_or(Vec3::NEG_Y);
            let kind = match kind {
                0 | 1 => LightKind::Point,
                2 => LightKind::Spot { direction: dir, inner_cone_angle: a.min(b), outer_cone_angle: a.max(b) },
                _ => LightKind::Directional { direction: dir },
            };
            Light {
                kind,
                position: Vec3::new(x, y, z),
                color: Vec3::new(1.0, 0.5, 0.25),
                intensity: 3.0,
                range,
                begin: range * begin_frac.min(1.0),
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Culling never drops a contributing light: every method's image equals the unculled one bit for bit,
    /// whatever the tile size.
    #[test]
    fn culling_never_drops_a_contributing_light(
        lights in prop::collection::vec(arb_light(), 1..24),
        tile_size in 1u32..40,
        slices in 1u32..20,
        brdf in 0usize..3,
        falloff in 0usize..2,
    ) {
        let gb = fixture::spheres(30, 18, 2).unwrap();
        let mask = gbuf::detect::baselines::ssaa(&gb);
        let base = ResolveConfig {
            brdf: Brdf::ALL[brdf],
            falloff: Falloff::ALL[falloff],
            culling: Culling::None,
            ..Default::default()
        };
        let none = resolve(&gb, &lights, &mask, &base).unwrap();
        for &culling in &Culling::ALL[1..] {
            let c = ResolveConfig { culling, tile_size, depth_slices: slices, ..base };
            let r = resolve(&gb, &lights, &mask, &c).unwrap();
            for (i, (a, b)) in none.image.rgb.iter().zip(&r.image.rgb).enumerate() {
                prop_assert!(a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits),
                    "{} tile {}: pixel {}: {} vs {}", culling, tile_size, i, a, b);
            }
            prop_assert_eq!(r.stats.light_pairs_lit, none.stats.light_pairs_lit);
        }
    }
}

/// The resolve's result apart from its timings.
fn without_times(mut r: gbuf::resolve::Resolved) -> gbuf::resolve::Resolved {
    r.stats.ms = Default::default();
    r
}

/// `gb` with sample-level damage the resolve must sanitise and count: NaN and Inf positions, normals and albedo,
/// negative specular, uncovered first samples (the per-pixel slow path), at positions chosen by `seed`.
fn damaged(mut gb: GBuffer, seed: u64) -> GBuffer {
    let n = gb.len();
    let mut at = seed | 1;
    let mut next = || {
        at = at.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (at >> 33) as usize % n
    };
    for _ in 0..n / 40 {
        gb.coverage[next()] = false;
        if let Some(p) = &mut gb.position {
            p[next()] = Vec3::new(f32::NAN, 0.0, -1.0);
            p[next()].z = f32::INFINITY;
        }
        if let Some(v) = &mut gb.normal {
            v[next()] = Vec3::splat(f32::NAN);
        }
        if let Some(v) = &mut gb.albedo {
            v[next()] = Vec3::new(-1.0, f32::INFINITY, 0.5);
        }
        if let Some(v) = &mut gb.specular {
            v[next()] = -2.0;
        }
    }
    gb
}

#[test]
fn split_order_gives_the_same_result_as_interleaved() {
    use gbuf::detect::{detect, Detector, DetectorConfig};
    use gbuf::resolve::SplitSamples;
    for (samples, seed) in [(1, 3), (2, 5), (4, 7), (8, 9)] {
        let mut gb = damaged(fixture::spheres(41, 27, samples).unwrap(), seed);
        let lights = mixed_lights(&gb, seed);
        let adaptive = detect(&gb, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
        assert!(samples == 1 || adaptive.shade_count.iter().any(|&c| c > 1), "{samples}x: no edge pixel");
        for (mask, what) in [(adaptive, "adaptive"), (gbuf::detect::baselines::ssaa(&gb), "ssaa")] {
            for culling in Culling::ALL {
                for brdf in Brdf::ALL {
                    let c = ResolveConfig { culling, tile_size: 7, ..cfg(culling, brdf, Falloff::Gltf) };
                    let want = without_times(resolve(&gb, &lights, &mask, &c).unwrap());
                    let split = SplitSamples::new(&gb).unwrap();
                    let got = without_times(resolve(&split, &lights, &mask, &c).unwrap());
                    let label = format!("{samples}x {what} {culling} {brdf}");
                    assert_bit_identical(&want.image, &got.image, &label);
                    assert_eq!(want.lights_per_pixel, got.lights_per_pixel, "{label}");
                    assert_eq!(want.stats, got.stats, "{label}");
                    assert!(want.stats.sanitized.total() > 0, "{label}: nothing was damaged");
                }
            }
        }
        // Positions from depth and the camera instead of a position plane.
        gb.position = None;
        let mask = gbuf::detect::baselines::ssaa(&gb);
        let c = ResolveConfig::default();
        let want = without_times(resolve(&gb, &lights, &mask, &c).unwrap());
        let got = without_times(resolve(&SplitSamples::new(&gb).unwrap(), &lights, &mask, &c).unwrap());
        assert_bit_identical(&want.image, &got.image, &format!("{samples}x from depth"));
        assert_eq!(want.stats, got.stats);
    }
}
