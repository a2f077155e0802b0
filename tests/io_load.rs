//! `gbuf::io::load` end to end: format detection, sidecars, folding, sanitizing, and every kind of bad input.

mod support;

use gbuf::gbuffer::Attribute;
use gbuf::io::{load, load_bytes, LoadOptions, ReadLimits, SourceFormat};
use gbuf::Error;
use std::path::{Path, PathBuf};
use support::*;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn err(p: &Path, opts: &LoadOptions) -> Error {
    match load(p, opts) {
        Ok(_) => panic!("{} loaded but should not", p.display()),
        Err(e) => e,
    }
}

const SIDECAR: &str = r#"{"camera": {"world_to_view": [[1,0,0,0],[0,1,0,0],[0,0,1,-2],[0,0,0,1]], "yfov": 0.8,
 "aspect": ASPECT, "znear": 0.1, "zfar": 100}, SUPER
 "lights": [{"type": "point", "position": [0, 1, -5], "intensity": 3, "range": 10},
            {"type": "directional", "direction": [0, -1, 0]}]}"#;

fn sidecar(aspect: f32, supersample: Option<u32>) -> String {
    SIDECAR
        .replace("ASPECT", &aspect.to_string())
        .replace("SUPER", &supersample.map_or(String::new(), |k| format!("\"supersample\": {k},")))
}

#[test]
fn canonical_with_its_sidecar_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut gb = plausible(8, 6, 4, 1);
    gb.camera = None;
    let p = write(dir.path(), "room.exr", &canonical_bytes(&gb));
    write(dir.path(), "room.json", sidecar(8.0 / 6.0, None).as_bytes());
    let l = load(&p, &LoadOptions::default()).unwrap();
    assert_eq!(l.format, SourceFormat::Canonical);
    assert_eq!(l.camera_source, "sidecar");
    let lights = l.lights.as_ref().unwrap();
    assert_eq!(lights.len(), 2);
    // World (0,1,-5) seen from a camera whose world_to_view translates z by -2.
    assert_eq!(lights[0].position, glam::Vec3::new(0.0, 1.0, -7.0));
    assert_eq!(l.gbuffer.depth, gb.depth);
    assert!(l.sanitized.is_empty());
    assert_eq!(l.compression, Some(("ZIP".to_string(), false)));
    // An explicit --scene wins over the one beside the file.
    write(dir.path(), "other.json", b"{}");
    let opts = LoadOptions { sidecar: Some(dir.path().join("other.json")), ..Default::default() };
    let l = load(&p, &opts).unwrap();
    assert_eq!(l.camera_source, "unknown");
    assert!(l.lights.is_none());
}

#[test]
fn sidecar_supersample_folds_and_fold_flag_overrides() {
    let dir = tempfile::tempdir().unwrap();
    let gb = plausible(12, 6, 1, 2);
    let p = write(dir.path(), "ss.exr", &canonical_bytes(&gb));
    write(dir.path(), "ss.json", sidecar(2.0, Some(2)).as_bytes());
    let l = load(&p, &LoadOptions::default()).unwrap();
    assert_eq!((l.gbuffer.width, l.gbuffer.height, l.gbuffer.samples), (6, 3, 4));
    let l = load(&p, &LoadOptions { fold: Some(3), ..Default::default() }).unwrap();
    assert_eq!((l.gbuffer.width, l.gbuffer.height, l.gbuffer.samples), (4, 2, 9));
    let e = err(&p, &LoadOptions { fold: Some(4), ..Default::default() }).to_string();
    assert!(e.contains("ss.exr") && e.contains("--fold") && e.contains("multiple of 4"), "{e}");
}

#[test]
fn sidecar_that_does_not_match_the_image_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let gb = plausible(12, 6, 1, 3);
    let p = write(dir.path(), "m.exr", &canonical_bytes(&gb));
    // Aspect off by 3%.
    write(dir.path(), "m.json", sidecar(2.06, None).as_bytes());
    let e = err(&p, &LoadOptions::default()).to_string();
    assert!(e.contains("m.json") && e.contains("aspect") && e.contains("12×6"), "{e}");
    // Within 1% is accepted (rounded 16:9-style aspects).
    write(dir.path(), "m.json", sidecar(2.01, None).as_bytes());
    load(&p, &LoadOptions::default()).unwrap();
    // A supersample factor that does not divide the size.
    write(dir.path(), "m.json", sidecar(2.0, Some(5)).as_bytes());
    let e = err(&p, &LoadOptions::default()).to_string();
    assert!(e.contains("m.json") && e.contains("multiple of 5"), "{e}");
    // Supersampling an already multisampled dump.
    let p4 = write(dir.path(), "ms.exr", &canonical_bytes(&plausible(12, 6, 4, 3)));
    write(dir.path(), "ms.json", sidecar(2.0, Some(2)).as_bytes());
    let e = err(&p4, &LoadOptions::default()).to_string();
    assert!(e.contains("ms.json") && e.contains("already has 4"), "{e}");
}

