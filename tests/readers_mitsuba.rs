//! The Mitsuba 3 `aov` EXR reader against fixtures/mitsuba_gbuffer.exr (rendered by
//! fixtures/scripts/mitsuba_gbuffer.py), variants of it built in code (user-chosen AOV names, missing passes, wrong
//! channel types), and a cross-check with Python's OpenEXR package when it is installed.

mod support;

use gbuf::io::exr::{read_raw, RawData, RawImage};
use gbuf::io::sidecar::Sidecar;
use gbuf::io::{fold::fold, mitsuba, LoadOptions, Loaded, ReadLimits};
use gbuf::{Attribute, Error};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

fn raw() -> RawImage {
    read_raw(&fixture("mitsuba_gbuffer.exr"), &ReadLimits::default()).unwrap()
}

fn sidecar() -> Sidecar {
    Sidecar::load(&fixture("mitsuba_gbuffer.json")).unwrap()
}

fn read(raw: &RawImage, sidecar: Option<&Sidecar>) -> gbuf::Result<Loaded> {
    mitsuba::read(raw, &fixture("mitsuba_gbuffer.exr"), sidecar, &LoadOptions::default())
}

/// Mitsuba traces exactly through pixel centres here (stratified sampler without jitter), so reconstruction is
/// limited by f32 rounding of world positions (~1e-7 relative) and the camera matrix; 1e-4 relative is generous.
const RECONSTRUCT_REL_TOL: f32 = 1e-4;
/// Normals are f32 in the file and go through one 3×3 rotation.
const UNIT_TOL: f32 = 1e-4;
/// The diffuse reflectances of the script's four shapes.
const ALBEDOS: [[f32; 3]; 4] = [[0.55, 0.5, 0.45], [0.8, 0.1, 0.08], [0.9, 0.7, 0.3], [0.1, 0.25, 0.7]];

#[test]
fn fixture_is_recognised_and_reads_with_its_sidecar() {
    let raw = raw();
    assert!(mitsuba::matches(&raw));
    assert!(!gbuf::io::blender::matches(&raw));
    let l = read(&raw, Some(&sidecar())).unwrap();
    assert_eq!(l.camera_source, "sidecar");
    let g = &l.gbuffer;
    assert_eq!((g.width, g.height, g.samples), (128, 96, 1));
    for a in [
        Attribute::Depth,
        Attribute::Position,
        Attribute::Normal,
        Attribute::Albedo,
        Attribute::ObjectId,
        Attribute::PrimitiveId,
    ] {
        assert!(g.has(a), "{} missing", a.name());
        assert!(l.sources.iter().any(|s| s.attribute == a.name()), "{} has no source", a.name());
    }
    let normal = l.sources.iter().find(|s| s.attribute == "normal").unwrap();
    assert_eq!(normal.channels, ["sh_normal.X", "sh_normal.Y", "sh_normal.Z"]);
    assert!(normal.note.as_deref().unwrap().contains("geo_normal"));
    assert_eq!(l.lights.as_ref().map(Vec::len), Some(1));
    let bg = g.background_samples() as f32 / g.len() as f32;
    assert!((0.1..0.6).contains(&bg), "background fraction {bg}");
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
            let rec = cam.view_position(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), d, g.width, g.height);
            assert!((rec - pos[i]).length() <= RECONSTRUCT_REL_TOL * d, "({x}, {y}) {rec} vs {}", pos[i]);
            facing_z += usize::from(normal[i].z > 0.0);
            facing_eye += usize::from(normal[i].dot(-pos[i]) > 0.0);
        }
    }
    assert!(facing_z as f32 > 0.8 * covered as f32);
    // Mitsuba's cylinder is open: through its top the inside shows, whose (outward) normals face away. That is a
    // handful of pixels; everything else faces the eye.
    assert!(facing_eye < covered && facing_eye as f32 > 0.98 * covered as f32, "{facing_eye} of {covered}");
    // The floor is the world's y = 0 plane (Y-up): wherever position is at world y ≈ 0, the normal is world +Y.
    let up = cam.to_view_dir(Vec3::Y);
    let inv = cam.world_to_view.inverse();
    let floor: Vec<usize> =
        (0..g.len()).filter(|&i| g.coverage[i] && inv.transform_point3(pos[i]).y.abs() < 1e-4).collect();
    assert!(floor.len() > g.len() / 10, "{} floor samples", floor.len());
    for i in floor {
        assert!((normal[i] - up).length() < 1e-3, "floor normal {} vs {up}", normal[i]);
    }
}

