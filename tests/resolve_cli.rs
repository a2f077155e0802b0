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
