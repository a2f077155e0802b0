//! The only file that names the `exr` crate: reads every flat channel of every part of an OpenEXR file into a
//! [`RawImage`] and writes one back. Format-specific readers (canonical, Blender, Mitsuba) map channel names to
//! attributes on top of this.
//!
//! Safety net (see [`ReadLimits`]): headers are inspected before any pixel is allocated.

use crate::error::{Error, Result};
pub use crate::io::raw::{RawChannel, RawData, RawImage};
use std::path::Path;

/// Limits applied before reading pixels.
#[derive(Clone, Copy, Debug)]
pub struct ReadLimits {
    /// Maximum bytes of decoded samples a file may declare.
    pub max_bytes: u64,
    /// Decode DWAA/DWAB-compressed files (the exr crate's DWA decoder trusts sizes inside chunks).
    pub allow_dwa: bool,
}

/// The share of the machine's available memory a file's declared samples may take by default: loading holds the
/// decoded samples and the f32 G-buffer built from them (twice their size for half floats) at once, briefly.
pub const DEFAULT_MEMORY_SHARE: u64 = 4;

/// The default limit where the available memory cannot be read (not Linux).
pub const FALLBACK_MAX_BYTES: u64 = 4 << 30;

impl ReadLimits {
    /// The default byte limit on this machine: a [`DEFAULT_MEMORY_SHARE`]th of its available memory
    /// (`MemAvailable` of /proc/meminfo), at least 64 MiB; [`FALLBACK_MAX_BYTES`] where that cannot be read.
    #[must_use]
    pub fn machine_max_bytes() -> u64 {
        available_memory().map_or(FALLBACK_MAX_BYTES, |a| (a / DEFAULT_MEMORY_SHARE).max(64 << 20))
    }

    /// Where the limit in force comes from, for the refusal's message.
    #[must_use]
    pub fn describe(&self) -> String {
        match available_memory() {
            Some(a) if self.max_bytes == (a / DEFAULT_MEMORY_SHARE).max(64 << 20) => format!(
                "the default: a quarter of the {:.1} GiB this machine has available",
                a as f64 / f64::from(1u32 << 30)
            ),
            None if self.max_bytes == FALLBACK_MAX_BYTES => "the default".to_string(),
            _ => "the limit given".to_string(),
        }
    }
}

/// `MemAvailable` of /proc/meminfo in bytes, read once per process so that the default and its description agree
/// (`None` elsewhere, or when it cannot be read).
fn available_memory() -> Option<u64> {
    static AVAILABLE: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        let text = std::fs::read_to_string("/proc/meminfo").ok()?;
        let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    })
}

impl Default for ReadLimits {
    /// [`ReadLimits::machine_max_bytes`], DWA refused.
    fn default() -> Self {
        ReadLimits { max_bytes: Self::machine_max_bytes(), allow_dwa: false }
    }
}

/// Reads all flat channels of the EXR at `path` (headers and the chunk table are checked against `limits` and the
/// file's length before any pixel is allocated).
pub fn read_raw(path: &Path, limits: &ReadLimits) -> Result<RawImage> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let read_at = |at: u64, buf: &mut [u8]| {
        use std::io::{Read, Seek};
        let mut f = &file;
        f.seek(std::io::SeekFrom::Start(at))?;
        f.read_exact(buf)
    };
    read_raw_from(std::io::BufReader::new(&file), read_at, len, path, limits)
}

