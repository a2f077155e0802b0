//! Streaming MSAA G-buffer compression (Kerzner & Salvi 2014, `analysis::compress`): the slot rules on hand-made
//! pixels, the lossless case against the uncompressed adaptive image, and the llvmpipe fixture's fragments against
//! its per-sample IDs.

use gbuf::analysis::compress::{aggregate, compress, footprint, Compressed, StreamingConfig};
use gbuf::analysis::surfaces::surfaces_per_pixel;
use gbuf::detect::{covered_per_pixel, detect, Detector, DetectorConfig};
use gbuf::io::LoadOptions;
use gbuf::resolve::{resolve, ResolveConfig};
use gbuf::scene::{default_lights, render, SceneName};
use gbuf::GBuffer;
use glam::Vec3;
use std::path::PathBuf;

fn cfg(slots: u32, merge: bool) -> StreamingConfig {
    StreamingConfig { slots, merge }
}

/// One 8× pixel: object 1 on five samples (facing the camera, depth 2), object 2 on two (depth 5, facing +X),
/// object 3 on one (depth 9, facing +X).
fn one_pixel() -> GBuffer {
    let mut gb = GBuffer::new(1, 1, 8).unwrap();
    let objects = [1u32, 1, 2, 1, 2, 1, 3, 1];
    gb.coverage = vec![true; 8];
    gb.object_id = Some(objects.to_vec());
    gb.primitive_id = Some(vec![0; 8]);
    let depth = |o: u32| [0.0, 2.0, 5.0, 9.0][o as usize];
    gb.depth = Some(objects.iter().map(|&o| depth(o)).collect());
    gb.position = Some(objects.iter().map(|&o| Vec3::new(0.0, 0.0, -depth(o))).collect());
    gb.normal = Some(objects.iter().map(|&o| if o == 1 { Vec3::Z } else { Vec3::X }).collect());
    gb.albedo = Some(objects.iter().map(|&o| Vec3::splat(0.1 * o as f32)).collect());
    gb
}

#[test]
fn a_full_pixel_evicts_the_fragment_covering_fewest_samples() {
    let gb = one_pixel();
    let all = compress(&gb, &cfg(3, false)).unwrap();
    assert_eq!((all.fragments, all.evicted_samples, all.discarded_pixels, all.slots_per_pixel[0]), (3, 0, 0, 3));
    let two = compress(&gb, &cfg(2, false)).unwrap();
    assert_eq!((two.evicted_samples, two.discarded_pixels, two.slots_per_pixel[0]), (1, 1, 2));
    // Object 3's sample is background now; the pixel's colour is spread over the 7 samples left.
    assert!(!two.gbuffer.coverage[6] && two.gbuffer.coverage.iter().filter(|&&c| c).count() == 7);
    assert_eq!(two.scale[0], 8.0 / 7.0);
    let one = compress(&gb, &cfg(1, false)).unwrap();
    assert_eq!((one.evicted_samples, one.slots_per_pixel[0]), (3, 1));
    assert_eq!(
        one.gbuffer
            .object_id
            .as_ref()
            .unwrap()
            .iter()
            .zip(&one.gbuffer.coverage)
            .filter(|(_, c)| **c)
            .map(|(o, _)| *o)
            .collect::<Vec<_>>(),
        vec![1; 5]
    );
    // One slot covering 5 of 8 samples is shaded per sample (its silhouette weight), not once whole.
    assert_eq!(one.mask.shade_count[0], 8);
    assert_eq!(all.evaluations(), 3);
    assert_eq!(all.slot_histogram(), vec![0, 0, 0, 1]);
}

#[test]
fn agreeing_fragments_merge_into_one_slot_with_weighted_fields() {
    let mut gb = one_pixel();
    // Objects 2 and 3 on one plane (depth 5, +X): they merge; object 1 faces elsewhere and stays apart.
    let objects = gb.object_id.clone().unwrap();
    for (i, &o) in objects.iter().enumerate() {
        if o == 3 {
            gb.depth.as_mut().unwrap()[i] = 5.0;
            gb.position.as_mut().unwrap()[i] = Vec3::new(0.0, 0.0, -5.0);
        }
    }
    let c = compress(&gb, &cfg(2, true)).unwrap();
    assert_eq!((c.merges, c.evicted_samples, c.slots_per_pixel[0]), (1, 0, 2));
    // The merged slot's albedo: (2·0.2 + 1·0.3) / 3 on all three of its samples; IDs of the larger part (object 2).
    let albedo = c.gbuffer.albedo.as_ref().unwrap();
    for i in [2usize, 4, 6] {
        assert!((albedo[i] - Vec3::splat(0.7 / 3.0)).abs().max_element() < 1e-6, "{}", albedo[i]);
        assert_eq!(c.gbuffer.object_id.as_ref().unwrap()[i], 2);
    }
    // Without merging the same pixel needs 3 slots.
    assert_eq!(compress(&gb, &cfg(3, false)).unwrap().slots_per_pixel[0], 3);
    // Bad slot counts are errors.
    assert!(compress(&gb, &cfg(0, true)).is_err() && compress(&gb, &cfg(9, true)).is_err());
}

