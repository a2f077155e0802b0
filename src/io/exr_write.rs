//! Our scan-line OpenEXR writer: one part, NONE or ZIP (16 lines per block), written block by block into the
//! temporary file that is then renamed over the target.
//!
//! Why not the exr crate's writer (which gbuf still uses for PIZ and RLE): on a 1920×1080 × 4 dump (597 MB of
//! samples) it took 1.55–2.15 s for ZIP and 2.28 s with no compression at all, against 0.15–0.5 s for writing the
//! same bytes raw (docs/FORMAT.md). Its ZIP is miniz_oxide at level 4 (176 MB/s per core on these blocks, measured);
//! zlib-rs at the same level gives the same size at 287 MB/s. Here the blocks are compressed in parallel in groups
//! and written as each group finishes, so neither the uncompressed nor the compressed file is ever whole in memory.
//!
//! The format (OpenEXR's "Technical Introduction" and `ImfZip.cpp`): the magic number and version 2 (flag 0x400
//! when a name is longer than 31 bytes), the header's attributes sorted by name and a null byte, one 64-bit file
//! offset per block, then the blocks: the block's first line (i32), its byte count (i32) and its data. A block's
//! data is, line by line, each channel's samples in channel-name order, little-endian. ZIP splits those bytes into
//! the even-indexed then the odd-indexed ones, replaces each byte by its difference to the previous one plus 128,
//! and deflates the result in a zlib stream; a block that would not shrink is stored as it was (readers tell it by
//! its size).

use crate::error::{Error, Result};
use crate::io::raw::{RawData, RawImage};
use rayon::prelude::*;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

/// The compressions this writer implements.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Compression {
    /// No compression, one line per block.
    None,
    /// zlib-deflated, 16 lines per block.
    Zip,
}

impl Compression {
    fn lines_per_block(self) -> usize {
        match self {
            Compression::None => 1,
            Compression::Zip => 16,
        }
    }
    /// The header's compression code.
    fn code(self) -> u8 {
        match self {
            Compression::None => 0,
            Compression::Zip => 3,
        }
    }
}

/// zlib level of ZIP blocks: 4 is the exr crate's (and so the size of files gbuf wrote before); measured on the
/// blocks of a 1080p × 4 room dump, zlib-rs level 4 gives 5.26:1 at 287 MB/s per core, level 1 4.94:1 at 490 MB/s,
/// level 6 5.29:1 at 170 MB/s.
const ZIP_LEVEL: u32 = 4;

/// Uncompressed bytes made per group of blocks, at least.
const GROUP_BYTES: usize = 32 << 20;

/// Longest name OpenEXR reads without the long-names flag.
const SHORT_NAME: usize = 31;
/// Longest name OpenEXR reads at all.
const LONG_NAME: usize = 255;

/// One channel as written: its name's bytes, its sample size and type code, its samples.
struct Channel<'a> {
    name: Vec<u8>,
    data: &'a RawData,
}

impl Channel<'_> {
    fn bytes_per_sample(&self) -> usize {
        match self.data {
            RawData::F16(_) => 2,
            RawData::F32(_) | RawData::U32(_) => 4,
        }
    }
    fn type_code(&self) -> i32 {
        match self.data {
            RawData::U32(_) => 0,
            RawData::F16(_) => 1,
            RawData::F32(_) => 2,
        }
    }
    /// Writes samples `from..from + n` into `dst` (their size exactly), little-endian.
    fn put(&self, from: usize, n: usize, dst: &mut [u8]) {
        match self.data {
            RawData::F16(v) => {
                dst.chunks_exact_mut(2).zip(&v[from..from + n]).for_each(|(d, s)| d.copy_from_slice(&s.to_le_bytes()));
            }
            RawData::F32(v) => {
                dst.chunks_exact_mut(4).zip(&v[from..from + n]).for_each(|(d, s)| d.copy_from_slice(&s.to_le_bytes()));
            }
            RawData::U32(v) => {
                dst.chunks_exact_mut(4).zip(&v[from..from + n]).for_each(|(d, s)| d.copy_from_slice(&s.to_le_bytes()));
            }
        }
    }
}

