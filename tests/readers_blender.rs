//! The Blender multilayer EXR reader against fixtures/blender_gbuffer.exr (rendered by
//! fixtures/scripts/blender_gbuffer.py), variants of it built in code (long pass names, other view-layer names,
//! missing passes, wrong channel types), and a cross-check with Python's OpenEXR package when it is installed.

mod support;

use gbuf::io::exr::{read_raw, RawChannel, RawData, RawImage};
use gbuf::io::sidecar::Sidecar;
use gbuf::io::{blender, fold::fold, LoadOptions, Loaded, ReadLimits};
use gbuf::{Attribute, Error};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

fn raw() -> RawImage {
    read_raw(&fixture("blender_gbuffer.exr"), &ReadLimits::default()).unwrap()
}

fn sidecar() -> Sidecar {
    Sidecar::load(&fixture("blender_gbuffer.json")).unwrap()
}

fn read(raw: &RawImage, sidecar: Option<&Sidecar>) -> gbuf::Result<Loaded> {
    blender::read(raw, &fixture("blender_gbuffer.exr"), sidecar, &LoadOptions::default())
}

/// The fixture renders each pixel with one ray inside a 0.01-pixel box filter, so a sample sits within 0.005 px of
/// the pixel centre; reconstructing a position from depth at the centre is off by that much of a pixel footprint.
/// At the fixture's ~0.03 world units per pixel per unit depth that is ≤ 2e-4 relative; 1e-3 leaves margin.
const RECONSTRUCT_REL_TOL: f32 = 1e-3;
/// Normals are f32 in the file and go through one 3×3 rotation.
const UNIT_TOL: f32 = 1e-4;

/// The material table of the script: (IndexMA, roughness, metallic, base colour).
const MATERIALS: [(u32, f32, f32, [f32; 3]); 4] = [
    (1, 0.8, 0.0, [0.55, 0.5, 0.45]),
    (2, 0.3, 0.0, [0.8, 0.1, 0.08]),
    (3, 0.2, 1.0, [1.0, 0.77, 0.34]),
    (4, 0.9, 0.0, [0.1, 0.25, 0.7]),
];

#[test]
fn fixture_is_recognised_and_reads_with_its_sidecar() {
    let raw = raw();
    assert!(blender::matches(&raw));
    let sc = sidecar();
    let l = read(&raw, Some(&sc)).unwrap();
    assert_eq!(l.camera_source, "sidecar");
    let g = &l.gbuffer;
    assert_eq!((g.width, g.height, g.samples), (128, 96, 1));
    for a in [
        Attribute::Depth,
        Attribute::Position,
        Attribute::Normal,
        Attribute::Albedo,
        Attribute::Specular,
        Attribute::Roughness,
        Attribute::Metallic,
        Attribute::MaterialId,
        Attribute::ObjectId,
        Attribute::Motion,
    ] {
        assert!(g.has(a), "{} missing", a.name());
        assert!(l.sources.iter().any(|s| s.attribute == a.name()), "{} has no source", a.name());
    }
    let spec = l.sources.iter().find(|s| s.attribute == "specular").unwrap();
    assert_eq!(spec.channels, ["ViewLayer.GlossCol.R", "ViewLayer.GlossCol.G", "ViewLayer.GlossCol.B"]);
    assert!(spec.note.as_deref().unwrap().contains("mean of the RGB"));
    assert_eq!(l.lights.as_ref().map(Vec::len), Some(2));
    // Background: the sky above the horizon, a plausible share of the frame.
    let bg = g.background_samples() as f32 / g.len() as f32;
    assert!((0.03..0.6).contains(&bg), "background fraction {bg}");
}

