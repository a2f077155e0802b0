//! `gbuf compare` against NVIDIA's own FLIP tool (the `flip` command of PyPI's `flip-evaluator`, run through its
//! Python entry point): every pooled statistic it prints (mean, weighted median, 1st and 3rd weighted quartiles,
//! min, max) on LDR (PNG) and HDR (EXR) pairs lit by gbuf from two fixtures; idiff's exit statuses; the outputs.
//! The cross-check is required in CI (`.ci/run` installs flip-evaluator), a noted skip elsewhere.

mod support;

use std::path::Path;
use std::process::{Command, Stdio};

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name).display().to_string()
}

/// Lights `dump` twice (the reference, and through `layout`) into `<tag>-ref/test.{exr,png}` in `dir`.
fn pair(dir: &Path, dump: &str, layout: &str, tag: &str) {
    for (name, extra) in [("ref", None), ("test", Some(layout))] {
        let exr = format!("{tag}-{name}.exr");
        let png = format!("{tag}-{name}.png");
        let mut args = vec!["resolve", dump, "-o", &exr, "--png", &png];
        if let Some(l) = extra {
            args.extend(["--layout", l]);
        }
        let o = support::gbuf(dir, &args);
        assert!(o.status.success(), "{}", support::stderr(&o));
    }
}