#[test]
fn broken_sidecar_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "b.exr", &canonical_bytes(&plausible(4, 4, 1, 4)));
    write(dir.path(), "b.json", b"{\"camera\": {\"yfov\": ");
    // Found beside the dump, a file that is not JSON may be any program's: ignored, with the reason.
    let l = load(&p, &LoadOptions::default()).unwrap();
    let w = l.warnings.iter().find(|w| w.code == gbuf::io::SIDECAR_IGNORED).expect("a warning");
    assert!(w.message.contains("b.json") && w.message.contains("not JSON"), "{}", w.message);
    // Named with --scene, it is an error that names it.
    let named = LoadOptions { sidecar: Some(dir.path().join("b.json")), ..Default::default() };
    let e = err(&p, &named);
    assert!(matches!(e, Error::Parse { .. }), "{e:?}");
    assert!(e.to_string().contains("b.json"), "{e}");
    write(dir.path(), "b.json", br#"{"lights": [{"type": "laser"}], "lights_space": "view"}"#);
    let e = err(&p, &LoadOptions::default()).to_string();
    assert!(e.contains("b.json") && e.contains("laser"), "{e}");
    let missing = LoadOptions { sidecar: Some(dir.path().join("nope.json")), ..Default::default() };
    let e = err(&p, &missing).to_string();
    assert!(e.contains("nope.json"), "{e}");
}

#[test]
fn nan_and_inf_are_counted_and_replaced() {
    let mut gb = plausible(5, 4, 2, 5);
    let d = gb.depth.as_mut().unwrap();
    d[3] = f32::NAN;
    d[4] = f32::INFINITY;
    d[7] = f32::NAN;
    gb.normal.as_mut().unwrap()[9].y = f32::NEG_INFINITY;
    gb.roughness.as_mut().unwrap()[0] = f32::NAN;
    let l = load_bytes(&canonical_bytes(&gb), Path::new("nan.exr"), &LoadOptions::default()).unwrap();
    assert_eq!(l.sanitized, vec![("depth", 2, 1), ("normal", 0, 1), ("roughness", 1, 0)]);
    let d = l.gbuffer.depth.as_ref().unwrap();
    assert!(d.iter().all(|v| v.is_finite()));
    assert_eq!(d[4], f32::MAX);
    let info = gbuf::io::stats::info(&l, Path::new("nan.exr"));
    let depth = &info.attributes.0.iter().find(|(n, _)| *n == "depth").unwrap().1;
    assert_eq!((depth.nan, depth.inf), (2, 1));
}

#[test]
fn unknown_naming_lists_channels_and_suggests_map() {
    let bytes = generic_exr(4, 3, &["Z", "Nrm.X", "Nrm.Y", "Nrm.Z"], |c, i| if c == 0 { 1.0 + i as f32 } else { 0.5 });
    let e = load_bytes(&bytes, Path::new("eng.exr"), &LoadOptions::default()).unwrap_err();
    let Error::MissingChannel { found, .. } = &e else { panic!("{e:?}") };
    assert_eq!(found, "Nrm.X, Nrm.Y, Nrm.Z, Z");
    let msg = e.to_string();
    assert!(msg.contains("eng.exr") && msg.contains("--map"), "{msg}");

    let map = vec![
        (Attribute::Depth, vec!["Z".to_string()]),
        (Attribute::Normal, vec!["Nrm.X".into(), "Nrm.Y".into(), "Nrm.Z".into()]),
    ];
    let opts = LoadOptions { map, ..Default::default() };
    let l = load_bytes(&bytes, Path::new("eng.exr"), &opts).unwrap();
    assert_eq!(l.format, SourceFormat::Mapped);
    assert_eq!(l.gbuffer.depth.as_ref().unwrap()[5], 6.0);
    assert_eq!(l.gbuffer.background_samples(), 0);
    assert_eq!(l.sources[1].channels, vec!["Nrm.X", "Nrm.Y", "Nrm.Z"]);

    // A mapped channel that does not exist is named, with the channels found.
    let opts = LoadOptions { map: vec![(Attribute::Depth, vec!["depth.V".into()])], ..Default::default() };
    let e = load_bytes(&bytes, Path::new("eng.exr"), &opts).unwrap_err().to_string();
    assert!(e.contains("missing channel depth.V") && e.contains("Nrm.X, Nrm.Y, Nrm.Z, Z"), "{e}");
}