#[test]
fn ray_distance_converts_to_view_depth() {
    let raw = raw();
    let sc = sidecar();
    let full = read(&raw, Some(&sc)).unwrap();
    let mut no_pos = raw.clone();
    no_pos.channels.retain(|c| !c.name.starts_with("position."));
    let l = read(&no_pos, Some(&sc)).unwrap();
    let src = l.sources.iter().find(|s| s.attribute == "depth").unwrap();
    assert_eq!(src.channels, ["depth.T"]);
    assert!(src.note.as_deref().unwrap().contains("ray distance"));
    let (a, b) = (full.gbuffer.depth.unwrap(), l.gbuffer.depth.unwrap());
    let t = raw.channel("depth.T").unwrap();
    let mut differs = 0;
    for i in 0..a.len() {
        assert!((a[i] - b[i]).abs() <= RECONSTRUCT_REL_TOL * a[i].max(1.0), "{i}: {} vs {}", a[i], b[i]);
        differs += usize::from(a[i] > 0.0 && (t.data.f32_at(i) - a[i]).abs() > 1e-3 * a[i]);
    }
    // Off-axis, t and view depth differ: the conversion is not the identity.
    assert!(differs > a.len() / 2, "{differs}");
}

#[test]
fn ids_are_integral_and_albedo_matches_the_script() {
    let l = read(&raw(), Some(&sidecar())).unwrap();
    let g = &l.gbuffer;
    let (obj, prim, albedo) =
        (g.object_id.as_ref().unwrap(), g.primitive_id.as_ref().unwrap(), g.albedo.as_ref().unwrap());
    let raw = raw();
    let (si, pi) = (raw.channel("shape_index.I").unwrap(), raw.channel("prim_index.I").unwrap());
    let mut shapes = std::collections::BTreeSet::new();
    for i in 0..g.len() {
        if !g.coverage[i] {
            continue;
        }
        assert_eq!(obj[i] as f32, si.data.f32_at(i), "integral shape index");
        assert_eq!(prim[i] as f32, pi.data.f32_at(i), "integral primitive index");
        shapes.insert(obj[i]);
        assert!(ALBEDOS.iter().any(|a| (albedo[i] - Vec3::from(*a)).abs().max_element() < 1e-5), "{}", albedo[i]);
    }
    assert_eq!(shapes.len(), 4, "four shapes visible: {shapes:?}");
    assert!(prim.iter().any(|p| *p > 0), "meshes have several primitives");
    assert!(l.sources.iter().all(|s| s.note.as_deref().is_none_or(|n| !n.contains("rounded"))));
}

#[test]
fn supersampled_fixture_folds_into_four_samples() {
    let l = read(&raw(), Some(&sidecar())).unwrap();
    let f = fold(&l.gbuffer, sidecar().supersample.unwrap()).unwrap();
    assert_eq!((f.width, f.height, f.samples), (64, 48, 4));
    f.validate().unwrap();
}

#[test]
fn camera_is_recovered_from_positions_without_a_sidecar() {
    let raw = raw();
    let (with, without) = (read(&raw, Some(&sidecar())).unwrap(), read(&raw, None).unwrap());
    assert_eq!(without.camera_source, "fit");
    let (a, b) = (with.gbuffer.camera.unwrap(), without.gbuffer.camera.unwrap());
    assert!((a.yfov - b.yfov).abs() < 1e-4, "yfov {} vs {}", a.yfov, b.yfov);
    assert!((a.aspect - b.aspect).abs() < 1e-4, "aspect {} vs {}", a.aspect, b.aspect);
    assert!(a.world_to_view.abs_diff_eq(b.world_to_view, 1e-3), "{}\nvs\n{}", a.world_to_view, b.world_to_view);
}

#[test]
fn without_camera_or_positions_depth_is_flagged_as_ray_distance() {
    let mut raw = raw();
    raw.channels.retain(|c| !c.name.starts_with("position."));
    let l = read(&raw, None).unwrap();
    assert_eq!(l.camera_source, "unknown");
    let d = l.sources.iter().find(|s| s.attribute == "depth").unwrap().note.clone().unwrap();
    assert!(d.contains("RAY DISTANCE"), "{d}");
    let n = l.sources.iter().find(|s| s.attribute == "normal").unwrap().note.clone().unwrap();
    assert!(n.contains("WORLD SPACE"), "{n}");
}

#[test]
fn user_chosen_aov_names_read_the_same() {
    let raw = raw();
    let mut renamed = raw.clone();
    for c in &mut renamed.channels {
        for (from, to) in [
            ("depth.", "dd.y."),
            ("sh_normal.", "nn."),
            ("position.", "pp."),
            ("albedo.", "base.color."),
            ("shape_index.", "si."),
            ("prim_index.", "triangles_prim."),
        ] {
            if let Some(rest) = c.name.strip_prefix(from) {
                c.name = format!("{to}{rest}");
                break;
            }
        }
    }
    assert!(mitsuba::matches(&renamed));
    let sc = sidecar();
    let (a, b) = (read(&raw, Some(&sc)).unwrap(), read(&renamed, Some(&sc)).unwrap());
    assert_eq!(a.gbuffer, b.gbuffer);
    let pos = b.sources.iter().find(|s| s.attribute == "position").unwrap();
    assert_eq!(pos.channels, ["pp.X", "pp.Y", "pp.Z"], "unnamed XYZ with non-unit values is a position");
}