#[test]
fn geometry_is_consistent_in_view_space() {
    let l = read(&raw(), Some(&sidecar())).unwrap();
    let g = &l.gbuffer;
    let cam = g.camera.unwrap();
    let (depth, pos, normal) = (g.depth.as_ref().unwrap(), g.position.as_ref().unwrap(), g.normal.as_ref().unwrap());
    let (mut facing_z, mut facing_eye, mut covered) = (0, 0, 0);
    for y in 0..g.height {
        for x in 0..g.width {
            let i = g.index(x, y, 0);
            if !g.coverage[i] {
                assert_eq!((depth[i], pos[i], normal[i]), (0.0, Vec3::ZERO, Vec3::ZERO));
                continue;
            }
            covered += 1;
            let d = depth[i];
            assert!(d > cam.znear && d < cam.zfar, "({x}, {y}) depth {d}");
            assert!((normal[i].length() - 1.0).abs() < UNIT_TOL);
            // Depth.Z is planar view depth: it equals −z of the view-space position ...
            assert!((-pos[i].z - d).abs() <= RECONSTRUCT_REL_TOL * d, "({x}, {y}) −z {} vs depth {d}", -pos[i].z);
            // ... and depth through the pixel centre reconstructs the position.
            let rec = cam.view_position(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), d, g.width, g.height);
            assert!((rec - pos[i]).length() <= RECONSTRUCT_REL_TOL * d, "({x}, {y}) {rec} vs {}", pos[i]);
            facing_z += usize::from(normal[i].z > 0.0);
            facing_eye += usize::from(normal[i].dot(-pos[i]) > 0.0);
        }
    }
    assert!(facing_z as f32 > 0.8 * covered as f32, "{facing_z} of {covered} normals with z > 0");
    // Smooth shading can tilt interpolated normals slightly away at silhouettes; nearly all face the eye.
    assert!(facing_eye as f32 > 0.98 * covered as f32, "{facing_eye} of {covered} normals face the eye");
    // The floor (material 1) is Blender's z = 0 plane: its view-space normal is the world up axis in view space.
    let up = cam.to_view_dir(Vec3::Z);
    let mat = g.material_id.as_ref().unwrap();
    for i in (0..g.len()).filter(|&i| g.coverage[i] && mat[i] == 1) {
        assert!((normal[i] - up).length() < 1e-3, "floor normal {} vs {up}", normal[i]);
    }
}

#[test]
fn ids_and_material_values_match_the_script() {
    let l = read(&raw(), Some(&sidecar())).unwrap();
    let g = &l.gbuffer;
    let (mat, obj) = (g.material_id.as_ref().unwrap(), g.object_id.as_ref().unwrap());
    let (rough, metal, albedo) =
        (g.roughness.as_ref().unwrap(), g.metallic.as_ref().unwrap(), g.albedo.as_ref().unwrap());
    let mut seen_mat = std::collections::BTreeSet::new();
    let mut seen_obj = std::collections::BTreeSet::new();
    for i in 0..g.len() {
        if !g.coverage[i] {
            assert_eq!((mat[i], obj[i]), (0, 0));
            continue;
        }
        seen_mat.insert(mat[i]);
        seen_obj.insert(obj[i]);
        let (_, r, m, base) = MATERIALS.iter().find(|t| t.0 == mat[i]).expect("known material");
        assert_eq!((rough[i], metal[i]), (*r, *m), "material {}", mat[i]);
        // Diffuse colour is the base colour for dielectrics and black for the metal.
        let expect = if *m == 1.0 { Vec3::ZERO } else { Vec3::from(*base) };
        assert!((albedo[i] - expect).abs().max_element() < 1e-3, "material {}: {} vs {expect}", mat[i], albedo[i]);
    }
    assert_eq!(seen_mat.into_iter().collect::<Vec<_>>(), [1, 2, 3, 4]);
    assert_eq!(seen_obj.into_iter().collect::<Vec<_>>(), [10, 11, 12, 13]);
    assert!(l.sources.iter().all(|s| s.note.as_deref().is_none_or(|n| !n.contains("rounded"))), "IDs are integral");
}

