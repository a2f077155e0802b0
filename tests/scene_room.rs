//! The `room` scene: geometric invariants of every sample, MSAA positions, IDs, smooth tessellation, determinism.

mod support;

use gbuf::scene::{objects, render, SceneName};
use gbuf::GBuffer;
use std::collections::{BTreeSet, HashMap};
use support::{assert_sample_invariants, sample_px, samples_of};

fn object_id(name: &str) -> u32 {
    objects(SceneName::Room, 1, 1).into_iter().find(|o| o.name == name).unwrap().object_id
}

#[test]
fn every_sample_is_consistent_with_the_camera_at_every_msaa_count() {
    for samples in [1, 2, 4, 8, 16] {
        let gb = render(SceneName::Room, 96, 54, samples).unwrap();
        assert_eq!(gb.sample_positions, gbuf::gbuffer::standard_sample_positions(samples).unwrap());
        assert_sample_invariants(&gb);
    }
}

#[test]
fn room_has_sky_many_materials_and_one_material_per_object() {
    let gb = render(SceneName::Room, 320, 180, 4).unwrap();
    let covered = gb.coverage.iter().filter(|c| **c).count() as f64 / gb.len() as f64;
    assert!(covered > 0.3 && covered < 0.95, "covered fraction {covered}: the room should show floor, walls and sky");
    let mat = gb.material_id.as_ref().unwrap();
    let obj = gb.object_id.as_ref().unwrap();
    let rough = gb.roughness.as_ref().unwrap();
    let mut material_of: HashMap<u32, (u32, f32)> = HashMap::new();
    for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
        let e = material_of.entry(obj[i]).or_insert((mat[i], rough[i]));
        assert_eq!(*e, (mat[i], rough[i]), "object {} has two materials", obj[i]);
    }
    let materials: BTreeSet<u32> = material_of.values().map(|m| m.0).collect();
    assert!(materials.len() >= 12, "only {} materials visible", materials.len());
    // The scene's own object table agrees with what was rendered.
    let table = objects(SceneName::Room, 320, 180);
    for (o, (m, _)) in &material_of {
        let info = table.iter().find(|t| t.object_id == *o).unwrap();
        assert_eq!(info.material_id, *m, "object {}", info.name);
    }
    // The window and the open side show sky between surfaces: some background pixels have covered neighbours
    // on both sides horizontally (the window), not just at the top of the image.
    let w = gb.width as usize;
    let px_cov = |x: usize, y: usize| gb.coverage[gb.index(x as u32, y as u32, 0)];
    let holes = (1..gb.height as usize - 1)
        .filter(|&y| (1..w - 1).any(|x| !px_cov(x, y) && (0..x).any(|l| px_cov(l, y)) && (x..w).any(|r| px_cov(r, y))))
        .count();
    assert!(holes > 5, "{holes} rows show sky between surfaces");
}

#[test]
fn msaa_samples_are_taken_at_their_own_positions() {
    let gb4 = render(SceneName::Room, 160, 90, 4).unwrap();
    let gb1 = render(SceneName::Room, 160, 90, 1).unwrap();
    let obj4 = gb4.object_id.as_ref().unwrap();
    let mixed = |gb: &GBuffer, ids: &[u32]| {
        (0..gb.pixel_count())
            .filter(|p| {
                let s = gb.samples as usize;
                let first = (ids[p * s], gb.coverage[p * s]);
                (1..s).any(|k| (ids[p * s + k], gb.coverage[p * s + k]) != first)
            })
            .count()
    };
    let edge_pixels = mixed(&gb4, obj4);
    assert!(edge_pixels > 200, "only {edge_pixels} pixels mix objects at 4×");
    assert_eq!(mixed(&gb1, gb1.object_id.as_ref().unwrap()), 0);
    // Every 4× sample projects back onto its own sub-pixel position, not onto the pixel centre.
    let cam = gb4.camera.unwrap();
    let pos = gb4.position.as_ref().unwrap();
    for i in (0..gb4.len()).filter(|&i| gb4.coverage[i]).step_by(7) {
        let back = cam.project(pos[i], gb4.width, gb4.height).unwrap();
        let want = sample_px(&gb4, i);
        assert!((back - want).length() < 1e-2, "sample {i} projects to {back}, expected {want}");
    }
    // The 1× centre sample differs from every 4× sample somewhere (the positions are really distinct).
    let d1 = gb1.depth.as_ref().unwrap();
    let d4 = gb4.depth.as_ref().unwrap();
    let differing = (0..gb1.len()).filter(|&p| (0..4).all(|k| d4[p * 4 + k] != d1[p])).count();
    assert!(differing > gb1.len() / 2, "{differing} pixels: 4× depths look like centre samples");
}

