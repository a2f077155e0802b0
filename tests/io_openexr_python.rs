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

const ALL_CHANNELS: &str = r#"
import sys, json, OpenEXR, numpy as np
f = OpenEXR.File(sys.argv[1], separate_channels=True)
h = f.header()
out = {"compression": str(h.get("compression")), "note": str(h.get("gbuf.note")), "channels": {}}
for name, ch in f.channels().items():
    px = ch.pixels
    view = np.uint16 if px.dtype == np.float16 else np.uint32
    out["channels"][name] = {"dtype": str(px.dtype), "shape": list(px.shape),
                             "bits": [int(v) for v in px.reshape(-1).view(view)]}
print(json.dumps(out))
"#;

/// Our own block writer (ZIP and NONE) against OpenEXR's reader: several ZIP blocks with a short last one, every
/// sample type, an odd row length of halves, a name past 31 bytes (the long-names flag), and a block too random to
/// shrink (stored raw) — OpenEXR must see every bit.
#[test]
fn python_openexr_reads_every_block_kind_we_write() {
    use gbuf::io::exr::{write_raw_with, RawChannel, RawData, RawImage, WriteCompression};
    if !support::python_has("OpenEXR, numpy") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (13u32, 37u32);
    let n = (w * h) as usize;
    let mut rng = gbuf::base::rng::SplitMix64::new(3);
    let noise: Vec<u32> = (0..n).map(|_| rng.next_u64() as u32).collect();
    let smooth = RawImage {
        width: w,
        height: h,
        channels: vec![
            RawChannel { name: "Z".into(), data: RawData::F32((0..n).map(|i| i as f32 * 0.5 - 7.0).collect()) },
            RawChannel {
                name: "albedo.R".into(),
                data: RawData::F16((0..n).map(|i| half::f16::from_f32((i % 9) as f32 / 8.0)).collect()),
            },
            RawChannel { name: "id.ID".into(), data: RawData::U32((0..n).map(|i| (i / 50) as u32).collect()) },
            RawChannel {
                name: "a.channel.name.longer.than.31.bytes".into(),
                data: RawData::F32(vec![f32::MIN_POSITIVE / 16.0; n]),
            },
        ],
        attributes: vec![("gbuf.note".into(), "written by gbuf".into())],
        ..Default::default()
    };
    let random = RawImage {
        width: w,
        height: h,
        channels: vec![RawChannel { name: "noise.V".into(), data: RawData::U32(noise) }],
        ..Default::default()
    };
    for (what, img) in [("smooth", &smooth), ("random", &random)] {
        for c in [WriteCompression::Zip, WriteCompression::None] {
            let p = dir.path().join(format!("{what}-{c}.exr"));
            write_raw_with(&p, img, c).unwrap();
            let o = Command::new("python3").args(["-c", ALL_CHANNELS, &p.display().to_string()]).output().unwrap();
            assert!(o.status.success(), "{what}/{c}: python: {}", String::from_utf8_lossy(&o.stderr));
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let want_c = if c == WriteCompression::Zip { "ZIP" } else { "NO" };
            assert!(v["compression"].as_str().unwrap().contains(want_c), "{what}/{c}: {}", v["compression"]);
            assert_eq!(v["channels"].as_object().unwrap().len(), img.channels.len(), "{what}/{c}");
            for ch in &img.channels {
                let got = &v["channels"][&ch.name];
                assert_eq!(got["shape"], serde_json::json!([h, w]), "{what}/{c}: {}", ch.name);
                let bits: Vec<u64> = got["bits"].as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect();
                let want: Vec<u64> = match &ch.data {
                    RawData::F16(v) => v.iter().map(|x| u64::from(x.to_bits())).collect(),
                    RawData::F32(v) => v.iter().map(|x| u64::from(x.to_bits())).collect(),
                    RawData::U32(v) => v.iter().map(|&x| u64::from(x)).collect(),
                };
                assert_eq!(bits, want, "{what}/{c}: {} ({})", ch.name, got["dtype"]);
            }
            if what == "smooth" {
                assert!(v["note"].as_str().unwrap().contains("written by gbuf"), "{}", v["note"]);
            }
        }
    }
}
