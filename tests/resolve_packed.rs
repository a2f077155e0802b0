//! The resolve lit from packed render targets (decoded band by band inside it, `Layout::frame`) against the resolve
//! of the unpacked G-buffer: the same image, heatmap and counts bit for bit, for every built-in layout, detector,
//! BRDF, culling mode, MSAA schedule, instruction set and thread count.

mod support;

use gbuf::base::isa::Isa;
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::layout::Layout;
use gbuf::light::Light;
use gbuf::resolve::{resolve_isa, ResolveConfig};
use gbuf::scene::{default_lights, render, SceneName};
use gbuf::GBuffer;

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