#[test]
fn supersampled_fixture_folds_into_four_samples() {
    let l = read(&raw(), Some(&sidecar())).unwrap();
    let k = sidecar().supersample.unwrap();
    let f = fold(&l.gbuffer, k).unwrap();
    assert_eq!((f.width, f.height, f.samples), (64, 48, 4));
    f.validate().unwrap();
    // Pixels along object silhouettes now hold samples of different objects.
    let obj = f.object_id.as_ref().unwrap();
    let mixed = (0..f.pixel_count()).filter(|p| obj[p * 4..p * 4 + 4].windows(2).any(|w| w[0] != w[1])).count();
    assert!(mixed > 20 && mixed < f.pixel_count() / 2, "{mixed} edge pixels");
}

#[test]
fn camera_is_recovered_from_positions_without_a_sidecar() {
    let raw = raw();
    let with = read(&raw, Some(&sidecar())).unwrap();
    let without = read(&raw, None).unwrap();
    assert_eq!(without.camera_source, "fit");
    assert!(without.lights.is_none());
    let (a, b) = (with.gbuffer.camera.unwrap(), without.gbuffer.camera.unwrap());
    assert!((a.yfov - b.yfov).abs() < 1e-3, "yfov {} vs {}", a.yfov, b.yfov);
    assert!((a.aspect - b.aspect).abs() < 1e-3, "aspect {} vs {}", a.aspect, b.aspect);
    assert!(a.world_to_view.abs_diff_eq(b.world_to_view, 1e-2), "{}\nvs\n{}", a.world_to_view, b.world_to_view);
    let note = without.sources.iter().find(|s| s.attribute == "normal").unwrap().note.clone().unwrap();
    assert!(note.contains("fitted") && note.contains("px"), "{note}");
    let (na, nb) = (with.gbuffer.normal.unwrap(), without.gbuffer.normal.unwrap());
    for (x, y) in na.iter().zip(&nb) {
        assert!((*x - *y).length() < 1e-2);
    }
}

fn without_channels(raw: &RawImage, pass: &str) -> RawImage {
    let mut r = raw.clone();
    r.channels.retain(|c| !c.name.contains(&format!(".{pass}.")));
    r
}

#[test]
fn without_camera_or_positions_normals_stay_in_world_space_and_say_so() {
    let raw = without_channels(&raw(), "Position");
    let l = read(&raw, None).unwrap();
    assert_eq!(l.camera_source, "unknown");
    assert!(l.gbuffer.position.is_none() && l.gbuffer.depth.is_some());
    let note = l.sources.iter().find(|s| s.attribute == "normal").unwrap().note.clone().unwrap();
    assert!(note.contains("WORLD SPACE"), "{note}");
    // The floor's world-space normal is Blender's +Z.
    let g = &l.gbuffer;
    let (mat, n) = (g.material_id.as_ref().unwrap(), g.normal.as_ref().unwrap());
    let floor = (0..g.len()).find(|&i| g.coverage[i] && mat[i] == 1).unwrap();
    assert!((n[floor] - Vec3::Z).length() < 1e-4);
}

#[test]
fn long_pass_names_and_other_view_layer_names_read_the_same() {
    let raw = raw();
    let mut renamed = raw.clone();
    for c in &mut renamed.channels {
        c.name = c
            .name
            .replace("ViewLayer.", "Render Layer.001.")
            .replace(".DiffCol.", ".Diffuse Color.")
            .replace(".GlossCol.", ".Glossy Color.")
            .replace(".IndexMA.", ".Material Index.")
            .replace(".IndexOB.", ".Object Index.");
    }
    let sc = sidecar();
    let (a, b) = (read(&raw, Some(&sc)).unwrap(), read(&renamed, Some(&sc)).unwrap());
    assert_eq!(a.gbuffer, b.gbuffer);
    let mat = b.sources.iter().find(|s| s.attribute == "material_id").unwrap();
    assert_eq!(mat.channels, ["Render Layer.001.Material Index.X"]);
}

