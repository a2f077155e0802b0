//! The ISPC `deferred` `.bin` reader against the fixture written by fixtures/scripts/ispc_gbuffer.py, its writer,
//! and damaged input.

use gbuf::io::ispc::{self, Header, HEADER_BYTES, LIGHT_SLOTS};
use gbuf::io::{LoadOptions, ReadLimits};
use gbuf::{Camera, Error, GBuffer, Light};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/ispc_deferred.bin")
}

/// The fixture's analytic scene (see fixtures/scripts/ispc_gbuffer.py), in the file's left-handed view space.
const W: u32 = 64;
const H: u32 = 48;
const NEAR: f32 = 0.5;
const FAR: f32 = 50.0;
/// (centre, radius, albedo, specular amount, specular power).
type Sphere = ([f32; 3], f32, [f32; 3], f32, f32);
const SPHERES: [Sphere; 2] =
    [([0.0, 0.0, 6.0], 1.5, [0.8, 0.2, 0.1], 0.8, 64.0), ([2.2, -0.4, 4.0], 0.6, [0.1, 0.3, 0.9], 0.5, 32.0)];
const FLOOR: (f32, [f32; 3], f32, f32) = (-1.0, [0.6, 0.55, 0.5], 0.2, 8.0);
const LIGHTS: [([f32; 3], f32, [f32; 3], f32); 5] = [
    ([0.0, 3.0, 4.0], 1.0, [1.0, 0.9, 0.8], 8.0),
    ([-3.0, 0.5, 5.0], 0.5, [0.2, 0.4, 1.0], 5.0),
    ([2.5, 1.0, 3.0], 0.5, [1.0, 0.3, 0.2], 4.0),
    ([0.0, -0.5, 9.0], 2.0, [0.5, 1.0, 0.5], 10.0),
    ([1.0, 2.0, 12.0], 3.0, [1.0, 1.0, 1.0], 20.0),
];

/// Depth goes through the f32 post-projection value z = a + b/d and back; near the far plane that loses ~d²/near
/// ulps of z. 1e-4 relative covers the fixture's depth range (≤ 50) comfortably.
const DEPTH_REL_TOL: f32 = 1e-4;
/// Normals are stored as two f16 spheremap coordinates (11 significant bits each).
const NORMAL_TOL: f32 = 4e-3;
/// Position is derived from depth, so it inherits its relative error.
const POSITION_REL_TOL: f32 = 2e-4;

/// (view depth, normal, albedo, specular, power).
type Hit = (f32, Vec3, Vec3, f32, f32);

/// Traces the analytic scene through the centre of pixel (x, y): (view depth, normal in OUR view space, albedo,
/// specular, power), or `None` for sky.
fn trace(x: u32, y: u32) -> Option<Hit> {
    let ys = 1.0 / (30f32.to_radians()).tan();
    let xs = ys / (W as f32 / H as f32);
    let sx = (x as f32 + 0.5) * 2.0 / W as f32 - 1.0;
    let sy = -(((y as f32 + 0.5) * 2.0 / H as f32) - 1.0);
    let d = Vec3::new(sx / xs, sy / ys, 1.0);
    let mut best: Option<Hit> = None;
    for (c, r, alb, spec, pow) in SPHERES {
        let c = Vec3::from(c);
        let b = d.dot(c);
        let disc = b * b - d.dot(d) * (c.dot(c) - r * r);
        if disc >= 0.0 {
            let t = (b - disc.sqrt()) / d.dot(d);
            if t > 0.0 && best.is_none_or(|h| t < h.0) {
                let n = (d * t - c) / r;
                best = Some((t, n, Vec3::from(alb), spec, pow));
            }
        }
    }
    if d.y < 0.0 {
        let t = FLOOR.0 / d.y;
        if best.is_none_or(|h| t < h.0) {
            best = Some((t, Vec3::Y, Vec3::from(FLOOR.1), FLOOR.2, FLOOR.3));
        }
    }
    best.filter(|h| (NEAR..FAR).contains(&h.0)).map(|(t, n, a, s, p)| (t, Vec3::new(n.x, n.y, -n.z), a, s, p))
}

fn load(path: &Path) -> gbuf::Result<gbuf::io::Loaded> {
    ispc::read(path, &LoadOptions::default())
}

