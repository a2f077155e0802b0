//! The resolve lit from packed render targets (decoded band by band inside it, `Layout::frame`) against the resolve
//! of the unpacked G-buffer: the same image, heatmap and counts bit for bit, for every built-in layout, detector,
//! BRDF, culling mode, MSAA schedule, instruction set and thread count. Coarse shading (one evaluation per coarse
//! pixel of a shading-rate image) against the full-rate resolve, from planes and from packed targets.

mod support;

use gbuf::base::isa::Isa;
use gbuf::detect::rate::{self, CoarseMode, Rate, Sri};
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::light::Light;
use gbuf::resolve::{resolve_coarse, resolve_coarse_isa, resolve_isa, Coarse, ResolveConfig};
use gbuf::scene::{default_lights, render, SceneName};
use gbuf::GBuffer;
use glam::Vec3;

/// The room (materials, IDs, a camera: depth-only layouts derive positions) at a size that is not a whole number
/// of tiles, and a frame with every attribute (roughness and metallic for GGX, values out of every codec's range).
fn frames() -> Vec<(&'static str, GBuffer, Vec<Light>)> {
    let room = render(SceneName::Room, 70, 37, 4).unwrap();
    let lights = default_lights(SceneName::Room, &room);
    let mut every = support::io::plausible(29, 21, 4, 3);
    let n = every.len();
    let mut r = gbuf::base::rng::SplitMix64::new(5);
    every.specular = Some((0..n).map(|_| r.range_f32(-0.2, 1.2)).collect());
    every.specular_power = Some((0..n).map(|_| r.range_f32(0.0, 300.0)).collect());
    every.roughness = Some((0..n).map(|_| r.range_f32(-0.1, 1.1)).collect());
    every.metallic = Some((0..n).map(|_| r.next_f32()).collect());
    every.zero_background();
    let every_lights = gbuf::resolve::fixture::lights_on_surfaces(&every, 20, 3.0, 7);
    vec![("room", room, lights), ("every-attribute", every, every_lights)]
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap()
}

#[test]
fn packed_input_lights_every_layout_as_its_unpacked_gbuffer() {
    let det_cfg = DetectorConfig::default();
    let mut checked = 0;
    for (name, gb, lights) in frames() {
        let masks: Vec<_> = [Detector::Lauritzen, Detector::Ssaa, Detector::None]
            .into_iter()
            .map(|d| (d, detect(&gb, d, &det_cfg).unwrap()))
            .collect();
        for layout in Layout::builtins() {
            let packed = layout.pack(&gb).unwrap();
            let unpacked = layout.unpack(&packed, &gb).unwrap();
            let frame = layout.frame(&packed, &gb).unwrap();
            for (d, mask) in &masks {
                for (cfg, label) in support::resolve_configs() {
                    for isa in Isa::available() {
                        let what = format!("{name} / {} / {d} / {label} / {isa:?}", layout.name());
                        let a = resolve_isa(isa, &unpacked, &lights, mask, &cfg).unwrap();
                        let b = resolve_isa(isa, &frame, &lights, mask, &cfg).unwrap();
                        assert!(a.stats.shading_evaluations > 0, "{what}: nothing shaded");
                        support::assert_same_resolve(&a, &b, &what);
                        checked += 1;
                    }
                }
            }
        }
    }
    // 2 frames × ≥ 8 layouts × 3 detectors × 3 BRDFs × 10 valid culling/schedule pairs × each ISA.
    assert!(checked >= 2 * 8 * 3 * 3 * 10 * Isa::available().len(), "{checked} combinations");
}

