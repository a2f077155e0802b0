//! `gbuf info` through the built binary, in a fresh temporary directory.

mod support;

use support::{gbuf, stderr};

use std::process::Output;
use support::*;

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "gbuf failed: {}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

#[test]
fn json_has_the_documented_fields_and_matches_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let gb = plausible(8, 6, 4, 11);
    std::fs::write(dir.path().join("d.exr"), canonical_bytes(&gb)).unwrap();
    let v = json(&gbuf(dir.path(), &["info", "d.exr", "--json"]));
    assert_eq!((v["width"].as_u64(), v["height"].as_u64(), v["samples"].as_u64()), (Some(8), Some(6), Some(4)));
    assert_eq!(v["sample_positions"].as_array().unwrap().len(), 4);
    assert_eq!(v["sample_positions"][0][0].as_f64(), Some(-2.0 / 16.0));
    assert_eq!(v["background_samples"].as_u64(), Some(gb.background_samples() as u64));
    assert_eq!(v["camera"]["source"], "file");
    assert!(v["camera"]["yfov"].as_f64().unwrap() > 0.0);
    assert_eq!(v["compression"]["lossy"], false);
    let depth = &v["attributes"]["depth"];
    assert_eq!(depth["channels"][0], "s*.depth.Z");
    let d = gb.depth.as_ref().unwrap();
    let covered: Vec<f32> = d.iter().zip(&gb.coverage).filter(|(_, c)| **c).map(|(v, _)| *v).collect();
    let min = covered.iter().copied().fold(f32::INFINITY, f32::min);
    assert_eq!(depth["min"].as_f64(), Some(f64::from(min)));
    assert_eq!(depth["nan"].as_u64(), Some(0));
    assert_eq!(v["attributes"]["normal"]["max"].as_array().unwrap().len(), 3);
    for name in ["depth", "position", "normal", "albedo", "roughness", "material_id"] {
        assert!(v["attributes"][name].is_object(), "{name} missing");
    }
}

#[test]
fn fold_flag_and_text_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ss.exr"), canonical_bytes(&plausible(8, 4, 1, 12))).unwrap();
    let v = json(&gbuf(dir.path(), &["info", "ss.exr", "--fold", "2", "--json"]));
    assert_eq!((v["width"].as_u64(), v["samples"].as_u64()), (Some(4), Some(4)));
    let o = gbuf(dir.path(), &["info", "ss.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("8×4 pixels, 1 samples per pixel") && text.contains("lossless"), "{text}");
}

#[test]
fn nan_and_inf_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut gb = plausible(4, 4, 1, 13);
    gb.albedo.as_mut().unwrap()[2].x = f32::NAN;
    gb.albedo.as_mut().unwrap()[3].y = f32::INFINITY;
    std::fs::write(dir.path().join("n.exr"), canonical_bytes(&gb)).unwrap();
    let v = json(&gbuf(dir.path(), &["info", "n.exr", "--json"]));
    assert_eq!(
        (v["attributes"]["albedo"]["nan"].as_u64(), v["attributes"]["albedo"]["inf"].as_u64()),
        (Some(1), Some(1))
    );
    let text = String::from_utf8(gbuf(dir.path(), &["info", "n.exr"]).stdout).unwrap();
    assert!(text.contains("1 NaN and 1 ±Inf"), "{text}");
}

