//! An ISPC `.bin` lit from its own arrays (`gbuf::io::open_packed`: decoded band by band inside the edge pass and
//! the resolve, as the example's shading loop reads the file) against the same file loaded whole (`gbuf::io::load`):
//! the same load report (lights, sources, sanitising counts, warnings), the same planes band by band, and the same
//! image, heatmap and counts bit for bit for every detector, BRDF, culling mode, MSAA schedule, instruction set,
//! tile size and thread count. Run on the real fixture and on a frame whose arrays hold NaN, ±Inf, depths out of
//! range and undecodable normals.

mod support;

use gbuf::base::isa::Isa;
use gbuf::detect::{detect, detect_packed, Detector, DetectorConfig};
use gbuf::gbuffer::Attribute;
use gbuf::io::ispc::{Header, HEADER_BYTES};
use gbuf::io::{load, open_packed, LoadOptions, Loaded, PackedDump};
use gbuf::layout::PackedFrame;
use gbuf::resolve::{resolve_isa, ResolveConfig};
use gbuf::scene::{render, SceneName};
use gbuf::GBuffer;
use half::f16;
use std::path::{Path, PathBuf};

/// The room written as a `.bin` (71×37: not a whole number of bands or tiles), its arrays then spoiled: NaN and
/// ±Inf in the half floats, depths outside [0, 1) and NaN, normal pairs that decode to nothing.
fn spoiled_room(dir: &Path) -> PathBuf {
    let gb = render(SceneName::Room, 71, 37, 1).unwrap();
    let lights = gbuf::resolve::fixture::lights_on_surfaces(&gb, 40, 3.0, 7);
    let path = dir.join("spoiled.bin");
    gbuf::io::ispc::write(&path, &gb, &lights).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let h = Header::parse(&bytes).unwrap();
    let at = |k: usize, elem: usize, i: usize| HEADER_BYTES + h.offsets[k] as usize + elem * i;
    let put16 = |b: &mut Vec<u8>, k: usize, i: usize, v: f16| {
        let o = at(k, 2, i);
        b[o..o + 2].copy_from_slice(&v.to_bits().to_le_bytes());
    };
    let mut spoiled = [0usize; 7];
    for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
        if i % 11 == 0 {
            put16(&mut bytes, 3, i, f16::NAN); // specular amount
            spoiled[0] += 1;
        }
        if i % 13 == 0 {
            put16(&mut bytes, 4, i, f16::INFINITY); // specular power
            spoiled[1] += 1;
        }
        if i % 17 == 0 {
            put16(&mut bytes, 4, i, f16::NEG_INFINITY);
            spoiled[2] += 1;
        }
        if i % 19 == 0 {
            put16(&mut bytes, 1, i, f16::NAN); // normal x: no direction
            spoiled[3] += 1;
        }
        for (j, (m, z)) in [(23, 2.0f32), (29, -0.5), (31, f32::NAN)].into_iter().enumerate() {
            if i % m == 0 {
                let o = at(0, 4, i);
                bytes[o..o + 4].copy_from_slice(&z.to_le_bytes());
                spoiled[4 + j] += 1;
            }
        }
    }
    assert!(spoiled.iter().all(|&n| n > 5), "every kind spoiled somewhere: {spoiled:?}");
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The fixture (a real renderer's frame) and the spoiled room, each loaded whole and opened as arrays.
fn inputs(dir: &Path) -> Vec<(PathBuf, Loaded, PackedDump)> {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/ispc_deferred.bin");
    [fixture, spoiled_room(dir)]
        .into_iter()
        .map(|p| {
            let opts = LoadOptions::default();
            let loaded = load(&p, &opts).unwrap();
            let dump = open_packed(&p, &opts).unwrap().expect("a .bin opens as arrays");
            (p, loaded, dump)
        })
        .collect()
}

#[test]
fn opening_the_arrays_reports_what_loading_the_frame_does() {
    let dir = tempfile::tempdir().unwrap();
    for (path, loaded, mut dump) in inputs(dir.path()) {
        let what = path.display().to_string();
        // Before the checks run, none of their findings is in the report.
        assert!(dump.loaded.sanitized.is_empty() && dump.loaded.warnings.is_empty(), "{what}: checked early");
        dump.check().unwrap();
        let a = &dump.loaded;
        assert_eq!(a.lights, loaded.lights, "{what}: lights");
        assert_eq!(a.sources, loaded.sources, "{what}: sources");
        assert_eq!(a.sanitized, loaded.sanitized, "{what}: sanitising counts");
        assert_eq!(a.warnings, loaded.warnings, "{what}: warnings");
        assert_eq!(a.format, loaded.format, "{what}");
        let (g, l) = (&a.gbuffer, &loaded.gbuffer);
        assert_eq!((g.width, g.height, g.samples), (l.width, l.height, l.samples), "{what}");
        assert_eq!(g.coverage, l.coverage, "{what}: coverage");
        assert_eq!(g.camera, l.camera, "{what}: camera");
        assert!(g.attributes().is_empty(), "{what}: the opened frame holds no planes");
        if what.ends_with("spoiled.bin") {
            // The spoiling shows: NaN and Inf replaced, depths out of range counted, undecodable normals warned of.
            let planes: Vec<&str> = a.sanitized.iter().map(|s| s.0).collect();
            assert_eq!(planes, ["specular", "specular_power"], "{:?}", a.sanitized);
            assert!(a.sanitized[1].2 > 5, "±Inf powers counted: {:?}", a.sanitized);
            assert!(a.sources[0].note.as_deref().is_some_and(|n| n.contains("outside [0, 1)")), "{:?}", a.sources[0]);
            assert!(a.warnings.iter().any(|w| w.code == "invalid-normals" && w.count > 5), "{:?}", a.warnings);
        }
    }
}

/// The checks counted on the bands the resolve decoded (each band once, however often or in whatever pieces it
/// was decoded; rows no band covered decoded by the check) are the whole loaded frame's.
#[test]
fn the_checks_counted_on_decoded_bands_are_the_loaded_frames() {
    let dir = tempfile::tempdir().unwrap();
    let opts = LoadOptions::default();
    for (path, loaded, _) in inputs(dir.path()) {
        let what = path.display().to_string();
        let lights = loaded.lights.clone().unwrap();
        let mask = detect(&loaded.gbuffer, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
        let h = loaded.gbuffer.height;
        // Lit first (every band decoded by the resolve), then checked; and bands decoded by hand: overlapping,
        // repeated, partial (only some planes: not counted) and leaving gaps.
        let lit = |dump: &PackedDump| {
            let frame = PackedFrame::of_source(&dump.loaded.gbuffer, &dump.arrays).unwrap();
            resolve_isa(Isa::detect(), &frame, &lights, &mask, &ResolveConfig::default()).unwrap();
        };
        let pieces = |dump: &PackedDump| {
            let frame = PackedFrame::of_source(&dump.loaded.gbuffer, &dump.arrays).unwrap();
            let mut band = GBuffer::default();
            for r in [3..20, 10..40, 0..5, 3..20, 50..h.min(61)] {
                frame.decode_rows(r.start.min(h - 1)..r.end.min(h), &mut band).unwrap();
            }
            frame.decode_rows_only(0..h, &mut band, &[Attribute::Normal]).unwrap();
        };
        for (how, before) in [("lit", &lit as &dyn Fn(&PackedDump)), ("pieces", &pieces)] {
            let mut dump = open_packed(&path, &opts).unwrap().unwrap();
            before(&dump);
            dump.check().unwrap();
            assert_eq!(dump.loaded.sanitized, loaded.sanitized, "{what} {how}: sanitising counts");
            assert_eq!(dump.loaded.warnings, loaded.warnings, "{what} {how}: warnings");
            // A second check changes nothing.
            let again = dump.check().unwrap().to_vec();
            assert_eq!(again, loaded.warnings, "{what} {how}: checked twice");
        }
    }
}

#[test]
fn every_band_is_the_loaded_frame_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    for (path, loaded, dump) in inputs(dir.path()) {
        let frame = PackedFrame::of_source(&dump.loaded.gbuffer, &dump.arrays).unwrap();
        let gb = &loaded.gbuffer;
        let row = gb.width as usize;
        for rows in [1, 5, 16, gb.height] {
            let mut band = GBuffer::default();
            let mut y = 0;
            while y < gb.height {
                let r = y..(y + rows).min(gb.height);
                let range = r.start as usize * row..r.end as usize * row;
                frame.decode_rows(r.clone(), &mut band).unwrap();
                let what = format!("{} rows {r:?}", path.display());
                assert_eq!((band.width, band.height, band.samples), (gb.width, r.end - r.start, 1), "{what}");
                assert_eq!(band.coverage, gb.coverage[range.clone()], "{what}: coverage");
                assert_eq!(band.camera, gb.camera, "{what}: camera");
                assert_eq!(band.attributes(), gb.attributes(), "{what}: planes");
                let rows_of = |a: Attribute| {
                    let bits = support::plane_bits(gb, a).unwrap();
                    let k = bits.len() / gb.len();
                    bits[range.start * k..range.end * k].to_vec()
                };
                for a in gb.attributes() {
                    assert!(support::plane_bits(&band, a).unwrap() == rows_of(a), "{what}: {}", a.name());
                }
                // Only some planes: each the same as the whole frame's; the others absent.
                let only = [Attribute::Normal, Attribute::Specular];
                frame.decode_rows_only(r.clone(), &mut band, &only).unwrap();
                assert_eq!(band.attributes(), only, "{what}");
                for a in only {
                    assert!(support::plane_bits(&band, a).unwrap() == rows_of(a), "{what}: only {}", a.name());
                }
                y = r.end;
            }
        }
        // The whole frame decoded for the reference is the loaded one.
        support::assert_bit_exact(&dump.decode(&path).unwrap(), gb);
    }
}

#[test]
fn the_arrays_light_as_the_loaded_frame_on_every_path() {
    let dir = tempfile::tempdir().unwrap();
    let det_cfg = DetectorConfig::default();
    let mut checked = 0;
    for (path, loaded, dump) in inputs(dir.path()) {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let frame = PackedFrame::of_source(&dump.loaded.gbuffer, &dump.arrays).unwrap();
        let gb = &loaded.gbuffer;
        let lights = loaded.lights.clone().unwrap();
        assert!(!lights.is_empty(), "{name}: the file's lights");
        for d in [Detector::Lauritzen, Detector::Ssaa, Detector::None] {
            let mask = detect(gb, d, &det_cfg).unwrap();
            assert_eq!(detect_packed(&frame, d, &det_cfg).unwrap().shade_count, mask.shade_count, "{name}: {d}");
            for (cfg, label) in support::resolve_configs() {
                for isa in Isa::available() {
                    let what = format!("{name} / {d} / {label} / {isa:?}");
                    let a = resolve_isa(isa, gb, &lights, &mask, &cfg).unwrap();
                    let b = resolve_isa(isa, &frame, &lights, &mask, &cfg).unwrap();
                    assert!(a.stats.shading_evaluations > 0, "{what}: nothing shaded");
                    support::assert_same_resolve(&a, &b, &what);
                    checked += 1;
                }
            }
        }
        // Tile sizes (bands of other heights) and thread counts.
        let mask = detect(gb, Detector::Lauritzen, &det_cfg).unwrap();
        for tile_size in [8, 16, 32] {
            let cfg = ResolveConfig { tile_size, ..Default::default() };
            let a = resolve_isa(Isa::detect(), gb, &lights, &mask, &cfg).unwrap();
            for threads in 1..=3 {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let b = pool.install(|| resolve_isa(Isa::detect(), &frame, &lights, &mask, &cfg).unwrap());
                support::assert_same_resolve(&a, &b, &format!("{name} / tile {tile_size} / {threads} threads"));
            }
        }
    }
    // 2 frames × 3 detectors × 3 BRDFs × 10 valid culling/schedule pairs × each ISA.
    assert!(checked >= 2 * 3 * 3 * 10 * Isa::available().len(), "{checked} combinations");
}

/// What is not a `.bin`, or is read with options that change its samples, is not opened as arrays; a damaged
/// `.bin` fails as loading it does, naming the file.
#[test]
fn only_a_bin_read_as_it_is_opens_as_arrays() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let opts = LoadOptions::default();
    assert!(open_packed(&root.join("room_1x.exr"), &opts).unwrap().is_none(), "an EXR");
    assert!(open_packed(&root.join("luxcore"), &opts).unwrap().is_none(), "a folder");
    let bin = root.join("ispc_deferred.bin");
    let folded = LoadOptions { fold: Some(2), ..LoadOptions::default() };
    assert!(open_packed(&bin, &folded).unwrap().is_none(), "folded");
    let bytes = std::fs::read(&bin).unwrap();
    let cut = dir.path().join("cut.bin");
    std::fs::write(&cut, &bytes[..bytes.len() - 1000]).unwrap();
    let a = open_packed(&cut, &opts).unwrap_err().to_string();
    let b = load(&cut, &opts).unwrap_err().to_string();
    assert_eq!(a, b);
    assert!(a.contains("cut.bin") && a.contains("truncated"), "{a}");
}