#[test]
fn mapped_depth_conventions_negative_z_and_sky() {
    // View-space z (negative) with sky at 0 and at 1e10.
    let bytes = generic_exr(3, 1, &["z"], |_, i| [-2.0, 0.0, 1e10][i]);
    let opts = LoadOptions { map: vec![(Attribute::Depth, vec!["z".into()])], ..Default::default() };
    let l = load_bytes(&bytes, Path::new("z.exr"), &opts).unwrap();
    assert_eq!(l.gbuffer.coverage, vec![true, false, false]);
    assert_eq!(l.gbuffer.depth.as_ref().unwrap(), &vec![2.0, 0.0, 0.0]);
}

#[test]
fn scalar_overrides_apply_to_canonical_single_sample() {
    let mut gb = plausible(4, 2, 1, 6);
    gb.metallic = None;
    let mut raw = gbuf::io::canonical::to_raw(&gb);
    raw.channels
        .push(gbuf::io::exr::RawChannel { name: "my.metal".into(), data: gbuf::io::exr::RawData::F32(vec![0.25; 8]) });
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("o.exr");
    gbuf::io::exr::write_raw(&p, &raw).unwrap();
    let opts = LoadOptions { map: vec![(Attribute::Metallic, vec!["my.metal".into()])], ..Default::default() };
    let l = load(&p, &opts).unwrap();
    let m = l.gbuffer.metallic.as_ref().unwrap();
    for (v, c) in m.iter().zip(&l.gbuffer.coverage) {
        assert_eq!(*v, if *c { 0.25 } else { 0.0 });
    }
}

#[test]
fn garbage_empty_and_truncated_files() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "garbage.exr", b"this is not an image at all");
    let e = err(&p, &LoadOptions::default()).to_string();
    assert!(e.contains("garbage.exr") && e.contains("neither an OpenEXR"), "{e}");
    let p = write(dir.path(), "empty.exr", b"");
    assert!(err(&p, &LoadOptions::default()).to_string().contains("empty"));
    let good = canonical_bytes(&plausible(16, 16, 2, 7));
    for cut in [5, 40, good.len() / 3, good.len() - 1] {
        let p = write(dir.path(), "cut.exr", &good[..cut]);
        let e = err(&p, &LoadOptions::default()).to_string();
        assert!(e.contains("cut.exr"), "{e}");
    }
    let e = err(&dir.path().join("absent.exr"), &LoadOptions::default()).to_string();
    assert!(e.contains("absent.exr"), "{e}");
}

fn set_attr(attrs: &mut [HeaderAttr], name: &str, value: Vec<u8>) {
    attrs.iter_mut().find(|a| a.name == name).unwrap().value = value;
}

fn box2i(w: i32, h: i32) -> Vec<u8> {
    [0, 0, w - 1, h - 1].iter().flat_map(|v: &i32| v.to_le_bytes()).collect()
}

#[test]
fn huge_declared_size_in_a_tiny_file_is_refused_before_allocating() {
    let bytes = generic_exr(4, 4, &["Z"], |_, i| i as f32);
    let (mut attrs, _) = parse_header(&bytes);
    set_attr(&mut attrs, "dataWindow", box2i(100_000, 100_000));
    set_attr(&mut attrs, "displayWindow", box2i(100_000, 100_000));
    let evil = rebuild(&bytes, &attrs, 0);
    assert!(evil.len() < 2000, "{}", evil.len());
    // Default limits: over the byte limit.
    let e = gbuf::io::exr::read_raw_bytes(&evil, Path::new("evil.exr"), &ReadLimits::default()).unwrap_err();
    assert!(matches!(e, Error::TooLarge { .. } | Error::Invalid { .. }), "{e:?}");
    assert!(e.to_string().contains("evil.exr"));
    // Even with a limit that would allow it, the chunk table cannot fit in the file.
    let lax = ReadLimits { max_bytes: u64::MAX, allow_dwa: false };
    let e = gbuf::io::exr::read_raw_bytes(&evil, Path::new("evil.exr"), &lax).unwrap_err();
    assert!(e.to_string().contains("chunks"), "{e}");
    // 1000×1000 fits the chunk table but cannot be stored by ZIP in a file this small.
    set_attr(&mut attrs, "dataWindow", box2i(1000, 2));
    set_attr(&mut attrs, "displayWindow", box2i(1000, 2));
    let wide = rebuild(&bytes, &attrs, 0);
    let small = ReadLimits { max_bytes: 1000, allow_dwa: false };
    let e = gbuf::io::exr::read_raw_bytes(&wide, Path::new("wide.exr"), &small).unwrap_err();
    assert!(matches!(e, Error::TooLarge { bytes: 8000, limit: 1000, .. }), "{e:?}");
}

