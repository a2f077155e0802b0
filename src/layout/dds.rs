//! A packed G-buffer as files an engine's tools open: each render target as a DDS texture in its exact DXGI format
//! (the DX10 header), the MSAA samples as the slices of a texture array (slice i = sample i, the way RenderDoc saves
//! a multisampled target with "samples to array slices"), and the material-ID table as JSON. `gbuf pack` writes
//! them; docs/FORMAT.md ("Packed render targets") describes every byte.
//!
//! The DDS layout follows Microsoft's documentation ("DDS file layout", `DDS_HEADER`, `DDS_PIXELFORMAT`,
//! `DDS_HEADER_DXT10`): the magic `DDS `, a 124-byte header whose pixel format is the FourCC `DX10`, a 20-byte DX10
//! header (DXGI format, `TEXTURE2D`, array size), then each slice's rows, top row first, texels little-endian. A
//! format with no DXGI twin (`rgb8`, 3 bytes per texel) goes out as `<target>.bin`: a little-endian u32 length,
//! that many bytes of JSON describing the texels, then the slices as in the DDS file.

use crate::base::files::write_bytes_atomic;
use crate::error::{Error, Result};
use crate::layout::formats::Format;
use crate::layout::pack::{Packed, TargetPlane};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// `DDS ` little-endian.
const MAGIC: u32 = 0x2053_4444;
/// `DX10` little-endian.
const FOURCC_DX10: u32 = 0x3031_5844;
const DDSD_CAPS: u32 = 0x1;
const DDSD_HEIGHT: u32 = 0x2;
const DDSD_WIDTH: u32 = 0x4;
const DDSD_PITCH: u32 = 0x8;
const DDSD_PIXELFORMAT: u32 = 0x1000;
const DDPF_FOURCC: u32 = 0x4;
const DDSCAPS_TEXTURE: u32 = 0x1000;
/// `D3D10_RESOURCE_DIMENSION_TEXTURE2D`.
const DIMENSION_TEXTURE2D: u32 = 3;
/// Bytes before the texels: magic, `DDS_HEADER`, `DDS_HEADER_DXT10`.
pub const HEADER_BYTES: usize = 4 + 124 + 20;

/// The DXGI format of `format` (`DXGI_FORMAT` of dxgiformat.h), `None` for formats with no DXGI twin (`rgb8`).
#[must_use]
pub fn dxgi_format(format: Format) -> Option<u32> {
    Some(match format {
        Format::R8 => 61,  // R8_UNORM
        Format::Rg8 => 49, // R8G8_UNORM
        Format::Rgb8 => return None,
        Format::Rgba8 => 28,       // R8G8B8A8_UNORM
        Format::Rgba8Srgb => 29,   // R8G8B8A8_UNORM_SRGB
        Format::Rgba8Snorm => 31,  // R8G8B8A8_SNORM
        Format::Rgb10A2 => 24,     // R10G10B10A2_UNORM
        Format::R11G11B10F => 26,  // R11G11B10_FLOAT
        Format::Rgb9e5 => 67,      // R9G9B9E5_SHAREDEXP
        Format::R16F => 54,        // R16_FLOAT
        Format::Rg16F => 34,       // R16G16_FLOAT
        Format::Rgba16F => 10,     // R16G16B16A16_FLOAT
        Format::R16Unorm => 56,    // R16_UNORM
        Format::Rg16Unorm => 35,   // R16G16_UNORM
        Format::Rg16Snorm => 37,   // R16G16_SNORM
        Format::Rgba16Unorm => 11, // R16G16B16A16_UNORM
        Format::R16Ui => 57,       // R16_UINT
        Format::R32F => 41,        // R32_FLOAT
        Format::Rg32F => 16,       // R32G32_FLOAT
        Format::Rgba32F => 2,      // R32G32B32A32_FLOAT
        Format::R32Ui => 42,       // R32_UINT
        Format::Rg32Ui => 17,      // R32G32_UINT
        Format::Rgba32Ui => 3,     // R32G32B32A32_UINT
        Format::D16 => 55,         // D16_UNORM
        Format::D24S8 => 45,       // D24_UNORM_S8_UINT
        Format::D32F => 40,        // D32_FLOAT
    })
}

