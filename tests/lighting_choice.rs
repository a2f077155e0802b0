//! The lighting model follows the data and is named everywhere: a frame with roughness or metallic is ranked under
//! GGX, one without under Blinn-Phong, `--brdf` overrides, and every command that lights says which and why. On a
//! real Blender scene with textured roughness (fixtures/blender_pbr.exr), the budget under GGX keeps roughness at
//! 8 bits or more (or in a material table) and beats `destiny-96`, which Blinn-Phong cannot tell from
//! `unreal-like`.
//!
//! Also the sidecar rules: a JSON beside a dump that is not a gbuf sidecar never blocks loading (one warning that
//! names the file, why and the flags), `--no-scene` looks for none, and a gbuf sidecar with several errors
//! reports all of them at once. And albedo above 1 is the data's error, said apart from the layouts' rows.

mod support;

use gbuf::io::{load, LoadOptions, SIDECAR_IGNORED};
use serde_json::Value;
use std::path::{Path, PathBuf};
use support::{gbuf, stderr};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

fn json_of(out: &std::process::Output) -> Value {
    assert!(out.status.success(), "gbuf failed: {}", stderr(out));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn budget_under_ggx_keeps_roughness_and_beats_destiny_on_a_textured_pbr_scene() {
    let dir = tempfile::tempdir().unwrap();
    let pbr = fixture("blender_pbr.exr");
    let out = gbuf(dir.path(), &["budget", pbr.to_str().unwrap(), "--max-bytes", "12", "-o", "best.toml", "--json"]);
    let j = json_of(&out);
    assert_eq!(j["lighting"]["brdf"], "ggx", "{}", j["lighting"]);
    assert!(j["lighting"]["why"].as_str().unwrap().contains("roughness"), "{}", j["lighting"]);
    assert!(stderr(&out).contains("lighting: BRDF ggx"), "{}", stderr(&out));
    // The winner stores roughness at 8 bits or more, or through a material table.
    let layout = std::fs::read_to_string(dir.path().join("best.toml")).unwrap();
    let spec: toml::Value = toml::from_str(&layout).unwrap();
    let summary = j["winner"]["summary"].as_str().unwrap();
    let roughness_bits = summary
        .split([',', '[', ']'])
        .filter_map(|f| f.trim().strip_prefix("roughness unorm-"))
        .filter_map(|b| b.parse::<u32>().ok())
        .max();
    let in_table = spec.get("material_table").is_some() || summary.contains("material_index");
    assert!(roughness_bits.is_some_and(|b| b >= 8) || in_table, "roughness kept too coarsely: {summary}");
    // And it beats destiny-96 measured the same way.
    let measured = j["measured"].as_array().unwrap();
    let rmse = |name: &str| measured.iter().find(|c| c["name"] == name).and_then(|c| c["rmse"].as_f64());
    let winner = j["winner"]["rmse"].as_f64().unwrap();
    let destiny = rmse("destiny-96").expect("destiny-96 measured (it fits 12 B)");
    assert!(winner < destiny, "winner {winner} does not beat destiny-96 {destiny}");
}

/// Layout RMSE per layout of `gbuf report --json`.
fn layout_rmse(rep: &Value) -> std::collections::BTreeMap<String, f64> {
    rep["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r["layout"].as_str().unwrap().to_string(), r["layout_error"]["rmse"].as_f64().unwrap()))
        .collect()
}

#[test]
fn report_ranks_under_the_data_s_brdf_names_it_and_brdf_overrides_it() {
    let dir = tempfile::tempdir().unwrap();
    let pbr = fixture("blender_pbr.exr");
    let p = pbr.to_str().unwrap();
    let base = ["report", p, "--candidates", "destiny-96,unreal-like", "--detectors", "lauritzen", "--flip", "none"];
    let mut auto: Vec<&str> = base.to_vec();
    auto.extend(["-o", "auto", "--json"]);
    let ggx = json_of(&gbuf(dir.path(), &auto));
    assert_eq!(ggx["lighting"]["brdf"], "ggx");
    let md = std::fs::read_to_string(dir.path().join("auto/report.md")).unwrap();
    assert!(md.contains("**Lighting:**") && md.contains("**ggx** BRDF"), "report.md does not name the BRDF");
    let html = std::fs::read_to_string(dir.path().join("auto/report.html")).unwrap();
    assert!(html.contains("ggx"), "report.html does not name the BRDF");

    let mut bp: Vec<&str> = base.to_vec();
    bp.extend(["-o", "bp", "--json", "--brdf", "blinn-phong"]);
    let phong = json_of(&gbuf(dir.path(), &bp));
    assert_eq!(phong["lighting"]["brdf"], "blinn-phong");
    assert_eq!(phong["lighting"]["why"], "--brdf");
    // Under Blinn-Phong (which reads no roughness) destiny-96's 4-bit roughness costs little; under GGX it is the
    // larger error by far.
    let (g, b) = (layout_rmse(&ggx), layout_rmse(&phong));
    let ratio = |m: &std::collections::BTreeMap<String, f64>| m["destiny-96"] / m["unreal-like"];
    assert!(ratio(&g) > 3.0, "GGX: destiny-96 / unreal-like = {}", ratio(&g));
    assert!(ratio(&b) < 1.5, "Blinn-Phong: destiny-96 / unreal-like = {}", ratio(&b));

    // Reports lit differently do not merge.
    let merged = gbuf(dir.path(), &["merge", "auto/report.json", "bp/report.json", "-o", "merged"]);
    assert!(!merged.status.success());
    assert!(stderr(&merged).contains("different lighting models"), "{}", stderr(&merged));
}

#[test]
fn a_frame_without_roughness_is_lit_with_blinn_phong_and_resolve_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let bin = fixture("ispc_deferred.bin");
    let out = gbuf(dir.path(), &["resolve", bin.to_str().unwrap(), "--no-reference", "--json"]);
    let j = json_of(&out);
    assert_eq!(j["lighting"]["brdf"], "blinn-phong", "{}", j["lighting"]);
    assert_eq!(j["config"]["brdf"], "blinn-phong");
    assert!(stderr(&out).contains("lighting: BRDF blinn-phong"), "{}", stderr(&out));
    let out = gbuf(dir.path(), &["resolve", bin.to_str().unwrap(), "--no-reference", "--json", "--brdf", "ggx"]);
    assert_eq!(json_of(&out)["config"]["brdf"], "ggx");
}

/// A copy of the Blender fixture in `dir` with `json` beside it as `<stem>.json`.
fn dump_with_json(dir: &Path, json: &str) -> PathBuf {
    let p = dir.join("frame.exr");
    std::fs::copy(fixture("blender_gbuffer.exr"), &p).unwrap();
    std::fs::write(dir.join("frame.json"), json).unwrap();
    p
}

#[test]
fn a_renderer_s_own_json_beside_the_dump_is_ignored_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    for json in [
        r#"{"frame": 12, "resolution": [128, 96], "camera": {"lens": 50}}"#,
        r#"{"render_time": 3.5, "samples": 64}"#,
        "[1, 2, 3]",
        "not json at all",
    ] {
        let p = dump_with_json(dir.path(), json);
        let l = load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{json}: {e}"));
        let ignored: Vec<_> = l.warnings.iter().filter(|w| w.code == SIDECAR_IGNORED).collect();
        assert_eq!(ignored.len(), 1, "{json}");
        let m = &ignored[0].message;
        assert!(m.contains("frame.json") && m.contains("--scene") && m.contains("--no-scene"), "{m}");
        assert!(l.lights.is_none(), "{json}: lights from a file that is not a sidecar");
        // --no-scene: nothing looked for, nothing said.
        let none = load(&p, &LoadOptions { no_sidecar: true, ..Default::default() }).unwrap();
        assert!(none.warnings.iter().all(|w| w.code != SIDECAR_IGNORED));
        // The command line loads it too (exit 0) and says so once.
        let out = gbuf(dir.path(), &["info", "frame.exr"]);
        assert!(out.status.success(), "{json}: {}", stderr(&out));
        // Once: `info` lists its warnings in its text, not again on stderr.
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
        assert_eq!(text.matches("not a gbuf sidecar").count(), 1, "{text}");
    }
}