/// Reads all flat channels of an EXR held in memory (`path` only names it in errors).
pub fn read_raw_bytes(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<RawImage> {
    let read_at = |at: u64, buf: &mut [u8]| {
        let src = usize::try_from(at).ok().and_then(|a| bytes.get(a..a.checked_add(buf.len())?));
        let src = src.ok_or_else(|| std::io::Error::from(std::io::ErrorKind::UnexpectedEof))?;
        buf.copy_from_slice(src);
        Ok(())
    };
    read_raw_from(std::io::Cursor::new(bytes), read_at, bytes.len() as u64, path, limits)
}

/// Largest factor by which a compression method can expand the bytes of a chunk: a part declaring more decoded
/// bytes than `factor ×` the bytes its chunks really occupy in the file cannot hold them and is refused before the
/// exr crate allocates its buffers. `None` only for methods the exr crate cannot decode anyway (HTJ2K).
fn max_expansion(c: ::exr::compression::Compression) -> Option<u64> {
    use ::exr::compression::Compression as C;
    match c {
        C::Uncompressed => Some(1),
        // A run of at most 128 bytes costs 2 bytes.
        C::RLE => Some(64),
        // Deflate cannot exceed 1032:1.
        C::ZIP1 | C::ZIP16 => Some(1032),
        // Deflate of 24-bit floats re-expanded to 32 bits.
        C::PXR24 => Some(1376),
        // A flat 4×4 half block (32 bytes) costs at least 3 bytes; other types are stored raw.
        C::B44 | C::B44A => Some(11),
        // PIZ: the wavelet and the value bitmap keep the count of 16-bit values; the Huffman stage's longest
        // expansion is its run code (≥ 1 bit) + an 8-bit count repeating the last value up to 255 times: 4080 bits
        // out of 9, 453:1.
        C::PIZ => Some(512),
        // DWA: zlib (≤ 1032:1) of OpenEXR's byte RLE (≤ 64:1) for the RLE-coded channels; the lossy channels' DC
        // plane is zlib of 2 bytes per 8×8 block (128 decoded bytes) and their AC end-of-block codes are Huffman
        // run codes, which is less. A loose bound, but a bound: the chunk table check proves the bytes exist.
        C::DWAA(_) | C::DWAB(_) => Some(1032 * 64),
        _ => None,
    }
}

/// The OpenEXR name of a compression method.
fn compression_name(c: ::exr::compression::Compression) -> &'static str {
    use ::exr::compression::Compression as C;
    match c {
        C::Uncompressed => "NONE",
        C::RLE => "RLE",
        C::ZIP1 => "ZIPS",
        C::ZIP16 => "ZIP",
        C::PIZ => "PIZ",
        C::PXR24 => "PXR24",
        C::B44 => "B44",
        C::B44A => "B44A",
        C::DWAA(_) => "DWAA",
        C::DWAB(_) => "DWAB",
        _ => "HTJ2K",
    }
}

/// A channel or layer name as a string: UTF-8 when the bytes are valid UTF-8 (what current OpenEXR writes), else
/// Latin-1 (what the format originally specified). Control characters are refused.
fn decode_name(bytes: &[u8], path: &Path, what: &str) -> Result<String> {
    let s = match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    };
    if s.is_empty() || s.chars().any(char::is_control) {
        return Err(Error::invalid(path, format!("{what} name {s:?} is empty or contains control characters")));
    }
    Ok(s)
}

/// Checks the full names (`layer.channel` for named parts) of every channel of every part: decodable, unique.
fn check_channel_names(meta: &::exr::meta::MetaData, path: &Path) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for header in meta.headers.iter() {
        let prefix = match &header.own_attributes.layer_name {
            Some(n) => format!("{}.", decode_name(n.bytes(), path, "part")?),
            None => String::new(),
        };
        for ch in &header.channels.list {
            let name = format!("{prefix}{}", decode_name(ch.name.bytes(), path, "channel")?);
            if !seen.insert(name.clone()) {
                return Err(Error::invalid(path, format!("duplicate channel name {name:?}")));
            }
        }
    }
    Ok(())
}

/// What the header check learned: compression, whether decoding in parallel is worth a thread pool.
struct Plan {
    compression: String,
    lossy: bool,
    parallel: bool,
}

