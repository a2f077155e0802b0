//! `gbuf codecs` run as a user would: the built binary in a fresh temp dir.
mod support;

fn gbuf(args: &[&str]) -> std::process::Output {
    support::gbuf(tempfile::tempdir().unwrap().path(), args)
}

#[test]
fn json_rows_carry_the_documented_fields_and_sane_values() {
    let out = gbuf(&["codecs", "--json", "--bits", "16,48", "--samples", "4000", "--timing-samples", "2000"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["codec"].as_str().unwrap()).collect();
    for expected in ["oct-16", "oct-precise-16", "spheremap-cry-16", "lambert-16", "xyz-snorm-48", "xyz-f16-48"] {
        assert!(names.contains(&expected), "{expected} missing from {names:?}");
    }
    for r in &rows {
        for field in ["bits", "mean_deg", "max_deg", "encode_ns", "decode_ns", "bound_deg"] {
            assert!(r[field].as_f64().is_some(), "{}: no {field}", r["codec"]);
        }
        let (mean, max, dom, bound) = (
            r["mean_deg"].as_f64().unwrap(),
            r["max_deg"].as_f64().unwrap(),
            r["max_domain_deg"].as_f64().unwrap(),
            r["bound_deg"].as_f64().unwrap(),
        );
        assert!(mean <= max && dom <= bound, "{r}");
        assert!(r["encode_ns"].as_f64().unwrap() > 0.0, "{r}");
        let timing = r["timing"].as_str().unwrap();
        assert!(timing.starts_with("slice, 1 thread, "), "{r}");
        assert!(["baseline", "avx2", "avx512"].iter().any(|i| timing.ends_with(i)), "{r}");
    }
    let oct = rows.iter().find(|r| r["codec"] == "oct-16").unwrap();
    assert_eq!(oct["exhaustive"]["codes"], 65536);
    assert_eq!(oct["exhaustive"]["reencode_mismatches"], 0);
    let mean = oct["mean_deg"].as_f64().unwrap();
    assert!((mean - 0.337).abs() < 0.03, "oct-16 mean {mean}° vs Cigolle's 0.33709°");
}

#[test]
fn text_output_is_a_table() {
    let out = gbuf(&["codecs", "--schemes", "oct", "--bits", "20", "--samples", "1000", "--no-exhaustive"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.lines().any(|l| l.starts_with("oct-20")), "{text}");
}

#[test]
fn bad_flags_fail_with_a_clear_message() {
    for (args, needle) in [
        (&["codecs", "--bits", "17"][..], "17 bits"),
        (&["codecs", "--bits", "abc"][..], "not a bit count"),
        (&["codecs", "--schemes", "octa"][..], "unknown scheme"),
        (&["codecs", "--samples", "0"][..], "--samples"),
    ] {
        let out = gbuf(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
