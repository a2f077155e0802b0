//! File sets (one image per buffer) against the LuxCoreRender fixture (fixtures/luxcore, made by
//! fixtures/scripts/luxcore_dump.py), presets laid out by their tools' documentation, declared conventions on
//! `--map`, and the plausibility warnings: they fire on the fixtures with those defects and stay quiet on clean ones.

mod support;

use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::io::exr::{read_raw, write_raw, RawChannel, RawData, RawImage, ReadLimits};
use gbuf::io::{canonical, LoadOptions};
use gbuf::{Attribute, GBuffer};
use glam::{DMat4, DVec3, Vec3};
use std::path::{Path, PathBuf};
use support::{gbuf, stderr};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

fn lux() -> PathBuf {
    fixture("luxcore")
}

/// Channel `c` of a LuxCore EXR, as f32.
fn channel(file: &str, c: &str) -> Vec<f32> {
    let raw = read_raw(&lux().join(file), &ReadLimits::default()).unwrap();
    let ch = raw.channel(c).unwrap();
    (0..ch.data.len()).map(|i| ch.data.f32_at(i)).collect()
}

fn ids_png(file: &str) -> Vec<u32> {
    let img = image::open(lux().join(file)).unwrap().to_rgb8();
    img.pixels().map(|p| u32::from(p[0]) + 256 * u32::from(p[1]) + 65536 * u32::from(p[2])).collect()
}

/// The LuxCore data merged into one canonical one-sample G-buffer by hand: world → view with the sidecar's matrix
/// in f64, depth = −z, coverage where DEPTH is finite, IDs from the PNGs. Written independently of the file-set
/// reader (only the raw EXR channel reader is shared).
fn merged_by_hand() -> GBuffer {
    let side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(lux().join("scene.json")).unwrap()).unwrap();
    let rows: Vec<f64> = side["camera"]["world_to_view"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| r.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect::<Vec<_>>())
        .collect();
    let m = DMat4::from_cols_array(&rows.try_into().unwrap()).transpose();
    let depth = channel("DEPTH.exr", "R");
    let (px, py, pz) = (channel("POSITION.exr", "R"), channel("POSITION.exr", "G"), channel("POSITION.exr", "B"));
    let (nx, ny, nz) =
        (channel("SHADING_NORMAL.exr", "R"), channel("SHADING_NORMAL.exr", "G"), channel("SHADING_NORMAL.exr", "B"));
    let (ar, ag, ab) = (channel("ALBEDO.exr", "R"), channel("ALBEDO.exr", "G"), channel("ALBEDO.exr", "B"));
    let (mat, obj) = (ids_png("MATERIAL_ID.png"), ids_png("OBJECT_ID.png"));
    let mut gb = GBuffer::new(320, 180, 1).unwrap();
    let n = gb.len();
    gb.coverage = depth.iter().map(|d| d.is_finite()).collect();
    let cov = gb.coverage.clone();
    let pick = |c: bool, v: Vec3| if c { v } else { Vec3::ZERO };
    let pos: Vec<Vec3> = (0..n)
        .map(|i| {
            let p = m.transform_point3(DVec3::new(px[i].into(), py[i].into(), pz[i].into()));
            pick(cov[i], p.as_vec3())
        })
        .collect();
    gb.depth = Some((0..n).map(|i| if cov[i] { -pos[i].z } else { 0.0 }).collect());
    gb.normal = Some(
        (0..n)
            .map(|i| {
                // A rigid transform: the rotation part maps normals (their length kept).
                let v = m.transform_vector3(DVec3::new(nx[i].into(), ny[i].into(), nz[i].into()));
                pick(cov[i], v.as_vec3())
            })
            .collect(),
    );
    gb.position = Some(pos);
    gb.albedo = Some((0..n).map(|i| pick(cov[i], Vec3::new(ar[i], ag[i], ab[i]))).collect());
    gb.material_id = Some((0..n).map(|i| if cov[i] { mat[i] } else { 0 }).collect());
    gb.object_id = Some((0..n).map(|i| if cov[i] { obj[i] } else { 0 }).collect());
    gb
}

