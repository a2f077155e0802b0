//! A PNG encoder that filters and deflates bands of rows in parallel: the fixed cost every `gbuf resolve --png`,
//! `demo` and `report` pays per picture, which the image crate's encoder paid on one thread.
//!
//! The picture is cut into bands of about [`BAND_BYTES`] of filtered rows. Each band is filtered row by row (the
//! adaptive choice of the PNG specification's five filters, as libpng's heuristic: the least sum of absolute signed
//! bytes), and deflated on its own as raw DEFLATE ending in a sync flush (the last band in the final block),
//! so the bands joined are one DEFLATE stream (the way pigz compresses in parallel). The zlib header goes in front
//! and the Adler-32 of all the filtered rows, combined from each band's, behind; the stream is cut into IDAT chunks.
//! Each band starts with an empty dictionary, which costs about 1% of the file at [`BAND_BYTES`]. The bytes do not
//! depend on the thread count: the bands are fixed by the picture's size.

use crate::error::{Error, Result};
use rayon::prelude::*;

/// The DEFLATE level. Level 3 against zlib's default 6 (the image crate's `Balanced`, gbuf's encoder before), on a
/// resolved 1280×720 room frame, 2 threads (`cargo bench --bench frame_io`): 7.7 against 19.6 ms, for a file 7.5%
/// larger (0.415 against 0.386 MB); level 1 is 4.8 ms but 76% larger.
pub const LEVEL: u32 = 3;
/// Filtered bytes per band: large enough that the restarted dictionary costs little, small enough that a 720p
/// picture gives each core several bands.
pub const BAND_BYTES: usize = 256 * 1024;
/// The largest IDAT chunk we write.
const IDAT_BYTES: usize = 1 << 20;
const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
/// PNG's largest width or height.
const MAX_SIDE: u32 = (1 << 31) - 1;
const ADLER_MOD: u64 = 65_521;

/// Encodes 8-bit RGB pixels (row-major, `width × height × 3` bytes) as a PNG file's bytes.
pub fn encode_rgb8(width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    encode(width, height, rgb, LEVEL, BAND_BYTES)
}

/// [`encode_rgb8`] with the DEFLATE level (0–9) and the band size given: the bench's and tests' entry point.
pub fn encode(width: u32, height: u32, rgb: &[u8], level: u32, band_bytes: usize) -> Result<Vec<u8>> {
    const CHANNELS: usize = 3;
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(Error::Argument(format!("PNG encoding: a {width}×{height} picture cannot be written")));
    }
    if level > 9 {
        return Err(Error::Argument(format!("PNG encoding: DEFLATE level {level} is not in 0–9")));
    }
    let stride = width as usize * CHANNELS;
    if Some(rgb.len()) != stride.checked_mul(height as usize) {
        return Err(Error::Argument(format!(
            "PNG encoding: {} bytes for a {width}×{height} RGB picture ({} expected)",
            rgb.len(),
            stride as u128 * u128::from(height)
        )));
    }
    let rows_per_band = (band_bytes / (stride + 1)).max(1);
    let starts: Vec<usize> = (0..height as usize).step_by(rows_per_band).collect();
    let bands = starts
        .par_iter()
        .map(|&y0| {
            let y1 = (y0 + rows_per_band).min(height as usize);
            let filtered = filter_rows(rgb, stride, CHANNELS, y0, y1);
            let adler = simd_adler32::adler32(&filtered.as_slice());
            deflate(&filtered, level, y1 == height as usize).map(|bytes| (bytes, adler, filtered.len()))
        })
        .collect::<Result<Vec<_>>>()?;

    let mut zlib = Vec::with_capacity(2 + bands.iter().map(|b| b.0.len()).sum::<usize>() + 4);
    zlib.extend_from_slice(&zlib_header(level));
    let mut adler = 1;
    for (bytes, band_adler, len) in &bands {
        zlib.extend_from_slice(bytes);
        adler = adler32_combine(adler, *band_adler, *len);
    }
    zlib.extend_from_slice(&adler.to_be_bytes());

    let mut out = Vec::with_capacity(zlib.len() + 64 + 12 * zlib.len().div_ceil(IDAT_BYTES));
    out.extend_from_slice(&SIGNATURE);
    let mut ihdr = [0u8; 13];
    ihdr[..4].copy_from_slice(&width.to_be_bytes());
    ihdr[4..8].copy_from_slice(&height.to_be_bytes());
    ihdr[8] = 8; // bit depth
    ihdr[9] = 2; // colour type: RGB; compression, filter and interlace methods 0
    chunk(&mut out, b"IHDR", &ihdr);
    for part in zlib.chunks(IDAT_BYTES) {
        chunk(&mut out, b"IDAT", part);
    }
    chunk(&mut out, b"IEND", &[]);
    Ok(out)
}

