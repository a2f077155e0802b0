//! A command with two or more outputs writes all of them or none: its output folders are checked before the
//! work, every file is staged beside its destination, and they are renamed into place only when all were
//! written. Each test makes the last output fail and checks that the earlier ones are not left under their
//! final names (nor any temporary file).

mod support;

use std::path::Path;
use support::{gbuf, stderr};

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name).display().to_string()
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn resolve_writes_its_image_png_and_heatmap_all_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let room = fixture("room_1x.exr");
    // The last output's folder is missing: refused before the work, nothing written.
    let o = gbuf(dir.path(), &["resolve", &room, "--no-reference", "-o", "a.exr", "--png", "missing/x.png"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing") && !stderr(&o).contains("lighting:"), "{}", stderr(&o));
    assert!(listing(dir.path()).is_empty(), "{:?}", listing(dir.path()));
    // The last output cannot be written (its path is a folder): the two before it are not left either.
    std::fs::create_dir(dir.path().join("heat.png")).unwrap();
    let o = gbuf(
        dir.path(),
        &["resolve", &room, "--no-reference", "-o", "a.exr", "--png", "p.png", "--heatmap", "heat.png"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("heat.png"), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), ["heat.png"]);
    // With every path writable, all three appear.
    std::fs::remove_dir(dir.path().join("heat.png")).unwrap();
    let o = gbuf(
        dir.path(),
        &["resolve", &room, "--no-reference", "-o", "a.exr", "--png", "p.png", "--heatmap", "heat.png"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), ["a.exr", "heat.png", "p.png"]);
}

#[test]
fn pipelines_writes_its_crops_and_heatmap_all_or_none() {
    let dir = tempfile::tempdir().unwrap();
    // No primitive IDs: the heatmap cannot be made, found before the work, and the crops are not written.
    let blender = fixture("blender_gbuffer.exr");
    let o = gbuf(dir.path(), &["pipelines", &blender, "--aa-crops", "crops.png", "--heatmap", "heat.png"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("primitive IDs"), "{}", stderr(&o));
    assert!(listing(dir.path()).is_empty(), "{:?}", listing(dir.path()));
    // The heatmap's path is a folder: the crops picture is not left alone.
    let raster = fixture("raster_4x.exr");
    std::fs::create_dir(dir.path().join("heat.png")).unwrap();
    let o = gbuf(dir.path(), &["pipelines", &raster, "--aa-crops", "crops.png", "--heatmap", "heat.png"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), ["heat.png"]);
}

#[test]
fn budget_writes_its_layout_and_shader_code_all_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let room = fixture("room_1x.exr");
    std::fs::create_dir(dir.path().join("best.hlsl")).unwrap();
    let o = gbuf(dir.path(), &["budget", &room, "--max-bytes", "12", "-o", "best.toml", "--emit", "hlsl"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), ["best.hlsl"]);
    std::fs::remove_dir(dir.path().join("best.hlsl")).unwrap();
    let o = gbuf(dir.path(), &["budget", &room, "--max-bytes", "12", "-o", "best.toml", "--emit", "hlsl"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), ["best.hlsl", "best.toml"]);
}
