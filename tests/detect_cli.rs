//! `gbuf edges` end to end: the built binary on canonical dumps written in a fresh temp dir.

mod support;

use support::gbuf as gbuf_cmd;

use gbuf::detect::truth::{id_truth, TruthSource};
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::measure::edges::{evaluate, evaluate_against};
use gbuf::GBuffer;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Output;
use support::{render, Shape, Surface};

/// A sphere in front of a tilted wall, with object and primitive IDs.
fn scene() -> GBuffer {
    let a = 30f32.to_radians();
    let wall =
        Surface::new(Shape::Plane { normal: Vec3::new(a.sin(), 0.0, a.cos()), point: Vec3::new(0.0, 0.0, -9.0) }, 1);
    let sphere = Surface::new(Shape::Sphere { center: Vec3::new(0.3, 0.0, -5.0), radius: 1.0 }, 2);
    render(40, 30, 4, &[wall, sphere])
}

fn write_dump(dir: &Path, gb: &GBuffer) -> PathBuf {
    let p = dir.join("scene.exr");
    gbuf::io::canonical::write(&p, gb).unwrap();
    p
}

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn all_detectors_json_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let gb = scene();
    write_dump(dir.path(), &gb);
    let v = json(&gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "all", "--json"]));
    assert_eq!((v["width"].as_u64(), v["samples"].as_u64(), v["truth"].as_str()), (Some(40), Some(4), Some("object")));
    let rows = v["results"].as_array().unwrap();
    assert_eq!(rows.len(), Detector::ALL.len());
    let prim = id_truth(&gb, TruthSource::Primitive).unwrap();
    let prim_fraction = prim.iter().filter(|&&t| t).count() as f64 / prim.len() as f64;
    assert_eq!(v["primitive_true_edge_fraction"].as_f64(), Some(prim_fraction));
    for (row, d) in rows.iter().zip(Detector::ALL) {
        assert_eq!(row["detector"], d.name());
        let mask = detect(&gb, d, &DetectorConfig::default()).unwrap();
        let s = evaluate(&gb, &mask).unwrap();
        assert_eq!(row["tp"].as_u64(), Some(s.tp), "{d}");
        assert_eq!(row["fp"].as_u64(), Some(s.fp), "{d}");
        assert_eq!(row["fn"].as_u64(), Some(s.fn_), "{d}");
        // What the mask costs (covered samples of per-sample pixels), not what it asks for (issue 16).
        let covered = gbuf::detect::covered_per_pixel(&gb);
        assert_eq!(row["shading_fraction"].as_f64(), Some(mask.evaluated_fraction(&covered)), "{d}");
        assert_eq!(s.shading_fraction, mask.evaluated_fraction(&covered), "{d}");
        // The primitive-ID truth (the forward-MSAA rate) gets its own scores.
        let p = evaluate_against(&mask, &prim);
        assert_eq!(
            (row["primitive"]["tp"].as_u64(), row["primitive"]["fn"].as_u64()),
            (Some(p.tp), Some(p.fn_)),
            "{d}"
        );
        assert!(
            row["precision"].as_f64().is_some() && row["recall"].as_f64().is_some() && row["ms"].as_f64().is_some()
        );
    }
    // The sphere's silhouette is a true edge that lauritzen finds.
    assert_eq!(rows[0]["recall"].as_f64(), Some(1.0), "{}", rows[0]);
    assert!(rows[0]["tp"].as_u64().unwrap() > 20);
}

#[test]
fn thresholds_flags_reach_the_detector() {
    let dir = tempfile::tempdir().unwrap();
    write_dump(dir.path(), &scene());
    let edges = |extra: &[&str]| {
        let mut args = vec!["edges", "scene.exr", "--detector", "depth", "--json"];
        args.extend_from_slice(extra);
        json(&gbuf_cmd(dir.path(), &args))["results"][0]["edge_fraction"].as_f64().unwrap()
    };
    let loose = edges(&["--depth-relative", "0.5"]);
    let tight = edges(&["--depth-relative", "0.0001"]);
    assert!(tight > loose, "{tight} vs {loose}");
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--normal-angle=-3"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("normal_angle_deg"));
}