#[test]
fn thin_bars_are_partially_covered_at_4x() {
    let gb = render(SceneName::Room, 320, 180, 4).unwrap();
    let bars: BTreeSet<u32> =
        objects(SceneName::Room, 1, 1).into_iter().filter(|o| o.name == "fence-bar").map(|o| o.object_id).collect();
    let obj = gb.object_id.as_ref().unwrap();
    let partial = (0..gb.pixel_count())
        .filter(|p| {
            let hits = (0..4).filter(|k| gb.coverage[p * 4 + k] && bars.contains(&obj[p * 4 + k])).count();
            hits > 0 && hits < 4
        })
        .count();
    assert!(partial > 20, "{partial} pixels partially covered by fence bars");
}

#[test]
fn tessellated_sphere_has_many_primitives_and_continuous_normals() {
    let gb = render(SceneName::Room, 480, 270, 1).unwrap();
    let id = object_id("sphere-chrome");
    let s = samples_of(&gb, id);
    let prim = gb.primitive_id.as_ref().unwrap();
    let nrm = gb.normal.as_ref().unwrap();
    let pos = gb.position.as_ref().unwrap();
    let prims: BTreeSet<u32> = s.iter().map(|&i| prim[i]).collect();
    assert!(prims.len() > 50, "sphere shows only {} triangles", prims.len());
    // Across horizontally adjacent pixels on different triangles, the normal turns by about the arc between
    // the points (radius 1 m), never by a facet step (≈ 2π/48 = 0.13 rad for this sphere).
    const ARC_FACTOR: f32 = 1.5; // interpolated normals are not exactly radial; allow 50 % over the arc
    const FACET_STEP: f32 = std::f32::consts::TAU / 48.0;
    let w = gb.width as usize;
    let mut crossings = 0;
    for &i in &s {
        let j = i + 1;
        if i % w == w - 1 || !gb.coverage[j] || gb.object_id.as_ref().unwrap()[j] != id || prim[j] == prim[i] {
            continue;
        }
        // Skip the silhouette, where normals are bent to face the eye.
        let to_eye = -pos[i].normalize();
        if nrm[i].dot(to_eye) < 0.2 {
            continue;
        }
        let arc = (pos[i] - pos[j]).length();
        if arc > FACET_STEP / 3.0 {
            continue; // a pixel step this long could hide a facet step
        }
        crossings += 1;
        let angle = nrm[i].dot(nrm[j]).clamp(-1.0, 1.0).acos();
        assert!(angle <= ARC_FACTOR * arc + 1e-3, "normal jumps {angle} rad across an edge, arc {arc}");
    }
    assert!(crossings > 30, "only {crossings} triangle-edge crossings checked");
}

#[test]
fn rendering_is_deterministic() {
    let a = render(SceneName::Room, 120, 70, 4).unwrap();
    let b = render(SceneName::Room, 120, 70, 4).unwrap();
    assert!(a == b, "two renders differ");
}

#[test]
fn bad_sizes_are_errors_not_panics() {
    assert!(render(SceneName::Room, 0, 10, 4).is_err());
    assert!(render(SceneName::Room, 10, 0, 4).is_err());
    assert!(render(SceneName::Room, 10, 10, 3).is_err());
    assert!(render(SceneName::Room, 100_000, 100_000, 16).is_err());
    for name in SceneName::ALL {
        for (w, h, s) in [(1, 1, 1), (1, 1, 16), (3, 200, 4), (200, 3, 2)] {
            let gb = render(name, w, h, s).unwrap();
            assert_eq!(gb.len(), (w * h * s) as usize);
            gb.validate().unwrap();
        }
    }
}

#[test]
fn scene_names_round_trip() {
    for n in SceneName::ALL {
        assert_eq!(SceneName::from_name(n.name()), Some(n));
    }
    assert_eq!(SceneName::from_name("ROOM"), Some(SceneName::Room));
    assert_eq!(SceneName::from_name("kitchen"), None);
}