/// `gbuf resolve` lights a `.bin` from its arrays: the warnings `gbuf info` prints of the loaded file, the image
/// of the library's resolve of the loaded frame.
#[test]
fn the_cli_resolve_of_a_bin_warns_and_lights_as_the_loaded_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = spoiled_room(dir.path());
    let p = path.to_str().unwrap();
    // With --json, `info` prints its warnings on stderr as every command does (its text lists them itself).
    let info = support::gbuf(dir.path(), &["info", p, "--json"]);
    assert!(info.status.success(), "{}", support::stderr(&info));
    let out = dir.path().join("lit.exr");
    let res = support::gbuf(dir.path(), &["resolve", p, "--no-reference", "-o", out.to_str().unwrap()]);
    assert!(res.status.success(), "{}", support::stderr(&res));
    let warnings = |s: String| s.lines().filter(|l| l.starts_with("warning:")).map(String::from).collect::<Vec<_>>();
    let w = warnings(support::stderr(&res));
    assert!(!w.is_empty() && w == warnings(support::stderr(&info)), "{w:?}");

    let loaded = load(&path, &LoadOptions::default()).unwrap();
    let mask = detect(&loaded.gbuffer, Detector::Lauritzen, &DetectorConfig::default()).unwrap();
    let lights = loaded.lights.unwrap();
    let want = resolve_isa(Isa::detect(), &loaded.gbuffer, &lights, &mask, &ResolveConfig::default()).unwrap();
    let got = gbuf::image::file::read(&out, &gbuf::io::ReadLimits::default()).unwrap().image;
    for (i, (x, y)) in got.rgb.iter().zip(&want.image.rgb).enumerate() {
        assert_eq!(x.to_array().map(f32::to_bits), y.to_array().map(f32::to_bits), "pixel {i}");
    }
}