#[test]
fn mask_png_marks_hits_misses_and_false_alarms() {
    let dir = tempfile::tempdir().unwrap();
    write_dump(dir.path(), &scene());
    // The normal test finds the sphere's silhouette and also flags its curvature (about 8° per pixel here):
    // expect red hits and cyan false alarms.
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "normal", "--mask", "m.png"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let gb = scene();
    let check = |png: &str, d: Detector| {
        let img = image::open(dir.path().join(png)).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (40, 30));
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count() as u64;
        let s = evaluate(&gb, &detect(&gb, d, &DetectorConfig::default()).unwrap()).unwrap();
        assert_eq!(count(gbuf::detect::picture::FLAGGED), s.tp, "{d}");
        assert_eq!(count(gbuf::detect::picture::MISSED), s.fn_, "{d}");
        assert_eq!(count(gbuf::detect::picture::FALSE_ALARM), s.fp, "{d}");
        s
    };
    let s = check("m.png", Detector::Normal);
    assert!(s.tp > 0 && s.fp > 0, "{s:?}");
    // `none` flags nothing: every true edge is a yellow miss.
    let out2 = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "none", "--mask", "n.png"]);
    assert!(out2.status.success());
    let s = check("n.png", Detector::None);
    assert!(s.fn_ > 0 && s.tp == 0, "{s:?}");
    // Human output names the detector.
    assert!(String::from_utf8_lossy(&out.stdout).contains("normal"));
}

#[test]
fn shading_truth_with_lights_from_the_sidecar() {
    let dir = tempfile::tempdir().unwrap();
    write_dump(dir.path(), &scene());
    let sidecar = r#"{"lights_space": "view", "lights": [
        {"type": "point", "position": [0.5, 1.0, -3.0], "color": [1, 1, 1], "intensity": 20, "range": 30}]}"#;
    std::fs::write(dir.path().join("scene.json"), sidecar).unwrap();
    let v = json(&gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "all", "--json"]));
    let t = &v["shading_truth"];
    assert_eq!(t["lights"], 1, "{v}");
    assert!(t["true_edge_fraction"].as_f64().unwrap() > 0.0, "{t}");
    for row in v["results"].as_array().unwrap() {
        let sh = &row["shading"];
        assert!(sh["precision"].as_f64().is_some(), "{row}");
        if row["detector"] == "ssaa" {
            assert_eq!(sh["recall"].as_f64(), Some(1.0), "ssaa shades every sample: {row}");
        }
    }
    // The tolerance is stated in the output: domain, threshold and rule; and the agreement with the ID truth.
    assert_eq!((t["tolerance"]["domain"].as_str(), t["tolerance"]["codes"].as_f64()), (Some("display"), Some(1.0)));
    assert!(t["rule"].as_str().unwrap().contains("code step"), "{t}");
    let agree = &t["agreement_with_id_truth"];
    assert!(agree["both"].as_u64().unwrap() > 0, "{t}");
    // A looser tolerance flags fewer pixels, an absolute linear one more; both are stated back.
    let fraction = |tol: &str| {
        let v = json(&gbuf_cmd(dir.path(), &["edges", "scene.exr", "--json", "--shading-tolerance", tol]));
        assert!(v["shading_truth"]["rule"].is_string(), "{v}");
        v["shading_truth"]["true_edge_fraction"].as_f64().unwrap()
    };
    let default = t["true_edge_fraction"].as_f64().unwrap();
    assert!(fraction("display:100") < default, "{default}");
    assert!(fraction("linear:0") > default, "{default}");
    let human = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--shading-tolerance", "2.5"]);
    let text = String::from_utf8_lossy(&human.stdout);
    assert!(text.contains("> 2.5 8-bit code step") && text.contains("vs ID truth"), "{text}");
    for bad in ["bogus", "linear:-1", "gamma:1"] {
        let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--shading-tolerance", bad]);
        assert_eq!(out.status.code(), Some(2), "{bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("shading tolerance"), "{bad}");
    }
    // The reference's lighting model is a flag too, and is stated back.
    let lambert =
        json(&gbuf_cmd(dir.path(), &["edges", "scene.exr", "--json", "--brdf", "lambert", "--falloff", "gltf"]));
    assert_eq!(
        (lambert["shading_truth"]["brdf"].as_str(), lambert["shading_truth"]["falloff"].as_str()),
        (Some("lambert"), Some("gltf"))
    );
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--brdf", "phong"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("blinn-phong"));
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--exposure", "0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("exposure"));
}

#[test]
fn bad_input_exits_1_with_the_file_name_and_bad_usage_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = gbuf_cmd(dir.path(), &["edges", "nope.exr"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.exr"));

    let out = gbuf_cmd(dir.path(), &["edges", "nope.exr", "--detector", "sobel"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("lauritzen"), "the error lists the detectors");

    let mut gb = scene();
    gb.primitive_id = None;
    write_dump(dir.path(), &gb);
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "forward-msaa"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("primitive_id") && err.contains("scene.exr"), "{err}");
    // In `all` mode the same detector is a skipped row, not a failure.
    let v = json(&gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "all", "--json"]));
    let fwd = v["results"].as_array().unwrap().iter().find(|r| r["detector"] == "forward-msaa").unwrap();
    assert!(fwd["skipped"].as_str().unwrap().contains("primitive_id"));

    // A usage error (flags that do not go together): exit 2, as the README promises.
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "all", "--mask", "x.png"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!dir.path().join("x.png").exists());
}

