//! Packed folders that cannot hurt: a material table whose rows are short, whose parameters name an attribute the
//! layout does not keep in its table (or none, or one twice), and sidecar sample positions outside the pixel are
//! each a clear error naming the file and the field (exit 1), never a panic, an internal error or a value written
//! into another attribute's plane.

mod support;

use std::path::Path;
use support::{gbuf, stderr};

/// A `gbuf pack` folder of the llvmpipe fixture with `destiny-96` (a material table), in `dir/p`.
fn packed(dir: &Path) -> std::path::PathBuf {
    let dump = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    let o = gbuf(dir, &["pack", dump.to_str().unwrap(), "--layout", "destiny-96", "-o", "p"]);
    assert!(o.status.success(), "{}", stderr(&o));
    dir.join("p")
}

fn edit_json(path: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(path, serde_json::to_vec(&v).unwrap()).unwrap();
}

/// Runs `gbuf info` on the folder and returns its exit code and stderr.
fn info(dir: &Path) -> (Option<i32>, String) {
    let o = gbuf(dir, &["info", "p"]);
    (o.status.code(), stderr(&o))
}

#[test]
fn material_table_rows_and_parameters_are_checked_against_the_layout() {
    let dir = tempfile::tempdir().unwrap();
    let p = packed(dir.path());
    let table = p.join("material_table.json");
    let original = std::fs::read(&table).unwrap();
    assert_eq!(info(dir.path()).0, Some(0), "the folder as packed loads");
    type Spoil = fn(&mut serde_json::Value);
    let cases: [(Spoil, &str); 5] = [
        (|v| v["entries"][0].as_array_mut().unwrap().truncate(1), "do not hold one value per parameter"),
        (|v| v["parameters"][0] = "depth".into(), "\"depth\" is not one of the layout's table parameters"),
        (|v| v["parameters"][0] = "normal".into(), "\"normal\" is not one of the layout's table parameters"),
        (|v| v["parameters"][0] = "gloss".into(), "\"gloss\" is not one of the layout's table parameters"),
        (
            |v| {
                let first = v["parameters"][0].clone();
                v["parameters"][1] = first;
            },
            "listed twice",
        ),
    ];
    for (spoil, want) in cases {
        std::fs::write(&table, &original).unwrap();
        edit_json(&table, spoil);
        let (code, err) = info(dir.path());
        assert_eq!(code, Some(1), "{want}: {err}");
        assert!(err.contains("material_table.json") && err.contains(want), "{want}: {err}");
        assert!(!err.contains("panicked") && !err.contains("internal error"), "{err}");
    }
}

#[test]
fn sidecar_sample_positions_outside_the_pixel_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = packed(dir.path());
    for bad in [1e30_f64, -0.75, 0.51] {
        edit_json(&p.join("scene.json"), |v| v["sample_positions"][2] = serde_json::json!([bad, 0.0]));
        let (code, err) = info(dir.path());
        assert_eq!(code, Some(1), "{bad}: {err}");
        assert!(err.contains("scene.json") && err.contains("sample_positions") && err.contains("outside"), "{err}");
    }
    edit_json(&p.join("scene.json"), |v| v["sample_positions"][2] = serde_json::json!([0.5, -0.5]));
    assert_eq!(info(dir.path()).0, Some(0), "the pixel's edge is inside it");
}

#[test]
fn a_folder_of_dds_targets_without_its_layout_says_which_flag_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let engine = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/engine_4x");
    let dds = dir.path().join("capture");
    std::fs::create_dir(&dds).unwrap();
    for t in ["depth", "gbuffer_a", "gbuffer_b", "gbuffer_c"] {
        std::fs::copy(engine.join(format!("{t}.dds")), dds.join(format!("{t}.dds"))).unwrap();
    }
    let o = gbuf(dir.path(), &["info", "capture"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--input-layout") && stderr(&o).contains("4 DDS"), "{}", stderr(&o));
    // With the layout named, the same folder loads.
    let toml = engine.join("engine.toml");
    let o = gbuf(dir.path(), &["info", "capture", "--input-layout", toml.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn max_memory_bounds_the_decoded_frame_not_only_the_files() {
    let dir = tempfile::tempdir().unwrap();
    packed(dir.path());
    // Every target file is under 2 MiB; the decoded frame (f32 planes, derived position, coverage) is not.
    let o = gbuf(dir.path(), &["info", "p", "--max-memory", "2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("decoded frame") && err.contains("--max-memory"), "{err}");
    assert!(gbuf(dir.path(), &["info", "p", "--max-memory", "64"]).status.success());
}
