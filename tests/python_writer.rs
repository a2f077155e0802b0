//! `python/gbuf_dump.py`, the canonical-EXR writer for capture code written in Python (numpy + OpenEXR, no build
//! step): its self-test frame (every attribute, IDs up to 2^32 − 1, background, a camera and sample positions)
//! reads in gbuf as exactly the arrays it was given, bit for bit; and bad input is refused before anything is
//! written. Required in CI (`.ci/run` installs numpy and OpenEXR).

mod support;

use gbuf::gbuffer::{Attribute, PlaneRef};
use gbuf::io::{load, LoadOptions};
use std::path::Path;
use std::process::Command;

/// Writes the self-test frame and dumps its `.npz` arrays as raw little-endian files `<name>.raw`.
const DUMP: &str = r#"
import sys, numpy as np
z = np.load(sys.argv[1])
for k in z.files:
    a = z[k]
    if a.dtype == np.bool_:
        a = a.astype(np.uint8)
    open(sys.argv[2] + "/" + k + ".raw", "wb").write(np.ascontiguousarray(a).tobytes())
print(" ".join(z.files))
"#;

#[test]
fn the_python_writer_round_trips_through_gbuf_bit_for_bit() {
    if !support::python_has("OpenEXR, numpy") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let o = Command::new("python3")
        .arg("-B")
        .arg(root.join("python/gbuf_dump.py"))
        .arg("--selftest")
        .arg(dir.path())
        .output()
        .expect("python3");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dump = dir.path().join("dump.py");
    std::fs::write(&dump, DUMP).unwrap();
    let o = Command::new("python3")
        .arg("-B")
        .arg(&dump)
        .arg(dir.path().join("selftest.npz"))
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let loaded = load(&dir.path().join("selftest.exr"), &LoadOptions::default()).unwrap();
    let gb = &loaded.gbuffer;
    assert_eq!((gb.width, gb.height, gb.samples), (17, 9, 4));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let raw = |name: &str| std::fs::read(dir.path().join(format!("{name}.raw"))).unwrap();
    let cov = raw("coverage");
    assert_eq!(gb.coverage.iter().map(|&c| u8::from(c)).collect::<Vec<_>>(), cov, "coverage");
    assert!(cov.contains(&0) && cov.contains(&1));
    let words = |b: Vec<u8>| b.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect::<Vec<u32>>();
    for a in Attribute::ALL {
        let want = words(raw(a.name()));
        let got: Vec<u32> = match gb.plane(a).unwrap_or_else(|| panic!("{} missing", a.name())) {
            PlaneRef::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
            PlaneRef::U32(v) => v.to_vec(),
            PlaneRef::Vec2(v) => v.iter().flat_map(|x| [x.x.to_bits(), x.y.to_bits()]).collect(),
            PlaneRef::Vec3(v) => v.iter().flat_map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()]).collect(),
        };
        assert_eq!(got, want, "{}", a.name());
    }
    assert!(words(raw("object_id")).contains(&u32::MAX) || words(raw("primitive_id")).contains(&u32::MAX));
    let pos: Vec<u32> = gb.sample_positions.iter().flat_map(|p| [p.x.to_bits(), p.y.to_bits()]).collect();
    assert_eq!(pos, words(raw("sample_positions")));
    let cam = gb.camera.expect("camera");
    let c = words(raw("camera"));
    assert_eq!([cam.yfov, cam.aspect, cam.znear, cam.zfar].map(f32::to_bits).to_vec(), c);
    // Bad input: a ValueError naming the attribute, and no file written.
    let bad = dir.path().join("bad.py");
    std::fs::write(
        &bad,
        format!(
            "import sys, numpy as np\nsys.path.insert(0, {:?})\nimport gbuf_dump\ntry:\n    gbuf_dump.write_canonical(sys.argv[1], {{'coverage': np.ones((2, 3, 1), bool), 'object_id': -np.ones((2, 3, 1, 1), np.int64)}})\nexcept ValueError as e:\n    print('refused:', e)\n",
            root.join("python").display().to_string()
        ),
    )
    .unwrap();
    let out = dir.path().join("bad.exr");
    let o = Command::new("python3").arg("-B").arg(&bad).arg(&out).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("refused") && text.contains("object_id"), "{text} {}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.exists());
}