#[test]
fn a_gbuf_sidecar_with_errors_reports_all_of_them_and_no_scene_skips_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dump_with_json(dir.path(), r#"{"camera": 5, "lights_space": "up", "supersample": 99}"#);
    let e = load(&p, &LoadOptions::default()).unwrap_err().to_string();
    for part in ["3 problems", "camera", "supersample 99", "lights_space \"up\""] {
        assert!(e.contains(part), "{part} missing from: {e}");
    }
    let l = load(&p, &LoadOptions { no_sidecar: true, ..Default::default() }).unwrap();
    assert!(l.lights.is_none());
    let out = gbuf(dir.path(), &["info", "frame.exr", "--no-scene"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The real sidecar named with --scene is used.
    std::fs::copy(fixture("blender_gbuffer.json"), dir.path().join("real.json")).unwrap();
    let l = load(&p, &LoadOptions { sidecar: Some(dir.path().join("real.json")), ..Default::default() }).unwrap();
    assert!(l.lights.is_some_and(|v| !v.is_empty()));
    let both = gbuf(dir.path(), &["info", "frame.exr", "--no-scene", "--scene", "real.json"]);
    assert_eq!(both.status.code(), Some(2), "--scene with --no-scene is a usage error");
}

#[test]
fn report_compares_layouts_under_several_brdfs() {
    let dir = tempfile::tempdir().unwrap();
    let pbr = fixture("blender_pbr.exr");
    let args = [
        "report",
        pbr.to_str().unwrap(),
        "--brdf",
        "ggx,blinn-phong",
        "--candidates",
        "destiny-96,unreal-like,fat-20",
        "--detectors",
        "lauritzen",
        "--flip",
        "none",
        "-o",
        "cmp",
        "--json",
    ];
    let rows = json_of(&gbuf(dir.path(), &args));
    // One report per BRDF, each lit as its folder says.
    for b in ["ggx", "blinn-phong"] {
        let rep: Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("cmp").join(b).join("report.json")).unwrap())
                .unwrap();
        assert_eq!(rep["lighting"]["brdf"], b);
    }
    assert!(dir.path().join("cmp/brdf_comparison.md").is_file());
    // destiny-96's 4-bit roughness: last under GGX, not under Blinn-Phong.
    let destiny = rows.as_array().unwrap().iter().find(|r| r["layout"] == "destiny-96").unwrap();
    let under = destiny["under"].as_array().unwrap();
    let (ggx, bp) = (&under[0], &under[1]);
    assert_eq!((ggx[0].as_str(), bp[0].as_str()), (Some("ggx"), Some("blinn-phong")));
    assert_eq!(ggx[2], 3, "destiny-96 ranks last of three under GGX: {destiny}");
    assert!(bp[2].as_u64().unwrap() < 3, "{destiny}");
    // Commands that light once refuse a list.
    let o = gbuf(dir.path(), &["budget", pbr.to_str().unwrap(), "--max-bytes", "12", "--brdf", "ggx,lambert"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// Albedo above 1 is the data's error: the report says, apart from the layouts' rows, what clamping it alone costs.
#[test]
fn albedo_above_one_is_kept_apart_from_the_layout_error() {
    let dir = tempfile::tempdir().unwrap();
    let lux = fixture("luxcore");
    let args =
        ["report", lux.to_str().unwrap(), "--candidates", "fat-20", "--detectors", "lauritzen", "--flip", "none"];
    let mut with_json: Vec<&str> = args.to_vec();
    with_json.extend(["-o", "r", "--json"]);
    let rep = json_of(&gbuf(dir.path(), &with_json));
    let notes = rep["frames"][0]["notes"].as_array().expect("the frame's notes");
    let note = notes.iter().filter_map(Value::as_str).find(|n| n.contains("exceed 1")).expect("the albedo note");
    let rmse: f64 = note.split("layout RMSE ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    let layout = rep["rows"][0]["layout_error"]["rmse"].as_f64().unwrap();
    assert!(rmse > 0.0 && rmse <= layout * 1.0001, "clamping alone {rmse}, the layout's whole error {layout}");
    let md = std::fs::read_to_string(dir.path().join("r/report.md")).unwrap();
    assert!(md.contains("exceed 1"), "report.md says it");
}