/// Refuses, from the headers alone, files that are unsupported or would allocate more than the limits allow.
fn check_headers(meta: &::exr::meta::MetaData, file_len: u64, path: &Path, limits: &ReadLimits) -> Result<Plan> {
    use ::exr::compression::Compression as C;
    if meta.headers.is_empty() {
        return Err(Error::invalid(path, "no parts"));
    }
    let mut declared: u128 = 0;
    let mut chunks: u128 = 0;
    let mut lossy = false;
    for (i, h) in meta.headers.iter().enumerate() {
        if h.deep {
            return Err(Error::Unsupported { path: path.into(), what: format!("part {i} holds deep data") });
        }
        if h.channels.list.is_empty() {
            return Err(Error::invalid(path, format!("part {i} has no channels")));
        }
        for ch in &h.channels.list {
            if ch.sampling.0 != 1 || ch.sampling.1 != 1 {
                return Err(Error::Unsupported {
                    path: path.into(),
                    what: format!(
                        "channel {:?} is subsampled ({}×{}); only full-resolution channels are supported",
                        ch.name.to_string(),
                        ch.sampling.0,
                        ch.sampling.1
                    ),
                });
            }
            lossy |= !h.compression.is_lossless_for(ch.sample_type);
        }
        if matches!(h.compression, C::DWAA(_) | C::DWAB(_)) && !limits.allow_dwa {
            return Err(Error::Unsupported {
                path: path.into(),
                what: format!(
                    "{} compression (lossy, and its decoder is not hardened against damaged files); pass --allow-dwa to decode it",
                    compression_name(h.compression)
                ),
            });
        }
        declared += part_bytes(h);
        chunks += h.chunk_count as u128;
    }
    if declared > u128::from(limits.max_bytes) {
        return Err(Error::TooLarge {
            path: path.into(),
            bytes: declared.min(u64::MAX as u128) as u64,
            limit: limits.max_bytes,
            why: limits.describe(),
        });
    }
    // Every chunk costs at least an 8-byte offset-table entry and an 8-byte chunk header.
    if chunks * 16 > u128::from(file_len) {
        return Err(Error::invalid(
            path,
            format!("declares {chunks} chunks, more than a {file_len}-byte file can hold (truncated or damaged)"),
        ));
    }
    check_channel_names(meta, path)?;
    let first = meta.headers[0].compression;
    Ok(Plan { compression: compression_name(first).to_string(), lossy, parallel: declared > 4 << 20 })
}

/// Decoded bytes of one part's samples, as its header declares them.
fn part_bytes(h: &::exr::meta::header::Header) -> u128 {
    let pixel_bytes: u128 = h.channels.list.iter().map(|c| c.sample_type.bytes_per_sample() as u128).sum();
    h.layer_size.0 as u128 * h.layer_size.1 as u128 * pixel_bytes
}