#[test]
fn header_fields_match_the_script() {
    let bytes = std::fs::read(fixture()).unwrap();
    let h = Header::parse(&bytes).unwrap();
    assert_eq!((h.width, h.height, h.num_lights), (64, 48, 5));
    assert_eq!((h.near, h.far), (NEAR, FAR));
    assert_eq!(HEADER_BYTES as u64 + h.chunk_size as u64, bytes.len() as u64);
    assert_eq!(h.proj[2][3], 1.0);
    assert!((h.proj[2][2] - FAR / (FAR - NEAR)).abs() < 1e-6);
    assert!((h.proj[3][2] + NEAR * FAR / (FAR - NEAR)).abs() < 1e-6);
    assert!(ispc::matches_file(&bytes[..256], bytes.len() as u64));
}

#[test]
fn pixels_match_the_analytic_scene() {
    let l = load(&fixture()).unwrap();
    let g = &l.gbuffer;
    assert_eq!((g.width, g.height, g.samples), (W, H, 1));
    assert_eq!(l.camera_source, "file");
    let cam = g.camera.unwrap();
    assert!((cam.yfov - 60f32.to_radians()).abs() < 1e-5 && (cam.aspect - 4.0 / 3.0).abs() < 1e-5);
    let (depth, normal, albedo) = (g.depth.as_ref().unwrap(), g.normal.as_ref().unwrap(), g.albedo.as_ref().unwrap());
    let (spec, power, pos) =
        (g.specular.as_ref().unwrap(), g.specular_power.as_ref().unwrap(), g.position.as_ref().unwrap());
    let mut sky = 0;
    for y in 0..H {
        for x in 0..W {
            let i = g.index(x, y, 0);
            match trace(x, y) {
                None => {
                    sky += 1;
                    assert!(!g.coverage[i], "({x}, {y}) should be sky");
                }
                Some((d, n, a, s, p)) => {
                    assert!(g.coverage[i], "({x}, {y}) should be covered");
                    assert!((depth[i] - d).abs() <= DEPTH_REL_TOL * d, "({x}, {y}) depth {} vs {d}", depth[i]);
                    assert!((normal[i] - n).length() < NORMAL_TOL, "({x}, {y}) normal {} vs {n}", normal[i]);
                    assert!((normal[i].length() - 1.0).abs() < 1e-5);
                    assert!((albedo[i] - a).abs().max_element() <= 0.5 / 255.0 + 1e-6);
                    let f16 = |v: f32| half::f16::from_f32(v).to_f32();
                    assert_eq!((spec[i], power[i]), (f16(s), f16(p)));
                    // Position agrees with depth through the camera, and lies on the view ray.
                    let px = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let expect = cam.view_position(px, depth[i], W, H);
                    assert!((pos[i] - expect).length() <= POSITION_REL_TOL * d, "{} vs {expect}", pos[i]);
                    assert!((-pos[i].z - depth[i]).abs() <= 1e-6 * d);
                    // Visible surfaces face the eye (n · (eye − p) > 0), even where perspective makes n.z < 0.
                    assert!(normal[i].dot(-pos[i]) > 0.0, "({x}, {y}) normal {} at {}", normal[i], pos[i]);
                }
            }
        }
    }
    // The top rows look over the horizon into the sky, the bottom rows at the floor.
    assert_eq!(sky, g.background_samples());
    assert!(sky > 0 && sky < (W * H) as usize / 2, "sky {sky}");
    assert!(!g.coverage[g.index(0, 0, 0)] && g.coverage[g.index(0, H - 1, 0)] && g.coverage[g.index(32, 24, 0)]);
}

#[test]
fn lights_are_converted_to_right_handed_view_space() {
    let l = load(&fixture()).unwrap();
    let lights = l.lights.unwrap();
    assert_eq!(lights.len(), LIGHTS.len());
    for (got, (p, begin, c, end)) in lights.iter().zip(LIGHTS) {
        assert_eq!(got.position, Vec3::new(p[0], p[1], -p[2]));
        assert_eq!((got.begin, got.range, got.intensity), (begin, end, 1.0));
        assert_eq!(got.color, Vec3::from(c));
        assert!(!got.is_directional());
    }
}

