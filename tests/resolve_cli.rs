//! `gbuf resolve` run as a binary in a fresh temporary directory.
mod support;

use support::{gbuf, stderr};

use std::path::Path;
use std::process::Output;

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
    assert_eq!(o.status.code(), Some(2), "a usage error");
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
    // Writing the files is timed (the fixed cost a user pays per run); nothing written, nothing timed.
    assert!(v["ms"]["output"].as_f64().unwrap() > 0.0, "{v}");
    let none = json(&gbuf(dir.path(), &["resolve", "room.exr", "--lights", "8", "--no-reference", "--json"]));
    assert_eq!(none["ms"]["output"].as_f64(), Some(0.0), "{none}");
    // The demo's LDR encoding and a layout round trip.
    let o = gbuf(
        dir.path(),
        &["resolve", "room.exr", "--lights", "8", "--png", "ldr.png", "--ldr", "gamma2.2", "--detector", "ssaa"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("error vs reference"));
    assert!(String::from_utf8_lossy(&o.stdout).contains("writing the output files"));
    let o = gbuf(dir.path(), &["resolve", "room.exr", "--lights", "8", "--scene", "missing.json"]);
    assert_eq!(o.status.code(), Some(1));
    let o = gbuf(dir.path(), &["resolve", "room.exr"]);
    assert_eq!(o.status.code(), Some(1), "no lights must be an error: {}", stderr(&o));
    assert!(stderr(&o).contains("--lights"), "{}", stderr(&o));
}

/// A small room dump in `dir` (no sidecar: lights come from `--lights` or a sidecar the test writes).
fn small_room(dir: &Path) -> gbuf::GBuffer {
    let gb = gbuf::scene::render(gbuf::scene::SceneName::Room, 48, 32, 4).unwrap();
    gbuf::io::canonical::write(&dir.join("room.exr"), &gb).unwrap();
    gb
}