/// Proves, before any pixel is allocated, that the chunks the headers promise are in the file: reads the offset
/// tables and every chunk's own header (part number, position, byte count) and checks that each chunk lies inside
/// the file, that no two overlap and that multi-part chunks name the part whose table points at them. Then each
/// part's declared samples must fit in what its chunks can decode to ([`max_expansion`] × their bytes). A file
/// whose tables point past its end (a few KB declaring gigabytes) is refused here, at the cost of reading a few
/// bytes per chunk. `read_at` reads exactly `buf.len()` bytes at an offset.
fn check_chunks(
    meta: &::exr::meta::MetaData,
    mut read_at: impl FnMut(u64, &mut [u8]) -> std::io::Result<()>,
    file_len: u64,
    path: &Path,
) -> Result<()> {
    use ::exr::meta::BlockDescription;
    let damaged = |what: String| Error::invalid(path, format!("{what} (truncated or damaged)"));
    let in_header = || damaged(format!("ends at byte {file_len}, inside its header"));
    let word = |at: u64, read_at: &mut dyn FnMut(u64, &mut [u8]) -> std::io::Result<()>| -> Result<u32> {
        let mut four = [0u8; 4];
        read_at(at, &mut four).map_err(|_| in_header())?;
        Ok(u32::from_le_bytes(four))
    };
    // Where the NUL that ends the string at `at` is (names are at most 255 bytes).
    let string_end = |at: u64, read_at: &mut dyn FnMut(u64, &mut [u8]) -> std::io::Result<()>| -> Result<u64> {
        let mut window = [0u8; 64];
        for k in 0..5u64 {
            let from = at + 64 * k;
            let n = file_len.saturating_sub(from).min(64) as usize;
            read_at(from, &mut window[..n]).map_err(|_| in_header())?;
            if let Some(i) = window[..n].iter().position(|&b| b == 0) {
                return Ok(from + i as u64);
            }
            if n < 64 {
                break;
            }
        }
        Err(in_header())
    };
    // Walk the headers to where the offset tables start: attributes are `name\0 type\0 size value`, an empty name
    // ends a header, and one more empty name ends the list of a multi-part file.
    let multipart = word(4, &mut read_at)? & 0x1000 != 0;
    let mut at = 8u64;
    for _ in 0..meta.headers.len() {
        loop {
            let name_end = string_end(at, &mut read_at)?;
            if name_end == at {
                at += 1;
                break;
            }
            let type_end = string_end(name_end + 1, &mut read_at)?;
            at = type_end + 1 + 4 + u64::from(word(type_end + 1, &mut read_at)?);
        }
    }
    if multipart {
        at += 1;
    }
    // The offset tables: one u64 per chunk, part by part.
    let tables_end = at + 8 * meta.headers.iter().map(|h| h.chunk_count as u64).sum::<u64>();
    if tables_end > file_len {
        return Err(damaged(format!("its chunk offset tables end at byte {tables_end}, past the file's {file_len}")));
    }
    let mut chunks: Vec<(u64, usize)> = Vec::with_capacity(((tables_end - at) / 8) as usize);
    let mut eight = [0u8; 8];
    for (part, h) in meta.headers.iter().enumerate() {
        for _ in 0..h.chunk_count {
            read_at(at, &mut eight).map_err(|e| Error::io(path, e))?;
            chunks.push((u64::from_le_bytes(eight), part));
            at += 8;
        }
    }
    chunks.sort_unstable();
    let mut stored = vec![0u64; meta.headers.len()];
    let mut previous_end = tables_end;
    for &(offset, part) in &chunks {
        let h = &meta.headers[part];
        let fields: u64 = match h.blocks {
            BlockDescription::ScanLines => 2,
            BlockDescription::Tiles(_) => 5,
        } + u64::from(multipart);
        if offset < previous_end || offset.saturating_add(4 * fields) > file_len {
            return Err(damaged(format!(
                "a chunk of part {part} is listed at byte {offset}, {} (the file is {file_len} bytes)",
                if offset < tables_end {
                    "inside the headers and offset tables".to_string()
                } else if offset < previous_end {
                    format!("inside the chunk before it, which ends at byte {previous_end}")
                } else {
                    "past the end of the file".to_string()
                }
            )));
        }
        if multipart {
            let named = word(offset, &mut read_at)?;
            if named as usize != part {
                return Err(damaged(format!(
                    "the chunk at byte {offset} belongs to part {named}, but part {part}'s offset table lists it"
                )));
            }
        }
        let size = word(offset + 4 * (fields - 1), &mut read_at)?;
        let end = offset + 4 * fields + u64::from(size);
        if size > i32::MAX as u32 || end > file_len {
            return Err(damaged(format!(
                "the chunk at byte {offset} declares {} bytes, past the end of the {file_len}-byte file",
                size as i32
            )));
        }
        stored[part] += u64::from(size);
        previous_end = end;
    }
    for (part, h) in meta.headers.iter().enumerate() {
        let (declared, factor) = (part_bytes(h), max_expansion(h.compression));
        if let Some(f) = factor.filter(|&f| declared > u128::from(stored[part]) * u128::from(f)) {
            return Err(damaged(format!(
                "part {part} declares {declared} bytes of samples, but its chunks hold {} bytes, which {} \
                 compression expands at most {f}×",
                stored[part],
                compression_name(h.compression)
            )));
        }
    }
    Ok(())
}

/// Runs `f`, turning a panic inside the exr crate into an error (a last line of defence: the header checks above
/// exist so that this does not happen).
fn guarded<T>(path: &Path, f: impl FnOnce() -> ::exr::error::Result<T>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(source)) => Err(Error::Exr { path: path.into(), source }),
        Err(_) => Err(Error::invalid(path, "the EXR decoder failed on damaged data")),
    }
}