#[test]
fn map_overrides_and_bad_channels_are_clear_errors() {
    let raw = raw();
    let path = fixture("blender_gbuffer.exr");
    let sc = sidecar();
    // --map roughness to the Metallic AOV: honoured.
    let opts =
        LoadOptions { map: vec![(Attribute::Roughness, vec!["ViewLayer.Metallic.X".into()])], ..Default::default() };
    let l = blender::read(&raw, &path, Some(&sc), &opts).unwrap();
    assert_eq!(l.gbuffer.roughness, l.gbuffer.metallic);
    // --map to a channel that does not exist: names it and lists what there is.
    let opts = LoadOptions { map: vec![(Attribute::Depth, vec!["ViewLayer.Nope.Z".into()])], ..Default::default() };
    let e = blender::read(&raw, &path, Some(&sc), &opts).unwrap_err().to_string();
    assert!(
        e.contains("ViewLayer.Nope.Z") && e.contains("ViewLayer.Depth.Z") && e.contains("blender_gbuffer.exr"),
        "{e}"
    );
    // --map with the wrong number of channels.
    let opts = LoadOptions { map: vec![(Attribute::Normal, vec!["ViewLayer.Normal.X".into()])], ..Default::default() };
    assert!(blender::read(&raw, &path, Some(&sc), &opts).is_err());
    // A depth channel stored as uint is not a depth.
    let mut bad = raw.clone();
    let d = bad.channels.iter_mut().find(|c| c.name == "ViewLayer.Depth.Z").unwrap();
    d.data = RawData::U32(vec![1; 128 * 96]);
    match read(&bad, Some(&sc)) {
        Err(Error::UnsupportedSampleType { channel, .. }) => assert_eq!(channel, "ViewLayer.Depth.Z"),
        other => panic!("expected UnsupportedSampleType, got {other:?}"),
    }
    // A channel of the wrong length.
    let mut bad = raw.clone();
    bad.channels.iter_mut().find(|c| c.name == "ViewLayer.Normal.Y").unwrap().data = RawData::F32(vec![0.0; 7]);
    assert!(matches!(read(&bad, Some(&sc)), Err(Error::SizeMismatch { .. })));
    // Only Combined left: not a G-buffer; the error lists the channels.
    let mut only = raw.clone();
    only.channels.retain(|c| c.name.contains(".Combined."));
    assert!(!blender::matches(&only));
    let e = read(&only, None).unwrap_err().to_string();
    assert!(e.contains("ViewLayer.Combined.R"), "{e}");
    // Half-float passes (Blender's "Half" colour depth) read as well.
    let mut half = raw.clone();
    for c in &mut half.channels {
        if let RawData::F32(v) = &c.data {
            c.data = RawData::F16(v.iter().map(|x| half::f16::from_f32(*x)).collect());
        }
    }
    let l = read(&half, Some(&sc)).unwrap();
    assert_eq!(l.sources.iter().find(|s| s.attribute == "depth").unwrap().file_type, "half");
    // Non-integral IDs are rounded and counted.
    let mut odd = raw.clone();
    if let RawData::F32(v) = &mut odd.channels.iter_mut().find(|c| c.name == "ViewLayer.IndexOB.X").unwrap().data {
        v[5000] += 0.4;
    }
    let l = read(&odd, Some(&sc)).unwrap();
    let note = l.sources.iter().find(|s| s.attribute == "object_id").unwrap().note.clone().unwrap();
    assert!(note.starts_with("1 non-integral"), "{note}");
}

