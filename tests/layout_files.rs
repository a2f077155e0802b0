//! User layouts from TOML/JSON files: the shipped examples load, save/load round-trips, and broken files are
//! refused with errors that name the file and the problem.

use gbuf::layout::{Layout, LayoutSpec};
use std::path::{Path, PathBuf};

fn examples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/layouts");
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    v.sort();
    v
}

#[test]
fn shipped_example_layouts_load() {
    let files = examples();
    assert!(files.len() >= 2);
    for f in files {
        let l = Layout::load(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        assert!(l.bytes_per_sample() > 0);
    }
    let thin = Layout::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/layouts/thin-12.toml")).unwrap();
    assert_eq!(thin.bytes_per_sample(), 12);
    assert_eq!(thin.spec().depth_range, Some([0.1, 500.0]));
}

#[test]
fn every_builtin_saves_and_loads_in_both_syntaxes() {
    let dir = tempfile::tempdir().unwrap();
    for l in Layout::builtins() {
        for ext in ["toml", "json"] {
            let p = dir.path().join(format!("{}.{ext}", l.name()));
            l.save(&p).unwrap();
            let back = Layout::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert_eq!(back, l, "{}", p.display());
        }
    }
    // Content sniffing: JSON without the extension.
    let p = dir.path().join("noext");
    std::fs::write(&p, Layout::by_name("fat-20").unwrap().spec().to_text(gbuf::layout::SpecSyntax::Json).unwrap())
        .unwrap();
    assert_eq!(Layout::load(&p).unwrap().name(), "fat-20");
}

const BASE: &str = r#"
name = "user"
[[targets]]
name = "rt0"
format = "rgba8"
fields = [
  { attribute = "normal", codec = "oct-16", offset = 0, bits = 16 },
  { attribute = "roughness", codec = "unorm-8", offset = 16, bits = 8 },
]
"#;

/// Writes `text` to a fresh file and loads it, returning the error message.
fn load_err(name: &str, text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    let err = Layout::load(&p).expect_err("must be refused").to_string();
    assert!(err.contains(name), "error does not name the file: {err}");
    err
}

#[test]
fn the_base_layout_is_valid() {
    let spec = LayoutSpec::parse(Path::new("x.toml"), BASE).unwrap();
    assert_eq!(Layout::from_spec(spec).unwrap().bytes_per_sample(), 4);
}

#[test]
fn overlapping_fields_are_refused() {
    let text = BASE.replace("offset = 16, bits = 8", "offset = 12, bits = 8");
    let e = load_err("overlap.toml", &text);
    assert!(e.contains("overlap") && e.contains("roughness") && e.contains("normal"), "{e}");
}

#[test]
fn fields_past_the_end_of_the_texel_are_refused() {
    let text = BASE.replace("offset = 16, bits = 8", "offset = 28, bits = 8");
    let e = load_err("wide.toml", &text);
    assert!(e.contains("past the end") && e.contains("32-bit"), "{e}");
}

#[test]
fn fields_not_matching_the_codec_width_are_refused() {
    let e = load_err("codec.toml", &BASE.replace("offset = 16, bits = 8", "offset = 16, bits = 12"));
    assert!(e.contains("wider than codec unorm-8"), "{e}");
    let e = load_err("codec2.toml", &BASE.replace("offset = 16, bits = 8", "offset = 16, bits = 4"));
    assert!(e.contains("narrower than codec unorm-8"), "{e}");
}

#[test]
fn unknown_formats_codecs_and_attributes_are_refused() {
    let e = load_err("fmt.toml", &BASE.replace("\"rgba8\"", "\"rgba7\""));
    assert!(e.contains("unknown format \"rgba7\"") && e.contains("r11g11b10f"), "{e}");
    let e = load_err("codec.toml", &BASE.replace("oct-16", "oct-17"));
    assert!(e.contains("oct-17"), "{e}");
    let e = load_err("attr.toml", &BASE.replace("\"roughness\"", "\"roughnes\""));
    assert!(e.contains("unknown attribute \"roughnes\""), "{e}");
}

#[test]
fn inconsistent_layouts_are_refused() {
    let twice = BASE.replace("\"roughness\", codec = \"unorm-8\"", "\"normal\", codec = \"unorm-8\"");
    assert!(load_err("twice.toml", &twice).contains("normal"));
    // (TOML tables must precede the [[targets]] array, so the constant goes right after the name.)
    let both = BASE.replace("name = \"user\"\n", "name = \"user\"\n[constants]\nroughness = 0.5\n");
    assert!(load_err("const.toml", &both).contains("cannot also be a constant"));
    let no_table = BASE.replace("\"roughness\", codec = \"unorm-8\"", "\"material_index\", codec = \"\"");
    assert!(load_err("index.toml", &no_table).contains("material_indirection"));
    let no_targets = "name = \"x\"\ntargets = []\n";
    assert!(load_err("empty.toml", no_targets).contains("no targets"));
    let many: String = (0..17).map(|i| format!("[[targets]]\nname = \"t{i}\"\nformat = \"rgba32ui\"\n")).collect();
    assert!(load_err("many.toml", &format!("name = \"m\"\n{many}")).contains("at most 16"));
}

#[test]
fn garbage_is_an_error_not_a_panic() {
    load_err("bin.toml", "\u{0}\u{1}\u{2}garbage[[[");
    load_err("trunc.json", "{\"name\": \"x\", \"targets\": [");
    load_err("types.json", "{\"name\": 3, \"targets\": []}");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("latin1.toml");
    std::fs::write(&p, [0xffu8, 0xfe, 0x41]).unwrap();
    assert!(Layout::load(&p).unwrap_err().to_string().contains("UTF-8"));
    assert!(Layout::load(&dir.path().join("missing.toml")).unwrap_err().to_string().contains("missing.toml"));
    let e = Layout::by_name_or_path("no-such-layout").unwrap_err().to_string();
    assert!(e.contains("fat-20") && e.contains("no-such-layout"), "{e}");
}
