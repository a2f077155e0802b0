//! One render target read back from a file: the texels of a DDS texture (DX10 and legacy headers, every DXGI format
//! the layout language has, array slices as MSAA samples), a `.bin` written by `gbuf pack`, a PNG (8/16-bit, 1–4
//! channels) or an EXR (half, float or uint channels), as the bits of a layout [`Format`]'s texels.
//!
//! The file says how its texels are stored; the layout says what they mean. A file is accepted for a target when
//! its texels have the target format's bits: the exact DXGI format, or another of the same bit layout (a
//! `TYPELESS`, `UINT` or `SRGB` twin: RenderDoc saves a `D32_FLOAT` depth buffer as it was created, often
//! `R32_TYPELESS`), and the layout's codecs interpret the bits. B8G8R8A8 files are swizzled to R8G8B8A8. DDS layout
//! per Microsoft's documentation ("DDS file layout", `DDS_HEADER`, `DDS_PIXELFORMAT`, `DDS_HEADER_DXT10`); the
//! legacy pixel formats map to DXGI as DirectXTex's `DDS.h` documents them.

use crate::error::{Error, Result};
use crate::io::ReadLimits;
use crate::layout::dds;
use crate::layout::formats::{ComponentKind, Format};
use std::io::Read;
use std::path::Path;

/// The texels of one render target as read: `slices` sample-major slices of `width × height` texels of
/// `texel_bytes` bytes, little-endian, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Array slices (the MSAA samples; 1 for PNG and EXR).
    pub slices: u32,
    /// What the file stores, in its own terms (e.g. `DDS DXGI 24 R10G10B10A2_UNORM`, `PNG RGBA 8-bit`).
    pub stored_as: String,
    /// The texels, slice after slice.
    pub bytes: Vec<u8>,
}

/// Bit-layout families of DXGI formats: formats of one family hold the same bits per texel and differ only in
/// how a GPU reads them. `(format, name, family)`; the family is the texel size with a tag.
const DXGI: &[(u32, &str, &str)] = &[
    (1, "R32G32B32A32_TYPELESS", "32x4"),
    (2, "R32G32B32A32_FLOAT", "32x4"),
    (3, "R32G32B32A32_UINT", "32x4"),
    (4, "R32G32B32A32_SINT", "32x4"),
    (9, "R16G16B16A16_TYPELESS", "16x4"),
    (10, "R16G16B16A16_FLOAT", "16x4"),
    (11, "R16G16B16A16_UNORM", "16x4"),
    (12, "R16G16B16A16_UINT", "16x4"),
    (13, "R16G16B16A16_SNORM", "16x4"),
    (14, "R16G16B16A16_SINT", "16x4"),
    (15, "R32G32_TYPELESS", "32x2"),
    (16, "R32G32_FLOAT", "32x2"),
    (17, "R32G32_UINT", "32x2"),
    (18, "R32G32_SINT", "32x2"),
    (23, "R10G10B10A2_TYPELESS", "10x3+2"),
    (24, "R10G10B10A2_UNORM", "10x3+2"),
    (25, "R10G10B10A2_UINT", "10x3+2"),
    (26, "R11G11B10_FLOAT", "11+11+10f"),
    (27, "R8G8B8A8_TYPELESS", "8x4"),
    (28, "R8G8B8A8_UNORM", "8x4"),
    (29, "R8G8B8A8_UNORM_SRGB", "8x4"),
    (30, "R8G8B8A8_UINT", "8x4"),
    (31, "R8G8B8A8_SNORM", "8x4"),
    (32, "R8G8B8A8_SINT", "8x4"),
    (33, "R16G16_TYPELESS", "16x2"),
    (34, "R16G16_FLOAT", "16x2"),
    (35, "R16G16_UNORM", "16x2"),
    (36, "R16G16_UINT", "16x2"),
    (37, "R16G16_SNORM", "16x2"),
    (38, "R16G16_SINT", "16x2"),
    (39, "R32_TYPELESS", "32"),
    (40, "D32_FLOAT", "32"),
    (41, "R32_FLOAT", "32"),
    (42, "R32_UINT", "32"),
    (43, "R32_SINT", "32"),
    (44, "R24G8_TYPELESS", "24+8"),
    (45, "D24_UNORM_S8_UINT", "24+8"),
    (46, "R24_UNORM_X8_TYPELESS", "24+8"),
    (47, "X24_TYPELESS_G8_UINT", "24+8"),
    (48, "R8G8_TYPELESS", "8x2"),
    (49, "R8G8_UNORM", "8x2"),
    (50, "R8G8_UINT", "8x2"),
    (51, "R8G8_SNORM", "8x2"),
    (52, "R8G8_SINT", "8x2"),
    (53, "R16_TYPELESS", "16"),
    (54, "R16_FLOAT", "16"),
    (55, "D16_UNORM", "16"),
    (56, "R16_UNORM", "16"),
    (57, "R16_UINT", "16"),
    (58, "R16_SNORM", "16"),
    (59, "R16_SINT", "16"),
    (60, "R8_TYPELESS", "8"),
    (61, "R8_UNORM", "8"),
    (62, "R8_UINT", "8"),
    (63, "R8_SNORM", "8"),
    (64, "R8_SINT", "8"),
    (65, "A8_UNORM", "8"),
    (67, "R9G9B9E5_SHAREDEXP", "9x3+5e"),
    (87, "B8G8R8A8_UNORM", "bgra8"),
    (91, "B8G8R8A8_UNORM_SRGB", "bgra8"),
];