fn read_raw_from<R: std::io::Read + std::io::Seek>(
    mut reader: R,
    read_at: impl FnMut(u64, &mut [u8]) -> std::io::Result<()>,
    file_len: u64,
    path: &Path,
    limits: &ReadLimits,
) -> Result<RawImage> {
    use ::exr::prelude::{read, FlatSamples, ReadChannels, ReadLayers};
    let meta = guarded(path, || ::exr::meta::MetaData::read_from_buffered(&mut reader, false))?;
    let plan = check_headers(&meta, file_len, path, limits)?;
    check_chunks(&meta, read_at, file_len, path)?;
    drop(meta);
    reader.seek(std::io::SeekFrom::Start(0)).map_err(|e| Error::io(path, e))?;
    let image = guarded(path, || {
        let r = read().no_deep_data().largest_resolution_level().all_channels().all_layers().all_attributes();
        if plan.parallel {
            r.from_buffered(reader)
        } else {
            r.non_parallel().from_buffered(reader)
        }
    })?;
    let mut out = RawImage { compression: plan.compression, lossy: plan.lossy, ..RawImage::default() };
    for (li, layer) in image.layer_data.into_iter().enumerate() {
        let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
        if li == 0 {
            out.width = w;
            out.height = h;
            for (k, v) in &layer.attributes.other {
                if let ::exr::meta::attribute::AttributeValue::Text(t) = v {
                    out.attributes.push((k.to_string(), t.to_string()));
                }
            }
            out.attributes.sort();
        } else if (w, h) != (out.width, out.height) {
            return Err(Error::Unsupported {
                path: path.into(),
                what: format!("parts of different sizes ({}×{} and {w}×{h})", out.width, out.height),
            });
        }
        let prefix = match &layer.attributes.layer_name {
            Some(n) => format!("{}.", decode_name(n.bytes(), path, "part")?),
            None => String::new(),
        };
        let n = w as usize * h as usize;
        for ch in layer.channel_data.list {
            let name = format!("{prefix}{}", decode_name(ch.name.bytes(), path, "channel")?);
            let data = match ch.sample_data {
                FlatSamples::F16(v) => RawData::F16(v),
                FlatSamples::F32(v) => RawData::F32(v),
                FlatSamples::U32(v) => RawData::U32(v),
            };
            if data.len() != n {
                return Err(Error::invalid(
                    path,
                    format!("channel {name} decoded to {} samples, expected {n}", data.len()),
                ));
            }
            out.channels.push(RawChannel { name, data });
        }
    }
    Ok(out)
}

/// Writes `image` as a single-part, ZIP16-compressed (lossless) scan-line EXR, atomically (temporary file + rename).
/// Channel names must be Latin-1; string attributes are stored as text header attributes.
pub fn write_raw(path: &Path, image: &RawImage) -> Result<()> {
    write_raw_with(path, image, WriteCompression::Zip)
}

/// The ZIP-compressed EXR file of `image` as bytes, as [`write_raw`] writes it (`name` names it in errors): for
/// outputs collected before they are written, such as a report's attachments.
pub fn raw_to_bytes(name: &Path, image: &RawImage) -> Result<Vec<u8>> {
    super::exr_write::to_bytes(name, image, super::exr_write::Compression::Zip)
}

/// [`write_raw`] with the compression given. ZIP and NONE go through gbuf's own block writer (`io::exr_write`:
/// parallel zlib-rs, blocks written as they are made); PIZ and RLE through the exr crate's.
pub fn write_raw_with(path: &Path, image: &RawImage, compression: WriteCompression) -> Result<()> {
    match compression {
        WriteCompression::Zip => super::exr_write::write(path, image, super::exr_write::Compression::Zip),
        WriteCompression::None => super::exr_write::write(path, image, super::exr_write::Compression::None),
        WriteCompression::Piz | WriteCompression::Rle => write_with_exr_crate(path, image.clone(), compression),
    }
}

