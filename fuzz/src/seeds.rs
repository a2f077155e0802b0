//! Seed corpora from fixtures/ (run through `fuzz/seed.sh`): the fixtures themselves are 80 KB–1.2 MB, too slow
//! for a fuzzer to mutate, so each EXR is subsampled to at most 16 pixels across (every channel, name and header
//! attribute kept, the aspect ratio too so sidecars still match) and written in several compressions; the ISPC
//! `.bin` is subsampled the same way and its light arrays cut to the lights in use. Sidecars and layout files are
//! copied as they are (JSON sidecars with pixel intrinsics are rescaled to the small image).

use crate::gen::{encode, EncodingIn, Part};
use gbuf::gbuffer::GBuffer;
use gbuf::io::exr::{RawChannel, RawData, RawImage};
use gbuf::io::{LoadOptions, ReadLimits, Sidecar};
use std::path::{Path, PathBuf};

type R<T> = std::result::Result<T, String>;

fn err(what: impl std::fmt::Display) -> String {
    what.to_string()
}

/// Writes every seed under `out/<target>/`; returns how many.
pub fn write_all(repo: &Path, out: &Path) -> R<usize> {
    let mut w = Writer { out: out.to_path_buf(), count: 0 };
    let fx = repo.join("fixtures");
    let mut exrs = glob(&fx, "exr")?;
    exrs.extend(glob(&fx.join("luxcore"), "exr")?);
    let mut small = Vec::new();
    for p in &exrs {
        let raw = gbuf::io::exr::read_raw(p, &ReadLimits::default()).map_err(err)?;
        let s = factor(raw.width);
        let sub = subsample_raw(&raw, s);
        let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("exr").to_string();
        let part = Part::from_raw(&sub);
        // (tag, encoding, targets)
        let variants: [(&str, EncodingIn, &[&str]); 9] = [
            ("none", EncodingIn::scan_lines(0), &["load", "exr_raw"]),
            ("zip", EncodingIn::scan_lines(3), &["load", "exr_raw"]),
            ("piz", EncodingIn::scan_lines(4), &["load", "exr_raw"]),
            (
                "rle-tiles",
                EncodingIn { tiles: Some((7, 3)), line_order: 1, ..EncodingIn::scan_lines(1) },
                &["load", "exr_raw"],
            ),
            ("zips", EncodingIn::scan_lines(2), &["exr_raw"]),
            ("pxr24", EncodingIn::scan_lines(5), &["exr_raw"]),
            ("b44a", EncodingIn::scan_lines(7), &["exr_raw"]),
            ("dwaa", EncodingIn { compression_patch: Some(8), ..EncodingIn::scan_lines(4) }, &["exr_raw"]),
            ("dwab", EncodingIn { compression_patch: Some(9), ..EncodingIn::scan_lines(3) }, &["exr_raw"]),
        ];
        for (tag, enc, targets) in variants {
            let bytes =
                encode(std::slice::from_ref(&part), &enc).ok_or_else(|| format!("{stem}: cannot encode {tag}"))?;
            for t in targets {
                w.put(t, &format!("{stem}-{tag}.exr"), &bytes)?;
            }
        }
        small.push((p.clone(), s, sub));
    }

    // ISPC .bin: the file as it is, and subsampled with 5, 1 and 0 lights.
    let bin = fx.join("ispc_deferred.bin");
    let bin_bytes = std::fs::read(&bin).map_err(err)?;
    w.put("ispc_bin", "ispc_deferred.bin", &bin_bytes)?;
    let loaded = gbuf::io::load(&bin, &LoadOptions::default()).map_err(err)?;
    let gb = subsample_gb(&loaded.gbuffer, 8);
    let lights = loaded.lights.clone().unwrap_or_default();
    let tmp = std::env::temp_dir().join(format!("gbuf-fuzz-seed-{}.bin", std::process::id()));
    let mut small_bins = Vec::new();
    for k in [lights.len(), 1, 0] {
        gbuf::io::ispc::write(&tmp, &gb, &lights[..k.min(lights.len())]).map_err(err)?;
        let bytes = compact_bin(&std::fs::read(&tmp).map_err(err)?)?;
        w.put("ispc_bin", &format!("ispc-8x6-{k}lights.bin"), &bytes)?;
        w.put("load", &format!("ispc-8x6-{k}lights.bin"), &bytes)?;
        small_bins.push(bytes);
    }
    let _ = std::fs::remove_file(&tmp);

    // Sidecars and layouts, as they are.
    let mut jsons = glob(&fx, "json")?;
    jsons.extend(glob(&fx.join("luxcore"), "json")?);
    for p in &jsons {
        w.copy("sidecar", p)?;
    }
    for p in glob(&repo.join("src/layout/builtin"), "toml")? {
        w.copy("layout", &p)?;
    }
    for ext in ["toml", "json"] {
        for p in glob(&repo.join("examples/layouts"), ext)? {
            w.copy("layout", &p)?;
        }
    }

    // load_options: OPTIONS\nSIDECAR\0DUMP.
    let find = |stem: &str| small.iter().find(|(p, _, _)| p.file_stem().is_some_and(|s| s == stem));
    let sidecar_for = |json: &Path, s: u32| -> R<Vec<u8>> { scaled_sidecar(json, s) };
    let zip = EncodingIn::scan_lines(3);
    let enc_of = |raw: &RawImage, e: &EncodingIn| encode(&[Part::from_raw(raw)], e).ok_or("encode");
    for (stem, options) in [
        ("blender_gbuffer", ""),
        ("blender_gbuffer", "fold=2 map=roughness=ViewLayer.Roughness.X,material_id=ViewLayer.IndexOB.X"),
        ("blender_gbuffer", "map=depth=ViewLayer.Depth.Z,normal=ViewLayer.Normal.X;ViewLayer.Normal.Y;ViewLayer.Normal.Z space=world"),
        ("mitsuba_gbuffer", ""),
        ("mitsuba_gbuffer", "map=depth=depth.T,normal=sh_normal.X;sh_normal.Y;sh_normal.Z,albedo=albedo.R;albedo.G;albedo.B space=world depth=ray"),
        ("raster_4x", ""),
        ("room_4x", "fold=1 max=1"),
    ] {
        let (p, s, raw) = find(stem).ok_or_else(|| format!("no fixture {stem}"))?;
        let json = p.with_extension("json");
        let side = if json.is_file() { Some(sidecar_for(&json, *s)?) } else { None };
        let tag = if options.is_empty() { "plain" } else { "opts" };
        let n = options.len();
        combo(&mut w, &format!("{stem}-{tag}-{n}"), options, side, &enc_of(raw, &zip)?)?;
    }
    // A DWAA-flagged file with DWA allowed.
    if let Some((p, s, raw)) = find("blender_gbuffer") {
        let dwa = EncodingIn { compression_patch: Some(8), ..EncodingIn::scan_lines(4) };
        combo(&mut w, "blender-dwaa", "dwa", Some(sidecar_for(&p.with_extension("json"), *s)?), &enc_of(raw, &dwa)?)?;
    }
    // The LuxCore file set merged into one EXR (channels `<FILE>.<R|G|B>`), read through --map with its conventions.
    let lux: Vec<_> = small.iter().filter(|(p, _, _)| p.parent().is_some_and(|d| d.ends_with("luxcore"))).collect();
    if let Some((_, s, first)) = lux.first() {
        let mut merged = RawImage { width: first.width, height: first.height, ..RawImage::default() };
        for (p, _, raw) in &lux {
            let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("X");
            for c in &raw.channels {
                merged.channels.push(RawChannel { name: format!("{stem}.{}", c.name), data: c.data.clone() });
            }
        }
        let side = sidecar_for(&fx.join("luxcore/scene.json"), *s)?;
        let map = "map=depth=DEPTH.R,position=POSITION.R;POSITION.G;POSITION.B,\
                   normal=SHADING_NORMAL.R;SHADING_NORMAL.G;SHADING_NORMAL.B,albedo=ALBEDO.R;ALBEDO.G;ALBEDO.B";
        for (i, conv) in [
            "fold=1 space=world depth=ray-from-near background=inf",
            "fold=1 space=world depth=ndc reversed znear=0.1 zfar=100 ids=rgb8 normals=unorm background=auto",
        ]
        .iter()
        .enumerate()
        {
            combo(
                &mut w,
                &format!("luxcore-map-{i}"),
                &format!("{map} {conv}"),
                Some(side.clone()),
                &enc_of(&merged, &zip)?,
            )?;
        }
        w.put("load", "luxcore-merged.exr", &enc_of(&merged, &zip)?)?;
    }
    // ISPC with a sidecar whose lights replace the file's.
    if let Some(b) = small_bins.first() {
        let side = br#"{"lights_space":"view","lights":[{"type":"point","position":[0,1,-3],"range":5},{"type":"spot","position":[0,0,0],"direction":[0,0,-1]}]}"#;
        combo(&mut w, "ispc-sidecar", "fold=2", Some(side.to_vec()), b)?;
    }
    Ok(w.count)
}