/// The name of a DXGI format (`DXGI_FORMAT_` left out), or `?` for one gbuf does not know.
#[must_use]
pub fn dxgi_name(format: u32) -> &'static str {
    DXGI.iter().find(|d| d.0 == format).map_or("?", |d| d.1)
}

fn dxgi_family(format: u32) -> Option<&'static str> {
    DXGI.iter().find(|d| d.0 == format).map(|d| d.2)
}

/// How a DXGI format read from a file becomes the target's texels: as they are, or with red and blue swapped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mapping {
    AsIs,
    SwapRedBlue,
}

/// Whether a file's DXGI format holds `format`'s bits, and how to read them.
fn dxgi_mapping(file: u32, format: Format) -> Option<Mapping> {
    let want = dds::dxgi_format(format)?;
    let (fam_file, fam_want) = (dxgi_family(file)?, dxgi_family(want)?);
    if fam_file == fam_want {
        Some(Mapping::AsIs)
    } else if fam_file == "bgra8" && fam_want == "8x4" {
        Some(Mapping::SwapRedBlue)
    } else {
        None
    }
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

/// The legacy `DDS_PIXELFORMAT` (no DX10 header) as a DXGI format, as DirectXTex maps them.
fn legacy_dxgi(flags: u32, fourcc: u32, bits: u32, masks: [u32; 4]) -> std::result::Result<u32, String> {
    const DDPF_ALPHAPIXELS: u32 = 0x1;
    const DDPF_ALPHA: u32 = 0x2;
    const DDPF_FOURCC: u32 = 0x4;
    const DDPF_RGB: u32 = 0x40;
    const DDPF_LUMINANCE: u32 = 0x2_0000;
    const DDPF_BUMPDUDV: u32 = 0x8_0000;
    if flags & DDPF_FOURCC != 0 {
        // D3DFORMAT numbers stored as the FourCC.
        return match fourcc {
            36 => Ok(11),  // A16B16G16R16
            110 => Ok(13), // Q16W16V16U16
            111 => Ok(54), // R16F
            112 => Ok(34), // G16R16F
            113 => Ok(10), // A16B16G16R16F
            114 => Ok(41), // R32F
            115 => Ok(16), // G32R32F
            116 => Ok(2),  // A32B32G32R32F
            _ => {
                let cc: String =
                    fourcc.to_le_bytes().iter().map(|&b| if b.is_ascii_graphic() { b as char } else { '?' }).collect();
                Err(format!(
                    "legacy FourCC {cc:?} ({fourcc}) is a block-compressed or unknown format; G-buffer targets are \
                     uncompressed"
                ))
            }
        };
    }
    let m = masks;
    let found = if flags & DDPF_RGB != 0 {
        match (bits, m) {
            (32, [0xff, 0xff00, 0xff_0000, a]) if a == 0xff00_0000 || flags & DDPF_ALPHAPIXELS == 0 => Some(28),
            (32, [0xff_0000, 0xff00, 0xff, a]) if a == 0xff00_0000 || flags & DDPF_ALPHAPIXELS == 0 => Some(87),
            (32, [0x3ff, 0xf_fc00, 0x3ff0_0000, 0xc000_0000]) => Some(24),
            // D3DX writes R10G10B10A2 with these (swapped) masks; DirectXTex reads them as R10G10B10A2 too.
            (32, [0x3ff0_0000, 0xf_fc00, 0x3ff, 0xc000_0000]) => Some(24),
            (32, [0xffff, 0xffff_0000, 0, 0]) => Some(35),
            (32, [0xffff_ffff, 0, 0, 0]) => Some(41),
            _ => None,
        }
    } else if flags & DDPF_LUMINANCE != 0 {
        match (bits, m) {
            (8, [0xff, 0, 0, 0]) => Some(61),
            (16, [0xffff, 0, 0, 0]) => Some(56),
            (16, [0xff, 0, 0, 0xff00]) => Some(49),
            _ => None,
        }
    } else if flags & DDPF_ALPHA != 0 {
        (bits == 8).then_some(65)
    } else if flags & DDPF_BUMPDUDV != 0 {
        match (bits, m) {
            (16, [0xff, 0xff00, 0, 0]) => Some(51),
            (32, [0xff, 0xff00, 0xff_0000, 0xff00_0000]) => Some(31),
            (32, [0xffff, 0xffff_0000, 0, 0]) => Some(37),
            _ => None,
        }
    } else {
        None
    };
    found.ok_or_else(|| {
        format!(
            "legacy pixel format (flags {flags:#x}, {bits} bits, masks {:#x} {:#x} {:#x} {:#x}) matches no DXGI \
             format gbuf reads; save the target with a DX10 header",
            m[0], m[1], m[2], m[3]
        )
    })
}

/// Reads one render target for a layout target of `format` from `path` (by content: DDS, PNG, EXR, else `.bin`).
pub fn read(path: &Path, format: Format, limits: &ReadLimits) -> Result<Texture> {
    let mut head = [0u8; 8];
    let n = {
        let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut n = 0;
        while n < head.len() {
            match f.read(&mut head[n..]).map_err(|e| Error::io(path, e))? {
                0 => break,
                k => n += k,
            }
        }
        n
    };
    let head = &head[..n];
    if head.starts_with(b"DDS ") {
        read_dds(path, format, limits)
    } else if head.starts_with(&[0x89, b'P', b'N', b'G']) {
        read_png(path, format, limits)
    } else if head.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        read_exr(path, format, limits)
    } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin")) {
        read_bin(path, format, limits)
    } else {
        Err(Error::invalid(path, "neither a DDS, PNG or EXR file nor a gbuf `.bin` target (by content and name)"))
    }
}