/// Rows `y0..y1`, each as its filter type byte and the filtered bytes, the filter chosen per row.
fn filter_rows(px: &[u8], stride: usize, bpp: usize, y0: usize, y1: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity((y1 - y0) * (stride + 1));
    let zeros = vec![0u8; stride];
    let mut tries: [Vec<u8>; 5] = std::array::from_fn(|_| vec![0u8; stride]);
    for y in y0..y1 {
        let row = &px[y * stride..][..stride];
        let prev = if y == 0 { &zeros[..] } else { &px[(y - 1) * stride..][..stride] };
        for (kind, t) in tries.iter_mut().enumerate() {
            apply_filter(kind, row, prev, bpp, t);
        }
        let cost = |t: &[u8]| t.iter().map(|&b| u64::from((b as i8).unsigned_abs())).sum::<u64>();
        let best = (0..5).min_by_key(|&k| (cost(&tries[k]), k)).unwrap_or(0);
        out.push(best as u8);
        out.extend_from_slice(&tries[best]);
    }
    out
}

/// PNG filter `kind` (0 None, 1 Sub, 2 Up, 3 Average, 4 Paeth) of `row` above `prev`, `bpp` bytes per pixel.
fn apply_filter(kind: usize, row: &[u8], prev: &[u8], bpp: usize, out: &mut [u8]) {
    let n = row.len();
    match kind {
        0 => out.copy_from_slice(row),
        1 => {
            out[..bpp].copy_from_slice(&row[..bpp]);
            for i in bpp..n {
                out[i] = row[i].wrapping_sub(row[i - bpp]);
            }
        }
        2 => {
            for ((o, &x), &b) in out.iter_mut().zip(row).zip(prev) {
                *o = x.wrapping_sub(b);
            }
        }
        3 => {
            for i in 0..bpp {
                out[i] = row[i].wrapping_sub(prev[i] >> 1);
            }
            for i in bpp..n {
                let avg = ((u16::from(row[i - bpp]) + u16::from(prev[i])) >> 1) as u8;
                out[i] = row[i].wrapping_sub(avg);
            }
        }
        _ => {
            for i in 0..bpp {
                out[i] = row[i].wrapping_sub(prev[i]); // Paeth with a = c = 0 predicts b
            }
            for i in bpp..n {
                out[i] = row[i].wrapping_sub(paeth(row[i - bpp], prev[i], prev[i - bpp]));
            }
        }
    }
}

/// The Paeth predictor of the PNG specification: of left `a`, above `b` and upper left `c`, the one nearest
/// `a + b − c`, ties to `a`, then `b`.
fn paeth(a: u8, b: u8, c: u8) -> u8 {
    let (ia, ib, ic) = (i16::from(a), i16::from(b), i16::from(c));
    let p = ia + ib - ic;
    let (pa, pb, pc) = ((p - ia).abs(), (p - ib).abs(), (p - ic).abs());
    if pa <= pb && pa <= pc {
        a
    } else if pb <= pc {
        b
    } else {
        c
    }
}

/// Raw DEFLATE of `input`: ending in a sync flush (byte-aligned, no final block) unless it is the `last` band.
fn deflate(input: &[u8], level: u32, last: bool) -> Result<Vec<u8>> {
    use flate2::{Compress, Compression, FlushCompress, Status};
    let mut c = Compress::new(Compression::new(level), false);
    let flush = if last { FlushCompress::Finish } else { FlushCompress::Sync };
    let mut out = Vec::with_capacity(input.len() / 2 + 4096);
    loop {
        let consumed = usize::try_from(c.total_in()).unwrap_or(input.len()).min(input.len());
        let status = c
            .compress_vec(&input[consumed..], &mut out, flush)
            .map_err(|e| Error::Argument(format!("PNG encoding: DEFLATE failed: {e}")))?;
        let all_in = c.total_in() == input.len() as u64;
        // A flush is complete when the compressor stops with output space left (zlib's contract).
        let done = match status {
            Status::StreamEnd => true,
            Status::Ok | Status::BufError => !last && all_in && out.len() < out.capacity(),
        };
        if done {
            return Ok(out);
        }
        out.reserve(out.capacity().max(4096));
    }
}