/// The texels of `plane` (pixel-major: all samples of a pixel together) reordered sample-major: slice `s` holds
/// sample `s` of every pixel, row by row.
fn slices(plane: &TargetPlane, pixels: usize, samples: usize) -> Vec<u8> {
    let tb = plane.format.bytes();
    let mut out = Vec::with_capacity(plane.bytes.len());
    for s in 0..samples {
        for p in 0..pixels {
            let i = (p * samples + s) * tb;
            out.extend_from_slice(&plane.bytes[i..i + tb]);
        }
    }
    out
}

/// One render target as a DDS file's bytes (`width` × `height`, `samples` array slices).
pub fn dds_bytes(plane: &TargetPlane, width: u32, height: u32, samples: u32) -> Result<Vec<u8>> {
    let dxgi = dxgi_format(plane.format).ok_or_else(|| {
        Error::Argument(format!("target {}: format {} has no DXGI twin (write it as .bin)", plane.name, plane.format))
    })?;
    let (pixels, s) = (width as usize * height as usize, samples as usize);
    if plane.bytes.len() != pixels * s * plane.format.bytes() {
        return Err(Error::Mismatch(format!(
            "target {}: {} bytes for {width}×{height}×{samples} texels of {}",
            plane.name,
            plane.bytes.len(),
            plane.format
        )));
    }
    let mut h: Vec<u32> = Vec::with_capacity(HEADER_BYTES / 4);
    h.push(MAGIC);
    // DDS_HEADER
    h.extend([124, DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PITCH | DDSD_PIXELFORMAT, height, width]);
    h.push(width * plane.format.bytes() as u32); // pitch
    h.extend([0, 1]); // depth, mip levels
    h.extend([0; 11]); // reserved
    h.extend([32, DDPF_FOURCC, FOURCC_DX10, 0, 0, 0, 0, 0]); // DDS_PIXELFORMAT
    h.extend([DDSCAPS_TEXTURE, 0, 0, 0, 0]); // caps, caps2..4, reserved2
                                             // DDS_HEADER_DXT10: format, dimension, misc flags, array size, misc flags 2 (alpha mode unknown).
    h.extend([dxgi, DIMENSION_TEXTURE2D, 0, samples, 0]);
    debug_assert_eq!(h.len() * 4, HEADER_BYTES);
    let mut out: Vec<u8> = h.iter().flat_map(|w| w.to_le_bytes()).collect();
    out.extend(slices(plane, pixels, s));
    Ok(out)
}

/// A single-sampled `R8_UINT` texture (DXGI 62) as a DDS file's bytes, rows top first: how a shading-rate image
/// (`D3D12_SHADING_RATE` per tile) is handed to an engine.
#[must_use]
pub fn r8_uint_dds(width: u32, height: u32, texels: &[u8]) -> Vec<u8> {
    debug_assert_eq!(texels.len(), width as usize * height as usize);
    let mut h: Vec<u32> = Vec::with_capacity(HEADER_BYTES / 4);
    h.push(MAGIC);
    h.extend([124, DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PITCH | DDSD_PIXELFORMAT, height, width, width]);
    h.extend([0, 1]);
    h.extend([0; 11]);
    h.extend([32, DDPF_FOURCC, FOURCC_DX10, 0, 0, 0, 0, 0]);
    h.extend([DDSCAPS_TEXTURE, 0, 0, 0, 0]);
    h.extend([62, DIMENSION_TEXTURE2D, 0, 1, 0]);
    let mut out: Vec<u8> = h.iter().flat_map(|w| w.to_le_bytes()).collect();
    out.extend_from_slice(texels);
    out
}

/// The JSON header of a `.bin` target (a format with no DXGI twin).
#[derive(Serialize)]
struct RawHeader<'a> {
    target: &'a str,
    format: String,
    width: u32,
    height: u32,
    samples: u32,
    texel_bytes: usize,
    /// Always `sample-major`: slice s (every pixel's sample s, rows top first), then slice s + 1.
    order: &'static str,
}

/// One render target as a `.bin` file's bytes: a little-endian u32 length, the JSON header, the slices.
pub fn raw_bytes(plane: &TargetPlane, width: u32, height: u32, samples: u32) -> Result<Vec<u8>> {
    let header = RawHeader {
        target: &plane.name,
        format: plane.format.to_string(),
        width,
        height,
        samples,
        texel_bytes: plane.format.bytes(),
        order: "sample-major",
    };
    let json = serde_json::to_vec(&header).map_err(|e| Error::Internal(format!("target header: {e}")))?;
    let mut out = (json.len() as u32).to_le_bytes().to_vec();
    out.extend(json);
    out.extend(slices(plane, width as usize * height as usize, samples as usize));
    Ok(out)
}