/// Latin-1 bytes of `s`, or an error naming `what` when a character is not Latin-1, the name is empty, holds a
/// null byte or is longer than OpenEXR allows.
fn latin1(path: &Path, s: &str, what: &str) -> Result<Vec<u8>> {
    let bytes: Option<Vec<u8>> = s.chars().map(|c| u8::try_from(u32::from(c)).ok().filter(|&b| b != 0)).collect();
    match bytes {
        Some(b) if !b.is_empty() && b.len() <= LONG_NAME => Ok(b),
        Some(b) if b.is_empty() => Err(Error::invalid(path, format!("{what} is empty"))),
        Some(_) => Err(Error::invalid(path, format!("{what} {s:?} is longer than {LONG_NAME} bytes"))),
        None => Err(Error::invalid(path, format!("{what} {s:?} is not Latin-1 (or holds a null byte)"))),
    }
}

/// Writes `image` at `path` (atomically: a temporary file, then a rename) with `compression`.
pub(crate) fn write(path: &Path, image: &RawImage, compression: Compression) -> Result<()> {
    encode(Target::File(path), path, image, compression)
}

/// The EXR file of `image` as bytes (`name` names it in errors).
pub(crate) fn to_bytes(name: &Path, image: &RawImage, compression: Compression) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    encode(Target::Memory(&mut bytes), name, image, compression)?;
    Ok(bytes)
}

fn encode(target: Target<'_>, path: &Path, image: &RawImage, compression: Compression) -> Result<()> {
    let (width, height) = (image.width as usize, image.height as usize);
    if width == 0 || height == 0 || i32::try_from(width).is_err() || i32::try_from(height).is_err() {
        return Err(Error::invalid(path, format!("cannot write a {width}×{height} EXR image")));
    }
    let n = width * height;
    let mut channels = Vec::with_capacity(image.channels.len());
    for ch in &image.channels {
        if ch.data.len() != n {
            return Err(Error::SizeMismatch {
                path: path.into(),
                what: format!("channel {} has {} samples, expected {n}", ch.name, ch.data.len()),
            });
        }
        channels.push(Channel { name: latin1(path, &ch.name, "channel name")?, data: &ch.data });
    }
    if channels.is_empty() {
        return Err(Error::invalid(path, "an EXR image needs at least one channel"));
    }
    channels.sort_by(|a, b| a.name.cmp(&b.name));
    if let Some(w) = channels.windows(2).find(|w| w[0].name == w[1].name) {
        return Err(Error::invalid(path, format!("channel {:?} appears twice", String::from_utf8_lossy(&w[0].name))));
    }
    let header = header(path, image, &channels, compression)?;
    let lines = compression.lines_per_block();
    let blocks = height.div_ceil(lines);
    let line_bytes: usize = channels.iter().map(|c| c.bytes_per_sample() * width).sum();
    // Blocks are made in groups of a few per thread (and at least GROUP_BYTES of samples) in one buffer reused from
    // group to group (fresh memory would cost a page fault per 4 KB), compressed, then written in order.
    let threads = rayon::current_num_threads().max(1);
    let block_bytes = lines * line_bytes;
    let group = (4 * threads).max(GROUP_BYTES / block_bytes.max(1)).min(blocks);
    let mut buf = vec![0u8; group * block_bytes];
    let geometry = Blocks { width, height, lines, blocks, block_bytes, group, compression };
    match target {
        Target::File(path) => {
            crate::base::files::write_atomic(path, |file| emit(file, &header, &channels, &geometry, &mut buf))
        }
        Target::Memory(bytes) => {
            let mut cursor = std::io::Cursor::new(std::mem::take(bytes));
            emit(&mut cursor, &header, &channels, &geometry, &mut buf).map_err(|e| Error::io(path, e))?;
            *bytes = cursor.into_inner();
            Ok(())
        }
    }
}