/// Checks the declared texels against the memory limit before anything is allocated.
fn check_size(path: &Path, w: u32, h: u32, slices: u32, tb: usize, limits: &ReadLimits) -> Result<usize> {
    if w == 0 || h == 0 || slices == 0 {
        return Err(Error::invalid(path, format!("empty texture: {w}×{h}, {slices} slice(s)")));
    }
    // Saturating: a hostile header's product must not wrap under the limit.
    let bytes = u64::from(w).saturating_mul(u64::from(h)).saturating_mul(u64::from(slices)).saturating_mul(tb as u64);
    if bytes > limits.max_bytes {
        return Err(Error::TooLarge { path: path.into(), bytes, limit: limits.max_bytes, why: limits.describe() });
    }
    Ok(bytes as usize)
}

/// Reads a file whose length the header already bounds (checked against the limit by the caller).
fn read_all(path: &Path, at_most: u64) -> Result<Vec<u8>> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut out = Vec::new();
    f.take(at_most).read_to_end(&mut out).map_err(|e| Error::io(path, e))?;
    Ok(out)
}

fn read_dds(path: &Path, format: Format, limits: &ReadLimits) -> Result<Texture> {
    const DDSD_MIPMAPCOUNT: u32 = 0x2_0000;
    const DDSCAPS2_CUBEMAP: u32 = 0x200;
    const DDSCAPS2_VOLUME: u32 = 0x20_0000;
    const RESOURCE_MISC_TEXTURECUBE: u32 = 0x4;
    let head = read_all(path, dds::HEADER_BYTES as u64)?;
    if head.len() < 128 {
        return Err(Error::invalid(path, format!("DDS file of {} bytes: the header alone is 128", head.len())));
    }
    let bad = |what: String| Error::invalid(path, what);
    if u32_at(&head, 4) != 124 || u32_at(&head, 76) != 32 {
        return Err(bad(format!(
            "DDS header size {} / pixel format size {} (the documentation fixes them at 124 and 32)",
            u32_at(&head, 4),
            u32_at(&head, 76)
        )));
    }
    let (flags, height, width) = (u32_at(&head, 8), u32_at(&head, 12), u32_at(&head, 16));
    let depth = u32_at(&head, 24);
    let mips = if flags & DDSD_MIPMAPCOUNT != 0 { u32_at(&head, 28).max(1) } else { 1 };
    let (pf_flags, fourcc, bitcount) = (u32_at(&head, 80), u32_at(&head, 84), u32_at(&head, 88));
    let masks = [u32_at(&head, 92), u32_at(&head, 96), u32_at(&head, 100), u32_at(&head, 104)];
    let caps2 = u32_at(&head, 112);
    if caps2 & (DDSCAPS2_CUBEMAP | DDSCAPS2_VOLUME) != 0 || depth > 1 {
        return Err(Error::Unsupported {
            path: path.into(),
            what: "a cube map or volume texture, not a render target".into(),
        });
    }
    let dx10 = pf_flags & 0x4 != 0 && &head[84..88] == b"DX10";
    let (dxgi, slices, data_at) = if dx10 {
        if head.len() < dds::HEADER_BYTES {
            return Err(bad("DDS file ends inside its DX10 header".into()));
        }
        let (dim, misc, array) = (u32_at(&head, 132), u32_at(&head, 136), u32_at(&head, 140));
        if dim != 3 {
            return Err(Error::Unsupported {
                path: path.into(),
                what: format!("resource dimension {dim} (a render target is TEXTURE2D, 3)"),
            });
        }
        if misc & RESOURCE_MISC_TEXTURECUBE != 0 {
            return Err(Error::Unsupported { path: path.into(), what: "a cube map, not a render target".into() });
        }
        (u32_at(&head, 128), array.max(1), dds::HEADER_BYTES)
    } else {
        (legacy_dxgi(pf_flags, fourcc, bitcount, masks).map_err(bad)?, 1, 128)
    };
    let mapping = dxgi_mapping(dxgi, format).ok_or_else(|| {
        bad(format!(
            "DXGI format {dxgi} ({}) does not hold the texels of the layout's {format} target (DXGI {} {})",
            dxgi_name(dxgi),
            dds::dxgi_format(format).map_or_else(|| "none".into(), |d| d.to_string()),
            dds::dxgi_format(format).map_or("", dxgi_name),
        ))
    })?;
    let tb = format.bytes();
    let want = check_size(path, width, height, slices, tb, limits)?;
    // Each slice holds its mip chain; gbuf reads level 0 of each.
    let mut slice_bytes = 0u64;
    for l in 0..mips.min(32) {
        slice_bytes += u64::from((width >> l).max(1)) * u64::from((height >> l).max(1)) * tb as u64;
    }
    let need = data_at as u64 + slice_bytes * u64::from(slices);
    let data = read_all(path, need)?;
    if (data.len() as u64) < need {
        return Err(bad(format!(
            "truncated: the header describes {width}×{height} texels × {slices} slice(s) × {mips} mip level(s) of \
             {tb} bytes ({need} bytes with the header), the file has {}",
            data.len()
        )));
    }
    let level0 = width as usize * height as usize * tb;
    let mut bytes = Vec::with_capacity(want);
    for s in 0..slices as usize {
        let at = data_at + s * slice_bytes as usize;
        bytes.extend_from_slice(&data[at..at + level0]);
    }
    if mapping == Mapping::SwapRedBlue {
        for t in bytes.chunks_exact_mut(4) {
            t.swap(0, 2);
        }
    }
    let header = if dx10 { "DDS" } else { "DDS (legacy header)" };
    Ok(Texture { width, height, slices, stored_as: format!("{header} DXGI {dxgi} {}", dxgi_name(dxgi)), bytes })
}