#[test]
fn sources_name_the_arrays() {
    let l = load(&fixture()).unwrap();
    let depth = l.sources.iter().find(|s| s.attribute == "depth").unwrap();
    assert_eq!(depth.channels, vec!["zBuffer".to_string()]);
    let normal = l.sources.iter().find(|s| s.attribute == "normal").unwrap();
    assert_eq!(normal.file_type, "half");
    assert!(normal.note.as_deref().unwrap().contains("spheremap"));
    // Every attribute present in the G-buffer is accounted for.
    for a in l.gbuffer.attributes() {
        assert!(l.sources.iter().any(|s| s.attribute == a.name()), "{} has no source", a.name());
    }
}

#[test]
fn writer_round_trips_the_fixture() {
    let l = load(&fixture()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("copy.bin");
    ispc::write(&out, &l.gbuffer, l.lights.as_deref().unwrap()).unwrap();
    let back = load(&out).unwrap();
    let (a, b) = (&l.gbuffer, &back.gbuffer);
    assert_eq!(a.coverage, b.coverage);
    assert_eq!(a.albedo, b.albedo);
    assert_eq!(a.specular, b.specular);
    assert_eq!(a.specular_power, b.specular_power);
    assert_eq!(l.lights, back.lights);
    for i in 0..a.len() {
        let (da, db) = (a.depth.as_ref().unwrap()[i], b.depth.as_ref().unwrap()[i]);
        assert!((da - db).abs() <= DEPTH_REL_TOL * da.max(1.0));
        let (na, nb) = (a.normal.as_ref().unwrap()[i], b.normal.as_ref().unwrap()[i]);
        assert!((na - nb).length() < NORMAL_TOL, "{na} vs {nb}");
    }
    // The writer always fills the sample's 1024 light slots.
    let bytes = std::fs::read(&out).unwrap();
    let h = Header::parse(&bytes).unwrap();
    assert_eq!(h.num_lights, 5);
    assert!(h.offsets[15] as usize + 4 * LIGHT_SLOTS <= h.chunk_size as usize);
}

#[test]
fn writer_refuses_what_the_format_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.bin");
    let mut g = GBuffer::new(4, 4, 4).unwrap();
    assert!(ispc::write(&out, &g, &[]).is_err(), "4 samples per pixel");
    g = GBuffer::new(4, 4, 1).unwrap();
    assert!(ispc::write(&out, &g, &[]).is_err(), "no camera");
    g.camera = Some(Camera::identity(1.0, 1.0, 0.1, 10.0));
    g.depth = Some(vec![1.0; 16]);
    g.normal = Some(vec![Vec3::Z; 16]);
    let too_many = vec![Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 1.0); LIGHT_SLOTS + 1];
    assert!(ispc::write(&out, &g, &too_many).is_err());
    assert!(!out.exists());
    // An off-centre camera: the format's readers rebuild positions with a centred projection.
    let mut off = g.clone();
    off.camera.as_mut().unwrap().principal = Vec2::new(0.25, 0.0);
    let e = ispc::write(&out, &off, &[]).unwrap_err().to_string();
    assert!(e.contains("principal point (0.25, 0)") && e.contains("x.bin"), "{e}");
    assert!(!out.exists());
    ispc::write(&out, &g, &too_many[..LIGHT_SLOTS]).unwrap();
    assert_eq!(load(&out).unwrap().lights.unwrap().len(), LIGHT_SLOTS);
}

fn expect_invalid(bytes: &[u8], what: &str) -> String {
    let p = Path::new("damaged.bin");
    match ispc::read_bytes(bytes, p, &LoadOptions::default()) {
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.contains("damaged.bin"), "{what}: error does not name the file: {msg}");
            msg
        }
        Ok(_) => panic!("{what}: accepted"),
    }
}

#[test]
fn truncation_at_every_length_is_an_error() {
    let bytes = std::fs::read(fixture()).unwrap();
    for len in 0..bytes.len() {
        let msg = expect_invalid(&bytes[..len], &format!("truncated to {len}"));
        if len >= HEADER_BYTES {
            assert!(msg.contains("truncated"), "{msg}");
        }
    }
    // Through the file path too, at a few lengths.
    let dir = tempfile::tempdir().unwrap();
    for len in [0, 1, 151, 152, 153, 5000, bytes.len() - 1] {
        let p = dir.path().join(format!("t{len}.bin"));
        std::fs::write(&p, &bytes[..len]).unwrap();
        let e = load(&p).unwrap_err().to_string();
        assert!(e.contains(&format!("t{len}.bin")), "{e}");
    }
    // Trailing bytes after the chunk are ignored.
    let mut longer = bytes.clone();
    longer.extend_from_slice(&[0xAB; 100]);
    ispc::read_bytes(&longer, Path::new("x.bin"), &LoadOptions::default()).unwrap();
}