/// The two zlib header bytes: DEFLATE with a 32 KiB window, the level class, and the check bits.
fn zlib_header(level: u32) -> [u8; 2] {
    let cmf: u16 = 0x78;
    let flevel: u16 = match level {
        0..=1 => 0,
        2..=5 => 1,
        6 => 2,
        _ => 3,
    };
    let flg = flevel << 6;
    let flg = flg + (31 - (cmf * 256 + flg) % 31) % 31;
    [cmf as u8, flg as u8]
}

/// The Adler-32 of `A ‖ B` from `adler(A)`, `adler(B)` and `B`'s length (zlib's `adler32_combine`):
/// `s1 = s1A + s1B − 1`, `s2 = s2A + s2B + len(B)·(s1A − 1)`, both mod 65521.
fn adler32_combine(a: u32, b: u32, len_b: usize) -> u32 {
    let m = ADLER_MOD;
    let rem = len_b as u64 % m;
    let (s1a, s2a) = (u64::from(a & 0xffff), u64::from(a >> 16));
    let (s1b, s2b) = (u64::from(b & 0xffff), u64::from(b >> 16));
    let s1 = (s1a + s1b + m - 1) % m;
    let s2 = (s2a + s2b + rem * ((s1a + m - 1) % m)) % m;
    ((s2 << 16) | s1) as u32
}