/// The JSON header of a `.bin` target (see `dds::raw_bytes`).
#[derive(serde::Deserialize)]
struct BinHeader {
    format: String,
    width: u32,
    height: u32,
    samples: u32,
    texel_bytes: usize,
    order: String,
}

fn read_bin(path: &Path, format: Format, limits: &ReadLimits) -> Result<Texture> {
    const MAX_HEADER: u32 = 1 << 16;
    let head = read_all(path, 4 + u64::from(MAX_HEADER))?;
    if head.len() < 4 {
        return Err(Error::invalid(path, "a `.bin` target starts with a 4-byte header length; the file is shorter"));
    }
    let n = u32_at(&head, 0);
    if n > MAX_HEADER || head.len() < 4 + n as usize {
        return Err(Error::invalid(path, format!("header length {n}: not a gbuf `.bin` target (or truncated)")));
    }
    let h: BinHeader = serde_json::from_slice(&head[4..4 + n as usize])
        .map_err(|e| Error::Parse { path: path.into(), what: format!("`.bin` target header: {e}") })?;
    let file_format = Format::from_name(&h.format)
        .ok_or_else(|| Error::invalid(path, format!("unknown format {:?} in the header", h.format)))?;
    if file_format.bytes() != format.bytes() || h.texel_bytes != format.bytes() {
        return Err(Error::invalid(
            path,
            format!(
                "the file holds {} ({} B texels); the layout's target is {format} ({} B)",
                h.format,
                h.texel_bytes,
                format.bytes()
            ),
        ));
    }
    if h.order != "sample-major" {
        return Err(Error::invalid(path, format!("texel order {:?}; gbuf writes and reads sample-major", h.order)));
    }
    let want = check_size(path, h.width, h.height, h.samples, format.bytes(), limits)?;
    let data = read_all(path, 4 + u64::from(n) + want as u64)?;
    if data.len() < 4 + n as usize + want {
        return Err(Error::invalid(
            path,
            format!(
                "truncated: {}×{}×{} texels of {} B need {want} bytes after the header",
                h.width, h.height, h.samples, h.texel_bytes
            ),
        ));
    }
    Ok(Texture {
        width: h.width,
        height: h.height,
        slices: h.samples,
        stored_as: format!("gbuf .bin {}", h.format),
        bytes: data[4 + n as usize..].to_vec(),
    })
}