#[test]
fn a_minimal_layout_in_code_reads() {
    // Just depth and normals under an unusual view-layer name, built in code as Blender would write it.
    let (w, h) = (8u32, 6u32);
    let n = (w * h) as usize;
    let depth: Vec<f32> = (0..n).map(|i| if i % 4 == 0 { 1e10 } else { 2.0 + i as f32 * 0.1 }).collect();
    let ch = |name: &str, v: Vec<f32>| RawChannel { name: name.into(), data: RawData::F32(v) };
    let raw = RawImage {
        width: w,
        height: h,
        channels: vec![
            ch("Layer.With.Dots.Depth.Z", depth.clone()),
            ch("Layer.With.Dots.Normal.X", vec![0.0; n]),
            ch("Layer.With.Dots.Normal.Y", vec![0.0; n]),
            ch("Layer.With.Dots.Normal.Z", vec![2.0; n]),
        ],
        ..Default::default()
    };
    assert!(blender::matches(&raw));
    let l = blender::read(&raw, Path::new("mini.exr"), None, &LoadOptions::default()).unwrap();
    let g = &l.gbuffer;
    assert!(g.motion.is_none());
    assert_eq!(g.background_samples(), n / 4);
    assert_eq!(g.depth.as_ref().unwrap()[1], depth[1]);
    assert_eq!(
        g.normal.as_ref().unwrap()[1],
        2.0 * Vec3::Z,
        "left in world space, length kept (the rule of every reader)"
    );
    assert_eq!(l.camera_source, "unknown");
}

/// Cross-check with the reference OpenEXR implementation (Python `OpenEXR` package): required in CI
/// (`support::python_has`), skipped with a note elsewhere when the package is missing.
#[test]
fn python_openexr_agrees() {
    if !support::python_has("OpenEXR, numpy") {
        return;
    }
    let script = r#"
import sys
import OpenEXR, numpy as np
f = OpenEXR.File(sys.argv[1], separate_channels=True)
ch = f.parts[0].channels
for name in ["ViewLayer.Depth.Z", "ViewLayer.Position.X", "ViewLayer.Normal.Y", "ViewLayer.IndexMA.X"]:
    a = ch[name].pixels.astype(np.float64)
    print(name, a.shape[1], a.shape[0], repr(float(a[a < 1e9].sum())), repr(float(a[40, 70])))
"#;
    let out = std::process::Command::new("python3").arg("-c").arg(script).arg(fixture("blender_gbuffer.exr")).output();
    let out = out.expect("run python3");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "python OpenEXR failed: {}", String::from_utf8_lossy(&out.stderr));
    let raw = raw();
    for line in text.lines() {
        let f: Vec<&str> = line.split(' ').collect();
        let c = raw.channel(f[0]).unwrap();
        assert_eq!((raw.width, raw.height), (f[1].parse().unwrap(), f[2].parse().unwrap()));
        let sum: f64 = (0..c.data.len()).map(|i| f64::from(c.data.f32_at(i))).filter(|v| *v < 1e9).sum();
        let py_sum: f64 = f[3].parse().unwrap();
        assert!((sum - py_sum).abs() <= 1e-9 * py_sum.abs().max(1.0), "{}: {sum} vs {py_sum}", f[0]);
        let px = f64::from(c.data.f32_at(40 * raw.width as usize + 70));
        assert_eq!(px, f[4].parse::<f64>().unwrap(), "{} at (70, 40)", f[0]);
    }
}

#[test]
fn vector_pass_becomes_motion_since_the_previous_frame() {
    // Values as Blender 3.4 wrote them for a cube moving right and up by (3.95, 1.98) px per frame
    // (measured on a throw-away render; the fixture itself is static).
    let n = 4;
    let ch = |name: &str, v: f32| RawChannel { name: name.into(), data: RawData::F32(vec![v; n]) };
    let raw = RawImage {
        width: 2,
        height: 2,
        channels: vec![
            ch("ViewLayer.Depth.Z", 3.0),
            ch("ViewLayer.Vector.X", -3.95),
            ch("ViewLayer.Vector.Y", -1.98),
            ch("ViewLayer.Vector.Z", -3.95),
            ch("ViewLayer.Vector.W", -1.98),
        ],
        ..Default::default()
    };
    let l = blender::read(&raw, Path::new("moving.exr"), None, &LoadOptions::default()).unwrap();
    // Moved right (+x) and up (−y in image rows) since the previous frame.
    assert_eq!(l.gbuffer.motion.unwrap()[0], Vec2::new(3.95, -1.98));
}