/// Every bad input exits with 1 and names the offending file.
#[test]
fn bad_inputs_exit_1_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = canonical_bytes(&plausible(8, 8, 1, 14));
    std::fs::write(d.join("trunc.exr"), &good[..good.len() / 2]).unwrap();
    std::fs::write(d.join("garbage.exr"), b"\x76\x2f\x31\x01garbage garbage garbage").unwrap();
    std::fs::write(d.join("eng.exr"), generic_exr(2, 2, &["Z", "N.X"], |_, _| 1.0)).unwrap();
    std::fs::write(d.join("ok.exr"), &good).unwrap();
    std::fs::write(d.join("bad.json"), b"{ not json").unwrap();
    std::fs::write(d.join("wrong.json"), br#"{"supersample": 3}"#).unwrap();
    let cases: &[(&[&str], &str, &str)] = &[
        (&["info", "trunc.exr"], "trunc.exr", ""),
        (&["info", "garbage.exr"], "garbage.exr", ""),
        (&["info", "absent.exr"], "absent.exr", ""),
        (&["info", "eng.exr"], "eng.exr", "--map"),
        (&["info", "eng.exr", "--map", "depth=nope"], "eng.exr", "N.X, Z"),
        (&["info", "ok.exr", "--scene", "bad.json"], "bad.json", "sidecar JSON"),
        (&["info", "ok.exr", "--scene", "wrong.json"], "wrong.json", "multiple of 3"),
        (&["info", "ok.exr", "--fold", "3"], "ok.exr", "multiple of 3"),
    ];
    for (args, file, hint) in cases {
        let o = gbuf(d, args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(e.contains(file) && e.contains(hint), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{args:?}: {e}");
    }
    // Usage errors are 2 (clap).
    assert_eq!(gbuf(d, &["info"]).status.code(), Some(2));
}

#[test]
fn map_flag_reads_unknown_naming() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = generic_exr(3, 2, &["N.X", "N.Y", "N.Z", "Z", "mat"], |c, i| match c {
        3 => 1.0 + i as f32,
        4 => 7.0,
        2 => 1.0,
        _ => 0.0,
    });
    std::fs::write(dir.path().join("e.exr"), bytes).unwrap();
    let v =
        json(&gbuf(dir.path(), &["info", "e.exr", "--map", "depth=Z,normal=N.X;N.Y;N.Z,material-id=mat", "--json"]));
    assert_eq!(v["format"], "mapped");
    assert_eq!(v["attributes"]["depth"]["max"].as_f64(), Some(6.0));
    assert_eq!(v["attributes"]["material_id"]["mean"].as_f64(), Some(7.0));
    assert_eq!(v["attributes"]["normal"]["channels"][2], "N.Z");
}

/// Surfaces per pixel by identity on the llvmpipe capture equal a count made here from its per-sample object and
/// primitive IDs (issue 36's first check), in `gbuf info --json`.
#[test]
fn surfaces_per_pixel_by_identity_match_the_captures_own_ids() {
    let dir = tempfile::tempdir().unwrap();
    let dump = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    let o = support::gbuf(dir.path(), &["info", dump.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let got: Vec<u64> = v["surfaces_per_pixel"]["by_identity"]
        .as_array()
        .expect("by_identity")
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    assert_eq!(v["surfaces_per_pixel"]["identity_key"], "object+primitive");
    let gb = gbuf::io::load(&dump, &gbuf::io::LoadOptions::default()).unwrap().gbuffer;
    let (obj, prim) = (gb.object_id.as_ref().unwrap(), gb.primitive_id.as_ref().unwrap());
    let mut want = vec![0u64; gb.samples as usize + 1];
    for y in 0..gb.height {
        for x in 0..gb.width {
            let ids: std::collections::BTreeSet<(u32, u32)> = (0..gb.samples)
                .map(|s| gb.index(x, y, s))
                .filter(|&i| gb.coverage[i])
                .map(|i| (obj[i], prim[i]))
                .collect();
            want[ids.len()] += 1;
        }
    }
    assert_eq!(got, want);
    assert!(want[2] + want[3] + want[4] > 0, "the capture has pixels with several surfaces");
}

/// `gbuf edges --json` and the report carry the same histograms as `gbuf info`, and the report draws the heatmap.
#[test]
fn edges_and_the_report_give_the_same_surfaces_per_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let dump = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    let dump = dump.to_str().unwrap();
    let info = json(&support::gbuf(dir.path(), &["info", dump, "--json"]))["surfaces_per_pixel"].clone();
    assert!(info["by_geometry"].is_array() && info["by_identity"].is_array(), "{info}");
    let edges = json(&support::gbuf(dir.path(), &["edges", dump, "--json"]))["surfaces_per_pixel"].clone();
    assert_eq!(edges, info);
    let o = support::gbuf(
        dir.path(),
        &["report", dump, "--candidates", "minimal-8", "--detectors", "lauritzen", "--flip", "none", "-o", "rep", "-q"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("rep/report.json")).unwrap()).unwrap();
    assert_eq!(report["frames"][0]["surfaces_per_pixel"], info);
    let png = std::fs::read(dir.path().join("rep/surfaces_per_pixel.png")).expect("the heatmap");
    assert!(png.starts_with(b"\x89PNG") && png.len() > 1000);
    let md = std::fs::read_to_string(dir.path().join("rep/report.md")).unwrap();
    assert!(md.contains("surfaces/pixel (object+primitive) 1: 82.76%"), "{md}");
}
