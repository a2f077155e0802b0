//! The `demo`, `report` and `budget` commands through the built binary, in fresh temp dirs.
mod support;

use support::gbuf_command as gbuf;

use std::path::Path;

fn check_png(path: &Path) -> (u32, u32) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (img.width(), img.height())
}

#[test]
fn demo_writes_the_report_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nested/gbuf-demo");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = gbuf()
        .args(["demo", "--width", "64", "--height", "36", "--msaa", "4", "--runs", "1"])
        .args(["--candidates", "fat-20,minimal-8,reference-f32", "--json", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is JSON");
    assert_eq!(json["frames"][0]["width"], 64);
    assert_eq!(json["rows"].as_array().unwrap().len(), 9);
    for key in [
        "layout",
        "bytes_per_sample",
        "detector",
        "normal_mean_deg",
        "normal_max_deg",
        "layout_error",
        "aa_error",
        "total_error",
        "bandwidth_mb",
        "resolve_pass_ms",
        "shading_fraction",
        "encode_ms",
        "decode_ms",
        "resolve_ms",
        "pareto",
    ] {
        assert!(json["rows"][0].get(key).is_some(), "row lacks {key}");
    }
    for key in [
        "constant",
        "absent",
        "material_count",
        "material_id_bits",
        "normals_face_camera",
        "depth_range",
        "pruned_layout",
    ] {
        assert!(json["frames"][0]["needs"].get(key).is_some(), "needs lacks {key}");
    }
    for f in ["report.md", "report.csv", "report.json", "error_vs_bytes.svg"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // The pruned layout comes with its shader code (the room's pruned layout keeps emittable codecs).
    for ext in ["toml", "glsl", "hlsl"] {
        let text = std::fs::read_to_string(out.join(format!("pruned_layout.{ext}"))).unwrap();
        assert!(ext == "toml" || text.contains("GbufSurface gbuf_unpack("), "pruned_layout.{ext}");
    }
    assert_eq!(std::fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
    assert_eq!(check_png(&out.join("error_vs_bytes.png")), gbuf::report::figures::PLOT_SIZE);
    assert_eq!(check_png(&out.join("error_vs_time.png")), gbuf::report::figures::PLOT_SIZE);
    // A heatmap plot: the 64×36 grid plus axes and a colour bar.
    let (w, h) = check_png(&out.join("lights_per_pixel.png"));
    assert!(w > 64 && h > 36, "lights_per_pixel.png is {w}×{h}");
    assert_eq!(check_png(&out.join("edges_lauritzen.png")), (64, 36));
    let csv = std::fs::read_to_string(out.join("report.csv")).unwrap();
    assert_eq!(csv.lines().count(), 10, "header + 9 rows");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("![") && md.contains("| fat-20 |"));
    // The pipelines table: every pipeline has a row (the room is rendered with primitive IDs).
    assert!(md.contains("## Forward or deferred: the pipelines on this frame"), "{md}");
    for p in [
        "forward",
        "forward-msaa",
        "forward-plus",
        "deferred-quad",
        "tiled-deferred",
        "light-prepass",
        "visibility-buffer",
    ] {
        assert!(
            md.lines().any(|l| l.starts_with(&format!("| {p} ")) || l.starts_with(&format!("| {p} (est.)"))),
            "no row for {p}"
        );
    }
    let fwd = &json["frames"][0]["pipelines"]["forward_msaa"];
    assert!(
        fwd["lanes"].as_u64().unwrap() >= fwd["covered_lanes"].as_u64().unwrap() && fwd["quads"].as_u64().unwrap() > 0
    );
    assert!(out.join("shading_per_pixel_forward_msaa.png").is_file());
    // The demo renders the 1-sample room too: MLAA works on the pixel-centre image, forward's quads are exact, and
    // the anti-aliasing picture is linked.
    assert!(md.contains("The no-AA image is the 1-sample render at pixel centres"), "{md}");
    assert!(md.lines().any(|l| l.starts_with("| forward |")), "forward is not an estimate in the demo");
    assert!(md.contains("aa_crops.png") && out.join("aa_crops.png").is_file());
    // The demo knows its geometry: the visibility buffer is re-materialised from the room's triangles, exactly.
    assert!(md.contains("re-materialised from the `room` scene's triangles") && md.contains("bit-identical"), "{md}");
    // Every image the markdown links exists.
    for line in md.lines().filter(|l| l.starts_with("![")) {
        let target = line.split("](").nth(1).unwrap().trim_end_matches(')');
        // An A/B pair names its other image as the title: `![…](a.png "b.png")`.
        for file in target.split(" \"").map(|f| f.trim_end_matches('"')) {
            assert!(out.join(file).is_file(), "{file} linked but missing");
        }
    }
}

#[test]
fn report_on_a_canonical_dump_and_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("room.exr");
    let o = gbuf()
        .args(["scene", "room", "--width", "48", "--height", "27", "--msaa", "2", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(o.status.success(), "scene: {}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("rep");
    let o = gbuf()
        .arg("report")
        .arg(&exr)
        .args(["--candidates", "minimal-8,lauritzen-15", "--detectors", "lauritzen", "--runs", "1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "report: {}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("minimal-8") && text.contains("report.md"), "{text}");
    assert!(out.join("report.json").is_file());
    // The worst layouts' error maps as float EXRs beside the report, linked from report.md: their largest values
    // are the rows' largest errors.
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let mut seen = 0;
    // Where each layout binds, at the frame's 2×: the library's verdicts, in report.json and report.md.
    for layout in ["minimal-8", "lauritzen-15"] {
        let fit = json["frames"][0]["fits"].as_array().unwrap().iter().find(|f| f["layout"] == layout).unwrap();
        let l = gbuf::layout::Layout::by_name(layout).unwrap();
        let want: Vec<&str> = gbuf::layout::limits::PLATFORMS
            .iter()
            .filter(|p| gbuf::layout::limits::check(p, l.formats(), 2).fits())
            .map(|p| p.name)
            .collect();
        assert_eq!(fit["fits"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect::<Vec<_>>(), want);
    }
    // (2× is guaranteed nowhere: WebGPU and Vulkan promise 1× and 4×.)
    assert!(md.contains("bind as one 2× pass") && md.contains("- minimal-8: none"), "{md}");
    for layout in ["minimal-8", "lauritzen-15"] {
        let file = format!("error_maps_{}.exr", layout.replace('-', "_"));
        let Ok(raw) = gbuf::io::exr::read_raw(&out.join(&file), &Default::default()) else { continue };
        seen += 1;
        assert!(md.contains(&format!("[{file}]({file})")), "report.md links {file}");
        let row = json["rows"].as_array().unwrap().iter().find(|r| r["layout"] == layout).unwrap();
        for (channel, key) in
            [("normal_deg", "normal_max_deg"), ("depth_rel", "depth_rel_max"), ("albedo_abs", "albedo_max_abs")]
        {
            let c = raw.channels.iter().find(|c| c.name == channel).unwrap_or_else(|| panic!("{file}: {channel}"));
            let gbuf::io::raw::RawData::F32(v) = &c.data else { panic!("{file}: {channel} is not f32") };
            let max = v.iter().copied().filter(|x| !x.is_nan()).fold(0.0f32, f32::max) as f64;
            let want = row[key].as_f64().unwrap();
            assert!((max - want).abs() <= 1e-3 * want.abs() + 1e-9, "{file} {channel}: max {max}, row {want}");
        }
    }
    assert!(seen >= 1, "no error map EXR in {:?}", std::fs::read_dir(&out).unwrap().collect::<Vec<_>>());

    // Garbage input: exit 1 with the file named, no panic.
    let bad = dir.path().join("bad.exr");
    std::fs::write(&bad, b"not an exr at all").unwrap();
    let o = gbuf().arg("report").arg(&bad).arg("-o").arg(dir.path().join("x")).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.exr") && !err.contains("panicked"), "{err}");
    // Unknown layout / detector names: usage errors (exit 2) with the known names, and the nearest when close.
    let o = gbuf().arg("report").arg(&exr).args(["--candidates", "nope"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let o = gbuf().arg("report").arg(&exr).args(["--layouts", "lauritzen15x"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("did you mean \"lauritzen-15\""));
    // An unknown name in an enum flag is a usage error (exit 2) like every other flag value clap refuses.
    let o = gbuf().arg("report").arg(&exr).args(["--detectors", "nope"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("lauritzen"));
    let o = gbuf().arg("budget").arg(&bad).args(["--max-bytes", "12"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
}

#[test]
fn budget_writes_a_layout_that_loads() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("room.exr");
    let o = gbuf()
        .args(["scene", "room", "--width", "48", "--height", "27", "--msaa", "2", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(o.status.success(), "scene: {}", String::from_utf8_lossy(&o.stderr));
    let toml = dir.path().join("best.toml");
    let o = gbuf().arg("budget").arg(&exr).args(["--max-bytes", "12", "--json", "-o"]).arg(&toml).output().unwrap();
    assert!(o.status.success(), "budget: {}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bytes = json["winner"]["bytes_per_sample"].as_u64().unwrap();
    assert!(bytes <= 12);
    let l = gbuf::layout::Layout::load(&toml).unwrap();
    assert_eq!(l.bytes_per_sample() as u64, bytes);
}

/// Rows recomputed from report.json: each flagged row is non-dominated in (bytes, layout error) and in (resolve
/// pass time, layout error) among its frame's rows; unflagged rows are dominated.
fn check_fronts(rows: &[serde_json::Value]) {
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    for r in rows {
        let same: Vec<&serde_json::Value> = rows.iter().filter(|q| q["frame"] == r["frame"]).collect();
        for (axis, cost) in [("bytes", "bytes_per_sample"), ("time", "resolve_pass_ms")] {
            let p = (num(&r[cost]), num(&r["layout_error"]["rmse"]));
            let dominated = same.iter().any(|q| {
                let q = (num(&q[cost]), num(&q["layout_error"]["rmse"]));
                q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1)
            });
            let on = r["pareto"][axis].as_bool().unwrap();
            assert_eq!(on, !dominated && p.0.is_finite() && p.1.is_finite(), "{axis}: {} {}", r["frame"], r["layout"]);
        }
    }
}

#[test]
fn report_over_several_frames_merges_to_the_same_answer() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("capture");
    std::fs::create_dir_all(&frames).unwrap();
    for (name, w, h) in [("a", "40", "24"), ("b", "48", "27")] {
        let o = gbuf()
            .args(["scene", "room", "--width", w, "--height", h, "--msaa", "2", "-o"])
            .arg(frames.join(format!("{name}.exr")))
            .output()
            .unwrap();
        assert!(o.status.success(), "scene: {}", String::from_utf8_lossy(&o.stderr));
    }
    let common = ["--candidates", "minimal-8,destiny-96,reference-f32", "--detectors", "lauritzen,ssaa", "--runs", "1"];
    // One run over the directory (both frames).
    let all = dir.path().join("all");
    let o = gbuf()
        .arg("report")
        .arg(&frames)
        .args(common)
        .args(["--max-bytes", "12", "--json", "-o"])
        .arg(&all)
        .output()
        .unwrap();
    assert!(o.status.success(), "report: {}", String::from_utf8_lossy(&o.stderr));
    let one: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(one["frames"].as_array().unwrap().len(), 2);
    let rows = one["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2 * 3 * 2);
    check_fronts(rows);
    for r in rows.iter().filter(|r| r["layout"] == "reference-f32") {
        assert_eq!(r["layout_error"]["rmse"], 0.0, "lossless: layout error 0");
    }
    let agg = one["aggregate"].as_array().unwrap();
    assert_eq!(agg.len(), 3 * 2);
    for a in agg {
        assert_eq!(a["frames"], 2);
        let st = &a["layout_rmse"];
        assert!(st["worst"].as_f64().unwrap() >= st["mean"].as_f64().unwrap());
        assert!(st["worst_frame"].as_str().unwrap().ends_with(".exr"));
    }
    let choice = &one["budget"];
    assert_eq!(choice["max_bytes"], 12);
    assert!(["minimal-8", "destiny-96"].contains(&choice["layout"].as_str().unwrap()), "{choice}");
    for f in ["report.md", "aggregate.csv", "error_vs_bytes.png", "frame1_reference.png", "frame2_reference.png"] {
        assert!(all.join(f).is_file(), "{f} missing");
    }

    // One run per frame, merged: the same aggregate, fronts and budget choice.
    let mut jsons = Vec::new();
    for name in ["a", "b"] {
        let out = dir.path().join(format!("rep-{name}"));
        let o = gbuf()
            .arg("report")
            .arg(frames.join(format!("{name}.exr")))
            .args(common)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "report {name}: {}", String::from_utf8_lossy(&o.stderr));
        jsons.push(out.join("report.json"));
    }
    let merged = dir.path().join("merged");
    let o = gbuf().arg("merge").args(&jsons).args(["--max-bytes", "12", "--json", "-o"]).arg(&merged).output().unwrap();
    assert!(o.status.success(), "merge: {}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // Errors and the bytes front are deterministic; the time front rests on each run's own measured times, so
    // two separate runs need not agree on it.
    let key = |a: &serde_json::Value| {
        (
            a["layout"].clone(),
            a["detector"].clone(),
            a["pareto"]["bytes"].clone(),
            a["frames"].clone(),
            a["layout_rmse"].clone(),
            a["aa_rmse"].clone(),
        )
    };
    let (ka, kb): (Vec<_>, Vec<_>) =
        (agg.iter().map(key).collect(), m["aggregate"].as_array().unwrap().iter().map(key).collect());
    assert_eq!(ka, kb, "same aggregate rows, errors and bytes front");
    // Merging the combined run's own report.json reproduces its aggregate exactly, time front included.
    let again = dir.path().join("again");
    let o = gbuf()
        .arg("merge")
        .arg(all.join("report.json"))
        .args(["--max-bytes", "12", "--json", "-o"])
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "merge: {}", String::from_utf8_lossy(&o.stderr));
    let again: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(again["aggregate"], one["aggregate"]);
    assert_eq!(again["budget"], one["budget"]);
    assert_eq!(m["budget"]["layout"], choice["layout"]);
    assert!(merged.join("report.md").is_file() && merged.join("aggregate.csv").is_file());
    // Merging a frame twice is refused.
    let o = gbuf().arg("merge").arg(&jsons[0]).arg(&jsons[0]).arg("-o").arg(dir.path().join("x")).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("each frame once"));

    // The budget over both frames: the winner's error is reported on each frame, the worst one decides.
    let o = gbuf().arg("budget").arg(&frames).args(["--max-bytes", "12", "--json"]).output().unwrap();
    assert!(o.status.success(), "budget: {}", String::from_utf8_lossy(&o.stderr));
    let b: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let w = &b["winner"];
    let per: Vec<f64> =
        w["frames"].as_array().unwrap().iter().map(|f| f["layout_error"]["rmse"].as_f64().unwrap()).collect();
    assert_eq!(per.len(), 2);
    assert_eq!(w["rmse"].as_f64().unwrap(), per.iter().copied().fold(0.0, f64::max), "worst frame decides");
    assert!(w["bytes_per_sample"].as_u64().unwrap() <= 12);
}

#[test]
fn fronts_hold_on_the_shipped_fixtures() {
    // A real rasterizer's 4× MSAA G-buffer (Mesa llvmpipe) and Blender's Cycles dump: the fronts recomputed from
    // report.json, and the lossless layout at layout error 0 on each.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    for fixture in ["raster_4x.exr", "blender_gbuffer.exr"] {
        let dir = tempfile::tempdir().unwrap();
        let o = gbuf()
            .arg("report")
            .arg(root.join(fixture))
            .args([
                "--candidates",
                "minimal-8,destiny-96,bevy-deferred,reference-f32",
                "--detectors",
                "lauritzen,combined",
            ])
            .args(["--runs", "1", "--json", "-o"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{fixture}: {}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let rows = v["rows"].as_array().unwrap();
        check_fronts(rows);
        for r in rows.iter().filter(|r| r["layout"] == "reference-f32") {
            assert_eq!(r["layout_error"]["rmse"], 0.0, "{fixture}");
        }
        // The lossless layout is never behind a lossy one on the bytes front's error axis.
        let min_lossy = rows
            .iter()
            .filter(|r| r["layout"] != "reference-f32")
            .map(|r| r["layout_error"]["rmse"].as_f64().unwrap())
            .fold(f64::INFINITY, f64::min);
        assert!(min_lossy >= 0.0);
        assert!(dir.path().join("flip_worst_layout.png").is_file(), "{fixture}: FLIP map of the worst layout");
    }
}