#[test]
fn a_sidecar_camera_from_another_render_is_refused() {
    let raw = raw();
    let good = sidecar();
    let l = read(&raw, Some(&good)).unwrap();
    let note = l.sources.iter().find(|s| s.attribute == "position").unwrap().note.clone().unwrap();
    assert!(note.contains("checked against the position pass"), "{note}");
    // A wider field of view, and a camera moved sideways: both move the reprojected positions by many pixels.
    let mut wide = good.clone();
    wide.camera.as_mut().unwrap().yfov *= 1.2;
    let mut moved = good.clone();
    moved.camera.as_mut().unwrap().world_to_view[0][3] += 0.5;
    for bad in [wide, moved] {
        let e = read(&raw, Some(&bad)).unwrap_err().to_string();
        assert!(e.contains("sidecar camera does not match") && e.contains("blender_gbuffer.exr"), "{e}");
    }
}

#[test]
fn colour_aovs_become_scalars_by_their_mean() {
    let mut raw = raw();
    // Turn the Metallic value AOV into a colour AOV named "Specular" holding (v, 2v, 3v): mean 2v.
    let v = match &raw.channel("ViewLayer.Metallic.X").unwrap().data {
        RawData::F32(v) => v.clone(),
        other => panic!("{other:?}"),
    };
    for (c, k) in [("R", 1.0), ("G", 2.0), ("B", 3.0)] {
        raw.channels.push(RawChannel {
            name: format!("ViewLayer.Specular.{c}"),
            data: RawData::F32(v.iter().map(|x| x * k).collect()),
        });
    }
    let l = read(&raw, Some(&sidecar())).unwrap();
    let spec = l.sources.iter().find(|s| s.attribute == "specular").unwrap();
    assert_eq!(spec.channels, ["ViewLayer.Specular.R", "ViewLayer.Specular.G", "ViewLayer.Specular.B"]);
    let (s, m) = (l.gbuffer.specular.unwrap(), l.gbuffer.metallic.unwrap());
    for (s, m) in s.iter().zip(&m) {
        assert!((s - 2.0 * m).abs() < 1e-6);
    }
}

#[test]
fn destiny_table_is_keyed_by_the_dumps_material_ids() {
    // The fixture carries 16 material IDs and a textured roughness: the table holds one entry per ID (not a
    // clustering of every distinct tuple), and its error is the variation inside each material.
    let loaded = gbuf::io::load(&fixture("blender_gbuffer.exr"), &LoadOptions::default()).unwrap();
    let gb = &loaded.gbuffer;
    let ids = gb.material_id.as_deref().expect("the fixture has material IDs");
    let mut distinct: Vec<u32> = ids.iter().zip(&gb.coverage).filter(|(_, c)| **c).map(|(i, _)| *i).collect();
    distinct.sort_unstable();
    distinct.dedup();
    let layout = gbuf::layout::Layout::by_name("destiny-96").unwrap();
    let packed = layout.pack(gb).unwrap();
    let t = packed.material_table.as_ref().unwrap();
    assert_eq!(t.key, "material-id");
    assert!(t.entries.len() <= 16 && t.entries.len() == distinct.len(), "{} entries", t.entries.len());
    assert_eq!(t.ids, distinct);
}

/// The fixture's sidecar with a `materials` list added, written to a temporary directory beside a copy of the dump.
fn with_materials(materials: serde_json::Value) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let dump = dir.path().join("frame.exr");
    std::fs::copy(fixture("blender_gbuffer.exr"), &dump).unwrap();
    let mut side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("blender_gbuffer.json")).unwrap()).unwrap();
    side["materials"] = materials;
    std::fs::write(dir.path().join("frame.json"), serde_json::to_string(&side).unwrap()).unwrap();
    (dir, dump)
}

