//! PNG output through the `png` crate: 8-bit RGB, the crate's fastest DEFLATE (`fdeflate`'s one-pass coder) after
//! the Paeth filter on every row (the crate's adaptive choice per row cost 12% more time on a 720p frame for files
//! 0–3% smaller), an `sRGB` chunk (the pixels are sRGB-encoded: every picture gbuf writes goes through
//! `base::picture`'s transfer function or a colour map) and provenance text chunks (`Software`: gbuf and its
//! version; `Source`: the command line).
//!
//! gbuf had its own encoder here (bands of rows filtered and deflated in parallel); the crate's is faster per
//! thread at the same level and one less thing to maintain (docs/DECISIONS.md, "Writing PNGs").

use crate::error::{Error, Result};

/// Encodes 8-bit RGB pixels (row-major, `width × height × 3` bytes) as a PNG file's bytes, with the crate's
/// fastest DEFLATE. Against zlib level 3 (gbuf's earlier choice) on resolved 1280×720 frames of the ISPC peer
/// (one thread, best of 7, AMD EPYC Zen 4): 3.4 against 36.7 ms for a file 15% larger (the Blender frame), 3.9
/// against 24.3 ms for one 27% larger (the room); at 1920×1080 7.8 against 45.7 ms, 28% larger
/// (docs/DECISIONS.md, "Writing PNGs").
pub fn encode_rgb8(width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    encode_with(width, height, rgb, png::DeflateCompression::FdeflateUltraFast)
}

/// [`encode_rgb8`] with the DEFLATE level given (0: stored, 1–9 zlib levels): smaller files, slower.
pub fn encode(width: u32, height: u32, rgb: &[u8], level: u8) -> Result<Vec<u8>> {
    if level > 9 {
        return Err(Error::Argument(format!("PNG encoding: DEFLATE level {level} is not in 0–9")));
    }
    let compression =
        if level == 0 { png::DeflateCompression::NoCompression } else { png::DeflateCompression::Level(level) };
    encode_with(width, height, rgb, compression)
}

fn encode_with(width: u32, height: u32, rgb: &[u8], compression: png::DeflateCompression) -> Result<Vec<u8>> {
    if width == 0 || height == 0 {
        return Err(Error::Argument(format!("PNG encoding: a {width}×{height} picture cannot be written")));
    }
    let expected = 3 * u128::from(width) * u128::from(height);
    if rgb.len() as u128 != expected {
        return Err(Error::Mismatch(format!(
            "PNG encoding: {} bytes for a {width}×{height} RGB picture ({expected} expected)",
            rgb.len()
        )));
    }
    let fail = |e: png::EncodingError| Error::Internal(format!("PNG encoding: {e}"));
    let mut out = Vec::with_capacity(rgb.len() / 2 + 1024);
    let mut enc = png::Encoder::new(&mut out, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    enc.set_deflate_compression(compression);
    enc.set_filter(png::Filter::Paeth);
    // Provenance: the tool and the command that wrote the picture (PNG's registered `Software` and `Source`
    // keywords), so a figure pasted anywhere still says where it came from.
    // `Source` is an iTXt chunk (UTF-8: paths may hold any character); provenance never fails a picture.
    let _ = enc.add_text_chunk("Software".into(), format!("gbuf {}", env!("CARGO_PKG_VERSION")));
    let command: Vec<String> = std::env::args_os().map(|a| a.to_string_lossy().into_owned()).collect();
    if !command.is_empty() {
        let _ = enc.add_itxt_chunk("Source".into(), command.join(" "));
    }
    let mut writer = enc.write_header().map_err(fail)?;
    writer.write_image_data(rgb).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn pictures_carry_srgb_and_their_provenance() {
        let bytes = encode_rgb8(2, 1, &[0, 10, 20, 30, 40, 50]).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let reader = dec.read_info().unwrap();
        let info = reader.info();
        assert!(info.srgb.is_some(), "an sRGB chunk");
        let text: Vec<(String, String)> =
            info.uncompressed_latin1_text.iter().map(|t| (t.keyword.clone(), t.text.clone())).collect();
        assert!(text.iter().any(|(k, v)| k == "Software" && v.starts_with("gbuf ")), "{text:?}");
        assert!(info.utf8_text.iter().any(|t| t.keyword == "Source"), "a UTF-8 Source chunk");
    }

    /// Decodes with the image crate's PNG reader.
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

    /// Every level round-trips the pixels exactly, and the file says its pixels are sRGB.
    #[test]
    fn every_level_round_trips_and_declares_srgb() {
        let (w, h) = (67, 41);
        let px = picture(w, h, 7);
        for level in [0, 1, 3, 9] {
            let png = encode(w, h, &px, level).unwrap();
            assert_eq!(decode(&png), (w, h, px.clone()), "level {level}");
            assert!(png.windows(4).any(|c| c == b"sRGB"), "an sRGB chunk at level {level}");
        }
        // The default (the fastest coder) too, and it compresses (stored would be 3 B a pixel and more).
        let png = encode_rgb8(w, h, &px).unwrap();
        assert_eq!(decode(&png), (w, h, px.clone()), "default");
        assert!(png.len() < px.len(), "{} bytes for {} of pixels", png.len(), px.len());
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(encode_rgb8(0, 2, &[]).is_err());
        assert!(encode_rgb8(2, 2, &[0; 11]).is_err());
        assert!(encode(2, 2, &[0; 12], 10).is_err());
    }

    proptest! {
        #[test]
        fn random_pictures_round_trip(w in 1u32..40, h in 1u32..40, seed in any::<u32>(), level in 0u8..=9) {
            let px = picture(w, h, seed);
            let png = encode(w, h, &px, level).unwrap();
            prop_assert_eq!(decode(&png), (w, h, px.clone()));
            prop_assert_eq!(decode(&encode_rgb8(w, h, &px).unwrap()), (w, h, px));
        }
    }
}