crate::named_enum! {
    /// The lossless compressions gbuf writes. Times and sizes on a 1920×1080 × 4 canonical room dump: docs/FORMAT.md
    /// (`cargo bench --bench exr_io`).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub enum WriteCompression: "EXR compression" {
        /// ZIP, 16 scan lines per block (the default: OpenEXR's usual lossless choice; small files).
        #[default]
        Zip => "zip",
        /// PIZ (wavelet + Huffman), 32 scan lines per block.
        Piz => "piz",
        /// Run-length encoding: fast, weak on float data.
        Rle => "rle",
        /// No compression: the fastest write, the largest file.
        None => "none",
    }
}

impl WriteCompression {
    fn encoding(self) -> ::exr::image::Encoding {
        use ::exr::compression::Compression as C;
        let compression = match self {
            WriteCompression::Zip => C::ZIP16,
            WriteCompression::Piz => C::PIZ,
            WriteCompression::Rle => C::RLE,
            WriteCompression::None => C::Uncompressed,
        };
        ::exr::image::Encoding { compression, ..::exr::image::Encoding::SMALL_LOSSLESS }
    }
}

/// [`write_raw_with`] taking the image by value: for PIZ and RLE its samples move into the exr crate's encoder
/// instead of being copied (a 1080p × 4 dump is ≈ 600 MB of samples, and a copy of fresh memory costs its page
/// faults too); ZIP and NONE write from it in place.
pub fn write_raw_owned(path: &Path, image: RawImage, compression: WriteCompression) -> Result<()> {
    match compression {
        WriteCompression::Zip | WriteCompression::None => write_raw_with(path, &image, compression),
        WriteCompression::Piz | WriteCompression::Rle => write_with_exr_crate(path, image, compression),
    }
}

/// The exr crate's writer (PIZ and RLE), with the header's attributes sorted afterwards.
fn write_with_exr_crate(path: &Path, image: RawImage, compression: WriteCompression) -> Result<()> {
    use ::exr::image::{AnyChannel, AnyChannels, FlatSamples, Image, Layer};
    use ::exr::meta::attribute::{AttributeValue, Text};
    use ::exr::meta::header::LayerAttributes;
    use ::exr::prelude::WritableImage;
    let n = image.width as usize * image.height as usize;
    let mut list = ::exr::prelude::SmallVec::new();
    let (width, height) = (image.width, image.height);
    for ch in image.channels {
        if ch.data.len() != n {
            return Err(Error::SizeMismatch {
                path: path.into(),
                what: format!("channel {} has {} samples, expected {n}", ch.name, ch.data.len()),
            });
        }
        let name = Text::new_or_none(ch.name.as_str())
            .ok_or_else(|| Error::invalid(path, format!("channel name {:?} is not Latin-1", ch.name)))?;
        let data = match ch.data {
            RawData::F16(v) => FlatSamples::F16(v),
            RawData::F32(v) => FlatSamples::F32(v),
            RawData::U32(v) => FlatSamples::U32(v),
        };
        list.push(AnyChannel::new(name, data));
    }
    let mut attributes = LayerAttributes::default();
    for (k, v) in &image.attributes {
        let (Some(k), Some(v)) = (Text::new_or_none(k.as_str()), Text::new_or_none(v.as_str())) else {
            return Err(Error::invalid(path, format!("header attribute {k:?} is not Latin-1")));
        };
        attributes.other.insert(k, AttributeValue::Text(v));
    }
    let layer =
        Layer::new((width as usize, height as usize), attributes, compression.encoding(), AnyChannels::sort(list));
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|source| Error::Exr { path: path.into(), source })?;
    let mut bytes = bytes.into_inner();
    sort_header_attributes(&mut bytes);
    crate::base::files::write_bytes_atomic(path, &bytes)
}