/// The hand merge written as `merged.exr` with the fixture's sidecar beside it (so it folds and lights the same).
fn write_merged(dir: &Path) -> PathBuf {
    let out = dir.join("merged.exr");
    canonical::write(&out, &merged_by_hand()).unwrap();
    std::fs::copy(lux().join("scene.json"), dir.join("merged.json")).unwrap();
    out
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * a.abs().max(1.0)
}

#[test]
fn luxcore_directory_loads_as_the_same_gbuffer_as_its_canonical_merge() {
    let dir = tempfile::tempdir().unwrap();
    let merged = gbuf::io::load(&write_merged(dir.path()), &LoadOptions::default()).unwrap().gbuffer;
    let set = gbuf::io::load(&lux(), &LoadOptions::default()).unwrap();
    assert_eq!(set.reading.as_ref().unwrap().preset.as_deref(), Some("luxcore"));
    let g = &set.gbuffer;
    assert_eq!((g.width, g.height, g.samples), (160, 90, 4));
    assert_eq!((merged.width, merged.height, merged.samples), (160, 90, 4));
    assert_eq!(g.coverage, merged.coverage);
    // CONVENTIONS.md: 14,992 of 57,600 pixels of the 320×180 image are background.
    assert_eq!(g.background_samples(), 14_992);
    assert_eq!(g.material_id, merged.material_id);
    assert_eq!(g.object_id, merged.object_id);
    let mut mats: Vec<u32> =
        (0..g.len()).filter(|&i| g.coverage[i]).map(|i| g.material_id.as_ref().unwrap()[i]).collect();
    mats.sort_unstable();
    mats.dedup();
    assert_eq!(mats, [1, 2, 3, 4, 5]);
    assert_eq!(g.albedo, merged.albedo);
    let (d, dm) = (g.depth.as_ref().unwrap(), merged.depth.as_ref().unwrap());
    let (p, pm) = (g.position.as_ref().unwrap(), merged.position.as_ref().unwrap());
    let (n, nm) = (g.normal.as_ref().unwrap(), merged.normal.as_ref().unwrap());
    for i in (0..g.len()).filter(|&i| g.coverage[i]) {
        assert!(close(d[i], dm[i], 1e-5), "depth {i}: {} vs {}", d[i], dm[i]);
        assert!((p[i] - pm[i]).abs().max_element() <= 1e-5 * pm[i].length().max(1.0), "position {i}");
        assert!((n[i] - nm[i]).abs().max_element() <= 1e-5, "normal {i}: {} vs {}", n[i], nm[i]);
    }
    // Depth range: CONVENTIONS.md measures view z from −15.711 to −4.240.
    let covered: Vec<f32> = (0..g.len()).filter(|&i| g.coverage[i]).map(|i| d[i]).collect();
    let (lo, hi) = covered.iter().fold((f32::MAX, 0f32), |(a, b), &v| (a.min(v), b.max(v)));
    assert!((lo - 4.240).abs() < 1e-3 && (hi - 15.711).abs() < 1e-3, "{lo} … {hi}");
    // Edge truth and detection agree.
    for det in [Detector::Lauritzen, Detector::Id] {
        let a = detect(g, det, &DetectorConfig::default()).unwrap();
        let b = detect(&merged, det, &DetectorConfig::default()).unwrap();
        assert_eq!(a, b, "{det:?}");
    }
}

/// A number at `path` (`a.b.c`) in JSON output.
fn num(v: &serde_json::Value, path: &str) -> f64 {
    path.split('.').fold(v, |v, k| &v[k]).as_f64().unwrap_or_else(|| panic!("{path} in {v}"))
}