/// A pixel shaded once whose sample 0 is unusable (nearer than the eye's minimum depth) is lit from its other
/// samples: from a packed band as from the unpacked G-buffer, bit for bit.
#[test]
fn a_pixel_whose_first_sample_is_unusable_is_lit_from_its_other_samples() {
    let (_, mut gb, lights) = frames().remove(0);
    let s = gb.samples as usize;
    let mut spoiled = Vec::new();
    for p in (0..gb.len() / s).step_by(7) {
        if gb.coverage[p * s] && gb.coverage[p * s + 1] {
            // In front of the eye but nearer than any usable position (the resolve's MIN_VIEW_DEPTH).
            let d = &mut gb.depth.as_mut().unwrap()[p * s];
            let scale = 1e-9 / *d;
            *d = 1e-9;
            gb.position.as_mut().unwrap()[p * s] *= scale;
            spoiled.push(p);
        }
    }
    assert!(spoiled.len() > 100, "{} pixels", spoiled.len());
    let det_cfg = DetectorConfig::default();
    let mut near_kept = 0;
    for layout in Layout::builtins() {
        let packed = layout.pack(&gb).unwrap();
        let unpacked = layout.unpack(&packed, &gb).unwrap();
        let frame = layout.frame(&packed, &gb).unwrap();
        let first_near = spoiled.iter().filter(|&&p| unpacked.depth.as_ref().unwrap()[p * s] < 1e-6).count();
        near_kept += usize::from(first_near == spoiled.len());
        for d in [Detector::None, Detector::Lauritzen] {
            let mask = detect(&unpacked, d, &det_cfg).unwrap();
            let cfg = ResolveConfig::default();
            let a = resolve_isa(Isa::detect(), &unpacked, &lights, &mask, &cfg).unwrap();
            let b = resolve_isa(Isa::detect(), &frame, &lights, &mask, &cfg).unwrap();
            support::assert_same_resolve(&a, &b, &format!("{} / {d}", layout.name()));
            if first_near == spoiled.len() {
                // Lit from the other samples: not the blank a pixel without a usable sample gets.
                let lit = spoiled.iter().filter(|&&p| b.lights_per_pixel[p] > 0).count();
                assert!(4 * lit > 3 * spoiled.len(), "{} / {d}: {lit} of {} lit", layout.name(), spoiled.len());
            }
        }
    }
    assert!(near_kept > 0, "no layout keeps the near depth: the case is not exercised");
}

