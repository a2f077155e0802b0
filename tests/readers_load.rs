//! The reader fixtures through the public entry point `gbuf::io::load`: dispatch, sidecar resolution, folding, and
//! damaged channel values that must never panic.

use gbuf::base::rng::SplitMix64;
use gbuf::io::exr::{read_raw, RawData, RawImage};
use gbuf::io::sidecar::Sidecar;
use gbuf::io::{blender, load, mitsuba, LoadOptions, ReadLimits, SourceFormat};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

#[test]
fn blender_fixture_loads_folded_with_its_sidecar() {
    let l = load(&fixture("blender_gbuffer.exr"), &LoadOptions::default()).unwrap();
    assert_eq!(l.format, SourceFormat::Blender);
    let g = &l.gbuffer;
    assert_eq!((g.width, g.height, g.samples), (64, 48, 4), "sidecar supersample 2 folds 128×96");
    assert_eq!(g.sample_positions, gbuf::gbuffer::ordered_grid_positions(2));
    assert_eq!(l.camera_source, "sidecar");
    assert_eq!(l.lights.as_ref().map(Vec::len), Some(2));
    assert_eq!(l.compression.as_ref().map(|c| c.1), Some(false), "ZIP is lossless");
    // Every sample of the floor faces up in view space; depth and position agree after folding.
    let (d, p) = (g.depth.as_ref().unwrap(), g.position.as_ref().unwrap());
    for i in (0..g.len()).filter(|&i| g.coverage[i]) {
        assert!((-p[i].z - d[i]).abs() < 1e-3 * d[i]);
    }
    assert!(l.sanitized.iter().all(|(_, nan, inf)| *nan == 0 && *inf == 0), "{:?}", l.sanitized);
}

#[test]
fn without_sidecar_blender_loads_unfolded_with_a_fitted_camera_or_folded_by_flag() {
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("render.exr");
    std::fs::copy(fixture("blender_gbuffer.exr"), &copy).unwrap();
    let l = load(&copy, &LoadOptions::default()).unwrap();
    assert_eq!((l.gbuffer.width, l.gbuffer.samples), (128, 1));
    assert_eq!(l.camera_source, "fit");
    let l = load(&copy, &LoadOptions { fold: Some(2), ..Default::default() }).unwrap();
    assert_eq!((l.gbuffer.width, l.gbuffer.samples), (64, 4));
}

#[test]
fn mitsuba_fixture_loads_folded_with_its_sidecar() {
    let l = load(&fixture("mitsuba_gbuffer.exr"), &LoadOptions::default()).unwrap();
    assert_eq!(l.format, SourceFormat::Mitsuba);
    let g = &l.gbuffer;
    assert_eq!((g.width, g.height, g.samples), (64, 48, 4));
    assert_eq!(l.camera_source, "sidecar");
    assert_eq!(l.lights.as_ref().map(Vec::len), Some(1));
    assert!(g.has(gbuf::Attribute::PrimitiveId) && g.has(gbuf::Attribute::ObjectId));
    let n = g.normal.as_ref().unwrap();
    for i in (0..g.len()).filter(|&i| g.coverage[i]) {
        assert!((n[i].length() - 1.0).abs() < 1e-4);
    }
}

#[test]
fn ispc_fixture_loads() {
    let l = load(&fixture("ispc_deferred.bin"), &LoadOptions::default()).unwrap();
    assert_eq!(l.format, SourceFormat::IspcBin);
    assert_eq!(l.camera_source, "file");
    assert_eq!((l.gbuffer.width, l.gbuffer.height, l.gbuffer.samples), (64, 48, 1));
    assert_eq!(l.lights.map(|v| v.len()), Some(5));
    // A truncated copy is refused with the file named.
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(fixture("ispc_deferred.bin")).unwrap();
    let cut = dir.path().join("cut.bin");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = load(&cut, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("cut.bin"), "{e}");
}

/// Poisons random samples of random channels with NaN, ±Inf, huge, negative and denormal values. The readers must
/// return a valid G-buffer or an error, never panic — including the camera fit, which sees the poisoned positions.
fn poison(raw: &RawImage, seed: u64) -> RawImage {
    const BAD: [f32; 7] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1.0, -1e30, 1e-42];
    let mut r = raw.clone();
    let mut rng = SplitMix64::new(seed);
    for _ in 0..1 + rng.next_u64() % 6 {
        let k = (rng.next_u64() % r.channels.len() as u64) as usize;
        let n = r.channels[k].data.len() as u64;
        let count = if rng.next_u64().is_multiple_of(4) { n } else { 1 + rng.next_u64() % 200 };
        for _ in 0..count {
            let i = (rng.next_u64() % n) as usize;
            let v = BAD[(rng.next_u64() % BAD.len() as u64) as usize];
            match &mut r.channels[k].data {
                RawData::F32(d) => d[i] = v,
                RawData::F16(d) => d[i] = half::f16::from_f32(v),
                RawData::U32(d) => d[i] = u32::MAX,
            }
        }
    }
    r
}

#[test]
fn poisoned_channel_values_never_panic() {
    let cases = [
        ("blender_gbuffer", read_raw(&fixture("blender_gbuffer.exr"), &ReadLimits::default()).unwrap()),
        ("mitsuba_gbuffer", read_raw(&fixture("mitsuba_gbuffer.exr"), &ReadLimits::default()).unwrap()),
    ];
    for (name, raw) in &cases {
        let sc = Sidecar::load(&fixture(&format!("{name}.json"))).unwrap();
        let path = fixture(&format!("{name}.exr"));
        for seed in 0..40u64 {
            let bad = poison(raw, seed);
            for side in [Some(&sc), None] {
                let got = if *name == "blender_gbuffer" {
                    blender::read(&bad, &path, side, &LoadOptions::default())
                } else {
                    mitsuba::read(&bad, &path, side, &LoadOptions::default())
                };
                if let Ok(l) = got {
                    l.gbuffer.validate().unwrap();
                    if let Some(c) = l.gbuffer.camera {
                        assert!(c.is_valid(), "{name} seed {seed}: invalid camera {c:?}");
                    }
                }
            }
        }
    }
}