/// Every sample of a (object, primitive) fragment takes its pixel's first sample of that fragment: a frame a
/// slot stores losslessly.
fn uniform_fragments(mut gb: GBuffer) -> GBuffer {
    let s = gb.samples as usize;
    let obj = gb.object_id.clone().unwrap();
    let prim = gb.primitive_id.clone().unwrap();
    for p in 0..gb.pixel_count() {
        for j in 0..s {
            let i = p * s + j;
            let Some(f) = (p * s..i).find(|&f| gb.coverage[f] && (obj[f], prim[f]) == (obj[i], prim[i])) else {
                continue;
            };
            if !gb.coverage[i] {
                continue;
            }
            macro_rules! copy {
                ($($plane:ident),*) => {$(if let Some(v) = gb.$plane.as_mut() { v[i] = v[f]; })*};
            }
            copy!(depth, position, normal, albedo, specular, specular_power, roughness, metallic, material_id, motion);
        }
    }
    gb
}

#[test]
fn with_a_slot_per_sample_the_compressed_image_is_the_uncompressed_adaptive_one() {
    // The room at 4×, each fragment's samples made equal (what one slot stores): K = samples evicts nothing, and
    // lighting the slots is lighting the frame with one evaluation per primitive (forward MSAA's adaptive mask,
    // silhouettes per sample) — bit for bit.
    let gb = uniform_fragments(render(SceneName::Room, 64, 40, 4).unwrap());
    let lights = default_lights(SceneName::Room, &gb);
    let c = compress(&gb, &cfg(4, false)).unwrap();
    assert_eq!((c.evicted_samples, c.discarded_pixels), (0, 0));
    assert_eq!(c.gbuffer.albedo, gb.albedo);
    assert_eq!(c.gbuffer.position, gb.position);
    let mut mask = detect(&gb, Detector::ForwardMsaa, &DetectorConfig::default()).unwrap();
    for (m, &n) in mask.shade_count.iter_mut().zip(&covered_per_pixel(&gb)) {
        if n > 0 && n < 4 {
            *m = 4;
        }
    }
    assert_eq!(c.mask.edges(), mask.edges());
    assert!(c.mask.edge_pixels() > 50, "the room has edges: {}", c.mask.edge_pixels());
    let rc = ResolveConfig::default();
    let want = resolve(&gb, &lights, &mask, &rc).unwrap();
    let got = c.light(&lights, &rc).unwrap();
    assert!(want
        .image
        .rgb
        .iter()
        .zip(&got.image.rgb)
        .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
    // One evaluation per fragment, not per sample.
    let fragments: u64 = c.fragments;
    assert_eq!(c.evaluations(), fragments);
    assert!(c.evaluations() < covered_per_pixel(&gb).iter().map(|&n| u64::from(n)).sum::<u64>());
}

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

#[test]
fn the_llvmpipe_fragments_are_its_distinct_primitives_and_fewer_slots_evict_more() {
    let gb = gbuf::io::load(&fixture("raster_4x.exr"), &LoadOptions::default()).unwrap().gbuffer;
    let h = surfaces_per_pixel(&gb);
    let by_id = h.by_identity.unwrap();
    let distinct: u64 = by_id.iter().enumerate().map(|(k, &n)| k as u64 * n).sum();
    let runs: Vec<Compressed> = (1..=4).map(|k| compress(&gb, &cfg(k, false)).unwrap()).collect();
    for c in &runs {
        assert_eq!(c.fragments, distinct, "one fragment per distinct (object, primitive) of a pixel");
        // A pixel of n primitives keeps min(n, K) slots.
        let want: Vec<u64> = (0..=c.config.slots as usize)
            .map(|k| if k < c.config.slots as usize { by_id[k] } else { by_id[k..].iter().sum() })
            .collect();
        assert_eq!(c.slot_histogram(), want);
    }
    assert_eq!(runs[3].evicted_samples, 0);
    assert!(runs[0].evicted_samples > runs[1].evicted_samples && runs[1].evicted_samples >= runs[2].evicted_samples);
    assert_eq!(runs[0].discarded_pixels, by_id[2..].iter().sum::<u64>());
    // Merging never needs more slots than not merging.
    let merged = compress(&gb, &cfg(4, true)).unwrap();
    assert!(merged.merges > 0 && merged.evaluations() < runs[3].evaluations());
    // Footprint: at 4×, 4 slots of a 20-byte layout cost more than the full G-buffer (4 × 24 + 8 = 104 vs 80 B);
    // 2 slots less (56); an 8-byte layout's coverage word eats the saving of 2 slots (32 vs 32).
    assert_eq!(footprint(20, 4, 4).compressed_bytes_per_pixel, 104);
    assert_eq!(footprint(20, 4, 2).compressed_bytes_per_pixel, 56);
    assert_eq!(footprint(8, 4, 2).compressed_bytes_per_pixel, footprint(8, 4, 2).full_bytes_per_pixel);
}

#[test]
fn aggregates_cut_a_pixel_at_its_largest_depth_gaps_and_average_each_layer() {
    let gb = one_pixel();
    // Depths 2 (×5), 5 (×2), 9 (×1): two layers cut at the larger gap (5 → 9); nothing evicted.
    let a = aggregate(&gb, 2).unwrap();
    assert_eq!((a.slots_per_pixel[0], a.evicted_samples, a.evaluations()), (2, 0, 2));
    let albedo = a.gbuffer.albedo.as_ref().unwrap();
    let near = Vec3::splat((5.0 * 0.1 + 2.0 * 0.2) / 7.0);
    for i in [0usize, 1, 2, 3, 4, 5, 7] {
        assert!((albedo[i] - near).abs().max_element() < 1e-6, "sample {i}: {}", albedo[i]);
    }
    assert!((albedo[6] - Vec3::splat(0.3)).abs().max_element() < 1e-6);
    // The near layer's normal: the renormalised mean of 5 × +Z and 2 × +X; its IDs the nearest sample's.
    let n = a.gbuffer.normal.as_ref().unwrap()[2];
    assert!((n - Vec3::new(2.0, 0.0, 5.0).normalize()).length() < 1e-6, "{n}");
    assert_eq!(a.gbuffer.object_id.as_ref().unwrap()[2], 1);
    // One aggregate: everything averaged, shaded per sample (8 of 8 covered, one layer → once).
    let one = aggregate(&gb, 1).unwrap();
    assert_eq!((one.slots_per_pixel[0], one.mask.shade_count[0]), (1, 1));
    // A pixel on one plane keeps one layer however many are allowed.
    let mut flat = gb.clone();
    flat.depth = Some(vec![3.0; 8]);
    flat.position = Some(vec![Vec3::new(0.0, 0.0, -3.0); 8]);
    assert_eq!(aggregate(&flat, 2).unwrap().slots_per_pixel[0], 1);
}

#[test]
fn aggregates_widen_the_specular_lobe_where_normals_disagree() {
    let mut gb = one_pixel();
    gb.specular_power = Some(vec![64.0; 8]);
    let a = aggregate(&gb, 1).unwrap();
    // Mean of 5 × +Z and 3 × +X: ρ = √34 / 8; Toksvig: ρs / (ρ + s(1 − ρ)).
    let rho = 34f32.sqrt() / 8.0;
    let want = rho * 64.0 / (rho + 64.0 * (1.0 - rho));
    let got = a.gbuffer.specular_power.as_ref().unwrap()[0];
    assert!((got - want).abs() < 1e-3 * want && got < 10.0, "{got} vs {want}");
    // Agreeing normals keep the power.
    let mut flat = gb.clone();
    flat.normal = Some(vec![Vec3::Z; 8]);
    assert_eq!(aggregate(&flat, 1).unwrap().gbuffer.specular_power.as_ref().unwrap()[0], 64.0);
}

#[test]
fn lighting_strip_by_strip_is_lighting_the_whole_compressed_frame() {
    use gbuf::analysis::compress::{light_compressed, CompressFrame, Method};
    for scene in [SceneName::Room, SceneName::Stress] {
        let gb = render(scene, 61, 45, 4).unwrap();
        let lights = default_lights(scene, &gb);
        let rc = ResolveConfig::default();
        for (method, slots) in [(Method::Streaming, 1), (Method::Streaming, 2), (Method::Aggregate, 2)] {
            let whole = match method {
                Method::Streaming => compress(&gb, &cfg(slots, true)).unwrap(),
                Method::Aggregate => gbuf::analysis::compress::aggregate(&gb, slots).unwrap(),
            };
            let want = whole.light(&lights, &rc).unwrap();
            for strip in [1, 7, 16, 64] {
                let frame = CompressFrame::new(&gb).unwrap();
                let lit = light_compressed(&frame, method, &cfg(slots, true), &lights, &rc, strip).unwrap();
                let what = format!("{scene:?} {method:?} {slots} slots, strips of {strip}");
                assert!(
                    want.image
                        .rgb
                        .iter()
                        .zip(&lit.image.rgb)
                        .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)),
                    "{what}"
                );
                assert_eq!(
                    (lit.evaluations, lit.slot_histogram.clone()),
                    (whole.evaluations(), whole.slot_histogram()),
                    "{what}"
                );
                assert_eq!(
                    (lit.fragments, lit.merges, lit.evicted_samples, lit.discarded_pixels),
                    (whole.fragments, whole.merges, whole.evicted_samples, whole.discarded_pixels),
                    "{what}"
                );
            }
        }
    }
}
