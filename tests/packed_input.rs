//! Packed render targets as an input (`layout::targets`, `--layout`/`--input-layout`): what `gbuf pack` writes
//! reads back as the layout's own unpack of the frame, bit for bit, for every built-in layout; repacking keeps every
//! byte; files other tools write (legacy DDS headers, typeless and BGRA formats, mip chains, PNG and EXR targets)
//! read as the same texels; bad folders give errors that name the file and the problem. A RenderDoc capture of the
//! same frame (`fixtures/engine_4x.rdc`, read through RenderDoc's replay) reads as the folder its targets were saved
//! to, at any of its actions.

mod support;

use gbuf::base::rng::SplitMix64;
use gbuf::gbuffer::{Attribute, GBuffer};
use gbuf::io::{load as load_dump, LoadOptions};
use gbuf::layout::targets::{self, PackedInput};
use gbuf::layout::Layout;
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::process::Command;
use support::io::{plane_bits, plausible};
use support::{gbuf, stderr};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures").join(name)
}

/// A plausible G-buffer with every attribute of the model (so every field of every layout has data).
fn every_attribute(w: u32, h: u32, samples: u32) -> GBuffer {
    let mut gb = plausible(w, h, samples, 7);
    let n = gb.len();
    let mut r = SplitMix64::new(11);
    let m: Vec<u32> = (0..n).map(|_| (r.next_u64() % 6) as u32).collect();
    gb.material_id = Some(m.clone());
    gb.specular = Some(m.iter().map(|&k| 0.02 + 0.05 * k as f32).collect());
    gb.specular_power = Some(m.iter().map(|&k| 4.0 * (1 + k) as f32).collect());
    gb.roughness = Some(m.iter().map(|&k| 0.15 * k as f32).collect());
    gb.metallic = Some(m.iter().map(|&k| (k % 2) as f32).collect());
    gb.object_id = Some((0..n).map(|_| (r.next_u64() % 500) as u32).collect());
    gb.primitive_id = Some((0..n).map(|_| r.next_u64() as u32 >> 4).collect());
    gb.motion = Some((0..n).map(|_| Vec2::new(r.range_f32(-0.5, 0.5), r.range_f32(-0.5, 0.5))).collect());
    gb.albedo = Some((0..n).map(|_| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32())).collect());
    gb.zero_background();
    gb
}

fn every_layout() -> Vec<Layout> {
    Layout::builtins().into_iter().chain(Layout::visibility_builtins()).collect()
}

/// Every plane the expected G-buffer has, the loaded one has with the same bits at covered samples; coverage and
/// sample positions are the same.
fn assert_same_covered(what: &str, want: &GBuffer, got: &GBuffer) {
    assert_eq!(want.coverage, got.coverage, "{what}: coverage");
    assert_eq!(want.sample_positions, got.sample_positions, "{what}: sample positions");
    let per = |a: Attribute| match a {
        Attribute::Position | Attribute::Normal | Attribute::Albedo => 3,
        Attribute::Motion => 2,
        _ => 1,
    };
    for a in Attribute::ALL {
        let Some(w) = plane_bits(want, a) else { continue };
        let g = plane_bits(got, a).unwrap_or_else(|| panic!("{what}: {} missing", a.name()));
        let k = per(a);
        let bad = (0..want.len()).find(|&i| want.coverage[i] && w[i * k..(i + 1) * k] != g[i * k..(i + 1) * k]);
        assert!(bad.is_none(), "{what}: {} differs at sample {bad:?}", a.name());
    }
}

/// `gbuf pack`'s files read back (no flags: the folder names its layout) as `layout.unpack(layout.pack(gb))`, for
/// every built-in layout, on the llvmpipe 4× fixture and on a frame with every attribute.
#[test]
fn packed_frames_read_back_as_the_layouts_unpack_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let raster = load_dump(&fixture("raster_4x.exr"), &LoadOptions::default()).unwrap();
    let frames = [
        ("raster_4x", raster.gbuffer, raster.lights.unwrap_or_default()),
        ("synthetic", every_attribute(23, 11, 4), Vec::new()),
    ];
    for (name, gb, lights) in &frames {
        for layout in every_layout() {
            let what = format!("{name} / {}", layout.name());
            let out = dir.path().join(format!("{name}-{}", layout.name()));
            targets::write_frame(&layout, gb, lights, &out).unwrap();
            assert!(targets::is_packed_dir(&out));
            let loaded = targets::load(&out, &PackedInput::default(), &LoadOptions::default())
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            let want = layout.unpack(&layout.pack(gb).unwrap(), gb).unwrap();
            assert_same_covered(&what, &want, &loaded.gbuffer);
            assert_eq!(loaded.lights.as_ref().map_or(0, Vec::len), lights.len(), "{what}: lights");
            // The same folder read with the layout given explicitly and no layout.toml.
            std::fs::remove_file(out.join(targets::LAYOUT_FILE)).unwrap();
            let input = PackedInput { layout: Some(layout.clone()), targets: Vec::new() };
            let again = targets::load(&out, &input, &LoadOptions::default()).unwrap();
            assert_same_covered(&format!("{what} (--layout)"), &want, &again.gbuffer);
            // The codes read are the codes written.
            let frame = targets::read_frame(&out, &layout, &[], &LoadOptions::default()).unwrap();
            assert_eq!(frame.packed.targets, layout.pack(gb).unwrap().targets, "{what}: texels");
        }
    }
}

fn files_of(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    v.sort();
    v
}