/// True when `format`'s texel is `channels` components of `bits` bits each, in order, none of them a float or a
/// shared exponent (what an integer image file can hold bit for bit).
fn integer_components(format: Format, channels: usize, bits: u32) -> bool {
    let c = format.components();
    c.len() == channels
        && c.iter().enumerate().all(|(i, c)| {
            c.bits == bits
                && c.offset == i as u32 * bits
                && matches!(
                    c.kind,
                    ComponentKind::Unorm | ComponentKind::Snorm | ComponentKind::Srgb | ComponentKind::Uint
                )
        })
}

/// The most DEFLATE can expand its input (RFC 1951: a 258-byte match costs at least 2 bits).
const MAX_DEFLATE_RATIO: u64 = 1032;

fn read_png(path: &Path, format: Format, limits: &ReadLimits) -> Result<Texture> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let cap = usize::try_from(limits.max_bytes).unwrap_or(usize::MAX);
    let mut dec = png::Decoder::new_with_limits(std::io::BufReader::new(file), png::Limits { bytes: cap });
    dec.set_transformations(png::Transformations::IDENTITY);
    let bad = |e: png::DecodingError| Error::invalid(path, format!("PNG: {e}"));
    let mut reader = dec.read_info().map_err(bad)?;
    let (w, h) = (reader.info().width, reader.info().height);
    let (color, depth) = (reader.info().color_type, reader.info().bit_depth);
    let channels = match color {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => {
            return Err(Error::Unsupported {
                path: path.into(),
                what: "a palette PNG holds colours, not texel bits".into(),
            })
        }
    };
    let bits = match depth {
        png::BitDepth::Eight => 8,
        png::BitDepth::Sixteen => 16,
        other => {
            return Err(Error::Unsupported {
                path: path.into(),
                what: format!("PNG bit depth {other:?} (8 or 16 hold texels)"),
            })
        }
    };
    if !integer_components(format, channels, bits) {
        return Err(Error::invalid(
            path,
            format!(
                "a {channels}-channel {bits}-bit PNG cannot hold the layout's {format} target bit for bit (PNG holds \
                 1–4 unorm/uint channels of 8 or 16 bits; save {format} as DDS)"
            ),
        ));
    }
    let want = check_size(path, w, h, 1, format.bytes(), limits)?;
    // DEFLATE cannot expand data more than 1032:1 (its longest match, 258 bytes, in 2 bits at best): a header whose
    // pixels (one filter byte per row included) need more than that of the file's size is refused before the
    // buffer is allocated, instead of decoding into gigabytes what a few hundred bytes claim.
    let file_len = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
    let raw = (want as u64).saturating_add(u64::from(h));
    if raw > file_len.saturating_mul(MAX_DEFLATE_RATIO) {
        return Err(Error::invalid(
            path,
            format!(
                "PNG header claims {w}×{h} pixels ({raw} bytes), more than its {file_len} bytes can hold compressed \
                 (DEFLATE expands at most {MAX_DEFLATE_RATIO}:1): a damaged or hostile file"
            ),
        ));
    }
    let mut buf = vec![0u8; reader.output_buffer_size().unwrap_or(0).max(want)];
    let info = reader.next_frame(&mut buf).map_err(bad)?;
    buf.truncate(info.buffer_size());
    if buf.len() != want {
        return Err(Error::invalid(path, format!("PNG decoded to {} bytes, expected {want}", buf.len())));
    }
    if bits == 16 {
        // PNG stores 16-bit samples big-endian; texels are little-endian.
        for s in buf.chunks_exact_mut(2) {
            s.swap(0, 1);
        }
    }
    Ok(Texture { width: w, height: h, slices: 1, stored_as: format!("PNG {color:?} {bits}-bit"), bytes: buf })
}