fn patch_i32(bytes: &[u8], at: usize, v: i32) -> Vec<u8> {
    let mut b = bytes.to_vec();
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    b
}

#[test]
fn bad_header_fields_are_errors() {
    let bytes = std::fs::read(fixture()).unwrap();
    let h = Header::parse(&bytes).unwrap();
    for k in 0..16 {
        let at = 88 + 4 * k;
        for v in [-1, i32::MIN, h.chunk_size - 1, h.chunk_size, i32::MAX] {
            let msg = expect_invalid(&patch_i32(&bytes, at, v), &format!("offset {k} = {v}"));
            assert!(msg.contains("offset") || msg.contains("chunk"), "{msg}");
        }
    }
    for (at, v, what) in [
        (72, 0, "width 0"),
        (72, -64, "negative width"),
        (76, 100_000, "height 100000"),
        (72, i32::MAX, "width i32::MAX"),
        (80, 1025, "numLights > slots"),
        (80, -1, "numLights -1"),
        (84, -5, "negative chunk"),
        (84, i32::MAX, "chunk past the end"),
    ] {
        expect_invalid(&patch_i32(&bytes, at, v), what);
    }
    // Large but representable sizes are refused by the memory limit before any allocation.
    let big = patch_i32(&patch_i32(&bytes, 72, 30_000), 76, 30_000);
    match ispc::read_bytes(&big, Path::new("big.bin"), &LoadOptions::default()) {
        Err(Error::TooLarge { .. }) => {}
        other => panic!("expected TooLarge, got {other:?}"),
    }
    let tight = LoadOptions { limits: ReadLimits { max_bytes: 1000, ..Default::default() }, ..Default::default() };
    assert!(matches!(ispc::read_bytes(&bytes, Path::new("x.bin"), &tight), Err(Error::TooLarge { .. })));
    // Camera: near ≥ far, a non-finite matrix entry.
    let mut b = bytes.clone();
    b[64..68].copy_from_slice(&100f32.to_le_bytes());
    expect_invalid(&b, "near > far");
    let mut b = bytes.clone();
    b[0..4].copy_from_slice(&f32::NAN.to_le_bytes());
    expect_invalid(&b, "NaN in cameraProj");
    // A light with a NaN attenuation end.
    let mut b = bytes.clone();
    let at = HEADER_BYTES + h.offsets[15] as usize;
    b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    expect_invalid(&b, "NaN light");
}

/// Seeded random byte mutations of the fixture (header-only and whole-file): `Err` or a valid G-buffer.
fn mutate_rounds(rounds: u64, seed: u64) {
    let bytes = std::fs::read(fixture()).unwrap();
    let mut rng = gbuf::base::rng::SplitMix64::new(seed);
    for round in 0..rounds {
        let mut b = bytes.clone();
        let header_only = round % 2 == 0;
        for _ in 0..1 + rng.next_u64() % 8 {
            let span = if header_only { HEADER_BYTES } else { b.len() };
            let at = (rng.next_u64() % span as u64) as usize;
            b[at] = rng.next_u64() as u8;
        }
        if let Ok(l) = ispc::read_bytes(&b, Path::new("m.bin"), &LoadOptions::default()) {
            l.gbuffer.validate().unwrap();
            assert!(l.lights.unwrap().len() <= LIGHT_SLOTS);
        }
    }
}

#[test]
fn random_mutations_never_panic() {
    mutate_rounds(400, 0x15bc);
}

/// The long version: `cargo test --release --test readers_ispc -- --ignored`.
#[test]
#[ignore]
fn random_mutations_never_panic_long() {
    mutate_rounds(50_000, 0xdeadbeef);
}

#[test]
fn other_files_do_not_match() {
    let exr = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/blender_gbuffer.exr")).unwrap();
    assert!(!ispc::matches_file(&exr[..HEADER_BYTES], exr.len() as u64));
    assert!(!ispc::matches_file(&[0u8; HEADER_BYTES], 10_000));
    assert!(!ispc::matches_file(&[], 0));
}