/// A file `write_targets` wrote.
#[derive(Clone, Debug, Serialize)]
pub struct WrittenTarget {
    /// The render target (or `material_table`).
    pub target: String,
    /// Its layout format (`json` for the table).
    pub format: String,
    /// The DXGI format written, `None` for `.bin` and JSON files.
    pub dxgi_format: Option<u32>,
    /// The file.
    pub path: PathBuf,
    /// Its size in bytes.
    pub bytes: usize,
}

/// Writes every render target of `packed` into `dir` (created if missing) as `<target>.dds` (or `.bin`), and the
/// material table as `material_table.json` when the layout has one. Each file is written atomically; a file this
/// run read is never replaced.
pub fn write_targets(packed: &Packed, dir: &Path) -> Result<Vec<WrittenTarget>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut out = Vec::new();
    for t in &packed.targets {
        if t.name.is_empty() || t.name.contains(['/', '\\']) || t.name.starts_with('.') {
            return Err(Error::Argument(format!("target name {:?} cannot name a file", t.name)));
        }
        let dxgi = dxgi_format(t.format);
        let (ext, bytes) = match dxgi {
            Some(_) => ("dds", dds_bytes(t, packed.width, packed.height, packed.samples)?),
            None => ("bin", raw_bytes(t, packed.width, packed.height, packed.samples)?),
        };
        let path = dir.join(format!("{}.{ext}", t.name));
        write_bytes_atomic(&path, &bytes)?;
        out.push(WrittenTarget {
            target: t.name.clone(),
            format: t.format.to_string(),
            dxgi_format: dxgi,
            path,
            bytes: bytes.len(),
        });
    }
    if let Some(table) = &packed.material_table {
        let json = serde_json::to_vec_pretty(table).map_err(|e| Error::Internal(format!("material table: {e}")))?;
        let path = dir.join("material_table.json");
        write_bytes_atomic(&path, &json)?;
        out.push(WrittenTarget {
            target: "material_table".into(),
            format: "json".into(),
            dxgi_format: None,
            path,
            bytes: json.len(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u32_at(b: &[u8], i: usize) -> u32 {
        u32::from_le_bytes(b[i..i + 4].try_into().unwrap())
    }

    /// Every format but rgb8 has a DXGI twin of the same texel size, and the header says what the documentation
    /// says; the slices hold sample s of every pixel in order.
    #[test]
    fn headers_and_slices_follow_the_documentation() {
        for f in Format::ALL {
            assert_eq!(dxgi_format(f).is_none(), f == Format::Rgb8, "{f}");
        }
        let (w, h, s) = (3u32, 2u32, 4u32);
        let tb = Format::Rg16F.bytes();
        let bytes: Vec<u8> = (0..(w * h * s) as usize * tb).map(|i| i as u8).collect();
        let plane = TargetPlane { name: "gbuffer_a".into(), format: Format::Rg16F, bytes: bytes.clone() };
        let d = dds_bytes(&plane, w, h, s).unwrap();
        assert_eq!(&d[..4], b"DDS ");
        assert_eq!(u32_at(&d, 4), 124);
        assert_eq!((u32_at(&d, 12), u32_at(&d, 16)), (h, w));
        assert_eq!(u32_at(&d, 20), w * tb as u32, "pitch");
        assert_eq!(u32_at(&d, 76), 32, "pixel format size");
        assert_eq!(&d[84..88], b"DX10");
        assert_eq!(u32_at(&d, 128), 34, "R16G16_FLOAT");
        assert_eq!(u32_at(&d, 132), 3, "TEXTURE2D");
        assert_eq!(u32_at(&d, 140), s, "array size = samples");
        assert_eq!(d.len(), HEADER_BYTES + bytes.len());
        let data = &d[HEADER_BYTES..];
        for sample in 0..s as usize {
            for p in 0..(w * h) as usize {
                let src = (p * s as usize + sample) * tb;
                let dst = (sample * (w * h) as usize + p) * tb;
                assert_eq!(data[dst..dst + tb], bytes[src..src + tb], "sample {sample} pixel {p}");
            }
        }
        let bad = TargetPlane { bytes: vec![0; 3], ..plane };
        assert!(dds_bytes(&bad, w, h, s).is_err());
    }
}