#[test]
fn mask_picture_can_be_coloured_against_the_shading_truth() {
    use gbuf::measure::edges::{evaluate_against, shading_truth, DEFAULT_SHADING_TOLERANCE};
    let dir = tempfile::tempdir().unwrap();
    let gb = scene();
    write_dump(dir.path(), &gb);
    let light = gbuf::Light::point(Vec3::new(0.5, 1.0, -3.0), Vec3::ONE, 20.0, 30.0);
    let sidecar = r#"{"lights_space": "view", "lights": [
        {"type": "point", "position": [0.5, 1.0, -3.0], "color": [1, 1, 1], "intensity": 20, "range": 30}]}"#;
    std::fs::write(dir.path().join("scene.json"), sidecar).unwrap();
    let radiance =
        gbuf::resolve::reference_per_sample(&gb, &[light], &gbuf::resolve::ResolveConfig::default()).unwrap();
    let shading = shading_truth(&gb, &radiance, DEFAULT_SHADING_TOLERANCE);
    let count_colours = |png: &str| {
        let img = image::open(dir.path().join(png)).unwrap().to_rgb8();
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count() as u64;
        use gbuf::detect::picture::{FALSE_ALARM, FLAGGED, MISSED};
        (count(FLAGGED), count(MISSED), count(FALSE_ALARM))
    };
    let args = ["edges", "scene.exr", "--detector", "normal", "--mask", "s.png", "--mask-truth", "shading", "--json"];
    let v = json(&gbuf_cmd(dir.path(), &args));
    assert_eq!(v["mask_truth"], "shading", "{v}");
    let s = evaluate_against(&detect(&gb, Detector::Normal, &DetectorConfig::default()).unwrap(), &shading);
    assert_eq!(count_colours("s.png"), (s.tp, s.fn_, s.fp), "{s:?}");
    assert!(s.tp > 0, "{s:?}");
    // Without object IDs the shading truth is the default; asking for the ID truth is then an error.
    let mut no_ids = gb.clone();
    no_ids.object_id = None;
    write_dump(dir.path(), &no_ids);
    let v = json(&gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "normal", "--mask", "d.png", "--json"]));
    assert_eq!(v["mask_truth"], "shading", "{v}");
    let out =
        gbuf_cmd(dir.path(), &["edges", "scene.exr", "--detector", "normal", "--mask", "e.png", "--mask-truth", "id"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no object IDs"));
    let out = gbuf_cmd(dir.path(), &["edges", "scene.exr", "--mask-truth", "shading"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--mask OUT.png"));
}

/// `gbuf vrs` on the real 4× raster fixture: the SRI it writes is the library's, D3D12-encoded, read back as
/// written; coarse shading saves evaluations and costs image error; sharing only the lighting is never coarser
/// than nothing and never finer than broadcasting.
#[test]
fn vrs_writes_the_sri_it_measures_and_saves_evaluations() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/raster_4x.exr");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("vrs");
    let run = |mode: &str| -> serde_json::Value {
        let o = gbuf_cmd(
            dir.path(),
            &[
                "vrs",
                fixture.to_str().unwrap(),
                "--tile",
                "8,16",
                "--mode",
                mode,
                "--extra-rates",
                "--out",
                out.to_str().unwrap(),
                "--json",
            ],
        );
        assert!(o.status.success(), "{}", support::stderr(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let broadcast = run("broadcast");
    let full = broadcast["full_rate_evaluations"].as_u64().unwrap();
    // gbuf's SRI and the oracle at its budget save on this frame (ffx's absolute cutoff may keep it at full rate).
    for row in broadcast["rows"].as_array().unwrap().iter().filter(|r| r["generator"] != "ffx") {
        let e = row["evaluations"].as_u64().unwrap();
        assert!(e < full && row["saved"].as_f64().unwrap() > 0.0, "{row}");
        assert!(row["vs_full_rate"]["rmse"].as_f64().unwrap() > 0.0, "coarse shading changes the image: {row}");
        assert!(row["vs_full_rate"]["flip_ldr"].as_f64().unwrap() < 0.2, "{row}");
    }
    // The SRI file is the library's SRI of the same frame and mask, in D3D12_SHADING_RATE values.
    let loaded = gbuf::load(&fixture, &Default::default()).unwrap();
    let gb = &loaded.gbuffer;
    let mask = detect(gb, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    let rule = gbuf::detect::rate::Smoothness::default();
    // With the lights and the lighting `gbuf vrs` chooses for the frame (the rule's preview term reads them).
    let lights = loaded.lights.clone().expect("the fixture's sidecar has lights");
    let lighting = gbuf::resolve::Lighting::choose(None, None, &gb.attributes());
    let preview =
        gbuf::resolve::LightPreview::new(gb, &lights, lighting.falloff, lighting.brdf, Default::default()).unwrap();
    let lit: Option<&dyn gbuf::detect::rate::Preview> = Some(&preview);
    let sri = gbuf::detect::rate::gbuffer_sri(gb, lit, &mask, 16, true, &rule).unwrap();
    let read =
        gbuf::layout::texture::read(&out.join("sri_gbuffer_16.dds"), gbuf::layout::Format::R8, &Default::default())
            .unwrap();
    assert_eq!((read.width, read.height, read.slices), (sri.cols, sri.rows, 1));
    assert_eq!(read.bytes, sri.d3d12_texels());
    let row = |json: &serde_json::Value, g: &str, tile: u64| {
        json["rows"].as_array().unwrap().iter().find(|r| r["generator"] == g && r["tile"] == tile).unwrap().clone()
    };
    let evals = |r: serde_json::Value| r["evaluations"].as_u64().unwrap();
    assert_eq!(gbuf::detect::rate::evaluations(gb, &mask, &sri), evals(row(&broadcast, "gbuffer", 16)));
    // The oracle, at gbuf's budget: no more evaluations.
    for tile in [8, 16] {
        assert!(evals(row(&broadcast, "oracle", tile)) <= evals(row(&broadcast, "gbuffer", tile)));
    }
    // --max-flip: the most saving of the rule's scaled thresholds within the bound, never less than a stricter
    // rule's.
    let o = gbuf_cmd(dir.path(), &["vrs", fixture.to_str().unwrap(), "--tile", "16", "--max-flip", "0.01", "--json"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let capped: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let best = row(&capped, "gbuffer-max-flip", 16);
    assert!(best["vs_full_rate"]["flip_ldr"].as_f64().unwrap() <= 0.01, "{best}");
    let strictest = gbuf::detect::rate::Smoothness {
        depth_relative: rule.depth_relative * 0.25,
        normal_deg: rule.normal_deg * 0.25,
        albedo: rule.albedo * 0.25,
        lobe: rule.lobe * 0.25,
        preview: rule.preview * 0.25,
        ..rule
    };
    let strict = gbuf::detect::rate::gbuffer_sri(gb, lit, &mask, 16, false, &strictest).unwrap();
    assert!(evals(best) <= gbuf::detect::rate::evaluations(gb, &mask, &strict));
    // Sharing only the lighting ignores albedo contrast: at least as coarse as broadcasting.
    let lighting = run("lighting");
    for tile in [8, 16] {
        assert!(evals(row(&lighting, "gbuffer", tile)) <= evals(row(&broadcast, "gbuffer", tile)));
    }
    // ffx with the additional rates is AMD's build that has them, on the full-rate image the run wrote, clamped to
    // the frame's 4 samples as D3D12 clamps it.
    let full_rate =
        gbuf::image::file::read(&out.join("full_rate.exr"), &gbuf::io::ReadLimits::default()).unwrap().image;
    let ffx = gbuf::detect::rate::ffx_sri(&full_rate, 16, 0.015, 64, true).unwrap().clamped(gb.samples, true);
    let read = gbuf::layout::texture::read(&out.join("sri_ffx_16.dds"), gbuf::layout::Format::R8, &Default::default())
        .unwrap();
    assert_eq!(read.bytes, ffx.d3d12_texels());
    // A looser VarianceCutoff coarsens ffx (the same build of AMD's pass both times); a negative one is refused.
    let ffx_at = |cutoff: &str| {
        let o = gbuf_cmd(
            dir.path(),
            &["vrs", fixture.to_str().unwrap(), "--tile", "16", "--no-flip", "--ffx-cutoff", cutoff, "--json"],
        );
        assert!(o.status.success(), "{}", support::stderr(&o));
        evals(row(&serde_json::from_slice(&o.stdout).unwrap(), "ffx", 16))
    };
    assert!(ffx_at("1") < ffx_at("0.015"));
    let bad = gbuf_cmd(dir.path(), &["vrs", fixture.to_str().unwrap(), "--ffx-cutoff=-1"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(support::stderr(&bad).contains("--ffx-cutoff"), "{}", support::stderr(&bad));
}