/// Writes a `load_options` input `OPTIONS\nSIDECAR\0DUMP`.
fn combo(w: &mut Writer, name: &str, options: &str, sidecar: Option<Vec<u8>>, dump: &[u8]) -> R<()> {
    let mut v = options.as_bytes().to_vec();
    v.push(b'\n');
    v.extend(sidecar.unwrap_or_default());
    v.push(0);
    v.extend_from_slice(dump);
    w.put("load_options", name, &v)
}

struct Writer {
    out: PathBuf,
    count: usize,
}

impl Writer {
    fn put(&mut self, target: &str, name: &str, bytes: &[u8]) -> R<()> {
        let dir = self.out.join(target);
        std::fs::create_dir_all(&dir).map_err(err)?;
        std::fs::write(dir.join(name), bytes).map_err(err)?;
        self.count += 1;
        Ok(())
    }
    fn copy(&mut self, target: &str, p: &Path) -> R<()> {
        let bytes = std::fs::read(p).map_err(err)?;
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("seed").to_string();
        self.put(target, &name, &bytes)
    }
}

fn glob(dir: &Path, ext: &str) -> R<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    Ok(v)
}

/// The subsampling factor that brings `width` to at most 16 pixels.
fn factor(width: u32) -> u32 {
    width.div_ceil(16).max(1)
}