/// One PNG chunk: length, type, data, and the CRC-32 of type and data.
fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    let mut crc = crc32fast::Hasher::new();
    crc.update(kind);
    crc.update(data);
    out.extend_from_slice(&crc.finalize().to_be_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Decodes with the image crate's PNG reader (the `png` crate): an independent decoder.
    fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
        let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png).unwrap().to_rgb8();
        (img.width(), img.height(), img.into_raw())
    }

    /// A picture with smooth gradients, edges and noise, so every filter wins somewhere.
    fn picture(w: u32, h: u32, seed: u32) -> Vec<u8> {
        let mut s = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        let mut noise = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        let mut v = Vec::with_capacity((w * h * 3) as usize);
        for y in 0..h {
            for x in 0..w {
                let edge = if (x / 7 + y / 5) % 3 == 0 { 90 } else { 0 };
                let n = (noise() % 5) as u8;
                v.extend([
                    (x * 3) as u8 ^ edge,
                    ((y * 2) as u8).wrapping_add(n),
                    ((x + y) as u8).wrapping_mul(5).wrapping_add(edge),
                ]);
            }
        }
        v
    }

    #[test]
    fn adler32_combine_is_the_adler_of_the_concatenation() {
        let data = picture(61, 37, 3);
        let whole = simd_adler32::adler32(&data.as_slice());
        for cut in [0, 1, 2, 999, 5552, 5553, data.len() - 1, data.len()] {
            let (a, b) = data.split_at(cut);
            let joined = adler32_combine(simd_adler32::adler32(&a), simd_adler32::adler32(&b), b.len());
            assert_eq!(joined, whole, "cut at {cut}");
        }
    }

    #[test]
    fn zlib_header_checks() {
        for level in 0..=9 {
            let [cmf, flg] = zlib_header(level);
            assert_eq!((u16::from(cmf) * 256 + u16::from(flg)) % 31, 0, "level {level}");
            assert_eq!(flg & 0x20, 0, "no preset dictionary");
        }
    }

    #[test]
    fn paeth_matches_the_specification_tie_order() {
        assert_eq!(paeth(10, 10, 10), 10);
        assert_eq!(paeth(1, 200, 1), 200); // p = 200: b exact
        assert_eq!(paeth(200, 1, 1), 200); // p = 200: a exact
        assert_eq!(paeth(50, 60, 100), 50); // p = 10: pa 40, pb 50, pc 90
        assert_eq!(paeth(100, 50, 75), 75); // p = 75: pa 25, pb 25, pc 0 → c
    }

    #[test]
    fn many_bands_and_one_round_trip_exactly() {
        for (w, h) in [(1, 1), (1, 9), (9, 1), (33, 17), (128, 77)] {
            let px = picture(w, h, w + h);
            for band_bytes in [1, 50, 4096, BAND_BYTES] {
                for level in [0, 1, 6, 9] {
                    let png = encode(w, h, &px, level, band_bytes).unwrap();
                    assert_eq!(decode(&png), (w, h, px.clone()), "{w}×{h}, bands of {band_bytes} B, level {level}");
                }
            }
        }
    }

    /// The concatenated IDAT data, after checking each chunk's CRC (the `png` crate's reader skips the zlib
    /// checksum, so the stream is also inflated here by zlib's own reader, which checks it).
    fn zlib_stream(png: &[u8]) -> Vec<u8> {
        assert_eq!(png[..8], SIGNATURE);
        let (mut at, mut idat) = (8, Vec::new());
        while at < png.len() {
            let len = u32::from_be_bytes(png[at..at + 4].try_into().unwrap()) as usize;
            let (kind, data) = (&png[at + 4..at + 8], &png[at + 8..at + 8 + len]);
            let crc = u32::from_be_bytes(png[at + 8 + len..at + 12 + len].try_into().unwrap());
            assert_eq!(crc, crc32fast::hash(&png[at + 4..at + 8 + len]), "CRC of {}", String::from_utf8_lossy(kind));
            if kind == b"IDAT" {
                idat.extend_from_slice(data);
            }
            at += 12 + len;
        }
        idat
    }

    #[test]
    fn the_zlib_stream_and_its_checksum_are_valid() {
        use std::io::Read;
        let (w, h) = (97, 131);
        let px = picture(w, h, 5);
        for band_bytes in [100, 3000, BAND_BYTES] {
            let png = encode(w, h, &px, LEVEL, band_bytes).unwrap();
            let mut inflated = Vec::new();
            flate2::read::ZlibDecoder::new(zlib_stream(&png).as_slice()).read_to_end(&mut inflated).unwrap();
            assert_eq!(inflated.len(), (h * (w * 3 + 1)) as usize);
            // Every row's filter type is one of the five, and unfiltering is what the decode above checks.
            assert!(inflated.chunks(w as usize * 3 + 1).all(|r| r[0] <= 4));
            // A wrong checksum is caught by that reader: flip the Adler-32's last byte.
            let mut bad = zlib_stream(&png);
            *bad.last_mut().unwrap() ^= 1;
            assert!(flate2::read::ZlibDecoder::new(bad.as_slice()).read_to_end(&mut Vec::new()).is_err());
        }
    }

    #[test]
    fn idat_is_split_into_chunks_and_still_decodes() {
        // Incompressible noise at level 0: the stream is larger than one IDAT chunk.
        let (w, h) = (700, 600);
        let mut s = 12_345u32;
        let px: Vec<u8> = (0..w * h * 3)
            .map(|_| {
                s = s.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (s >> 16) as u8
            })
            .collect();
        let png = encode(w, h, &px, 0, BAND_BYTES).unwrap();
        let idats = png.windows(4).filter(|k| k == b"IDAT").count();
        assert!(idats >= 2, "{idats} IDAT chunks for {} bytes", png.len());
        assert_eq!(decode(&png), (w, h, px));
    }

    #[test]
    fn bytes_do_not_depend_on_the_thread_count() {
        let (w, h) = (300, 200);
        let px = picture(w, h, 7);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| encode(w, h, &px, LEVEL, 8192).unwrap())
        };
        let one = run(1);
        assert_eq!(one, run(3));
        assert!(
            one.len() < px.len() / 2,
            "{} bytes for {} of pixels: filters or DEFLATE not working",
            one.len(),
            px.len()
        );
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(encode_rgb8(0, 4, &[]).is_err());
        assert!(encode_rgb8(4, 0, &[]).is_err());
        assert!(encode_rgb8(2, 2, &[0; 11]).is_err());
        assert!(encode_rgb8(2, 2, &[0; 13]).is_err());
        assert!(encode(2, 2, &[0; 12], 10, BAND_BYTES).is_err());
        assert!(encode_rgb8(u32::MAX, 1, &[]).is_err());
    }

    proptest! {
        #[test]
        fn random_pictures_round_trip(w in 1u32..40, h in 1u32..40, seed in any::<u32>(), band in 1usize..600,
                                      level in 0u32..=9) {
            let px = picture(w, h, seed);
            let png = encode(w, h, &px, level, band).unwrap();
            prop_assert_eq!(decode(&png), (w, h, px));
        }
    }
}