/// What `gbuf::io::load` (format detection included) says about `bytes` saved as `damaged.bin`; checks the
/// message names the file.
fn load_refusal(bytes: &[u8], what: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("damaged.bin");
    std::fs::write(&p, bytes).unwrap();
    let msg = match gbuf::io::load(&p, &LoadOptions::default()) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("{what}: accepted"),
    };
    assert!(msg.contains("damaged.bin"), "{what}: error does not name the file: {msg}");
    msg
}

fn patch_f32(bytes: &[u8], at: usize, v: f32) -> Vec<u8> {
    let mut b = bytes.to_vec();
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    b
}

/// Every header field, damaged, through the loader's format detection: the refusal names the file, the field and
/// its value (issue 16: a huge width used to get "neither an OpenEXR file nor an ISPC .bin").
#[test]
fn every_bad_header_field_is_refused_by_name_and_value() {
    let bytes = std::fs::read(fixture()).unwrap();
    let h = Header::parse(&bytes).unwrap();
    let expect = |b: Vec<u8>, what: &str, words: &[&str]| {
        let msg = load_refusal(&b, what);
        for w in words {
            assert!(msg.contains(w), "{what}: {w:?} missing from: {msg}");
        }
        assert!(!msg.contains("neither"), "{what}: not recognised as a .bin: {msg}");
    };
    for (v, value) in [(100_000, "100000"), (0, "0"), (-64, "-64"), (i32::MAX, "2147483647")] {
        expect(patch_i32(&bytes, 72, v), "width", &["width", value]);
        expect(patch_i32(&bytes, 76, v), "height", &["height", value]);
    }
    expect(patch_i32(&bytes, 80, 1025), "numLights", &["numLights", "1025"]);
    expect(patch_i32(&bytes, 80, -1), "numLights", &["numLights", "-1"]);
    expect(patch_i32(&bytes, 84, -5), "chunk size", &["chunk size", "-5"]);
    expect(patch_i32(&bytes, 84, i32::MAX), "chunk size", &["chunk", "2147483647"]);
    expect(patch_i32(&bytes, 84, 100), "chunk size too small", &["chunk", "100"]);
    expect(patch_f32(&bytes, 64, -1.0), "near", &["near", "-1"]);
    expect(patch_f32(&bytes, 64, f32::NAN), "near NaN", &["near", "NaN"]);
    expect(patch_f32(&bytes, 68, 0.25), "far < near", &["far", "0.25"]);
    expect(patch_f32(&bytes, 68, f32::INFINITY), "far", &["far", "inf"]);
    for r in 0..4 {
        for c in 0..4 {
            if (r, c) == (2, 3) {
                continue; // the one entry the format is recognised by: below
            }
            let at = (r * 4 + c) * 4;
            expect(patch_f32(&bytes, at, f32::NAN), "cameraProj NaN", &[&format!("cameraProj[{r}][{c}]"), "NaN"]);
        }
    }
    expect(patch_f32(&bytes, 0, -2.0), "x scale", &["cameraProj[0][0]", "-2"]);
    expect(patch_f32(&bytes, 20, 0.0), "y scale", &["cameraProj[1][1]", "= 0"]);
    expect(patch_f32(&bytes, 56, 0.0), "[3][2]", &["cameraProj[3][2]", "= 0"]);
    for (k, name) in ["zBuffer", "normalEncoded_x", "albedo_z", "lightPositionView_x", "lightAttenuationEnd"]
        .iter()
        .enumerate()
        .map(|(i, n)| ([0, 1, 7, 8, 15][i], *n))
    {
        let at = 88 + 4 * k;
        expect(patch_i32(&bytes, at, -8), name, &[name, &format!("offsets[{k}]"), "-8"]);
        let past = h.chunk_size - 1;
        expect(patch_i32(&bytes, at, past), name, &[name, &format!("offsets[{k}]"), &past.to_string()]);
    }
    for k in 0..16 {
        expect(patch_i32(&bytes, 88 + 4 * k, i32::MIN), "offset", &[&format!("offsets[{k}]"), "-2147483648"]);
    }
    // Declared sizes beyond the memory limit: the limit's own error, naming the file.
    let big = patch_i32(&patch_i32(&bytes, 72, 30_000), 76, 30_000);
    load_refusal(&big, "30000²");
    // The entry the format is recognised by: the file is not taken for a .bin, but the refusal still names it.
    let msg = load_refusal(&patch_f32(&bytes, 44, 2.0), "[2][3]");
    assert!(msg.contains("cameraProj[2][3] = 2"), "{msg}");
}
