//! Cross-check with the reference implementation: the Python `OpenEXR` package (OpenEXR's own bindings) reads our
//! canonical file and must see the same bits. Required in CI (`.ci/run`
//! installs it with pip; `support::python_has` fails the test there when it cannot run), skipped with a note elsewhere.

mod support;

use gbuf::gbuffer::{Attribute, PlaneRef};
use std::process::Command;

const SCRIPT: &str = r#"
import sys, json, OpenEXR, numpy as np
f = OpenEXR.File(sys.argv[1], separate_channels=True)
h = f.header()
ch = f.channels()
out = {"samples": str(h.get("gbuf.samples")), "format": str(h.get("gbuf.format")), "channels": {}}
for name in sys.argv[2:]:
    px = ch[name].pixels
    out["channels"][name] = [int(v) for v in px.reshape(-1).view(np.uint32)]
print(json.dumps(out))
"#;

#[test]
fn python_openexr_reads_our_bits() {
    if !support::python_has("OpenEXR, numpy") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let gb = support::every_attribute(5, 3, 4, 77);
    let p = dir.path().join("x.exr");
    gbuf::io::canonical::write(&p, &gb).unwrap();
    let names =
        ["s0.depth.Z", "s3.normal.X", "s1.albedo.B", "s2.material_id.ID", "s3.primitive_id.ID", "s1.coverage.V"];
    let mut args = vec!["-c".to_string(), SCRIPT.to_string(), p.display().to_string()];
    args.extend(names.iter().map(|s| s.to_string()));
    let o = Command::new("python3").args(&args).output().unwrap();
    assert!(o.status.success(), "python: {}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // Python may print header strings with quotes or as bytes; compare the content.
    assert!(v["samples"].as_str().unwrap().contains('4'), "{}", v["samples"]);
    assert!(v["format"].as_str().unwrap().contains("gbuf-canonical"), "{}", v["format"]);
    let spp = gb.samples as usize;
    let expect = |attr: Attribute, s: usize, comp: usize| -> Vec<u64> {
        (0..gb.pixel_count())
            .map(|p| {
                let i = p * spp + s;
                u64::from(match gb.plane(attr).unwrap() {
                    PlaneRef::F32(v) => v[i].to_bits(),
                    PlaneRef::Vec2(v) => v[i][comp].to_bits(),
                    PlaneRef::Vec3(v) => v[i][comp].to_bits(),
                    PlaneRef::U32(v) => v[i],
                })
            })
            .collect()
    };
    let got = |name: &str| -> Vec<u64> {
        v["channels"][name].as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect()
    };
    assert_eq!(got("s0.depth.Z"), expect(Attribute::Depth, 0, 0));
    assert_eq!(got("s3.normal.X"), expect(Attribute::Normal, 3, 0));
    assert_eq!(got("s1.albedo.B"), expect(Attribute::Albedo, 1, 2));
    assert_eq!(got("s2.material_id.ID"), expect(Attribute::MaterialId, 2, 0));
    assert_eq!(got("s3.primitive_id.ID"), expect(Attribute::PrimitiveId, 3, 0));
    let cov: Vec<u64> = (0..gb.pixel_count()).map(|p| u64::from(gb.coverage[p * spp + 1])).collect();
    assert_eq!(got("s1.coverage.V"), cov);
}