fn json(dir: &Path, args: &[&str]) -> serde_json::Value {
    let o = gbuf(dir, args);
    assert!(o.status.success(), "gbuf {args:?}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn the_commands_give_the_same_answers_on_the_directory_and_on_the_merge() {
    let dir = tempfile::tempdir().unwrap();
    let merged = write_merged(dir.path());
    let (m, l) = (merged.to_str().unwrap(), lux());
    let l = l.to_str().unwrap();
    let (a, b) = (json(dir.path(), &["info", l, "--json"]), json(dir.path(), &["info", m, "--json"]));
    assert_eq!(num(&a, "background_samples"), num(&b, "background_samples"));
    for k in ["attributes.depth.min", "attributes.depth.max", "attributes.material_id.max"] {
        assert!((num(&a, k) - num(&b, k)).abs() < 1e-4, "{k}");
    }
    assert_eq!(a["warnings"][0]["code"], "invalid-normals");
    assert_eq!(a["warnings"][0]["count"], 891);
    let (a, b) = (json(dir.path(), &["edges", l, "--json"]), json(dir.path(), &["edges", m, "--json"]));
    assert_eq!(a["true_edge_fraction"], b["true_edge_fraction"]);
    let strip = |v: &serde_json::Value| {
        let mut v = v.clone();
        for r in v["results"].as_array_mut().into_iter().flatten() {
            r.as_object_mut().unwrap().remove("ms");
        }
        v["results"].clone()
    };
    assert_eq!(strip(&a), strip(&b));
    let (a, b) = (json(dir.path(), &["resolve", l, "--json"]), json(dir.path(), &["resolve", m, "--json"]));
    for k in ["rmse", "shading_evaluations", "light_pairs_lit"] {
        let (x, y) = (num(&a, k), num(&b, k));
        assert!((x - y).abs() <= 1e-4 * y.abs().max(1.0), "{k}: {x} vs {y}");
    }
    // And the report runs on the directory as one frame.
    let out = dir.path().join("rep");
    let o = gbuf(
        dir.path(),
        &["report", l, "-o", out.to_str().unwrap(), "--candidates", "reference-f32,fat-20", "--flip", "none"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert!(!rep["rows"].as_array().unwrap().is_empty());
}

#[test]
fn world_space_data_through_map_is_converted_when_declared_and_refused_when_not() {
    let dir = tempfile::tempdir().unwrap();
    for f in ["POSITION.exr", "SHADING_NORMAL.exr", "ALBEDO.exr", "scene.json"] {
        std::fs::copy(lux().join(f), dir.path().join(f)).unwrap();
    }
    let map = "position=R;G;B,normal=SHADING_NORMAL.exr,albedo=ALBEDO.exr";
    // Taken as view space (the default of --map), it cannot be right: an error naming the file and the fix.
    let o = gbuf(dir.path(), &["resolve", "POSITION.exr", "--map", map, "--scene", "scene.json"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("POSITION.exr") && e.contains("behind the camera") && e.contains("--space world"), "{e}");
    // Declared, it gives the preset's image.
    let declared = json(
        dir.path(),
        &["resolve", "POSITION.exr", "--map", map, "--scene", "scene.json", "--space", "world", "--json"],
    );
    let opts = LoadOptions {
        files: vec![
            (Attribute::Position, "POSITION.exr".into(), vec![]),
            (Attribute::Normal, "SHADING_NORMAL.exr".into(), vec![]),
            (Attribute::Albedo, "ALBEDO.exr".into(), vec![]),
        ],
        conventions: gbuf::io::conventions::Overrides {
            space: Some(gbuf::io::conventions::Space::World),
            ..Default::default()
        },
        sidecar: Some(dir.path().join("scene.json")),
        ..Default::default()
    };
    let a = gbuf::io::load(&dir.path().join("POSITION.exr"), &opts).unwrap().gbuffer;
    let b = gbuf::io::load(&lux(), &LoadOptions::default()).unwrap().gbuffer;
    assert_eq!(a.coverage, b.coverage);
    assert_eq!(a.position, b.position);
    assert_eq!(a.normal, b.normal);
    assert!(num(&declared, "rmse") > 0.0 && num(&declared, "shading_evaluations") > 0.0);
}

#[test]
fn plausibility_warnings_fire_on_defects_and_stay_quiet_on_clean_fixtures() {
    for clean in ["room_4x.exr", "blender_gbuffer.exr", "mitsuba_gbuffer.exr", "raster_4x.exr", "ispc_deferred.bin"] {
        let l = gbuf::io::load(&fixture(clean), &LoadOptions::default()).unwrap();
        assert!(l.warnings.is_empty(), "{clean}: {:?}", l.warnings);
    }
    let l = gbuf::io::load(&lux(), &LoadOptions::default()).unwrap();
    let codes: Vec<&str> = l.warnings.iter().map(|w| w.code).collect();
    assert_eq!(codes, ["invalid-normals", "albedo-above-one"]);
    assert_eq!(l.warnings[0].count, 891);
    // LuxCoreRender's ALBEDO holds more than the base colour on some surfaces: said with its largest value.
    let bright = &l.warnings[1];
    assert!(bright.count > 0 && bright.message.contains("above 1 (up to"), "{}", bright.message);

    // Depth values mapped as normals.
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(lux().join("DEPTH.exr"), dir.path().join("DEPTH.exr")).unwrap();
    let opts = LoadOptions {
        map: vec![(Attribute::Depth, vec!["R".into()]), (Attribute::Normal, vec!["R".into(), "G".into(), "B".into()])],
        ..Default::default()
    };
    let l = gbuf::io::load(&dir.path().join("DEPTH.exr"), &opts).unwrap();
    let w = l.warnings.iter().find(|w| w.code == "invalid-normals").expect("flagged");
    assert_eq!(w.count, w.of);
    assert!(w.message.contains("another buffer mapped as normal"), "{}", w.message);

    // Sample positions assumed: a 4× canonical file without them.
    let gb = gbuf::io::load(&fixture("raster_4x.exr"), &LoadOptions::default()).unwrap().gbuffer;
    let mut raw = canonical::to_raw(&gb);
    raw.attributes.retain(|(k, _)| k != canonical::ATTR_SAMPLE_POSITIONS);
    let p = dir.path().join("nopos.exr");
    write_raw(&p, &raw).unwrap();
    let l = gbuf::io::load(&p, &LoadOptions::default()).unwrap();
    assert!(l.warnings.iter().any(|w| w.code == "sample-positions-assumed"), "{:?}", l.warnings);

    // Positions that disagree with depth (ray distance taken as view depth).
    let dir2 = tempfile::tempdir().unwrap();
    for f in ["POSITION.exr", "DEPTH.exr", "scene.json"] {
        std::fs::copy(lux().join(f), dir2.path().join(f)).unwrap();
    }
    let opts = LoadOptions {
        files: vec![
            (Attribute::Position, "POSITION.exr".into(), vec![]),
            (Attribute::Depth, "DEPTH.exr".into(), vec![]),
        ],
        conventions: gbuf::io::conventions::Overrides {
            space: Some(gbuf::io::conventions::Space::World),
            ..Default::default()
        },
        sidecar: Some(dir2.path().join("scene.json")),
        ..Default::default()
    };
    // The reader derives view depth from the position when both exist, so the depth agrees by construction…
    let l = gbuf::io::load(&dir2.path().join("POSITION.exr"), &opts).unwrap();
    assert!(!l.warnings.iter().any(|w| w.code == "position-depth"), "{:?}", l.warnings);
    // …and the reprojection through the sidecar's intrinsics (principal point one pixel down) stays under a pixel.
    let (median, max, far) = gbuf::io::plausible::reprojection(&l.gbuffer).unwrap();
    assert!(far == 0 && max < 0.5 && median < 0.3, "{median} {max} {far}");
    // Without the intrinsics the rays are a pixel off: the error grows (CONVENTIONS.md: 1 px up in the file).
    let mut side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir2.path().join("scene.json")).unwrap()).unwrap();
    side["camera"].as_object_mut().unwrap().remove("intrinsics");
    std::fs::write(dir2.path().join("scene.json"), side.to_string()).unwrap();
    let l2 = gbuf::io::load(&dir2.path().join("POSITION.exr"), &opts).unwrap();
    let (median2, _, _) = gbuf::io::plausible::reprojection(&l2.gbuffer).unwrap();
    assert!(median2 > median + 0.1, "{median2} vs {median}");
}

/// Writes a one-channel-per-component EXR named `name` in `dir`.
fn exr(dir: &Path, name: &str, w: u32, h: u32, chans: &[(&str, Vec<f32>)]) {
    let raw = RawImage {
        width: w,
        height: h,
        channels: chans.iter().map(|(n, v)| RawChannel { name: (*n).into(), data: RawData::F32(v.clone()) }).collect(),
        compression: "ZIP".into(),
        lossy: false,
        attributes: vec![],
    };
    write_raw(&dir.join(name), &raw).unwrap();
}

/// A small view-space scene for the documentation-laid-out presets: a tilted plane, sky in the top row.
fn small_scene() -> (GBuffer, gbuf::io::sidecar::Sidecar) {
    let (w, h) = (8u32, 6u32);
    let cam = gbuf::Camera::look_at(Vec3::new(0.5, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.9, w as f32 / h as f32, 0.1, 50.0);
    let mut gb = GBuffer::new(w, h, 1).unwrap();
    gb.camera = Some(cam);
    let n = gb.len();
    gb.coverage = (0..n).map(|i| i as u32 >= w).collect();
    let mut depth = vec![0.0; n];
    let mut pos = vec![Vec3::ZERO; n];
    for i in (0..n).filter(|&i| gb.coverage[i]) {
        let (x, y) = (i as u32 % w, i as u32 / w);
        depth[i] = 3.0 + 0.25 * x as f32 + 0.1 * y as f32;
        pos[i] = cam.view_position(glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5), depth[i], w, h);
    }
    let nv = cam.to_view_dir(Vec3::new(0.2, 1.0, 0.3).normalize());
    gb.depth = Some(depth);
    gb.position = Some(pos);
    gb.normal = Some((0..n).map(|i| if gb.coverage[i] { nv } else { Vec3::ZERO }).collect());
    gb.albedo = Some((0..n).map(|i| if gb.coverage[i] { Vec3::new(0.5, 0.25, 0.125) } else { Vec3::ZERO }).collect());
    gb.roughness = Some((0..n).map(|i| if gb.coverage[i] { 0.25 + 0.05 * (i % 5) as f32 } else { 0.0 }).collect());
    let side = gbuf::scene::lights::scene_sidecar(&gb, &[]);
    (gb, side)
}

fn world_normals(gb: &GBuffer) -> Vec<Vec3> {
    let inv = gb.camera.unwrap().world_to_view.inverse();
    gb.normal.as_ref().unwrap().iter().map(|n| inv.transform_vector3(*n)).collect()
}

fn write_side(dir: &Path, side: &gbuf::io::sidecar::Sidecar) {
    std::fs::write(dir.join("scene.json"), serde_json::to_string(side).unwrap()).unwrap();
}

fn assert_same(a: &GBuffer, b: &GBuffer, what: &str) {
    assert_eq!(a.coverage, b.coverage, "{what}: coverage");
    let (da, db) = (a.depth.as_ref().unwrap(), b.depth.as_ref().unwrap());
    let (na, nb) = (a.normal.as_ref().unwrap(), b.normal.as_ref().unwrap());
    for i in (0..a.len()).filter(|&i| a.coverage[i]) {
        assert!(close(da[i], db[i], 1e-4), "{what}: depth {i}: {} vs {}", da[i], db[i]);
        assert!((na[i] - nb[i]).length() < 2e-3, "{what}: normal {i}: {} vs {}", na[i], nb[i]);
    }
    if let (Some(ra), Some(rb)) = (&a.roughness, &b.roughness) {
        for i in (0..a.len()).filter(|&i| a.coverage[i]) {
            assert!((ra[i] - rb[i]).abs() < 1e-3, "{what}: roughness {i}");
        }
    }
}

#[test]
fn unity_hdrp_aovs_laid_out_by_the_recorder_documentation() {
    // Files as the Recorder names them (`<Recorder>_<AOV>_<Take>_<Frame>`), Normal world space n·0.5+0.5,
    // Depth the reversed-Z device depth (0 at the far plane = sky), Smoothness = 1 − roughness.
    let (gb, side) = small_scene();
    let cam = gb.camera.unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (gb.width, gb.height);
    let dev: Vec<f32> = (0..gb.len())
        .map(|i| if gb.coverage[i] { 1.0 - cam.post_projection_depth(gb.depth.as_ref().unwrap()[i]) } else { 0.0 })
        .collect();
    let nw = world_normals(&gb);
    let enc = |c: usize| nw.iter().map(|n| n[c] * 0.5 + 0.5).collect::<Vec<f32>>();
    exr(dir.path(), "AOV Image Sequence_Depth_001_0000.exr", w, h, &[("R", dev)]);
    exr(dir.path(), "AOV Image Sequence_Normal_001_0000.exr", w, h, &[("R", enc(0)), ("G", enc(1)), ("B", enc(2))]);
    let smooth: Vec<f32> = gb.roughness.as_ref().unwrap().iter().map(|r| 1.0 - r).collect();
    exr(dir.path(), "AOV Image Sequence_Smoothness_001_0000.exr", w, h, &[("R", smooth)]);
    write_side(dir.path(), &side);
    let l = gbuf::io::load(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(l.reading.as_ref().unwrap().preset.as_deref(), Some("unity-hdrp"));
    assert_same(&l.gbuffer, &gb, "unity");
}

#[test]
fn unreal_and_blender_file_output_laid_out_by_their_documentation() {
    let (gb, side) = small_scene();
    let (w, h) = (gb.width, gb.height);
    let nw = world_normals(&gb);
    let comp = |v: &[Vec3], c: usize| v.iter().map(|n| n[c]).collect::<Vec<f32>>();
    let sky = |far: f32| -> Vec<f32> {
        (0..gb.len()).map(|i| if gb.coverage[i] { gb.depth.as_ref().unwrap()[i] } else { far }).collect()
    };
    // Unreal: `<shot>_<Buffer>.exr`, SceneDepthWorldUnits planar depth (sky at a huge value), WorldNormal signed.
    let dir = tempfile::tempdir().unwrap();
    exr(
        dir.path(),
        "HighresScreenshot00000_SceneDepthWorldUnits.exr",
        w,
        h,
        &[("R", sky(6.5e4)), ("G", sky(6.5e4)), ("B", sky(6.5e4))],
    );
    exr(
        dir.path(),
        "HighresScreenshot00000_WorldNormal.exr",
        w,
        h,
        &[("R", comp(&nw, 0)), ("G", comp(&nw, 1)), ("B", comp(&nw, 2))],
    );
    write_side(dir.path(), &side);
    // 6.5e4 is below the automatic background threshold: the user says what marks the sky.
    let opts = LoadOptions {
        conventions: gbuf::io::conventions::Overrides {
            background: Some(gbuf::io::conventions::Background::Value(6.5e4)),
            ..Default::default()
        },
        ..Default::default()
    };
    let l = gbuf::io::load(dir.path(), &opts).unwrap();
    assert_eq!(l.reading.as_ref().unwrap().preset.as_deref(), Some("unreal"));
    assert_same(&l.gbuffer, &gb, "unreal");
    // The same buffers named the way a HighResShot with a frame number names them:
    // `HighResScreenshot_<Buffer>_00001.exr`.
    let named = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(dir.path()).unwrap() {
        let f = f.unwrap().path();
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        let name = match name.strip_prefix("HighresScreenshot00000_").and_then(|n| n.strip_suffix(".exr")) {
            Some(buffer) => format!("HighResScreenshot_{buffer}_00001.exr"),
            None => name,
        };
        std::fs::copy(&f, named.path().join(name)).unwrap();
    }
    let l = gbuf::io::load(named.path(), &opts).unwrap();
    assert_eq!(l.reading.as_ref().unwrap().preset.as_deref(), Some("unreal"));
    assert_same(&l.gbuffer, &gb, "unreal, frame-numbered names");

    // Blender File Output: `<slot><frame>.exr`, Depth = view-axis distance (1e10 for sky), world normals and
    // positions, IndexMA as float.
    let dir = tempfile::tempdir().unwrap();
    let inv = gb.camera.unwrap().world_to_view.inverse();
    let pw: Vec<Vec3> = gb.position.as_ref().unwrap().iter().map(|p| inv.transform_point3(*p)).collect();
    exr(dir.path(), "Depth0001.exr", w, h, &[("R", sky(1e10)), ("G", sky(1e10)), ("B", sky(1e10))]);
    exr(dir.path(), "Normal0001.exr", w, h, &[("R", comp(&nw, 0)), ("G", comp(&nw, 1)), ("B", comp(&nw, 2))]);
    exr(dir.path(), "Position0001.exr", w, h, &[("R", comp(&pw, 0)), ("G", comp(&pw, 1)), ("B", comp(&pw, 2))]);
    exr(dir.path(), "IndexMA0001.exr", w, h, &[("R", (0..gb.len()).map(|i| (i % 3) as f32).collect())]);
    write_side(dir.path(), &side);
    let l = gbuf::io::load(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(l.reading.as_ref().unwrap().preset.as_deref(), Some("blender-file-output"));
    assert_same(&l.gbuffer, &gb, "blender");
    let ids = l.gbuffer.material_id.as_ref().unwrap();
    assert!((0..gb.len()).filter(|&i| gb.coverage[i]).all(|i| ids[i] == (i % 3) as u32));
}

#[test]
fn errors_that_guide() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("notes.png"), b"not a png").unwrap();
    let o = gbuf(dir.path(), &["info", "."]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("not a recognised file set") && e.contains("notes.png") && e.contains("luxcore"), "{e}");
    assert!(!e.contains("Is a directory"), "{e}");
    let o = gbuf(dir.path(), &["info", lux().join("MATERIAL_ID.png").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("a PNG on its own is not a dump"), "{}", stderr(&o));
    let o = gbuf(dir.path(), &["edges", lux().to_str().unwrap(), "--detector", "all", "--mask", "m.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // A set whose files disagree in size names the file.
    for f in ["DEPTH.exr", "POSITION.exr"] {
        std::fs::copy(lux().join(f), dir.path().join(f)).unwrap();
    }
    exr(dir.path(), "ALBEDO.exr", 4, 4, &[("R", vec![0.0; 16]), ("G", vec![0.0; 16]), ("B", vec![0.0; 16])]);
    std::fs::remove_file(dir.path().join("notes.png")).unwrap();
    let err = gbuf::io::load(dir.path(), &LoadOptions::default()).unwrap_err().to_string();
    assert!(err.contains("ALBEDO.exr") && err.contains("4×4"), "{err}");
}

/// A LuxCore folder with the film outputs a user typically enables beside the six gbuf reads (AVG_SHADING_NORMAL,
/// RGB, RGBA, RGB_IMAGEPIPELINE, MATERIAL_ID_COLOR, UV, ALPHA, SAMPLECOUNT) loads with no flags, as the same
/// G-buffer: `AVG_SHADING_NORMAL` is its own buffer, not a second `SHADING_NORMAL` (a suffix match once made the
/// folder "not a recognised file set").
#[test]
fn a_luxcore_folder_with_every_film_output_loads_as_the_six_buffers() {
    let dir = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(lux()).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.path().join(f.file_name().unwrap())).unwrap();
    }
    for (from, to) in [
        ("SHADING_NORMAL.exr", "AVG_SHADING_NORMAL.exr"),
        ("RGB_IMAGEPIPELINE.png", "RGB.png"),
        ("RGB_IMAGEPIPELINE.png", "RGBA.png"),
        ("MATERIAL_ID.png", "MATERIAL_ID_COLOR.png"),
        ("ALBEDO.exr", "UV.exr"),
        ("DEPTH.exr", "ALPHA.exr"),
        ("DEPTH.exr", "SAMPLECOUNT.exr"),
    ] {
        std::fs::copy(lux().join(from), dir.path().join(to)).unwrap();
    }
    // The longer name is read as its own buffer: a different AVG_SHADING_NORMAL must not change the normals.
    std::fs::copy(lux().join("GEOMETRY_NORMAL.exr"), dir.path().join("AVG_SHADING_NORMAL.exr")).unwrap();
    let want = gbuf::io::load(&lux(), &LoadOptions::default()).unwrap().gbuffer;
    let got = gbuf::io::load(dir.path(), &LoadOptions::default()).unwrap();
    assert!(got.gbuffer == want, "the folder with every output loads as the fixture's six buffers");
    // The outputs it does not read are listed (in `gbuf info`), not silently dropped.
    let ignored = &got.reading.as_ref().unwrap().ignored;
    for f in ["AVG_SHADING_NORMAL.exr", "RGB.png", "UV.exr", "SAMPLECOUNT.exr", "GEOMETRY_NORMAL.exr"] {
        assert!(ignored.iter().any(|i| i == f), "{f} not in {ignored:?}");
    }
    assert!(!ignored.iter().any(|i| i == "DEPTH.exr" || i == "SHADING_NORMAL.exr"), "{ignored:?}");
}

/// A folder holding a sequence (`DEPTH_0001.exr`, `DEPTH_0002.exr`, … as renderers and Blender's File Output
/// write frames): one frame is read with `--frame N` (here frame 2 has other normals), without it a single-dump
/// command says which frames there are, `budget` reads every frame, and numbered buffers no preset reads
/// (`RADIANCE_GROUP_0`, `_1`) do not make a one-frame folder a sequence.
#[test]
fn a_sequence_folder_reads_frame_by_frame() {
    let dir = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(lux()).unwrap() {
        let f = f.unwrap().path();
        let name = f.file_name().unwrap().to_str().unwrap().to_string();
        match name.rsplit_once('.') {
            Some((stem, ext)) if ext == "exr" || ext == "png" => {
                std::fs::copy(&f, dir.path().join(format!("{stem}_0001.{ext}"))).unwrap();
                let second = if stem == "SHADING_NORMAL" { lux().join("GEOMETRY_NORMAL.exr") } else { f.clone() };
                std::fs::copy(&second, dir.path().join(format!("{stem}_0002.{ext}"))).unwrap();
            }
            _ => {
                std::fs::copy(&f, dir.path().join(&name)).unwrap();
            }
        }
    }
    assert_eq!(gbuf::io::fileset::frames_in(dir.path()).unwrap(), vec![1, 2]);
    assert!(gbuf::io::fileset::looks_like_file_set(dir.path()));
    let e = gbuf::io::load(dir.path(), &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("--frame") && e.contains("1, 2"), "{e}");
    let want = gbuf::io::load(&lux(), &LoadOptions::default()).unwrap().gbuffer;
    let one = gbuf::io::load(dir.path(), &LoadOptions { frame: Some(1), ..LoadOptions::default() }).unwrap().gbuffer;
    assert!(one == want, "frame 1 is the fixture");
    let two = gbuf::io::load(dir.path(), &LoadOptions { frame: Some(2), ..LoadOptions::default() }).unwrap().gbuffer;
    assert!(two.normal != want.normal && two.depth == want.depth, "frame 2 has its own normals");
    let e = gbuf::io::load(dir.path(), &LoadOptions { frame: Some(7), ..LoadOptions::default() }).unwrap_err();
    assert!(e.to_string().contains("--frame 7"), "{e}");
    let o = gbuf(dir.path(), &["budget", dir.path().to_str().unwrap(), "--max-bytes", "12", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["frame_names"].as_array().map(Vec::len), Some(2), "{}", j["frame_names"]);
    let o = gbuf(dir.path(), &["info", dir.path().to_str().unwrap(), "--frame", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // One frame with numbered outputs beside it is not a sequence.
    let one_frame = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(lux()).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, one_frame.path().join(f.file_name().unwrap())).unwrap();
    }
    for k in 0..2 {
        std::fs::copy(lux().join("DEPTH.exr"), one_frame.path().join(format!("RADIANCE_GROUP_{k}.exr"))).unwrap();
    }
    assert!(gbuf::io::fileset::frames_in(one_frame.path()).unwrap().is_empty());
    assert!(gbuf::io::load(one_frame.path(), &LoadOptions::default()).unwrap().gbuffer == want);
}