/// Hostile files: every prefix of the fixture (in steps) and seeded byte flips in its header open as arrays
/// exactly when they load, with the same error, and what opens lights as what loads: no panic, no hang.
#[test]
fn damaged_bins_open_as_they_load() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/ispc_deferred.bin")).unwrap();
    let opts = LoadOptions::default();
    let mut variants: Vec<Vec<u8>> = (0..good.len()).step_by(997).map(|n| good[..n].to_vec()).collect();
    let mut rng = gbuf::base::rng::SplitMix64::new(34);
    for _ in 0..200 {
        let mut b = good.clone();
        let at = (rng.next_u64() % HEADER_BYTES as u64) as usize;
        b[at] ^= 1 << (rng.next_u64() % 8);
        variants.push(b);
    }
    let (mut opened, mut refused) = (0, 0);
    for (k, bytes) in variants.iter().enumerate() {
        let path = dir.path().join(format!("v{k}.bin"));
        std::fs::write(&path, bytes).unwrap();
        let checked = open_packed(&path, &opts).and_then(|d| {
            d.map(|mut d| {
                d.check()?;
                Ok(d)
            })
            .transpose()
        });
        let (a, b) = (checked, load(&path, &opts));
        match (a, b) {
            (Ok(Some(dump)), Ok(loaded)) => {
                assert_eq!(dump.loaded.warnings, loaded.warnings, "variant {k}");
                assert_eq!(dump.loaded.gbuffer.coverage, loaded.gbuffer.coverage, "variant {k}");
                opened += 1;
            }
            // Not recognised as a `.bin` at all: `load` names the file's problem.
            (Ok(None), Err(e)) => {
                assert!(e.to_string().contains(&format!("v{k}.bin")), "{e}");
                refused += 1;
            }
            (Err(a), Err(b)) => {
                assert_eq!(a.to_string(), b.to_string(), "variant {k}");
                refused += 1;
            }
            (a, b) => panic!("variant {k}: open {:?} but load {:?}", a.map(|d| d.is_some()), b.map(|_| ())),
        }
    }
    assert!(opened > 10 && refused > 10, "{opened} opened, {refused} refused");
}