fn json(o: &Output) -> serde_json::Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn layout_flag_packs_before_lighting_and_lossy_layouts_cost_error() {
    let dir = tempfile::tempdir().unwrap();
    small_room(dir.path());
    // ssaa: every sample shaded, so the only error left is the layout's (and f32 vs f64 arithmetic).
    let run = |layout: Option<&str>| {
        // Blinn-Phong (the room stores roughness, so GGX would be the default): its 8-byte layout's 4-bit specular
        // power and the 15-byte one's are the difference this test reads.
        let mut args =
            vec!["resolve", "room.exr", "--lights", "16", "--detector", "ssaa", "--json", "--brdf", "blinn-phong"];
        if let Some(l) = layout {
            args.extend(["--layout", l]);
        }
        json(&gbuf(dir.path(), &args))
    };
    let plain = run(None);
    let lossless = run(Some("reference-f32"));
    assert_eq!(lossless["layout"], "reference-f32");
    assert!(plain["layout"].is_null());
    // reference-f32 stores every attribute as f32: lighting it is lighting the original.
    assert_eq!(lossless["rmse"], plain["rmse"], "{lossless}");
    // The errors apart: the lossless layout's layout error is 0 (FLIP too), its total is the AA error.
    assert_eq!(lossless["layout_error"]["rmse"], 0.0);
    assert_eq!(lossless["layout_error"]["flip_ldr"], 0.0);
    assert_eq!(lossless["total_error"]["rmse"], lossless["aa_error"]["rmse"]);
    assert!(plain["layout_error"].is_null(), "no layout: no layout error");
    let flip = plain["total_error"]["flip_ldr"].as_f64().unwrap();
    assert!((0.0..1.0).contains(&flip) && plain["total_error"]["flip_hdr"].as_f64().is_some());
    assert_eq!(plain["viewing"]["tone_map"], "reinhard");
    let rmse = |v: &serde_json::Value| v["rmse"].as_f64().unwrap();
    for lossy in ["minimal-8", "lauritzen-15"] {
        let v = run(Some(lossy));
        assert_eq!(v["layout"], lossy);
        assert!(rmse(&v) > 10.0 * rmse(&lossless), "{lossy}: {} vs {}", rmse(&v), rmse(&lossless));
        assert!(v["psnr_db"].as_f64().unwrap() < lossless["psnr_db"].as_f64().unwrap(), "{lossy}");
        assert!(v["layout_error"]["flip_ldr"].as_f64().unwrap() > 0.0, "{lossy}: a lossy layout is visible");
    }
    // 8 bytes per sample lose more than 15.
    assert!(rmse(&run(Some("minimal-8"))) > rmse(&run(Some("lauritzen-15"))));
    // A layout file works as well as a built-in name.
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/layouts/thin-12.toml");
    let v = run(Some(file));
    assert_eq!(v["layout"], file);
    assert!(rmse(&v) > rmse(&lossless), "{v}");

    // A layout name that names nothing: a usage error (exit 2), found before the dump is read or lit.
    let o = gbuf(dir.path(), &["resolve", "room.exr", "--lights", "4", "--layout", "nosuch"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(!err.contains("lighting:"), "the layout is checked before the work: {err}");
    assert!(
        err.contains("--layout nosuch") && err.contains("reference-f32"),
        "the error names the flag and lists the built-ins: {err}"
    );
    assert!(o.stdout.is_empty());
    let o = gbuf(dir.path(), &["resolve", "room.exr", "--lights", "4", "--layout", "missing.toml"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing.toml"), "{}", stderr(&o));
}

#[test]
fn light_prepass_reports_its_error_against_full_deferred() {
    let dir = tempfile::tempdir().unwrap();
    let gb = small_room(dir.path());
    let run = |extra: &[&str]| {
        // Blinn-Phong: its specular is monochrome, so under white lights the pre-pass is exact (GGX's metals have a
        // coloured Fresnel term the pre-pass cannot carry).
        let mut args = vec!["resolve", "room.exr", "--json", "--brdf", "blinn-phong"];
        args.extend_from_slice(extra);
        json(&gbuf(dir.path(), &args))
    };
    // Scattered lights have random hues: the monochrome specular takes the wrong colour.
    let deferred = run(&["--lights", "16"]);
    assert!(deferred["prepass_vs_deferred"].is_null(), "{deferred}");
    let pre = run(&["--lights", "16", "--schedule", "light-prepass"]);
    let e = &pre["prepass_vs_deferred"];
    for key in ["rmse", "psnr_db", "max_abs", "rel_mse"] {
        assert!(e[key].is_number(), "prepass_vs_deferred.{key} missing in {pre}");
    }
    assert!(e["rel_mse"].as_f64().unwrap() > 1e-6 && e["max_abs"].as_f64().unwrap() > 0.0, "{e}");
    assert!(pre["ms"]["deferred_for_prepass"].as_f64().unwrap() > 0.0, "{pre}");
    // The error against the reference is the pre-pass's own, not a copy of deferred's.
    assert_ne!(pre["rmse"], deferred["rmse"]);

    // The same lights, all white (a sidecar next to the dump): pre-pass and deferred agree up to f32 rounding.
    let lights = gbuf::scene::scatter_lights(&gb, 16, 1);
    let list: Vec<String> = lights
        .iter()
        .map(|l| {
            let p = l.position;
            format!(
                r#"{{"type": "point", "position": [{}, {}, {}], "color": [1, 1, 1], "intensity": {}, "range": {}}}"#,
                p.x, p.y, p.z, l.intensity, l.range
            )
        })
        .collect();
    let sidecar = format!(r#"{{"lights_space": "view", "lights": [{}]}}"#, list.join(", "));
    std::fs::write(dir.path().join("room.json"), sidecar).unwrap();
    let white = run(&["--schedule", "light-prepass"]);
    assert_eq!(white["lights_source"], "file", "{white}");
    let w = &white["prepass_vs_deferred"];
    assert!(w["rel_mse"].as_f64().unwrap() < 1e-10, "white lights: {w}");
    assert!(w["psnr_db"].as_f64().unwrap() > 100.0, "{w}");

    // The human output has its own line for it.
    let o = gbuf(dir.path(), &["resolve", "room.exr", "--lights", "16", "--schedule", "light-prepass"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("light pre-pass vs full deferred") && text.contains("error vs reference"), "{text}");
}

/// A library user gets `gbuf resolve`'s numbers from `analysis::job::resolve_frame`: the same image error, layout
/// and detector errors and work counts as the command's JSON, on the same frame, lights and layout.
#[test]
fn the_library_resolve_job_gives_the_commands_numbers() {
    use gbuf::analysis::job::{resolve_frame, ResolveJob};
    let dir = tempfile::tempdir().unwrap();
    let gb = small_room(dir.path());
    let cli = json(&gbuf(
        dir.path(),
        &["resolve", "room.exr", "--lights", "16", "--layout", "lauritzen-15", "--json", "--no-flip"],
    ));
    let lights = gbuf::scene::choose_lights(&gb, None, Some(16), None, 1).unwrap().0;
    let layout = gbuf::layout::Layout::by_name("lauritzen-15").unwrap();
    let lighting = gbuf::resolve::Lighting::choose(None, None, &gb.attributes());
    let job = ResolveJob {
        layout: Some(&layout),
        detector: gbuf::detect::Detector::Lauritzen,
        thresholds: Default::default(),
        config: lighting.apply(Default::default()),
        reference: true,
        flip: None,
    };
    let steps = std::sync::Mutex::new(Vec::new());
    let (done, beside) =
        resolve_frame("room.exr", &gb, None, &lights, &job, &|s| steps.lock().unwrap().push(s.to_string()), |r| {
            r.image.width
        })
        .unwrap();
    assert_eq!(beside, 48, "the closure ran on the lit frame");
    assert_eq!(steps.into_inner().unwrap(), ["edges", "lighting", "the every-sample reference"]);
    let e = done.error.unwrap();
    assert_eq!(cli["rmse"].as_f64().unwrap(), e.rmse);
    assert_eq!(cli["layout_error"]["rmse"].as_f64().unwrap(), done.triad.layout.unwrap().rmse);
    assert_eq!(cli["aa_error"]["rmse"].as_f64().unwrap(), done.triad.aa.unwrap().rmse);
    assert_eq!(cli["shading_evaluations"].as_u64().unwrap(), done.resolved.stats.shading_evaluations);
    assert_eq!(cli["edge_fraction"].as_f64().unwrap(), done.mask.edge_fraction());
    assert!(e.rmse > 0.0 && done.stages.total >= done.stages.detect);
    // An empty frame lights nothing: an error naming the frame, not a success.
    let mut empty = gb.clone();
    empty.coverage.iter_mut().for_each(|c| *c = false);
    let err = resolve_frame("empty.exr", &empty, None, &lights, &job, &|_| {}, |_| ()).unwrap_err().to_string();
    assert!(err.contains("empty.exr"), "{err}");
}