fn read_exr(path: &Path, format: Format, limits: &ReadLimits) -> Result<Texture> {
    use crate::io::raw::RawData;
    let raw = crate::io::exr::read_raw(path, limits)?;
    if raw.lossy {
        return Err(Error::invalid(
            path,
            format!("{} compression loses bits; texels need a lossless EXR", raw.compression),
        ));
    }
    // Channels in R, G, B, A order (a single channel of any name is red).
    let order = |name: &str| {
        let last = name.rsplit('.').next().unwrap_or(name).to_ascii_uppercase();
        ["R", "G", "B", "A"].iter().position(|c| *c == last)
    };
    let mut chans: Vec<&crate::io::raw::RawChannel> = raw.channels.iter().collect();
    if chans.len() > 1 {
        if chans.iter().any(|c| order(&c.name).is_none()) {
            return Err(Error::invalid(
                path,
                format!(
                    "channels {}: a packed target's EXR holds R, G, B, A channels (or one channel)",
                    chans.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            ));
        }
        chans.sort_by_key(|c| order(&c.name));
    }
    let comps = format.components();
    let fits = comps.len() == chans.len()
        && comps.iter().zip(&chans).enumerate().all(|(i, (c, ch))| {
            let (bits, kind_ok) = match ch.data {
                RawData::F16(_) => (16, c.kind == ComponentKind::Float),
                RawData::F32(_) => (32, c.kind == ComponentKind::Float),
                RawData::U32(_) => (32, matches!(c.kind, ComponentKind::Uint)),
            };
            c.bits == bits && c.offset == i as u32 * bits && kind_ok
        });
    if !fits {
        return Err(Error::invalid(
            path,
            format!(
                "channels {} cannot hold the layout's {format} target bit for bit (EXR holds half/float/uint \
                 components: r16f–rgba32f, r32ui–rgba32ui; save {format} as DDS)",
                chans.iter().map(|c| format!("{} ({})", c.name, c.data.type_name())).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    let want = check_size(path, raw.width, raw.height, 1, format.bytes(), limits)?;
    let mut bytes = Vec::with_capacity(want);
    for i in 0..raw.width as usize * raw.height as usize {
        for ch in &chans {
            match &ch.data {
                RawData::F16(v) => bytes.extend_from_slice(&v[i].to_bits().to_le_bytes()),
                RawData::F32(v) => bytes.extend_from_slice(&v[i].to_bits().to_le_bytes()),
                RawData::U32(v) => bytes.extend_from_slice(&v[i].to_le_bytes()),
            }
        }
    }
    Ok(Texture {
        width: raw.width,
        height: raw.height,
        slices: 1,
        stored_as: format!(
            "EXR {}",
            chans.iter().map(|c| format!("{}:{}", c.name, c.data.type_name())).collect::<Vec<_>>().join(" ")
        ),
        bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every layout format's own DXGI format maps to itself; typeless twins are accepted; other sizes are not.
    #[test]
    fn families_accept_twins_and_refuse_other_bits() {
        for f in Format::ALL {
            if let Some(d) = dds::dxgi_format(f) {
                assert_eq!(dxgi_mapping(d, f), Some(Mapping::AsIs), "{f}");
                assert_ne!(dxgi_name(d), "?", "{f}");
            }
        }
        assert_eq!(dxgi_mapping(39, Format::D32F), Some(Mapping::AsIs), "R32_TYPELESS holds D32_FLOAT");
        assert_eq!(dxgi_mapping(44, Format::D24S8), Some(Mapping::AsIs));
        assert_eq!(dxgi_mapping(87, Format::Rgba8), Some(Mapping::SwapRedBlue));
        assert_eq!(dxgi_mapping(28, Format::Rgb10A2), None);
        assert_eq!(dxgi_mapping(41, Format::Rg16F), None);
        assert_eq!(dxgi_mapping(26, Format::Rgb9e5), None);
    }

    #[test]
    fn legacy_pixel_formats_map_as_directxtex_does() {
        assert_eq!(legacy_dxgi(0x41, 0, 32, [0xff, 0xff00, 0xff_0000, 0xff00_0000]), Ok(28));
        assert_eq!(legacy_dxgi(0x41, 0, 32, [0x3ff, 0xf_fc00, 0x3ff0_0000, 0xc000_0000]), Ok(24));
        assert_eq!(legacy_dxgi(0x4, 113, 0, [0; 4]), Ok(10));
        assert_eq!(legacy_dxgi(0x4, 114, 0, [0; 4]), Ok(41));
        assert_eq!(legacy_dxgi(0x2_0000, 0, 16, [0xffff, 0, 0, 0]), Ok(56));
        assert!(legacy_dxgi(0x4, u32::from_le_bytes(*b"DXT1"), 0, [0; 4]).unwrap_err().contains("DXT1"));
    }

    #[test]
    fn png_and_exr_hold_only_whole_integer_or_float_components() {
        assert!(integer_components(Format::Rgba8, 4, 8));
        assert!(integer_components(Format::Rgba8Srgb, 4, 8));
        assert!(integer_components(Format::R16Unorm, 1, 16));
        assert!(integer_components(Format::Rg16Unorm, 2, 16));
        assert!(!integer_components(Format::Rgb10A2, 4, 8));
        assert!(!integer_components(Format::Rg16F, 2, 16));
        assert!(!integer_components(Format::D24S8, 2, 16));
    }
}
