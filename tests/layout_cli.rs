//! `gbuf layouts` and `gbuf roundtrip` through the built binary, plus every layout on the analytic scenes.
mod support;

use support::gbuf;

use gbuf::gbuffer::Attribute;
use gbuf::layout::Layout;
use gbuf::measure::gbuffer::compare;
use gbuf::scene::{render, SceneName};
use serde_json::Value;
use std::path::Path;
use std::process::Output;

fn json(out: &Output) -> Value {
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn layouts_json_has_the_seed_footprint() {
    let dir = tempfile::tempdir().unwrap();
    let rows = json(&gbuf(dir.path(), &["layouts", "--resolution", "1900x1200", "--msaa", "4", "--json"]));
    let rows = rows.as_array().unwrap();
    // The lit layouts, then the visibility buffer's.
    assert_eq!(rows.len(), Layout::builtins().len() + Layout::visibility_builtins().len());
    assert_eq!(rows.last().unwrap()["name"], "visibility-8");
    let fat = rows.iter().find(|r| r["name"] == "fat-20").unwrap();
    assert_eq!(fat["bytes_per_sample"], 20);
    assert_eq!(fat["footprint_bytes"], 182_400_000u64);
    for r in rows {
        let sum: u64 = r["targets"].as_array().unwrap().iter().map(|t| t["bytes"].as_u64().unwrap()).sum();
        assert_eq!(r["bytes_per_sample"].as_u64().unwrap(), sum, "{}", r["name"]);
        assert_eq!(r["footprint_bytes"].as_u64().unwrap(), 1900 * 1200 * 4 * sum);
        assert!(r["targets"][0]["fields"].as_array().is_some());
    }
    // Human output mentions every layout.
    let text = gbuf(dir.path(), &["layouts"]);
    let text = String::from_utf8(text.stdout).unwrap();
    for l in Layout::builtin_names() {
        assert!(text.contains(&l), "{l} missing from\n{text}");
    }
}

#[test]
fn layouts_shows_user_files_and_refuses_bad_ones() {
    let dir = tempfile::tempdir().unwrap();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/layouts/thin-12.toml");
    let rows = json(&gbuf(dir.path(), &["layouts", example.to_str().unwrap(), "--json"]));
    assert_eq!(rows[0]["name"], "thin-12");
    assert_eq!(rows[0]["bytes_per_sample"], 12);
    std::fs::write(dir.path().join("bad.toml"), "name = \"b\"\n[[targets]]\nname = \"t\"\nformat = \"rgba9\"\n")
        .unwrap();
    let out = gbuf(dir.path(), &["layouts", "bad.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml") && err.contains("rgba9"), "{err}");
    let out = gbuf(dir.path(), &["layouts", "--resolution", "0x5"]);
    assert_eq!(out.status.code(), Some(2));
}

/// serde_json parses floats without the `float_roundtrip` feature, which may be off by one ulp.
const JSON_REL_SLACK: f64 = 1e-14;

fn assert_close(got: &Value, want: f64, what: &str) {
    let got = got.as_f64().unwrap_or_else(|| panic!("{what}: {got} is not a number"));
    assert!((got - want).abs() <= JSON_REL_SLACK * want.abs(), "{what}: JSON {got} vs library {want}");
}

#[test]
fn roundtrip_json_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let gb = render(SceneName::Room, 48, 32, 4).unwrap();
    let file = dir.path().join("room.exr");
    gbuf::io::canonical::write(&file, &gb).unwrap();
    for name in ["fat-20", "destiny-96", "reference-f32"] {
        let row = json(&gbuf(dir.path(), &["roundtrip", "room.exr", "--layout", name, "--json"]));
        let layout = Layout::by_name(name).unwrap();
        let want = compare(&gb, &layout.roundtrip(&gb).unwrap()).unwrap();
        assert_eq!(row["layout"], name);
        assert_eq!(row["bytes_per_sample"].as_u64().unwrap() as usize, layout.bytes_per_sample());
        let n = want.normal.as_ref().unwrap();
        assert_close(&row["normal_mean_deg"], n.mean_deg, name);
        assert_close(&row["normal_p95_deg"], n.p95_deg, name);
        assert_close(&row["normal_max_deg"], n.max_deg, name);
        assert_close(&row["depth_rel_max"], want.depth.as_ref().unwrap().rel_max, name);
        assert_close(&row["albedo_max_abs"], want.albedo.as_ref().unwrap().max_abs, name);
        assert_eq!(row["errors"]["normal"]["worst"]["x"].as_u64().unwrap(), u64::from(n.worst.x));
    }
    // Bytes after framebuffer compression: the library's, per target of the packed frame; MSAA rules out AFBC.
    let row = json(&gbuf(dir.path(), &["roundtrip", "room.exr", "--layout", "fat-20", "--json"]));
    let want = gbuf::layout::compression::compressed(&Layout::by_name("fat-20").unwrap().pack(&gb).unwrap());
    let got = row["compression"].as_array().unwrap();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!((g["target"].as_str().unwrap(), g["nominal"].as_u64().unwrap()), (w.target.as_str(), w.nominal));
        for (gs, ws) in g["schemes"].as_array().unwrap().iter().zip(&w.schemes) {
            assert_eq!(gs["bytes"].as_u64(), ws.bytes, "{}: {}", w.target, ws.scheme);
        }
        assert_eq!(g["zstd"].as_u64(), w.zstd);
        let afbc = g["schemes"].as_array().unwrap().iter().find(|s| s["scheme"] == "afbc").unwrap();
        assert!(afbc["bytes"].is_null(), "AFBC holds no multisampled target: {g}");
    }
    // The normal target alone under each codec: the library's rows, and `--layout` and `--normal-targets` exclusive.
    let rows = json(&gbuf(dir.path(), &["roundtrip", "room.exr", "--normal-targets", "--json"]));
    let want = gbuf::analysis::normal_targets::normal_targets(&gb).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), want.len());
    for (g, w) in rows.iter().zip(&want) {
        assert_eq!(
            (g["codec"].as_str().unwrap(), g["format"].as_str().unwrap()),
            (w.codec.as_str(), w.format.as_str())
        );
        assert_close(&g["mean_deg"], w.mean_deg, &w.codec);
        assert_close(&g["compressed"][0], w.compressed[0], &w.codec);
    }
    let reference = json(&gbuf(dir.path(), &["roundtrip", "room.exr", "--layout", "reference-f32", "--json"]));
    assert_eq!(reference["normal_max_deg"], 0.0);
    assert_eq!(reference["depth_rel_max"], 0.0);
    // A user layout file works too, and the text output names the worst pixel.
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/layouts/thin-12.toml");
    let out = gbuf(dir.path(), &["roundtrip", "room.exr", "--layout", example.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("thin-12") && text.contains("worst at pixel"), "{text}");
}