/// Channel list attribute bytes for (name, pixel type 0=uint 1=half 2=float, x sampling, y sampling).
fn chlist(chans: &[(&[u8], i32, i32, i32)]) -> Vec<u8> {
    let mut v = Vec::new();
    for (name, t, xs, ys) in chans {
        v.extend_from_slice(name);
        v.push(0);
        v.extend_from_slice(&t.to_le_bytes());
        v.extend_from_slice(&[0, 0, 0, 0]);
        v.extend_from_slice(&xs.to_le_bytes());
        v.extend_from_slice(&ys.to_le_bytes());
    }
    v.push(0);
    v
}

#[test]
fn subsampled_duplicate_and_odd_channel_names() {
    let bytes = generic_exr(4, 4, &["A", "B"], |c, i| (c * 100 + i) as f32);
    let (mut attrs, _) = parse_header(&bytes);
    let read = |attrs: &[HeaderAttr]| {
        gbuf::io::exr::read_raw_bytes(&rebuild(&bytes, attrs, 0), Path::new("odd.exr"), &ReadLimits::default())
    };
    set_attr(&mut attrs, "channels", chlist(&[(b"A", 2, 1, 1), (b"B", 2, 2, 2)]));
    let e = read(&attrs).unwrap_err();
    assert!(matches!(e, Error::Unsupported { .. }) && e.to_string().contains("subsampled"), "{e}");
    set_attr(&mut attrs, "channels", chlist(&[(b"A", 2, 1, 1), (b"A", 2, 1, 1)]));
    let e = read(&attrs).unwrap_err().to_string();
    assert!(e.contains("odd.exr") && e.contains("duplicate"), "{e}");
    set_attr(&mut attrs, "channels", chlist(&[(b"A", 2, 1, 1), (b"B\x01", 2, 1, 1)]));
    let e = read(&attrs).unwrap_err().to_string();
    assert!(e.contains("odd.exr") && e.contains("control"), "{e}");
    // UTF-8 names (what current OpenEXR writes) are decoded as UTF-8; other high bytes as Latin-1.
    set_attr(&mut attrs, "channels", chlist(&[(b"B\xe9", 2, 1, 1), ("Ä".as_bytes(), 2, 1, 1)]));
    let raw = read(&attrs).unwrap();
    let names: Vec<&str> = raw.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["Bé", "Ä"]);
    // A non-Latin-1 name cannot be written.
    let mut raw = raw;
    raw.channels[1].name = "Ж".into();
    let e = gbuf::io::exr::write_raw(Path::new("/nonexistent/w.exr"), &raw).unwrap_err().to_string();
    assert!(e.contains("Latin-1"), "{e}");
}

#[test]
fn deep_parts_and_dwa_are_refused_and_lossy_compression_is_named() {
    let bytes = generic_exr(4, 4, &["Z"], |_, i| i as f32);
    let (mut attrs, _) = parse_header(&bytes);
    // Deep scan lines: the type attribute, the version's deep bit (0x800) and the deep attributes.
    attrs.push(HeaderAttr { name: "type".into(), kind: "string".into(), value: b"deepscanline".to_vec() });
    attrs.push(HeaderAttr { name: "version".into(), kind: "int".into(), value: 1i32.to_le_bytes().to_vec() });
    attrs.push(HeaderAttr {
        name: "maxSamplesPerPixel".into(),
        kind: "int".into(),
        value: 4i32.to_le_bytes().to_vec(),
    });
    let deep = rebuild(&bytes, &attrs, 0x800);
    let e = gbuf::io::exr::read_raw_bytes(&deep, Path::new("deep.exr"), &ReadLimits::default()).unwrap_err();
    assert!(e.to_string().contains("deep.exr") && e.to_string().contains("deep data"), "{e}");
    let (mut attrs, _) = parse_header(&bytes);
    set_attr(&mut attrs, "compression", vec![8]); // DWAA
    let dwa = rebuild(&bytes, &attrs, 0);
    let e = gbuf::io::exr::read_raw_bytes(&dwa, Path::new("dwa.exr"), &ReadLimits::default()).unwrap_err();
    assert!(e.to_string().contains("DWAA") && e.to_string().contains("--allow-dwa"), "{e}");

    // PXR24 on float channels is lossy and named so.
    use exr::prelude::*;
    let layer = Layer::new(
        (8, 8),
        LayerAttributes::named("L"),
        Encoding { compression: Compression::PXR24, ..Encoding::SMALL_LOSSLESS },
        AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Z", FlatSamples::F32(vec![1.2345678; 64]))])),
    );
    let mut buf = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut buf).unwrap();
    let raw = gbuf::io::exr::read_raw_bytes(buf.get_ref(), Path::new("p.exr"), &ReadLimits::default()).unwrap();
    assert_eq!((raw.compression.as_str(), raw.lossy), ("PXR24", true));
    assert_eq!(raw.channels[0].name, "L.Z");
}