#[test]
fn map_overrides_and_bad_channels_are_clear_errors() {
    let raw = raw();
    let path = fixture("mitsuba_gbuffer.exr");
    let sc = sidecar();
    // --map the normal to geo_normal instead of sh_normal.
    let opts = LoadOptions {
        map: vec![(Attribute::Normal, vec!["geo_normal.X".into(), "geo_normal.Y".into(), "geo_normal.Z".into()])],
        ..Default::default()
    };
    let l = mitsuba::read(&raw, &path, Some(&sc), &opts).unwrap();
    assert_eq!(l.sources.iter().find(|s| s.attribute == "normal").unwrap().channels[0], "geo_normal.X");
    // --map a scalar (roughness from uv.U, for the sake of it).
    let opts = LoadOptions { map: vec![(Attribute::Roughness, vec!["uv.U".into()])], ..Default::default() };
    assert!(mitsuba::read(&raw, &path, Some(&sc), &opts).unwrap().gbuffer.roughness.is_some());
    // Missing channel in --map.
    let opts = LoadOptions { map: vec![(Attribute::Depth, vec!["zz.T".into()])], ..Default::default() };
    let e = mitsuba::read(&raw, &path, Some(&sc), &opts).unwrap_err().to_string();
    assert!(e.contains("zz.T") && e.contains("depth.T") && e.contains("mitsuba_gbuffer.exr"), "{e}");
    // A depth AOV stored as uint.
    let mut bad = raw.clone();
    bad.channels.iter_mut().find(|c| c.name == "depth.T").unwrap().data = RawData::U32(vec![1; 128 * 96]);
    assert!(matches!(read(&bad, Some(&sc)), Err(Error::UnsupportedSampleType { .. })));
    // Only colour and uv: nothing to build a G-buffer from; the error lists the channels.
    let mut only = raw.clone();
    only.channels.retain(|c| c.name.len() == 1 || c.name.starts_with("uv."));
    assert!(!mitsuba::matches(&only));
    // A merge of passes with position, normal and albedo groups but no Mitsuba depth/index AOV is not called a
    // Mitsuba dump (it goes to the --map reader, which asks for its conventions).
    let mut merge = raw.clone();
    merge.channels.retain(|c| ["position.", "sh_normal.", "albedo."].iter().any(|p| c.name.starts_with(p)));
    assert!(!merge.channels.is_empty() && !mitsuba::matches(&merge));
    let e = read(&only, None).unwrap_err().to_string();
    assert!(e.contains("uv.U") && e.contains("--map"), "{e}");
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
for name in ["depth.T", "position.Z", "sh_normal.X", "shape_index.I"]:
    a = ch[name].pixels.astype(np.float64)
    print(name, a.shape[1], a.shape[0], repr(float(a.sum())), repr(float(a[60, 50])))
"#;
    let out = std::process::Command::new("python3").arg("-c").arg(script).arg(fixture("mitsuba_gbuffer.exr")).output();
    let out = out.expect("run python3");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "python OpenEXR failed: {}", String::from_utf8_lossy(&out.stderr));
    let raw = raw();
    for line in text.lines() {
        let f: Vec<&str> = line.split(' ').collect();
        let c = raw.channel(f[0]).unwrap();
        assert_eq!((raw.width, raw.height), (f[1].parse().unwrap(), f[2].parse().unwrap()));
        let sum: f64 = (0..c.data.len()).map(|i| f64::from(c.data.f32_at(i))).sum();
        let py_sum: f64 = f[3].parse().unwrap();
        assert!((sum - py_sum).abs() <= 1e-9 * py_sum.abs().max(1.0), "{}: {sum} vs {py_sum}", f[0]);
        assert_eq!(f64::from(c.data.f32_at(60 * raw.width as usize + 50)), f[4].parse::<f64>().unwrap(), "{}", f[0]);
    }
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
        assert!(e.contains("sidecar camera does not match") && e.contains("mitsuba_gbuffer.exr"), "{e}");
    }
}

#[test]
fn an_unnamed_uint_xyz_group_is_ignored_not_fatal() {
    let mut raw = raw();
    for c in ["X", "Y", "Z"] {
        raw.channels
            .push(gbuf::io::exr::RawChannel { name: format!("extra.{c}"), data: RawData::U32(vec![7; 128 * 96]) });
    }
    let l = read(&raw, Some(&sidecar())).unwrap();
    assert!(l.sources.iter().all(|s| !s.channels.iter().any(|c| c.starts_with("extra."))));
    assert_eq!(l.sources.iter().find(|s| s.attribute == "position").unwrap().channels[0], "position.X");
}