/// `gbuf pack DUMP` → `gbuf pack DIR` with the same layout writes the same bytes in every file; `gbuf info DIR
/// --layout L` (no layout.toml) reads the frame; another layout re-encodes the decoded frame.
#[test]
fn the_cli_repacks_a_packed_frame_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let dump = fixture("raster_4x.exr");
    for name in ["unreal-like", "destiny-96", "lauritzen-15", "visibility-8"] {
        let a = dir.path().join(format!("{name}-a"));
        let b = dir.path().join(format!("{name}-b"));
        let o = gbuf(dir.path(), &["pack", dump.to_str().unwrap(), "--layout", name, "-o", a.to_str().unwrap()]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let o = gbuf(dir.path(), &["pack", a.to_str().unwrap(), "--layout", name, "-o", b.to_str().unwrap(), "--json"]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["codes_copied"], true, "{name}");
        assert_eq!(files_of(&a), files_of(&b), "{name}: repacked files differ");
    }
    let a = dir.path().join("unreal-like-a");
    std::fs::remove_file(a.join("layout.toml")).unwrap();
    let o = gbuf(dir.path(), &["info", a.to_str().unwrap(), "--layout", "unreal-like", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["format"], "packed-targets", "{j}");
    // `gbuf convert` writes the decoded frame as the canonical EXR: it reads back as the same G-buffer.
    let exr = dir.path().join("converted.exr");
    let o = gbuf(dir.path(), &["convert", a.to_str().unwrap(), "--layout", "unreal-like", "-o", exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let layout = Layout::by_name("unreal-like").unwrap();
    let input = PackedInput { layout: Some(layout), targets: Vec::new() };
    let packed = targets::load(&a, &input, &LoadOptions::default()).unwrap();
    let converted = load_dump(&exr, &LoadOptions::default()).unwrap();
    support::io::assert_bit_exact(&packed.gbuffer, &converted.gbuffer);
    assert_eq!(converted.lights.map(|l| l.len()), packed.lights.map(|l| l.len()));
    // Without the layout the folder is not a dump gbuf recognises: an error, not a guess.
    let o = gbuf(dir.path(), &["info", a.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // Another layout: decoded through unreal-like, encoded with fat-20.
    let c = dir.path().join("fat");
    let o = gbuf(
        dir.path(),
        &[
            "pack",
            a.to_str().unwrap(),
            "--input-layout",
            "unreal-like",
            "--layout",
            "fat-20",
            "-o",
            c.to_str().unwrap(),
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["codes_copied"], false);
    for t in ["depth", "lighting", "normal", "motion_specular", "albedo"] {
        assert!(c.join(format!("{t}.dds")).exists(), "fat-20 target {t}");
    }
}

/// Files written by another tool, from Microsoft's documentation: a legacy header (RGB masks for RGBA8 and
/// R10G10B10A2, D3DFMT FourCC 114 for R32F), BGRA8 for an RGBA8 target, R32_TYPELESS for D32_FLOAT, a 3-level mip
/// chain per slice; and a 1-sample frame's targets as PNG (8-bit RGBA) and EXR (float channel). Each reads as the
/// texels `gbuf pack` wrote.
#[test]
fn targets_other_tools_write_read_as_the_same_texels() {
    if !support::python_has("OpenEXR, numpy") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let layout = Layout::by_name("unreal-like").unwrap();
    let gb = every_attribute(17, 9, 1);
    let a = dir.path().join("a");
    targets::write_frame(&layout, &gb, &[], &a).unwrap();
    let want = targets::read_frame(&a, &layout, &[], &LoadOptions::default()).unwrap();
    let conv = dir.path().join("convert.py");
    std::fs::write(&conv, CONVERT).unwrap();
    for mode in ["legacy", "variants", "png-exr"] {
        let b = dir.path().join(mode);
        let py = Command::new("python3").arg(&conv).arg(mode).arg(&a).arg(&b).output().expect("python3");
        assert!(py.status.success(), "{mode}: {}", String::from_utf8_lossy(&py.stderr));
        let got =
            targets::read_frame(&b, &layout, &[], &LoadOptions::default()).unwrap_or_else(|e| panic!("{mode}: {e}"));
        assert_eq!(got.packed.targets, want.packed.targets, "{mode}");
        assert_eq!(got.shell.coverage, want.shell.coverage, "{mode}");
        let listing: Vec<&str> = got.files.iter().map(|f| f.2.as_str()).collect();
        let expect = match mode {
            "legacy" => "legacy header",
            "variants" => "TYPELESS",
            _ => "PNG",
        };
        assert!(listing.iter().any(|l| l.contains(expect)), "{mode}: {listing:?}");
    }
}

/// Converts gbuf's DX10 DDS targets into what other tools write. Written from Microsoft's "DDS file layout".
const CONVERT: &str = r#"
import struct, sys, os, shutil, zlib
mode, src, dst = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(dst)
for f in os.listdir(src):
    if not f.endswith(".dds"):
        shutil.copy(os.path.join(src, f), os.path.join(dst, f))
for f in sorted(os.listdir(src)):
    if not f.endswith(".dds"):
        continue
    data = open(os.path.join(src, f), "rb").read()
    h, w = struct.unpack_from("<II", data, 12)
    fmt, dim, misc, arr, misc2 = struct.unpack_from("<5I", data, 128)
    texels = data[148:]
    tb = len(texels) // (w * h * arr)
    name = f[:-4]
    def legacy_header(pf_flags, fourcc, bits, masks):
        hdr = struct.pack("<7I", 124, 0x1007, h, w, w * tb, 0, 1) + b"\0" * 44
        hdr += struct.pack("<8I", 32, pf_flags, fourcc, bits, *masks)
        hdr += struct.pack("<5I", 0x1000, 0, 0, 0, 0)
        return b"DDS " + hdr
    if mode == "legacy":
        assert arr == 1
        if fmt in (28, 29):
            out = legacy_header(0x41, 0, 32, (0xff, 0xff00, 0xff0000, 0xff000000)) + texels
        elif fmt == 24:
            out = legacy_header(0x41, 0, 32, (0x3ff, 0xffc00, 0x3ff00000, 0xc0000000)) + texels
        elif fmt in (40, 41):
            out = legacy_header(0x4, 114, 0, (0, 0, 0, 0)) + texels
        else:
            out = data
    elif mode == "variants":
        # BGRA for RGBA8 targets, R32_TYPELESS for depth, and a mip chain of 3 levels after each slice.
        fmt2 = {28: 87, 40: 39}.get(fmt, fmt)
        if fmt2 == 87:
            t = bytearray(texels)
            for i in range(0, len(t), 4):
                t[i], t[i + 2] = t[i + 2], t[i]
            texels = bytes(t)
        slices = [texels[s * w * h * tb:(s + 1) * w * h * tb] for s in range(arr)]
        mips = b"".join(b"\xab" * (max(1, w >> l) * max(1, h >> l) * tb) for l in (1, 2))
        hdr = bytearray(data[:148])
        struct.pack_into("<I", hdr, 8, 0x1007 | 0x20000)
        struct.pack_into("<I", hdr, 28, 3)
        struct.pack_into("<I", hdr, 128, fmt2)
        out = bytes(hdr) + b"".join(s + mips for s in slices)
    else:
        assert arr == 1
        if fmt in (28, 29):
            raw = b"".join(b"\0" + texels[y * w * 4:(y + 1) * w * 4] for y in range(h))
            def chunk(kind, body):
                return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
            png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
            png += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
            open(os.path.join(dst, name + ".png"), "wb").write(png)
            continue
        if fmt == 40:
            import OpenEXR, numpy as np
            px = np.frombuffer(texels, dtype="<f4").reshape(h, w)
            OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION}, {"R": px.astype(np.float32)}).write(os.path.join(dst, name + ".exr"))
            continue
        out = data
    open(os.path.join(dst, f), "wb").write(out)
"#;

/// Bad folders: each gives exit code 1 and a message naming the file and the problem, never a panic.
#[test]
fn bad_packed_folders_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let dump = fixture("raster_4x.exr");
    let a = dir.path().join("a");
    let o = gbuf(dir.path(), &["pack", dump.to_str().unwrap(), "--layout", "unreal-like", "-o", a.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = |args: &[&str], want: &[&str]| {
        let o = gbuf(dir.path(), args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        for w in want {
            assert!(e.contains(w), "{args:?}: {w:?} not in {e}");
        }
    };
    let info = |d: &Path| d.to_str().unwrap().to_string();
    // A missing target.
    let b = dir.path().join("missing");
    copy_dir(&a, &b);
    std::fs::remove_file(b.join("gbuffer_b.dds")).unwrap();
    run(&["info", &info(&b)], &["gbuffer_b", "no file for target"]);
    // A truncated target.
    let c = dir.path().join("truncated");
    copy_dir(&a, &c);
    let f = c.join("gbuffer_a.dds");
    let bytes = std::fs::read(&f).unwrap();
    std::fs::write(&f, &bytes[..bytes.len() / 2]).unwrap();
    run(&["info", &info(&c)], &["gbuffer_a.dds", "truncated"]);
    // A target of the wrong format (R32_FLOAT where R10G10B10A2 is expected).
    let d = dir.path().join("format");
    copy_dir(&a, &d);
    std::fs::copy(d.join("depth.dds"), d.join("gbuffer_a.dds")).unwrap();
    run(&["info", &info(&d)], &["gbuffer_a.dds", "D32_FLOAT", "rgb10a2"]);
    // Targets of different sizes.
    let e = dir.path().join("size");
    copy_dir(&a, &e);
    let mut bytes = std::fs::read(e.join("gbuffer_c.dds")).unwrap();
    bytes[140..144].copy_from_slice(&1u32.to_le_bytes()); // one array slice
    std::fs::write(e.join("gbuffer_c.dds"), &bytes).unwrap();
    run(&["info", &info(&e)], &["slice"]);
    // A --target naming no target of the layout; a layout with no depth and no coverage file.
    let args = ["info", a.to_str().unwrap(), "--target", "gbuffer_z=x.dds"];
    run(&args, &["gbuffer_z", "no such target"]);
    let v = dir.path().join("nodepth");
    std::fs::create_dir(&v).unwrap();
    let spec = "name = \"albedo-only\"\n[[targets]]\nname = \"albedo\"\nformat = \"rgba8\"\nfields = [{ attribute = \"albedo\", codec = \"unorm-8\", offset = 0, bits = 24 }]\n";
    std::fs::write(v.join("layout.toml"), spec).unwrap();
    std::fs::copy(a.join("gbuffer_c.dds"), v.join("albedo.dds")).unwrap();
    run(&["info", v.to_str().unwrap()], &["stores no depth", "coverage"]);
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
    }
}

/// The code-space report runs on every fixture: its counts agree with the G-buffer's own distinct values (object
/// IDs through visibility-8's 8-bit field, which saturates at 255), extremes bound every code, and the bits it calls
/// constant are the same in the smallest and the largest code.
#[test]
fn the_code_space_report_runs_on_every_fixture() {
    use gbuf::layout::codespace::code_space;
    let fixtures = [
        "raster_4x.exr",
        "raster_1x.exr",
        "room_1x.exr",
        "room_4x.exr",
        "blender_gbuffer.exr",
        "mitsuba_gbuffer.exr",
        "mitsuba_16x.exr",
        "ispc_deferred.bin",
        "luxcore",
    ];
    let vis = Layout::by_name("visibility-8").unwrap();
    let unreal = Layout::by_name("unreal-like").unwrap();
    for name in fixtures {
        let gb = load_dump(&fixture(name), &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}")).gbuffer;
        for layout in [&vis, &unreal] {
            let packed = layout.pack(&gb).unwrap();
            let rows = code_space(layout, &packed, &gb.coverage);
            assert_eq!(rows.len(), layout.fields().len(), "{name}");
            let covered = gb.coverage.iter().filter(|&&c| c).count() as u64;
            for r in &rows {
                assert_eq!(r.samples, covered, "{name} {}", r.field);
                assert!(r.distinct >= 1 && r.distinct <= r.samples && r.min <= r.max, "{name}: {r:?}");
                assert_eq!((r.min ^ r.max) & r.constant_bits, 0, "{name}: {r:?}");
                assert!(r.max >> r.bits == 0, "{name}: {r:?}");
            }
            if let (Some(ids), true) = (&gb.object_id, std::ptr::eq(layout, &vis)) {
                let want: std::collections::HashSet<u32> =
                    ids.iter().zip(&gb.coverage).filter(|(_, &c)| c).map(|(&i, _)| i.min(255)).collect();
                let r = rows.iter().find(|r| r.field == "object_id").unwrap();
                assert_eq!(r.distinct, want.len() as u64, "{name}: distinct object IDs");
            }
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let o =
        gbuf(dir.path(), &["roundtrip", fixture("room_1x.exr").to_str().unwrap(), "--layout", "destiny-96", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = j["code_space"].as_array().unwrap();
    assert!(rows.iter().any(|r| r["field"] == "material_index" && r["distinct"].as_u64().unwrap() > 1), "{j}");
}

/// The llvmpipe engine capture (fixtures/engine_4x: Cigolle octahedral normals as unorm in RGB10A2, sRGB albedo,
/// UNORM roughness/metallic/material ID, reversed-Z D32F, 4× MSAA saved as DDS arrays) read with nothing but its
/// layout gives the float truth of the same render, sample for sample, within each field's codec bound: IDs and
/// coverage exact; albedo, roughness, metallic within the codec bound; depth within the codec bound plus the GPU's
/// f32 arithmetic of d (2e-6 relative measured; 1e-5 allowed); normals within two codec bounds, because llvmpipe
/// converts a float written to a 10-bit UNORM target as `rne(v·65535) >> 6`, which lands one code off the nearest
/// for 1.8 % of components (fixtures/README.md): the bound of a one-code error.
#[test]
fn the_llvmpipe_engine_capture_decodes_to_its_float_truth() {
    use gbuf::codec::{color_codec, depth_codec, normal_codec, scalar_codec};
    let dir = fixture("engine_4x");
    let layout = Layout::load(&dir.join("engine.toml")).unwrap();
    let input = PackedInput { layout: Some(layout), targets: Vec::new() };
    let got = targets::load(&dir, &input, &LoadOptions::default()).unwrap();
    let truth = load_dump(&dir.join("truth.exr"), &LoadOptions::default()).unwrap().gbuffer;
    let gb = &got.gbuffer;
    assert_eq!((gb.width, gb.height, gb.samples), (truth.width, truth.height, truth.samples));
    assert_eq!(gb.coverage, truth.coverage, "coverage from the reversed-Z clear value");
    assert_eq!(gb.sample_positions, truth.sample_positions);
    let cam = gb.camera.expect("the sidecar's camera");
    let normal = normal_codec("oct-unorm-20").unwrap();
    let srgb = color_codec("srgb8").unwrap();
    let unorm8 = scalar_codec("unorm-8").unwrap();
    let depth = depth_codec("f32-reversed", cam.znear, cam.zfar).unwrap();
    let (mut worst_n, mut worst_z) = (0f32, 0f32);
    for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
        assert_eq!(gb.material_id.as_ref().unwrap()[i], truth.material_id.as_ref().unwrap()[i], "material ID at {i}");
        let (n, tn) = (gb.normal.as_ref().unwrap()[i], truth.normal.as_ref().unwrap()[i]);
        worst_n = worst_n.max(gbuf::codec::angle_deg(n, tn));
        let (a, ta) = (gb.albedo.as_ref().unwrap()[i], truth.albedo.as_ref().unwrap()[i]);
        let bound = srgb.error_bound(ta) + glam::Vec3::splat(1e-6);
        assert!((a - ta).abs().cmple(bound).all(), "albedo at {i}: {a} vs {ta} (bound {bound})");
        for (p, tp) in [(&gb.roughness, &truth.roughness), (&gb.metallic, &truth.metallic)] {
            let (v, tv) = (p.as_ref().unwrap()[i], tp.as_ref().unwrap()[i]);
            assert!((v - tv).abs() <= unorm8.error_bound(tv) + 1e-6, "roughness/metallic at {i}: {v} vs {tv}");
        }
        let (z, tz) = (gb.depth.as_ref().unwrap()[i], truth.depth.as_ref().unwrap()[i]);
        assert!((z - tz).abs() <= depth.error_bound(tz) + 1e-5 * tz, "depth at {i}: {z} vs {tz}");
        worst_z = worst_z.max((z - tz).abs() / tz);
    }
    assert!(worst_n <= 2.0 * normal.max_error_deg(), "normal {worst_n}° > 2 × {}°", normal.max_error_deg());
    assert!(worst_z < 1e-5, "depth relative {worst_z}");
    // With no flag but its layout, the CLI reads it too, says there is no float truth, and converts it.
    let tmp = tempfile::tempdir().unwrap();
    let toml = dir.join("engine.toml");
    let o = gbuf(tmp.path(), &["info", dir.to_str().unwrap(), "--layout", toml.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // `info` lists the warning in its text (once, not again on stderr).
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("no float truth") && !stderr(&o).contains("no float truth"), "{text}");
    assert!(text.contains("code space"));
    let exr = tmp.path().join("engine.exr");
    let o = gbuf(
        tmp.path(),
        &["convert", dir.to_str().unwrap(), "--layout", toml.to_str().unwrap(), "-o", exr.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    support::io::assert_bit_exact(gb, &load_dump(&exr, &LoadOptions::default()).unwrap().gbuffer);
    // The report says it too, in report.md and report.json.
    let out = tmp.path().join("report");
    let args = [
        "report",
        dir.to_str().unwrap(),
        "--input-layout",
        toml.to_str().unwrap(),
        "--candidates",
        "minimal-8",
        "-o",
        out.to_str().unwrap(),
    ];
    let o = gbuf(tmp.path(), &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("**Note:**") && md.contains("no float truth"), "report.md lacks the note");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert!(json["frames"][0]["notes"][0].as_str().is_some_and(|n| n.contains("no float truth")));
}

/// RenderDoc's "slices as grid" export of a multisampled target: one image of 2×2 tiles, tile s = sample s.
/// `--grid 2x2` (LoadOptions::grid) unfolds it, for packed targets (a DDS written here as such a mosaic) and for
/// any dump (a canonical EXR mosaic): both give the frame back.
#[test]
fn slices_as_grid_mosaics_unfold_into_samples() {
    let dir = tempfile::tempdir().unwrap();
    let layout = Layout::by_name("unreal-like").unwrap();
    let gb = every_attribute(13, 7, 4);
    let a = dir.path().join("arrays");
    targets::write_frame(&layout, &gb, &[], &a).unwrap();
    let want = targets::read_frame(&a, &layout, &[], &LoadOptions::default()).unwrap();
    // The same targets as 26×14 one-slice mosaics.
    let m = dir.path().join("mosaic");
    std::fs::create_dir(&m).unwrap();
    for f in std::fs::read_dir(&a).unwrap() {
        let f = f.unwrap().path();
        let name = f.file_name().unwrap().to_str().unwrap().to_string();
        if !name.ends_with(".dds") {
            std::fs::copy(&f, m.join(&name)).unwrap();
            continue;
        }
        let d = std::fs::read(&f).unwrap();
        let (h, w) =
            (u32::from_le_bytes(d[12..16].try_into().unwrap()), u32::from_le_bytes(d[16..20].try_into().unwrap()));
        let texels = &d[148..];
        let tb = texels.len() / (w * h * 4) as usize;
        let (w, h) = (w as usize, h as usize);
        let mut mosaic = vec![0u8; texels.len()];
        for s in 0..4 {
            for y in 0..h {
                for x in 0..w {
                    let src = ((s * h + y) * w + x) * tb;
                    let dst = (((s / 2) * h + y) * 2 * w + (s % 2) * w + x) * tb;
                    mosaic[dst..dst + tb].copy_from_slice(&texels[src..src + tb]);
                }
            }
        }
        let mut hdr = d[..148].to_vec();
        hdr[12..16].copy_from_slice(&(2 * h as u32).to_le_bytes());
        hdr[16..20].copy_from_slice(&(2 * w as u32).to_le_bytes());
        hdr[20..24].copy_from_slice(&((2 * w * tb) as u32).to_le_bytes());
        hdr[140..144].copy_from_slice(&1u32.to_le_bytes());
        hdr.extend(mosaic);
        std::fs::write(m.join(&name), hdr).unwrap();
    }
    let opts = LoadOptions { grid: Some((2, 2)), ..LoadOptions::default() };
    let got = targets::read_frame(&m, &layout, &[], &opts).unwrap();
    assert_eq!(got.packed.targets, want.packed.targets, "the mosaic's tiles are the array's slices");
    assert_eq!(got.shell.coverage, want.shell.coverage);
    let loaded = targets::load(&m, &PackedInput::default(), &opts).unwrap();
    assert_eq!((loaded.gbuffer.width, loaded.gbuffer.height, loaded.gbuffer.samples), (13, 7, 4));
    // A float dump saved the same way (a canonical EXR of one sample per pixel, 2×2 tiles).
    let mut mosaic = GBuffer::new(26, 14, 1).unwrap();
    let at = |x: usize, y: usize, s: usize| ((s / 2) * 7 + y) * 26 + (s % 2) * 13 + x;
    let n = mosaic.len();
    mosaic.coverage = vec![false; n];
    let mut depth = vec![0f32; n];
    let mut normal = vec![glam::Vec3::ZERO; n];
    let mut ids = vec![0u32; n];
    for y in 0..7 {
        for x in 0..13 {
            for s in 0..4 {
                let i = gb.index(x as u32, y as u32, s as u32);
                let j = at(x, y, s);
                mosaic.coverage[j] = gb.coverage[i];
                depth[j] = gb.depth.as_ref().unwrap()[i];
                normal[j] = gb.normal.as_ref().unwrap()[i];
                ids[j] = gb.object_id.as_ref().unwrap()[i];
            }
        }
    }
    (mosaic.depth, mosaic.normal, mosaic.object_id) = (Some(depth), Some(normal), Some(ids));
    mosaic.camera = gb.camera;
    let exr = dir.path().join("mosaic.exr");
    gbuf::io::canonical::write(&exr, &mosaic).unwrap();
    let back = load_dump(&exr, &opts).unwrap().gbuffer;
    assert_eq!((back.width, back.height, back.samples), (13, 7, 4));
    assert_eq!(back.coverage, gb.coverage);
    assert_eq!(plane_bits(&back, Attribute::Depth), plane_bits(&gb, Attribute::Depth));
    assert_eq!(plane_bits(&back, Attribute::ObjectId), plane_bits(&gb, Attribute::ObjectId));
    assert!(back.camera.is_none(), "the mosaic's own camera described the mosaic");
    let o = gbuf(dir.path(), &["info", exr.to_str().unwrap(), "--grid", "2x2", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = gbuf(dir.path(), &["info", exr.to_str().unwrap(), "--grid", "3x2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("multiple"), "{}", stderr(&o));
}

/// Hostile target files: every prefix of a DDS and of a `.bin` target, and seeded byte flips in their headers, read
/// as an error or as texels, never a panic, and never past the memory limit (a header claiming 2^31 × 2^31 texels
/// is refused before anything is allocated).
#[test]
fn hostile_target_files_are_errors_not_panics() {
    use gbuf::io::ReadLimits;
    use gbuf::layout::texture;
    let dir = tempfile::tempdir().unwrap();
    let layout = Layout::by_name("lauritzen-15").unwrap();
    let gb = every_attribute(5, 3, 2);
    let a = dir.path().join("a");
    targets::write_frame(&layout, &gb, &[], &a).unwrap();
    let limits = ReadLimits { max_bytes: 1 << 20, allow_dwa: false };
    let mut rng = SplitMix64::new(9);
    for (file, format) in [("depth.dds", gbuf::layout::Format::R32F), ("albedo.bin", gbuf::layout::Format::Rgb8)] {
        let good = std::fs::read(a.join(file)).unwrap_or_else(|_| panic!("{file}"));
        let f = dir.path().join(file);
        for len in 0..good.len() {
            std::fs::write(&f, &good[..len]).unwrap();
            let _ = texture::read(&f, format, &limits);
        }
        for _ in 0..2000 {
            let mut b = good.clone();
            for _ in 0..1 + rng.next_u64() % 4 {
                let i = (rng.next_u64() % 160.min(b.len() as u64)) as usize;
                b[i] = rng.next_u64() as u8;
            }
            std::fs::write(&f, &b).unwrap();
            if let Ok(t) = texture::read(&f, format, &limits) {
                assert!(t.bytes.len() as u64 <= limits.max_bytes, "{file}: {} bytes", t.bytes.len());
            }
        }
        let mut huge = good.clone();
        if file.ends_with(".dds") {
            huge[12..16].copy_from_slice(&(1u32 << 31).to_le_bytes());
            huge[16..20].copy_from_slice(&(1u32 << 31).to_le_bytes());
            std::fs::write(&f, &huge).unwrap();
            let e = texture::read(&f, format, &limits).unwrap_err().to_string();
            assert!(e.contains("limit"), "{e}");
        }
    }
}

// --- RenderDoc captures -------------------------------------------------------------------------------------------

/// The options that read `fixtures/engine_4x.rdc` (or its folder) through its layout, at `event`.
fn capture_options(event: Option<u32>) -> LoadOptions {
    LoadOptions {
        input_layout: Some(fixture("engine_4x/engine.toml").display().to_string()),
        sidecar: Some(fixture("engine_4x/scene.json")),
        capture: gbuf::io::rdc::Selection { event, marker: None },
        ..Default::default()
    }
}

#[test]
fn a_renderdoc_capture_reads_as_the_targets_saved_from_it() {
    if !support::renderdoc_has() {
        return;
    }
    // The capture is of the very render fixtures/engine_4x/ was saved from (fixtures/scripts/rdc_capture.sh):
    // RenderDoc's replay of its last draw gives the same codes, so the same decoded frame, bit for bit.
    let from_capture = gbuf::load(fixture("engine_4x.rdc"), &capture_options(None)).unwrap();
    let from_folder = gbuf::load(fixture("engine_4x"), &capture_options(None)).unwrap();
    assert_eq!(from_capture.gbuffer, from_folder.gbuffer);
    assert_eq!(from_capture.format, from_folder.format);
    // Each attribute says which attachment of which event it came from.
    let normal = from_capture.sources.iter().find(|s| s.attribute == "normal").unwrap();
    let note = normal.note.as_deref().unwrap();
    assert!(note.contains("RenderDoc event 185") && note.contains("color5 \"gbuffer_a\""), "{note}");

    // An earlier action: after the floor's draw (event 52) only the floor is there; it is covered where the
    // finished frame's floor is, plus where later draws hid it.
    let floor = gbuf::load(fixture("engine_4x.rdc"), &capture_options(Some(52))).unwrap().gbuffer;
    let (fc, all) = (&floor.coverage, &from_folder.gbuffer.coverage);
    let count = |c: &[bool]| c.iter().filter(|&&c| c).count();
    assert!(count(fc) > 0 && count(fc) < count(all), "{} of {}", count(fc), count(all));
    let ids = floor.material_id.as_ref().unwrap();
    let floor_ids: std::collections::BTreeSet<u32> = (0..fc.len()).filter(|&i| fc[i]).map(|i| ids[i]).collect();
    assert_eq!(floor_ids.len(), 1, "one material after the first draw: {floor_ids:?}");
    let last = from_folder.gbuffer.material_id.as_ref().unwrap();
    let id = *floor_ids.first().unwrap();
    assert!((0..fc.len()).all(|i| !all[i] || last[i] != id || fc[i]), "the finished floor was drawn by event 52");

    // The same event chosen by its marker.
    let by_marker = LoadOptions {
        capture: gbuf::io::rdc::Selection { event: None, marker: Some("GBuffer/floor".into()) },
        ..capture_options(None)
    };
    assert_eq!(gbuf::load(fixture("engine_4x.rdc"), &by_marker).unwrap().gbuffer, floor);
}

#[test]
fn a_renderdoc_capture_lists_its_actions_and_refuses_what_it_cannot_read() {
    if !support::renderdoc_has() {
        return;
    }
    let dir = fixture("");
    let rdc = fixture("engine_4x.rdc").display().to_string();
    let out = gbuf(&dir, &["info", &rdc, "--list", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let list: gbuf::io::rdc::Listing = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((list.api.as_str(), list.default_event), ("OpenGL", Some(185)));
    let last = list.actions.iter().find(|a| a.event == 185).unwrap();
    let a = last.colors.iter().find(|t| t.name == "gbuffer_a").unwrap();
    assert_eq!((a.slot, a.format.as_str(), a.width, a.height, a.samples), (Some(5), "R10G10B10A2_UNORM", 160, 90, 4));
    assert_eq!(last.depth.as_ref().map(|d| d.format.as_str()), Some("D32"));

    let layout = fixture("engine_4x/engine.toml").display().to_string();
    let scene = fixture("engine_4x/scene.json").display().to_string();
    let info = |extra: &[&str], env: Option<&str>| {
        let mut c = support::gbuf_command();
        c.current_dir(&dir).args(["info", &rdc, "--input-layout", &layout, "--scene", &scene]).args(extra);
        if let Some(py) = env {
            c.env("GBUF_RDC_PYTHON", py);
        }
        c.output().unwrap()
    };
    let fails = |o: &std::process::Output, words: &[&str]| {
        let e = stderr(o);
        assert!(!o.status.success() && e.contains("engine_4x.rdc"), "{e}");
        for w in words {
            assert!(e.contains(w), "{w:?} not in: {e}");
        }
        assert!(!e.contains("panicked") && !e.contains("gbuf-rdc-"), "{e}");
    };
    // A layout target pointed at an attachment that is not bound, or that holds another format.
    fails(&info(&["--target", "gbuffer_a=color9"], None), &["color9", "bound there", "gbuffer_a"]);
    fails(&info(&["--target", "gbuffer_a=color6"], None), &["event 185", "color6", "R8G8B8A8_UNORM_SRGB"]);
    // An event that is not an action.
    fails(&info(&["--event", "99999"], None), &["99999"]);
    // No Python with RenderDoc's module: what to install and which variable to set.
    fails(&info(&[], Some("/nonexistent/python3")), &["python3-renderdoc", "GBUF_RDC_PYTHON"]);
    // Without a layout: how to give it.
    let o = gbuf(&dir, &["info", &rdc]);
    fails(&o, &["--input-layout", "--list"]);
}

/// RenderDoc's 32-bit → 24-bit colour hash of an ID, as the emitted views compute it (Wellons' lowbias32).
fn id_colour(id: u32) -> [f32; 3] {
    let mut h = id;
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    [(h & 255) as f32 / 255.0, ((h >> 8) & 255) as f32 / 255.0, ((h >> 16) & 255) as f32 / 255.0]
}

#[test]
fn renderdoc_views_show_gbufs_decode_of_every_sample_in_renderdocs_own_replay() {
    if !support::renderdoc_has() {
        return;
    }
    // The frame as gbuf decodes it, and its camera (the depth view's near and far).
    let loaded = gbuf::load(fixture("engine_4x.rdc"), &capture_options(None)).unwrap();
    let gb = &loaded.gbuffer;
    let cam = gb.camera.unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let views = tmp.path().join("views");
    let layout = fixture("engine_4x/engine.toml").display().to_string();
    let (zn, zf) = (cam.znear.to_string(), cam.zfar.to_string());
    let args =
        ["layouts", &layout, "--emit", "renderdoc", "-o", views.to_str().unwrap(), "--znear", &zn, "--zfar", &zf];
    let out = gbuf(tmp.path(), &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let formats = std::fs::read_to_string(views.join("buffer_formats.txt")).unwrap();
    assert!(
        formats.contains("uint normal_r : 10; uint normal_g : 10;") && formats.contains("float depth;"),
        "{formats}"
    );

    // Each view, run by RenderDoc on the capture's targets at every sample and "average value".
    let shown: Vec<(&str, &str)> = vec![
        ("gbuffer_a", "normal"),
        ("gbuffer_b", "albedo"),
        ("gbuffer_c", "roughness"),
        ("gbuffer_c", "metallic"),
        ("gbuffer_c", "material_id"),
        ("depth", "depth"),
    ];
    let file = |t: &str, a: &str| views.join(format!("gbuf_engine_oct_rgb10a2_{t}_{a}.glsl"));
    let results = tmp.path().join("out");
    std::fs::create_dir(&results).unwrap();
    let python = std::env::var("GBUF_RDC_PYTHON").unwrap_or_else(|_| "/usr/bin/python3".into());
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/support/renderdoc_views.py");
    let mut run = Command::new(python);
    run.arg(script).arg(fixture("engine_4x.rdc")).arg("185").arg(&results);
    for (t, a) in &shown {
        run.arg(format!("{t}={}", file(t, a).display()));
    }
    let out = run.output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let compiled: serde_json::Value =
        serde_json::from_slice(&std::fs::read(results.join("compile.json")).unwrap()).unwrap();
    for (t, a) in &shown {
        let name = file(t, a).file_name().unwrap().to_string_lossy().into_owned();
        assert_eq!(compiled[&name], "", "{name} did not compile in RenderDoc");
    }

    let (w, s) = (gb.width as usize, gb.samples as usize);
    // What a view should show for sample i, as f32 (RenderDoc stores it as RGBA16F, rounding toward zero).
    let want = |a: &str, i: usize| -> [f32; 3] {
        match a {
            "normal" => (gb.normal.as_ref().unwrap()[i] * 0.5 + 0.5).to_array(),
            "albedo" => gb.albedo.as_ref().unwrap()[i].to_array(),
            "roughness" => [gb.roughness.as_ref().unwrap()[i]; 3],
            "metallic" => [gb.metallic.as_ref().unwrap()[i]; 3],
            "material_id" => id_colour(gb.material_id.as_ref().unwrap()[i]),
            _ => [gb.depth.as_ref().unwrap()[i]; 3],
        }
    };
    let close = |got: f32, want: f32| (got - want).abs() <= want.abs() * (1.0 / 1024.0) + 1e-6;
    for (t, a) in &shown {
        let name = file(t, a).file_name().unwrap().to_string_lossy().into_owned();
        let read = |label: &str| -> Vec<f32> {
            let bytes = std::fs::read(results.join(format!("{name}.{label}.f16"))).unwrap();
            bytes.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()).collect()
        };
        let mut differs_from_sample_0 = 0;
        let first = read("0");
        for k in 0..s {
            let got = read(&k.to_string());
            assert_eq!(got.len(), gb.pixel_count() * 4, "{name}");
            for p in 0..gb.pixel_count() {
                let i = p * s + k;
                if !gb.coverage[i] {
                    continue;
                }
                let (g, e) = (&got[4 * p..4 * p + 3], want(a, i));
                assert!(
                    (0..3).all(|c| close(g[c], e[c])),
                    "{name}, sample {k}, pixel ({}, {}): RenderDoc shows {g:?}, gbuf decodes {e:?}",
                    p % w,
                    p / w
                );
                differs_from_sample_0 += usize::from(g != &first[4 * p..4 * p + 3]);
            }
        }
        assert!(differs_from_sample_0 > 0, "{name}: every sample showed sample 0's value");
        // "Average value": the mean of the decoded samples (IDs: sample 0), where every sample is covered.
        let avg = read("avg");
        for p in (0..gb.pixel_count()).filter(|&p| (0..s).all(|k| gb.coverage[p * s + k])) {
            let e: [f32; 3] = if *a == "material_id" {
                want(a, p * s)
            } else {
                let sum = (0..s).fold([0.0f32; 3], |acc, k| {
                    let v = want(a, p * s + k);
                    [acc[0] + v[0], acc[1] + v[1], acc[2] + v[2]]
                });
                sum.map(|x| x / s as f32)
            };
            let g = &avg[4 * p..4 * p + 3];
            assert!(
                (0..3).all(|c| (g[c] - e[c]).abs() <= e[c].abs() * 2e-3 + 1e-5),
                "{name} average at {p}: {g:?} vs {e:?}"
            );
        }
    }
}

#[test]
fn two_captures_compare_as_frames_and_convert_alike() {
    if !support::renderdoc_has() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (rdc, folder) = (fixture("engine_4x.rdc"), fixture("engine_4x"));
    let (layout, scene) = (fixture("engine_4x/engine.toml"), fixture("engine_4x/scene.json"));
    let common = ["--input-layout", layout.to_str().unwrap(), "--scene", scene.to_str().unwrap()];
    let compare = |a: &Path, b: &Path, extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["compare", a.to_str().unwrap(), b.to_str().unwrap(), "--json"];
        args.extend(common);
        args.extend(extra);
        let o = gbuf(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    // The capture against the folder saved from the same render: nothing differs, lit or not.
    let same = compare(&rdc, &folder, &[]);
    assert_eq!(same["attributes"]["normal"]["max_deg"], 0.0);
    assert_eq!(same["attributes"]["ids"][0]["mismatches"], 0);
    assert_eq!((same["lit"]["rmse"].as_f64(), same["lit"]["flip_ldr"].as_f64()), (Some(0.0), Some(0.0)));
    // The finished frame against the capture before its last draw (the rod): the rod's samples differ, and so does
    // the lit image.
    let before = compare(&folder, &rdc, &["--event", "166"]);
    let mismatches = before["attributes"]["ids"][0]["mismatches"].as_u64().unwrap();
    assert!(mismatches > 0 && mismatches < 1000, "{before}");
    assert!(before["lit"]["flip_ldr"].as_f64().unwrap() > 0.0, "{before}");
    // Converted to the canonical EXR, the capture and the folder give the same bytes.
    let convert = |input: &Path, out: &str| {
        let out = dir.path().join(out);
        let mut args = vec!["convert", input.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend(common);
        let o = gbuf(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(out).unwrap()
    };
    assert!(convert(&rdc, "a.exr") == convert(&folder, "b.exr"), "the converted EXRs differ");
}