#[test]
fn sidecar_materials_become_the_table_and_the_error_is_the_variation_around_them() {
    // IDs 1 and 2 declared with the script's roughness and metallic; the other IDs are left to the per-ID mean.
    let (_dir, dump) = with_materials(serde_json::json!([
        { "id": MATERIALS[0].0, "name": "floor", "roughness": 0.5, "metallic": MATERIALS[0].2 },
        { "id": MATERIALS[1].0, "roughness": MATERIALS[1].1 },
        { "id": 999, "roughness": 0.1 }
    ]));
    let loaded = gbuf::io::load(&dump, &LoadOptions::default()).unwrap();
    let gb = &loaded.gbuffer;
    assert_eq!(gb.materials.len(), 3);
    let info = serde_json::to_value(gbuf::io::stats::info(&loaded, &dump)).unwrap();
    assert_eq!(info["materials"][0]["name"], "floor");

    let layout = gbuf::layout::Layout::by_name("destiny-96").unwrap();
    let t = layout.pack(gb).unwrap().material_table.unwrap();
    assert_eq!(t.key, "material-id");
    let col = |name: &str| t.parameters.iter().position(|p| p == name).unwrap();
    let (r, m) = (col("roughness"), col("metallic"));
    let e1 = t.ids.iter().position(|&id| id == MATERIALS[0].0).unwrap();
    let e2 = t.ids.iter().position(|&id| id == MATERIALS[1].0).unwrap();
    assert_eq!(t.entries[e1][r], 0.5);
    assert_eq!(t.entries[e1][m], MATERIALS[0].2);
    assert_eq!(t.entries[e2][r], MATERIALS[1].1);
    assert_eq!(t.from_sidecar, 3);
    let note = t.note.as_deref().unwrap();
    assert!(note.contains(&format!("{} of {} material IDs", t.ids.len() - 2, t.ids.len())), "{note}");

    // Undeclared entries are the per-ID mean; the error covers the distance to the declared 0.5.
    let ids = gb.material_id.as_deref().unwrap();
    let rough = gb.roughness.as_deref().unwrap();
    let mut worst = 0f32;
    for (e, &id) in t.ids.iter().enumerate().filter(|(e, _)| *e != e1 && *e != e2) {
        let vals: Vec<f64> =
            (0..gb.len()).filter(|&i| gb.coverage[i] && ids[i] == id).map(|i| f64::from(rough[i])).collect();
        let mean = (vals.iter().sum::<f64>() / vals.len() as f64) as f32;
        assert!((t.entries[e][r] - mean).abs() <= 1e-6 * mean.abs().max(1.0), "ID {id}");
    }
    for i in (0..gb.len()).filter(|&i| gb.coverage[i] && ids[i] == MATERIALS[0].0) {
        worst = worst.max((rough[i] - 0.5).abs());
    }
    assert!(worst > 0.0 && t.max_abs_error[r] >= worst, "{} < {worst}", t.max_abs_error[r]);

    // The unpacked G-buffer carries the declared value on every sample of material 1.
    let un = layout.unpack(&layout.pack(gb).unwrap(), gb).unwrap();
    let ur = un.roughness.as_deref().unwrap();
    assert!((0..gb.len()).filter(|&i| gb.coverage[i] && ids[i] == MATERIALS[0].0).all(|i| ur[i] == 0.5));

    // The canonical EXR keeps the catalogue.
    let canon = _dir.path().join("canonical.exr");
    gbuf::io::canonical::write(&canon, gb).unwrap();
    let back = gbuf::io::load(&canon, &LoadOptions::default()).unwrap();
    assert_eq!(back.gbuffer.materials, gb.materials);
}

#[test]
fn sidecar_materials_that_cannot_be_right_are_refused_naming_the_sidecar() {
    for (bad, what) in [
        (serde_json::json!([{ "id": 1, "roughness": 0.5 }, { "id": 1 }]), "listed twice"),
        (serde_json::json!([{ "id": 1, "roughness": 2.0 }]), "roughness = 2 is out of range"),
        (serde_json::json!([{ "id": 1, "glossiness": 0.5 }]), "unknown field"),
    ] {
        let (_dir, dump) = with_materials(bad);
        let err = gbuf::io::load(&dump, &LoadOptions::default()).unwrap_err().to_string();
        assert!(err.contains("frame.json") && err.contains(what), "{err}");
    }
}