#[test]
fn roundtrip_errors_are_clear() {
    let dir = tempfile::tempdir().unwrap();
    let out = gbuf(dir.path(), &["roundtrip", "missing.exr", "--layout", "fat-20"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.exr"));
    let gb = render(SceneName::Room, 8, 8, 1).unwrap();
    gbuf::io::canonical::write(&dir.path().join("r.exr"), &gb).unwrap();
    // A layout name that names nothing is a usage error (exit 2), listing the built-ins.
    let out = gbuf(dir.path(), &["roundtrip", "r.exr", "--layout", "nope"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nope") && err.contains("fat-20"), "{err}");
}

/// An angular tolerance for comparing a layout's measured normal error with its codec's documented bound:
/// the bound is stated in f32 degrees, the measurement is f64.
const BOUND_SLACK_DEG: f64 = 1e-4;

#[test]
fn scene_roundtrips_stay_within_the_codec_bounds() {
    for scene in SceneName::ALL {
        let gb = render(scene, 64, 40, 4).unwrap();
        for layout in Layout::builtins() {
            let back = layout.roundtrip(&gb).unwrap();
            let e = compare(&gb, &back).unwrap();
            let name = format!("{} on {scene:?}", layout.name());
            let Some(field) = layout.fields().iter().find(|f| f.slot == gbuf::layout::Slot::Whole(Attribute::Normal))
            else {
                assert_eq!(e.normal.as_ref().unwrap().max_deg, 0.0, "{name}");
                continue;
            };
            let codec = gbuf::codec::normal_codec(&field.codec).unwrap();
            let normals = gb.normal.as_ref().unwrap();
            let in_domain = (0..gb.len()).filter(|&i| gb.coverage[i]).all(|i| codec.in_domain(normals[i]));
            let n = e.normal.as_ref().unwrap();
            if in_domain {
                assert!(
                    n.max_deg <= f64::from(codec.max_error_deg()) + BOUND_SLACK_DEG,
                    "{name}: {} > bound {}",
                    n.max_deg,
                    codec.max_error_deg()
                );
            }
            assert!(n.max_deg.is_finite() && n.p95_deg <= n.max_deg && n.mean_deg <= n.max_deg, "{name}");
            assert!(e.nonfinite == 0, "{name}: {} non-finite", e.nonfinite);
        }
    }
}

/// `gbuf layouts --check`: a row per layout and platform, the library's verdicts, reasons named, and an unknown
/// platform refused with the known ones listed.
#[test]
fn layouts_check_says_where_each_layout_binds() {
    let dir = tempfile::tempdir().unwrap();
    let at = |msaa: &str| json(&gbuf(dir.path(), &["layouts", "--check", "--msaa", msaa, "--json"]));
    let four = at("4");
    let rows = four.as_array().unwrap();
    assert_eq!(rows.len(), Layout::builtins().len() * gbuf::layout::limits::PLATFORMS.len());
    let row = |rows: &[Value], l: &str, p: &str| {
        rows.iter().find(|r| r["layout"] == l && r["platform"] == p).unwrap_or_else(|| panic!("{l} on {p}")).clone()
    };
    // Bevy's deferred texel is RGBA32_UINT: WebGPU binds it single-sampled, never at 4×.
    let bevy = row(rows, "bevy-deferred", "webgpu");
    assert_eq!(bevy["fits"], false);
    assert!(bevy["problems"][0].as_str().unwrap().contains("rgba32ui has no guaranteed 4x MSAA"), "{bevy}");
    let one = at("1");
    assert_eq!(row(one.as_array().unwrap(), "bevy-deferred", "webgpu")["fits"], true);
    // fat-20's five targets fill WebGPU's default 32 bytes per sample exactly.
    let fat = row(rows, "fat-20", "webgpu");
    assert_eq!(
        (fat["fits"].clone(), fat["color_bytes"].clone(), fat["color_bytes_limit"].clone()),
        (true.into(), 32.into(), 32.into())
    );
    // The f32 reference layout needs 80 bytes per sample: over every WebGPU budget, fine on D3D12.
    assert_eq!(row(rows, "reference-f32", "webgpu-128")["fits"], false);
    assert_eq!(row(rows, "reference-f32", "d3d12")["fits"], true);
    // MSAA never keeps AFBC.
    assert!(fat["afbc"].as_array().unwrap().iter().all(|t| t[1] == "never"), "{fat}");
    let text = gbuf(dir.path(), &["layouts", "--check", "fat-20", "--platform", "metal-apple2,webgpu"]);
    let text = String::from_utf8(text.stdout).unwrap();
    assert!(text.contains("fat-20 on metal-apple2: d24s8 is not a guaranteed attachment format"), "{text}");
    // On a dump: each layout's bytes after the compression models, the library's; an AFRC layout refuses 4×.
    let gb = render(SceneName::Room, 32, 16, 4).unwrap();
    gbuf::io::canonical::write(&dir.path().join("room.exr"), &gb).unwrap();
    let args = ["layouts", "--check", "fat-20", "fat-20@afrc3", "--platform", "webgpu", "--dump", "room.exr", "--json"];
    let on = json(&gbuf(dir.path(), &args));
    let fat = &on[0]["compressed"]["Ok"];
    let want = gbuf::layout::compression::compressed_models_of(&Layout::by_name("fat-20").unwrap(), &gb).unwrap();
    let want = gbuf::layout::compression::bytes_per_sample(&want, gb.len() as u64);
    assert_close(&fat["dcc"], want[0], "fat-20 dcc");
    assert_close(&fat["ccs"], want[1], "fat-20 ccs");
    assert_eq!((fat["stored"].as_f64(), fat["afbc"].as_f64()), (Some(20.0), Some(20.0)), "no AFBC at 4×: {fat}");
    assert!(on[1]["compressed"]["Err"].as_str().unwrap().contains("multisampled"), "{}", on[1]);
    let bad = gbuf(dir.path(), &["layouts", "--check", "--platform", "xbox"]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("--platform xbox") && err.contains("webgpu-64") && err.contains("metal-apple7"), "{err}");
}