#[test]
fn packed_input_is_independent_of_thread_count_and_tile_size() {
    let (_, gb, lights) = frames().remove(0);
    let mask = detect(&gb, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    for layout in Layout::builtins() {
        let packed = layout.pack(&gb).unwrap();
        let unpacked = layout.unpack(&packed, &gb).unwrap();
        let frame = layout.frame(&packed, &gb).unwrap();
        for tile_size in [8, 16, 32] {
            let cfg = ResolveConfig { tile_size, ..Default::default() };
            let a = pool(1).install(|| resolve_isa(Isa::detect(), &unpacked, &lights, &mask, &cfg).unwrap());
            for threads in [1, 2, 3] {
                let b = pool(threads).install(|| resolve_isa(Isa::detect(), &frame, &lights, &mask, &cfg).unwrap());
                support::assert_same_resolve(
                    &a,
                    &b,
                    &format!("{} / tile {tile_size} / {threads} threads", layout.name()),
                );
            }
        }
    }
}

#[test]
fn a_packed_frame_with_nothing_to_derive_positions_from_is_refused() {
    let (_, mut gb, lights) = frames().remove(0);
    gb.camera = None;
    let layout = Layout::by_name_or_path("lauritzen-15").unwrap();
    let packed = layout.pack(&gb).unwrap();
    let frame = layout.frame(&packed, &gb).unwrap();
    let mask = detect(&gb, Detector::None, &DetectorConfig::default()).unwrap();
    let err = gbuf::resolve::resolve(&frame, &lights, &mask, &ResolveConfig::default()).unwrap_err().to_string();
    assert!(err.contains("positions") && err.contains("lauritzen-15"), "{err}");
}

#[test]
fn a_corrupt_material_index_is_an_error_not_a_panic() {
    let (_, gb, lights) = frames().remove(0);
    let layout = Layout::builtins().into_iter().find(|l| l.indirection().is_some()).expect("a layout with a table");
    let mut packed = layout.pack(&gb).unwrap();
    let table = packed.material_table.as_mut().unwrap();
    table.entries.truncate(1);
    let frame = layout.frame(&packed, &gb).unwrap();
    let mask = detect(&gb, Detector::None, &DetectorConfig::default()).unwrap();
    let err = gbuf::resolve::resolve(&frame, &lights, &mask, &ResolveConfig::default()).unwrap_err().to_string();
    assert!(err.contains("material index"), "{err}");
}

#[test]
fn detectors_on_packed_bands_match_the_unpacked_gbuffer() {
    let det_cfg = DetectorConfig::default();
    let mut compared = 0;
    for (name, gb, _) in frames() {
        for layout in Layout::builtins() {
            let packed = layout.pack(&gb).unwrap();
            let unpacked = layout.unpack(&packed, &gb).unwrap();
            let frame = layout.frame(&packed, &gb).unwrap();
            for d in Detector::ALL {
                let what = format!("{name} / {} / {d}", layout.name());
                match (detect(&unpacked, d, &det_cfg), gbuf::detect::detect_packed(&frame, d, &det_cfg)) {
                    (Ok(a), Ok(b)) => {
                        assert_eq!(a, b, "{what}");
                        compared += 1;
                    }
                    // The same refusal (the list of planes it gives differs by the position the lighting derives).
                    (Err(a), Err(b)) => {
                        let cause =
                            |e: gbuf::Error| e.to_string().split("; the G-buffer has").next().unwrap().to_string();
                        assert_eq!(cause(a), cause(b), "{what}");
                    }
                    (a, b) => panic!("{what}: {a:?} vs {b:?}"),
                }
            }
        }
    }
    assert!(compared >= 2 * 8 * 5, "{compared} masks compared");
}

/// Per pixel, the pixel whose evaluation it takes under `sri` (`None`: shaded itself, or uncovered), by the
/// definition: in each coarse pixel (aligned to its size within its tile, clipped to the frame), the first non-edge
/// pixel in row order with a covered sample is shaded, the other covered non-edge pixels take its evaluation.
fn representatives(gb: &GBuffer, mask: &gbuf::base::mask::EdgeMask, sri: &Sri) -> Vec<Option<usize>> {
    let mut out = vec![None; gb.pixel_count()];
    let s = gb.samples as usize;
    let covered = |p: usize| gb.coverage[p * s..(p + 1) * s].contains(&true);
    for ty in 0..sri.rows {
        for tx in 0..sri.cols {
            let (w, h) = sri.rates[(ty * sri.cols + tx) as usize].size();
            let (x_end, y_end) = (((tx + 1) * sri.tile).min(gb.width), ((ty + 1) * sri.tile).min(gb.height));
            for cy in (ty * sri.tile..y_end).step_by(h as usize) {
                for cx in (tx * sri.tile..x_end).step_by(w as usize) {
                    let mut rep = None;
                    for y in cy..(cy + h).min(y_end) {
                        for x in cx..(cx + w).min(x_end) {
                            let p = (y * gb.width + x) as usize;
                            if mask.is_edge(p) || !covered(p) {
                                continue;
                            }
                            match rep {
                                None => rep = Some(p),
                                Some(r) => out[p] = Some(r),
                            }
                        }
                    }
                }
            }
        }
    }
    out
}

/// Coarse shading (`resolve_coarse`), against the full-rate resolve, for every BRDF, culling mode, MSAA schedule,
/// instruction set, thread count and for packed input: an all-1×1 SRI gives the full-rate resolve bit for bit;
/// under a random SRI every pixel that is not shared is the full-rate image's bit for bit, a shared pixel holds its
/// representative's colour (`broadcast`) or that colour times its albedo over the representative's (`lighting`),
/// spends no light evaluation, and the evaluations are what `rate::evaluations` counts from the SRI and the mask.
#[test]
fn coarse_shading_takes_one_evaluation_per_coarse_pixel() {
    let mut checked = 0;
    for samples in [1, 4] {
        let gb = render(SceneName::Room, 70, 37, samples).unwrap();
        let lights = default_lights(SceneName::Room, &gb);
        let mask = detect(&gb, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
        let mut rng = gbuf::base::rng::SplitMix64::new(11);
        let allowed: Vec<Rate> = Rate::ALL.into_iter().filter(|r| r.allowed(samples, true)).collect();
        let mut sri = Sri::uniform(gb.width, gb.height, 8, Rate::R1x1);
        for r in &mut sri.rates {
            *r = allowed[rng.next_u64() as usize % allowed.len()];
        }
        let reps = representatives(&gb, &mask, &sri);
        assert!(reps.iter().filter(|r| r.is_some()).count() > gb.pixel_count() / 8, "the SRI shares pixels");
        let full_rate = Sri::uniform(gb.width, gb.height, 8, Rate::R1x1);
        let layout = Layout::by_name("minimal-8").unwrap();
        let packed = layout.pack(&gb).unwrap();
        let unpacked = layout.unpack(&packed, &gb).unwrap();
        let frame = layout.frame(&packed, &gb).unwrap();
        for (cfg, label) in support::resolve_configs() {
            for isa in Isa::available() {
                let what = format!("{samples}× / {label} / {isa:?}");
                let full = resolve_isa(isa, &gb, &lights, &mask, &cfg).unwrap();
                let one = Coarse { sri: &full_rate, mode: CoarseMode::Broadcast };
                support::assert_same_resolve(
                    &full,
                    &resolve_coarse_isa(isa, &gb, &lights, &mask, one, &cfg).unwrap(),
                    &what,
                );
                for mode in [CoarseMode::Broadcast, CoarseMode::Lighting] {
                    let coarse = Coarse { sri: &sri, mode };
                    let got =
                        pool(1 + checked % 2).install(|| resolve_coarse_isa(isa, &gb, &lights, &mask, coarse, &cfg));
                    let got = got.unwrap();
                    let what = format!("{what} / {mode:?}");
                    assert_eq!(got.stats.shading_evaluations, rate::evaluations(&gb, &mask, &sri), "{what}");
                    let albedo = |p: usize| {
                        let s = (0..samples as usize).map(|k| p * samples as usize + k).find(|&i| gb.coverage[i]);
                        gb.albedo.as_ref().unwrap()[s.unwrap()]
                    };
                    for (p, rep) in reps.iter().enumerate() {
                        let want = match (rep, mode) {
                            (None, _) => full.image.rgb[p],
                            (Some(r), CoarseMode::Broadcast) => full.image.rgb[*r],
                            (Some(r), CoarseMode::Lighting) => {
                                let (own, theirs) = (albedo(p), albedo(*r));
                                let ratio = |o: f32, t: f32| if t >= 1.0 / 1024.0 { o / t } else { 1.0 };
                                let m =
                                    Vec3::new(ratio(own.x, theirs.x), ratio(own.y, theirs.y), ratio(own.z, theirs.z));
                                full.image.rgb[*r] * m
                            }
                        };
                        let g = got.image.rgb[p];
                        assert!(
                            g.to_array().map(f32::to_bits) == want.to_array().map(f32::to_bits),
                            "{what}: pixel {p}: {g} vs {want}"
                        );
                        // (How many lights a shaded pixel tests follows the culling of its tile's list.)
                        if rep.is_some() {
                            assert_eq!(got.lights_per_pixel[p], 0, "{what}: pixel {p} spent evaluations");
                        }
                    }
                    // Lit from packed targets, band by band: the same as from their decoded planes.
                    let a = resolve_coarse_isa(isa, &unpacked, &lights, &mask, coarse, &cfg).unwrap();
                    let b = resolve_coarse_isa(isa, &frame, &lights, &mask, coarse, &cfg).unwrap();
                    support::assert_same_resolve(&a, &b, &format!("{what} / packed"));
                    checked += 1;
                }
            }
        }
    }
    assert!(checked >= 2 * 2 * 9, "{checked}");
}

/// An SRI that does not cover the frame, or whose coarse pixels would cross resolve tiles, is refused.
#[test]
fn coarse_shading_refuses_an_sri_that_does_not_fit() {
    let gb = render(SceneName::Room, 40, 24, 1).unwrap();
    let lights = default_lights(SceneName::Room, &gb);
    let mask = detect(&gb, Detector::None, &DetectorConfig::default()).unwrap();
    let small = Sri::uniform(32, 24, 8, Rate::R2x2);
    let c = Coarse { sri: &small, mode: CoarseMode::Broadcast };
    let e = resolve_coarse(&gb, &lights, &mask, c, &ResolveConfig::default()).unwrap_err().to_string();
    assert!(e.contains("4×3 tiles of 8") && e.contains("40×24"), "{e}");
    let sri = Sri::uniform(40, 24, 8, Rate::R4x4);
    let c = Coarse { sri: &sri, mode: CoarseMode::Broadcast };
    let cfg = ResolveConfig { tile_size: 6, ..Default::default() };
    let e = resolve_coarse(&gb, &lights, &mask, c, &cfg).unwrap_err().to_string();
    assert!(e.contains("multiple of 4"), "{e}");
    // A tile size that is a multiple of the coarse pixels is fine.
    let cfg = ResolveConfig { tile_size: 12, ..Default::default() };
    assert!(resolve_coarse(&gb, &lights, &mask, c, &cfg).is_ok());
}
