//! `gbuf resolve` run as a binary in a fresh temporary directory.

use std::path::Path;
use std::process::{Command, Output};

fn gbuf(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gbuf")).current_dir(dir).args(args).output().expect("run gbuf")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn missing_file_is_exit_1_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let o = gbuf(dir.path(), &["resolve", "nope.exr", "--lights", "4"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("nope.exr"), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
}

#[test]
fn unknown_choices_are_usage_errors_listing_the_known_ones() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, value, known) in [
        ("--culling", "octree", "clustered"),
        ("--brdf", "phong", "blinn-phong"),
        ("--falloff", "cubic", "gltf"),
        ("--schedule", "forward", "light-prepass"),
        ("--ldr", "gamma2.4", "gamma2.2"),
        ("--detector", "magic", "lauritzen"),
    ] {
        let o = gbuf(dir.path(), &["resolve", "x.exr", flag, value]);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {}", stderr(&o));
        assert!(stderr(&o).contains(known), "{flag} {value}: {}", stderr(&o));
    }
}

#[test]
fn inconsistent_flags_are_refused_before_loading() {
    let dir = tempfile::tempdir().unwrap();
    let o = gbuf(dir.path(), &["resolve", "x.exr", "--ldr", "gamma2.2"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--png"), "{}", stderr(&o));
    let o = gbuf(dir.path(), &["resolve", "x.exr", "--tile-size", "0"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("tile size"), "{}", stderr(&o));
}

#[test]
fn resolves_a_canonical_dump_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let gb = gbuf::scene::render(gbuf::scene::SceneName::Room, 48, 32, 4).unwrap();
    gbuf::io::canonical::write(&dir.path().join("room.exr"), &gb).unwrap();
    let o = gbuf(
        dir.path(),
        &[
            "resolve",
            "room.exr",
            "--lights",
            "24",
            "--seed",
            "3",
            "-o",
            "lit.exr",
            "--png",
            "lit.png",
            "--heatmap",
            "heat.png",
            "--json",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["shading_fraction", "edge_fraction", "light_pairs_tested", "light_pairs_lit", "rmse", "psnr_db"] {
        assert!(v[key].is_number(), "{key} missing in {v}");
    }
    for key in ["max_abs", "rel_mse"] {
        assert!(v[key].is_number(), "{key} missing in {v}");
    }
    for key in ["decode", "detect", "cull", "shade", "total"] {
        assert!(v["ms"][key].is_number(), "ms.{key} missing in {v}");
    }
    let sf = v["shading_fraction"].as_f64().unwrap();
    assert!(sf > 0.0 && sf <= 1.0, "{sf}");
    // Same scene, every sample shaded against the f64 reference: tiny error.
    assert!(v["rel_mse"].as_f64().unwrap() < 0.05, "{v}");
    for f in ["lit.exr", "lit.png", "heat.png"] {
        assert!(dir.path().join(f).metadata().unwrap().len() > 0, "{f} not written");
    }
    // The demo's LDR encoding and a layout round trip.
    let o = gbuf(
        dir.path(),
        &["resolve", "room.exr", "--lights", "8", "--png", "ldr.png", "--ldr", "gamma2.2", "--detector", "ssaa"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("error vs reference"));
    let o = gbuf(dir.path(), &["resolve", "room.exr", "--lights", "8", "--scene", "missing.json"]);
    assert_eq!(o.status.code(), Some(1));
    let o = gbuf(dir.path(), &["resolve", "room.exr"]);
    assert_eq!(o.status.code(), Some(1), "no lights must be an error: {}", stderr(&o));
    assert!(stderr(&o).contains("--lights"), "{}", stderr(&o));
}