/// Sorts the attributes of a single-part header by name, in place. The exr crate writes custom attributes in hash
/// map order, which would make identical images produce different files; the header keeps its length, so the
/// offset table stays valid. Leaves the bytes alone if the header does not parse.
fn sort_header_attributes(bytes: &mut [u8]) {
    let mut i = 8;
    let mut attrs: Vec<(&[u8], std::ops::Range<usize>)> = Vec::new();
    while i < bytes.len() && bytes[i] != 0 {
        let start = i;
        let Some(n1) = bytes[i..].iter().position(|&b| b == 0) else { return };
        let Some(n2) = bytes.get(i + n1 + 1..).and_then(|r| r.iter().position(|&b| b == 0)) else { return };
        let at = i + n1 + n2 + 2;
        let Some(size) = bytes.get(at..at + 4).map(|s| i32::from_le_bytes(s.try_into().expect("4 bytes"))) else {
            return;
        };
        let Ok(size) = usize::try_from(size) else { return };
        i = at + 4 + size;
        if i > bytes.len() {
            return;
        }
        attrs.push((&bytes[start..start + n1], start..i));
    }
    let (Some(first), Some(last)) = (attrs.first().map(|a| a.1.start), attrs.last().map(|a| a.1.end)) else {
        return;
    };
    attrs.sort_by(|a, b| a.0.cmp(b.0));
    let sorted: Vec<u8> = attrs.iter().flat_map(|(_, r)| bytes[r.clone()].to_vec()).collect();
    bytes[first..last].copy_from_slice(&sorted);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bulk conversion equals the per-sample one for each sample type, over several blocks and a short one.
    #[test]
    fn to_f32_vec_equals_f32_at_for_every_type() {
        let n = (1 << 16) * 2 + 77;
        let halves: Vec<half::f16> = (0..n).map(|i| half::f16::from_bits((i * 7919 % 65536) as u16)).collect();
        let cases = [
            RawData::F16(halves),
            RawData::F32((0..n).map(|i| i as f32 * 0.37 - 1e4).collect()),
            RawData::U32((0..n).map(|i| (i as u32).wrapping_mul(2_654_435_761)).collect()),
        ];
        for d in &cases {
            let bulk = d.to_f32_vec();
            assert_eq!(bulk.len(), d.len());
            let same = bulk.iter().enumerate().all(|(i, v)| v.to_bits() == d.f32_at(i).to_bits());
            assert!(same, "{}", d.type_name());
        }
    }

    #[test]
    fn raw_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.exr");
        let img = RawImage {
            width: 3,
            height: 2,
            channels: vec![
                RawChannel {
                    name: "a.F".into(),
                    data: RawData::F32(vec![1.0, -0.0, f32::MIN_POSITIVE / 4.0, 1e30, 0.5, 7.0]),
                },
                RawChannel { name: "b.H".into(), data: RawData::F16(vec![half::f16::from_f32(0.25); 6]) },
                RawChannel { name: "c.U".into(), data: RawData::U32(vec![0, 1, u32::MAX, 3, 4, 5]) },
            ],
            compression: String::new(),
            lossy: false,
            attributes: vec![("gbuf.version".into(), "1".into())],
        };
        write_raw(&p, &img).unwrap();
        let back = read_raw(&p, &ReadLimits::default()).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        for ch in &img.channels {
            let b = back.channel(&ch.name).unwrap();
            match (&ch.data, &b.data) {
                (RawData::F32(x), RawData::F32(y)) => {
                    assert_eq!(
                        x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                        y.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                    )
                }
                (x, y) => assert_eq!(x, y),
            }
        }
        assert_eq!(back.attributes, img.attributes);
    }

    #[test]
    fn identical_images_give_identical_files() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = RawImage { width: 2, height: 1, ..Default::default() };
        img.channels.push(RawChannel { name: "Z".into(), data: RawData::F32(vec![1.0, 2.0]) });
        img.attributes = (0..12).map(|i| (format!("key{i}"), format!("value {i}"))).collect();
        img.attributes.sort();
        let files: Vec<Vec<u8>> = (0..4)
            .map(|i| {
                let p = dir.path().join(format!("{i}.exr"));
                write_raw(&p, &img).unwrap();
                std::fs::read(&p).unwrap()
            })
            .collect();
        assert!(files.iter().all(|f| *f == files[0]));
        let back = read_raw_bytes(&files[0], Path::new("mem"), &ReadLimits::default()).unwrap();
        assert_eq!(back.attributes, img.attributes);
        assert_eq!(back.channels, img.channels);
    }
}