/// NVIDIA's tool's printout: the six statistics in its order.
fn nvidia(dir: &Path, reference: &str, test: &str) -> Vec<f64> {
    let o = Command::new("python3")
        .current_dir(dir)
        .args([
            "-c",
            "import sys; from flip_evaluator.flip_python_api import main; sys.argv = ['flip'] + sys.argv[1:]; main()",
            "-r",
            reference,
            "-t",
            test,
            "--no-error-map",
        ])
        .output()
        .expect("python3");
    assert!(o.status.success(), "flip: {}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    ["Mean:", "Weighted median:", "1st weighted quartile:", "3rd weighted quartile:", "Min:", "Max:"]
        .iter()
        .map(|key| {
            let line =
                text.lines().find(|l| l.trim_start().starts_with(key)).unwrap_or_else(|| panic!("{key} in {text}"));
            line.trim_start()[key.len()..].trim().parse().unwrap()
        })
        .collect()
}

fn ours(dir: &Path, reference: &str, test: &str) -> serde_json::Value {
    let o = support::gbuf(dir, &["compare", reference, test, "--json"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn compare_matches_nvidias_flip_tool_on_every_pooled_statistic() {
    if !support::python_has("flip_evaluator, numpy") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    pair(dir.path(), &fixture("raster_4x.exr"), "minimal-8", "raster");
    pair(dir.path(), &fixture("blender_gbuffer.exr"), "lauritzen-15", "blender");
    let mut checked = 0;
    for tag in ["raster", "blender"] {
        for (ext, key) in [("png", "flip_ldr"), ("exr", "flip_hdr")] {
            let (r, t) = (format!("{tag}-ref.{ext}"), format!("{tag}-test.{ext}"));
            let theirs = nvidia(dir.path(), &r, &t);
            let v = ours(dir.path(), &r, &t);
            let p = &v[key];
            let mine: Vec<f64> = ["mean", "weighted_median", "weighted_q1", "weighted_q3", "min", "max"]
                .iter()
                .map(|k| p[k].as_f64().unwrap_or_else(|| panic!("{key}.{k} in {v}")))
                .collect();
            assert!(theirs[0] > 1e-3, "{tag} {ext}: the pair must differ to test anything ({theirs:?})");
            for (i, (a, b)) in mine.iter().zip(&theirs).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-4,
                    "{tag} {ext}: statistic {i}: gbuf {a}, NVIDIA {b} ({mine:?} vs {theirs:?})"
                );
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 4);
}

#[test]
fn thresholds_and_problems_exit_as_idiff_does() {
    let dir = tempfile::tempdir().unwrap();
    pair(dir.path(), &fixture("raster_4x.exr"), "minimal-8", "r");
    let code = |args: &[&str]| {
        let mut a = vec!["compare"];
        a.extend_from_slice(args);
        let o = support::gbuf(dir.path(), &a);
        (o.status.code().unwrap(), support::stderr(&o))
    };
    assert_eq!(code(&["r-ref.png", "r-ref.png", "--fail-above", "flip=0,rmse=0"]).0, 0, "identical: pass");
    assert_eq!(code(&["r-ref.png", "r-test.png", "--fail-above", "flip=0.9"]).0, 0);
    let (c, e) = code(&["r-ref.png", "r-test.png", "--warn-above", "flip=0.001", "--fail-above", "flip=0.9"]);
    assert_eq!(c, 1, "warn: {e}");
    assert!(e.contains("WARN: flip = "), "{e}");
    let (c, e) = code(&["r-ref.exr", "r-test.exr", "--fail-above", "rmse=1e-6", "--warn-above", "flip=0.9"]);
    assert_eq!(c, 2, "fail: {e}");
    assert!(e.contains("FAIL: rmse = "), "{e}");
    // Different kinds, different sizes: 3.
    let (c, e) = code(&["r-ref.exr", "r-test.png"]);
    assert_eq!(c, 3, "{e}");
    assert!(e.contains("compare an EXR with an EXR"), "{e}");
    image::RgbImage::new(7, 5).save(dir.path().join("small.png")).unwrap();
    let (c, e) = code(&["r-ref.png", "small.png"]);
    assert_eq!(c, 3, "{e}");
    assert!(e.contains("320×180 and 7×5"), "{e}");
    // Files that cannot be read: 4, naming the file, the cause once.
    let (c, e) = code(&["r-ref.png", "missing.png"]);
    assert_eq!(c, 4, "{e}");
    assert!(e.contains("missing.png") && e.matches("No such file").count() == 1, "{e}");
    std::fs::write(dir.path().join("bad.exr"), b"not an exr").unwrap();
    assert_eq!(code(&["bad.exr", "r-ref.exr"]).0, 4);
    // A threshold on a measure that was not computed, or not a measure: usage (2), said.
    let (c, e) = code(&["r-ref.png", "r-test.png", "--flip", "none", "--fail-above", "flip=0.1"]);
    assert_eq!(c, 2);
    assert!(e.contains("was not computed"), "{e}");
    let (c, e) = code(&["r-ref.png", "r-test.png", "--fail-above", "flop=0.1"]);
    assert_eq!(c, 2);
    assert!(e.contains("flop"), "{e}");
}

#[test]
fn the_error_map_csv_and_flip_map_hold_what_was_measured() {
    let dir = tempfile::tempdir().unwrap();
    pair(dir.path(), &fixture("raster_4x.exr"), "minimal-8", "r");
    let o = support::gbuf(
        dir.path(),
        &[
            "compare",
            "r-ref.exr",
            "r-test.exr",
            "--json",
            "--error-map",
            "e.exr",
            "--flip-map",
            "f.png",
            "--csv",
            "log.csv",
        ],
    );
    assert!(o.status.success(), "{}", support::stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let raw = gbuf::io::exr::read_raw(&dir.path().join("e.exr"), &gbuf::io::exr::ReadLimits::default()).unwrap();
    let flip = raw.channel("flip").expect("a flip channel").data.to_f32_vec();
    let mean = flip.iter().map(|&x| f64::from(x)).sum::<f64>() / flip.len() as f64;
    assert!((mean - v["flip_hdr"]["mean"].as_f64().unwrap()).abs() < 1e-9, "the map is the HDR-FLIP measured");
    let r = raw.channel("R").unwrap().data.to_f32_vec();
    let largest = r.iter().fold(0.0f32, |m, &x| m.max(x));
    assert!(f64::from(largest) <= v["numeric"]["max_abs"].as_f64().unwrap() + 1e-6);
    let png = image::open(dir.path().join("f.png")).unwrap();
    assert_eq!((png.width(), png.height()), (320, 180));
    // A second run appends a row under the one header.
    let o = support::gbuf(dir.path(), &["compare", "r-ref.png", "r-test.png", "--csv", "log.csv"]);
    assert!(o.status.success(), "{}", support::stderr(&o));
    let text = std::fs::read_to_string(dir.path().join("log.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(lines[0].starts_with("Reference,Test,Mean,Weighted median"), "{text}");
    assert!(lines[1].contains(",HDR,") && lines[2].contains(",LDR,"), "{text}");
}

#[test]
fn json_into_a_closed_pipe_exits_quietly() {
    for args in [vec!["info", "fixtures/raster_4x.exr", "--json"], vec!["layouts", "--json"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_gbuf"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the read end at once: the writer meets a broken pipe (as `| head -c0` does).
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{args:?}: {:?} {}", o.status, String::from_utf8_lossy(&o.stderr));
        assert!(o.stderr.is_empty(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    }
}