/// Every `s`-th pixel of every channel (from the centre of each s×s block).
fn subsample_raw(raw: &RawImage, s: u32) -> RawImage {
    let (w, h) = (raw.width / s, raw.height / s);
    let pick = |x: u32, y: u32| ((y * s + s / 2) * raw.width + x * s + s / 2) as usize;
    let idx: Vec<usize> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| pick(x, y)).collect();
    let channels = raw
        .channels
        .iter()
        .map(|c| RawChannel {
            name: c.name.clone(),
            data: match &c.data {
                RawData::F16(v) => RawData::F16(idx.iter().map(|&i| v[i]).collect()),
                RawData::F32(v) => RawData::F32(idx.iter().map(|&i| v[i]).collect()),
                RawData::U32(v) => RawData::U32(idx.iter().map(|&i| v[i]).collect()),
            },
        })
        .collect();
    RawImage { width: w, height: h, channels, ..raw.clone() }
}

/// Every `s`-th pixel of a G-buffer, all samples of each.
fn subsample_gb(gb: &GBuffer, s: u32) -> GBuffer {
    let (w, h) = (gb.width / s, gb.height / s);
    let spp = gb.samples as usize;
    let idx: Vec<usize> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .flat_map(|(x, y)| {
            let p = ((y * s + s / 2) * gb.width + x * s + s / 2) as usize;
            (0..spp).map(move |k| p * spp + k)
        })
        .collect();
    fn sub<T: Copy>(plane: &Option<Vec<T>>, idx: &[usize]) -> Option<Vec<T>> {
        plane.as_ref().map(|v| idx.iter().map(|&i| v[i]).collect())
    }
    GBuffer {
        width: w,
        height: h,
        coverage: idx.iter().map(|&i| gb.coverage[i]).collect(),
        depth: sub(&gb.depth, &idx),
        position: sub(&gb.position, &idx),
        normal: sub(&gb.normal, &idx),
        albedo: sub(&gb.albedo, &idx),
        specular: sub(&gb.specular, &idx),
        specular_power: sub(&gb.specular_power, &idx),
        roughness: sub(&gb.roughness, &idx),
        metallic: sub(&gb.metallic, &idx),
        material_id: sub(&gb.material_id, &idx),
        object_id: sub(&gb.object_id, &idx),
        primitive_id: sub(&gb.primitive_id, &idx),
        motion: sub(&gb.motion, &idx),
        ..gb.clone()
    }
}

/// An ISPC `.bin` with its light arrays cut from 1024 slots to the lights in use (the reader needs only those).
fn compact_bin(bytes: &[u8]) -> R<Vec<u8>> {
    use gbuf::io::ispc::{Header, HEADER_BYTES};
    let mut h = Header::parse(bytes).ok_or("short .bin")?;
    let chunk = &bytes[HEADER_BYTES..];
    let pixels = (h.width * h.height) as usize;
    let elem = [4usize, 2, 2, 2, 2, 1, 1, 1, 4, 4, 4, 4, 4, 4, 4, 4];
    let mut out = Vec::new();
    for (k, e) in elem.iter().enumerate() {
        let count = if k < 8 { pixels } else { h.num_lights as usize };
        let at = h.offsets[k] as usize;
        while out.len() % 4 != 0 {
            out.push(0);
        }
        h.offsets[k] = out.len() as i32;
        out.extend_from_slice(chunk.get(at..at + count * e).ok_or("array outside the chunk")?);
    }
    h.chunk_size = out.len() as i32;
    let mut file = h.to_bytes();
    file.extend(out);
    Ok(file)
}

/// A sidecar's text for the image subsampled by `s` (pixel intrinsics divided by `s`).
fn scaled_sidecar(p: &Path, s: u32) -> R<Vec<u8>> {
    let text = std::fs::read_to_string(p).map_err(err)?;
    let mut side = Sidecar::parse(&text, p).map_err(err)?;
    match side.camera.as_mut().and_then(|c| c.intrinsics.as_mut()) {
        Some(k) => {
            for v in k.iter_mut() {
                *v /= s as f32;
            }
            serde_json::to_vec_pretty(&side).map_err(err)
        }
        None => Ok(text.into_bytes()),
    }
}