/// A sidecar beside the `.bin` (its default `<stem>.json`) gives the lights, which win over the file's, and its
/// camera is checked against the image: opened as arrays exactly as loaded, a wrong aspect refused by both.
#[test]
fn a_sidecar_beside_the_bin_applies_as_when_loading() {
    let dir = tempfile::tempdir().unwrap();
    let path = spoiled_room(dir.path());
    let side = dir.path().join("spoiled.json");
    std::fs::write(
        &side,
        r#"{"lights_space": "view", "lights": [
            {"type": "point", "position": [0.5, 0.2, -3.0], "color": [1, 0.5, 0.25], "intensity": 2, "range": 6}]}"#,
    )
    .unwrap();
    let opts = LoadOptions::default();
    let (dump, loaded) = (open_packed(&path, &opts).unwrap().unwrap(), load(&path, &opts).unwrap());
    let lights = dump.loaded.lights.as_ref().unwrap();
    assert_eq!(lights.len(), 1, "the sidecar's light, not the file's 40");
    assert_eq!(dump.loaded.lights, loaded.lights);
    let camera = r#""camera": {"world_to_view": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
        "yfov": 0.9, "aspect": 3.0, "znear": 0.1, "zfar": 100}"#;
    std::fs::write(&side, format!("{{ {camera} }}")).unwrap();
    let (a, b) = (open_packed(&path, &opts).unwrap_err().to_string(), load(&path, &opts).unwrap_err().to_string());
    assert_eq!(a, b);
    assert!(a.contains("spoiled.json") && a.contains("aspect"), "{a}");
}
