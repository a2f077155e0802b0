//! `gbuf scene` through the built binary, in a fresh temporary directory.
mod support;

use support::{gbuf, stderr};

use gbuf::io::canonical;
use gbuf::io::sidecar::Sidecar;
use gbuf::io::LoadOptions;
use gbuf::scene::{default_lights, render, scatter_lights, SceneName};
use std::path::Path;

#[test]
fn writes_a_canonical_exr_and_sidecar_that_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let out =
        gbuf(dir.path(), &["scene", "room", "-o", "r.exr", "--width", "48", "--height", "27", "--msaa", "4", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["width"], 48);
    assert_eq!(summary["samples"], 4);
    assert_eq!(summary["lights_source"], "default");
    let frac = summary["covered_fraction"].as_f64().unwrap();
    assert!(frac > 0.3 && frac < 0.95, "{frac}");

    let expect = render(SceneName::Room, 48, 27, 4).unwrap();
    let got = canonical::read(&dir.path().join("r.exr"), &LoadOptions::default()).unwrap();
    assert!(got == expect, "the EXR does not read back as the rendered G-buffer");

    let side = Sidecar::load(&dir.path().join("r.json")).unwrap();
    assert_eq!(side.lights_space.as_deref(), Some("view"));
    assert_eq!(side.camera.as_ref().unwrap().to_camera(), expect.camera.unwrap());
    let lights = side.view_lights(None, Path::new("r.json")).unwrap();
    assert_eq!(lights, default_lights(SceneName::Room, &expect));
    // Only the two outputs: no temporary files left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn scattered_lights_follow_lights_and_seed() {
    let dir = tempfile::tempdir().unwrap();
    let out = gbuf(
        dir.path(),
        &[
            "scene", "stress", "-o", "s.exr", "--width", "40", "--height", "30", "--msaa", "1", "--lights", "37",
            "--seed", "9",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("37 (scattered"), "{text}");
    let gb = render(SceneName::Stress, 40, 30, 1).unwrap();
    let lights = Sidecar::load(&dir.path().join("s.json")).unwrap().view_lights(None, Path::new("s.json")).unwrap();
    assert_eq!(lights, scatter_lights(&gb, 37, 9));
}

#[test]
fn bad_arguments_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    // Usage errors: exit 2 from clap, with the problem named.
    for (args, needle) in [
        (&["scene", "kitchen", "-o", "a.exr"][..], "unknown scene"),
        (&["scene", "room", "-o", "a.exr", "--msaa", "3"][..], "samples per pixel"),
        (&["scene", "room", "-o", "a.exr", "--width", "0"][..], "width"),
        (&["scene", "room"][..], "--out"),
    ] {
        let o = gbuf(dir.path(), args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    // Bad input: exit 1 with a message naming the path.
    for (args, needle) in [
        (&["scene", "room", "-o", "a.json", "--width", "8", "--height", "8"][..], "a.json"),
        (&["scene", "room", "-o", "sub", "--width", "8", "--height", "8"][..], "directory"),
        (&["scene", "room", "-o", "missing/dir/a.exr", "--width", "8", "--height", "8"][..], "missing/dir/a.exr"),
        (&["scene", "room", "-o", "a.exr", "--width", "16384", "--height", "16384", "--msaa", "16"][..], "limit"),
        (&["scene", "room", "-o", "a.exr", "--width", "8", "--height", "8", "--lights", "99999999"][..], "at most"),
    ] {
        let o = gbuf(dir.path(), args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{args:?}: {}", stderr(&o));
    }
    // Nothing was written by the failed runs.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, vec![std::ffi::OsString::from("sub")]);
}