/// Where [`encode`] puts the file.
enum Target<'a> {
    /// A file, written atomically.
    File(&'a Path),
    /// Bytes in memory.
    Memory(&'a mut Vec<u8>),
}

/// The block geometry of one image.
struct Blocks {
    width: usize,
    height: usize,
    lines: usize,
    blocks: usize,
    block_bytes: usize,
    group: usize,
    compression: Compression,
}

/// Writes the header, the offset table and the blocks to `file`, then the table's offsets.
fn emit<W: Write + Seek>(
    file: &mut W,
    header: &[u8],
    channels: &[Channel<'_>],
    g: &Blocks,
    buf: &mut [u8],
) -> std::io::Result<()> {
    let Blocks { width, height, lines, blocks, block_bytes, group, compression } = *g;
    {
        let mut out = std::io::BufWriter::with_capacity(1 << 20, &mut *file);
        out.write_all(header)?;
        let table_at = header.len() as u64;
        out.write_all(&vec![0u8; 8 * blocks])?;
        let mut at = table_at + 8 * blocks as u64;
        let mut offsets = Vec::with_capacity(blocks);
        for first in (0..blocks).step_by(group) {
            let count = group.min(blocks - first);
            let made: Vec<Made<'_>> = buf
                .par_chunks_mut(block_bytes)
                .take(count)
                .enumerate()
                .map_init(Vec::new, |scratch, (k, block)| {
                    let y0 = (first + k) * lines;
                    let rows = lines.min(height - y0);
                    let mut off = 0;
                    for y in y0..y0 + rows {
                        for c in channels {
                            let len = c.bytes_per_sample() * width;
                            c.put(y * width, width, &mut block[off..off + len]);
                            off += len;
                        }
                    }
                    let block: &[u8] = block;
                    let raw = &block[..off];
                    let packed = match compression {
                        Compression::None => None,
                        Compression::Zip => zip(raw, scratch),
                    };
                    (y0, raw, packed)
                })
                .collect();
            for (y0, raw, packed) in made {
                let data = packed.as_deref().unwrap_or(raw);
                offsets.push(at);
                let size = i32::try_from(data.len()).map_err(|_| std::io::Error::other("block over 2 GB"))?;
                out.write_all(&(y0 as i32).to_le_bytes())?;
                out.write_all(&size.to_le_bytes())?;
                out.write_all(data)?;
                at += 8 + data.len() as u64;
            }
        }
        out.flush()?;
        drop(out);
        file.seek(SeekFrom::Start(table_at))?;
        let table: Vec<u8> = offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
        file.write_all(&table)?;
    }
    Ok(())
}

/// A block made: its first line, its raw bytes, and its ZIP bytes when they are smaller.
type Made<'a> = (usize, &'a [u8], Option<Vec<u8>>);

/// ZIP of one block's bytes, or `None` when deflating would not shrink them (the block is then stored as it is);
/// `scratch` is reused from block to block.
fn zip(raw: &[u8], scratch: &mut Vec<u8>) -> Option<Vec<u8>> {
    scratch.clear();
    scratch.resize(raw.len(), 0);
    let half = raw.len().div_ceil(2);
    let (even, odd) = scratch.split_at_mut(half);
    for (i, pair) in raw.chunks(2).enumerate() {
        even[i] = pair[0];
        if let Some(&b) = pair.get(1) {
            odd[i] = b;
        }
    }
    let mut prev = scratch.first().copied().unwrap_or(0);
    for b in scratch.iter_mut().skip(1) {
        let v = *b;
        *b = v.wrapping_sub(prev).wrapping_add(128);
        prev = v;
    }
    let mut z = flate2::write::ZlibEncoder::new(Vec::with_capacity(raw.len() / 4), flate2::Compression::new(ZIP_LEVEL));
    z.write_all(scratch).and_then(|()| z.finish()).ok().filter(|p| p.len() < raw.len())
}

/// The magic number, version and header (attributes sorted by name, then a null byte).
fn header(path: &Path, image: &RawImage, channels: &[Channel<'_>], compression: Compression) -> Result<Vec<u8>> {
    let (w, h) = (image.width as i32, image.height as i32);
    let mut chlist = Vec::new();
    for c in channels {
        chlist.extend_from_slice(&c.name);
        chlist.push(0);
        chlist.extend_from_slice(&c.type_code().to_le_bytes());
        chlist.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved
        chlist.extend_from_slice(&1i32.to_le_bytes()); // x sampling
        chlist.extend_from_slice(&1i32.to_le_bytes()); // y sampling
    }
    chlist.push(0);
    let window: Vec<u8> = [0, 0, w - 1, h - 1].iter().flat_map(|v: &i32| v.to_le_bytes()).collect();
    let mut attrs: Vec<(Vec<u8>, &[u8], Vec<u8>)> = vec![
        (b"channels".to_vec(), b"chlist".as_slice(), chlist),
        (b"compression".to_vec(), b"compression".as_slice(), vec![compression.code()]),
        (b"dataWindow".to_vec(), b"box2i".as_slice(), window.clone()),
        (b"displayWindow".to_vec(), b"box2i".as_slice(), window),
        (b"lineOrder".to_vec(), b"lineOrder".as_slice(), vec![0]),
        (b"pixelAspectRatio".to_vec(), b"float".as_slice(), 1.0f32.to_le_bytes().to_vec()),
        (b"screenWindowCenter".to_vec(), b"v2f".as_slice(), [0.0f32.to_le_bytes(), 0.0f32.to_le_bytes()].concat()),
        (b"screenWindowWidth".to_vec(), b"float".as_slice(), 1.0f32.to_le_bytes().to_vec()),
    ];
    for (k, v) in &image.attributes {
        let name = latin1(path, k, "header attribute name")?;
        if attrs.iter().any(|a| a.0 == name) {
            return Err(Error::invalid(path, format!("header attribute {k:?} is set twice or is a standard one")));
        }
        let value: Option<Vec<u8>> = v.chars().map(|c| u8::try_from(u32::from(c)).ok()).collect();
        let value = value.ok_or_else(|| Error::invalid(path, format!("header attribute {k:?} is not Latin-1")))?;
        attrs.push((name, b"string".as_slice(), value));
    }
    attrs.sort_by(|a, b| a.0.cmp(&b.0));
    let long = attrs.iter().any(|a| a.0.len() > SHORT_NAME) || channels.iter().any(|c| c.name.len() > SHORT_NAME);
    let mut out = vec![0x76, 0x2f, 0x31, 0x01];
    out.extend_from_slice(&(2u32 | if long { 0x400 } else { 0 }).to_le_bytes());
    for (name, kind, value) in attrs {
        let size = i32::try_from(value.len())
            .map_err(|_| Error::invalid(path, "a header attribute is larger than 2 GB".to_string()))?;
        out.extend_from_slice(&name);
        out.push(0);
        out.extend_from_slice(kind);
        out.push(0);
        out.extend_from_slice(&size.to_le_bytes());
        out.extend_from_slice(&value);
    }
    out.push(0);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;
    use crate::io::exr::{read_raw, RawChannel};
    use crate::io::ReadLimits;

    /// 13 × 37 (three ZIP blocks, the last of 5 lines; odd rows of halves), one channel of each type plus a channel
    /// of random bits, and a channel with a name past the 31 bytes of short names.
    fn image(random_only: bool) -> RawImage {
        let (w, h) = (13u32, 37u32);
        let n = (w * h) as usize;
        let mut rng = SplitMix64::new(7);
        let noise =
            RawChannel { name: "noise.V".into(), data: RawData::U32((0..n).map(|_| rng.next_u64() as u32).collect()) };
        let channels = if random_only {
            vec![noise]
        } else {
            vec![
                RawChannel { name: "Z".into(), data: RawData::F32((0..n).map(|i| i as f32 * 0.25 - 3.0).collect()) },
                RawChannel {
                    name: "a.H".into(),
                    data: RawData::F16((0..n).map(|i| half::f16::from_f32((i % 17) as f32 / 4.0)).collect()),
                },
                RawChannel { name: "id.U".into(), data: RawData::U32((0..n).map(|i| (i / 40) as u32).collect()) },
                RawChannel {
                    name: "a.name.longer.than.thirty.one.bytes.V".into(),
                    data: RawData::F32(vec![f32::MIN_POSITIVE / 8.0; n]),
                },
                noise,
            ]
        };
        RawImage {
            width: w,
            height: h,
            channels,
            attributes: vec![("zz.last".into(), "é, Latin-1".into()), ("gbuf.version".into(), "1".into())],
            ..Default::default()
        }
    }

    fn bits(d: &RawData) -> Vec<u32> {
        match d {
            RawData::F16(v) => v.iter().map(|x| u32::from(x.to_bits())).collect(),
            RawData::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
            RawData::U32(v) => v.clone(),
        }
    }

    /// Every channel and attribute reads back bit for bit through the exr crate's reader, with either compression,
    /// compressible or not (a block that does not shrink is stored raw).
    #[test]
    fn round_trips_bit_exact_through_the_exr_crate() {
        let dir = tempfile::tempdir().unwrap();
        for random_only in [false, true] {
            let img = image(random_only);
            for c in [Compression::Zip, Compression::None] {
                let p = dir.path().join(format!("{random_only}-{c:?}.exr"));
                write(&p, &img, c).unwrap();
                let back = read_raw(&p, &ReadLimits::default()).unwrap();
                assert_eq!((back.width, back.height), (img.width, img.height));
                assert_eq!(back.channels.len(), img.channels.len());
                for ch in &img.channels {
                    let b = back.channel(&ch.name).unwrap_or_else(|| panic!("{c:?}: {} missing", ch.name));
                    assert_eq!(bits(&b.data), bits(&ch.data), "{c:?}: {}", ch.name);
                    assert_eq!(std::mem::discriminant(&b.data), std::mem::discriminant(&ch.data));
                }
                let mut attrs = img.attributes.clone();
                attrs.sort();
                assert_eq!(back.attributes, attrs, "{c:?}");
                let expect = if c == Compression::Zip { "ZIP" } else { "NONE" };
                assert!(back.compression.to_uppercase().contains(expect), "{c:?}: {}", back.compression);
            }
        }
    }

    /// ZIP shrinks a compressible image and stores an incompressible one at its raw size (plus the block headers).
    #[test]
    fn zip_shrinks_what_it_can_and_stores_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let size = |img: &RawImage, c| {
            let p = dir.path().join("s.exr");
            write(&p, img, c).unwrap();
            std::fs::metadata(&p).unwrap().len()
        };
        let smooth = RawImage {
            width: 64,
            height: 40,
            channels: vec![RawChannel { name: "Z".into(), data: RawData::F32(vec![2.5; 64 * 40]) }],
            ..Default::default()
        };
        assert!(size(&smooth, Compression::Zip) * 10 < size(&smooth, Compression::None));
        let noise = image(true);
        let (zip, none) = (size(&noise, Compression::Zip), size(&noise, Compression::None));
        // Stored raw: the samples and 3 blocks' headers and offsets, against NONE's 37 one-line blocks.
        assert_eq!(zip + 34 * 16, none, "{zip} vs {none}");
    }

    /// Bad images are refused with the file and the problem named, and nothing is left at the path.
    #[test]
    fn refuses_what_it_cannot_write() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.exr");
        let one = |name: &str, n: usize| RawChannel { name: name.into(), data: RawData::F32(vec![0.0; n]) };
        let cases = [
            (RawImage { width: 0, height: 3, channels: vec![one("Z", 0)], ..Default::default() }, "0×3"),
            (RawImage { width: 2, height: 2, ..Default::default() }, "at least one channel"),
            (RawImage { width: 2, height: 2, channels: vec![one("Z", 3)], ..Default::default() }, "expected 4"),
            (RawImage { width: 1, height: 1, channels: vec![one("Z", 1), one("Z", 1)], ..Default::default() }, "twice"),
            (RawImage { width: 1, height: 1, channels: vec![one("Ω", 1)], ..Default::default() }, "Latin-1"),
            (RawImage { width: 1, height: 1, channels: vec![one("", 1)], ..Default::default() }, "empty"),
            (
                RawImage {
                    width: 1,
                    height: 1,
                    channels: vec![one("Z", 1)],
                    attributes: vec![("compression".into(), "x".into())],
                    ..Default::default()
                },
                "standard",
            ),
        ];
        for (img, want) in cases {
            let e = write(&p, &img, Compression::Zip).unwrap_err().to_string();
            assert!(e.contains("bad.exr") && e.contains(want), "{want}: {e}");
            assert!(!p.exists(), "{want}: a file was left");
        }
    }
}
