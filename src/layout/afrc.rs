//! Arm Fixed Rate Compression (AFRC) as a layout choice: a render target stored **lossily** at a fixed `k` bits per
//! component, so its error goes through the lighting like any codec's and a user can weigh "RGBA8 at 3 bpc" against a
//! narrower layout on the same footing.
//!
//! **Published constraints, modelled** (Khronos `VK_EXT_image_compression_control`; Linux `drm_fourcc.h`'s AFRC
//! modifiers; Mesa's panfrost `pan_afrc.h`; Arm's `image_compression_control` Vulkan sample):
//! - formats: 8-bit UNORM with 1, 2 or 4 components (`r8`, `rg8`, `rgba8`, `rgba8-srgb`); not float, not 16-bit,
//!   not mixed widths such as RGB10A2, not depth;
//! - rates: 2, 3 or 4 bits per component, every coding unit stored in 16, 24 or 32 bytes (64 components × `k` bits);
//! - coding units: 4 × 4 pixels for 4 components, 8 × 4 for 2, 16 × 4 for 1, each coded independently at its fixed
//!   size, so memory and traffic shrink by `k / 8` whatever the content;
//! - not for multisampled images (nor storage images): packing an MSAA frame into an AFRC target is an error.
//!
//! **The coder is a model, not Arm's** (AFRC's is proprietary and unpublished): per unit and component, the unit's
//! smallest and largest code (8 bits each) and, per texel, an index of `k − 1` bits onto the evenly spaced levels
//! between them (`(64 k − 16 c) / 64` bits per index, rounded down, for `c` components: `k − 1` for every shape
//! above). A plain endpoint-and-index coder is likely worse than Arm's on smooth content (Arm quotes 49.85 dB PSNR at
//! 2 bpc on a photograph), so errors here lean pessimistic. A unit whose range fits the levels is stored exactly.

use super::formats::Format;

/// The rates AFRC offers for 8-bit formats, in bits per component.
pub const RATES: [u32; 3] = [2, 3, 4];

/// Whether AFRC can hold a target of `format` (8-bit UNORM, 1, 2 or 4 components).
#[must_use]
pub fn eligible(format: Format) -> bool {
    matches!(format, Format::R8 | Format::Rg8 | Format::Rgba8 | Format::Rgba8Srgb)
}

/// The coding unit of a format with `components` components, in pixels: 64 components per unit.
#[must_use]
pub fn unit(components: usize) -> (u32, u32) {
    match components {
        1 => (16, 4),
        2 => (8, 4),
        _ => (4, 4),
    }
}

/// Stored bits per texel of `format` at `rate` bits per component.
#[must_use]
pub fn bits_per_texel(format: Format, rate: u32) -> u32 {
    format.components().len() as u32 * rate
}

/// Codes `bytes` (a single-sampled `width × height` target of `format`, texels little-endian) at `rate` bits per
/// component and writes back what the GPU would read: each coding unit's components on `2^(rate − 1)` levels between
/// its smallest and largest code.
pub fn roundtrip(bytes: &mut [u8], format: Format, width: u32, height: u32, rate: u32) {
    use rayon::prelude::*;
    let c = format.bytes();
    debug_assert!(eligible(format) && RATES.contains(&rate));
    debug_assert_eq!(bytes.len(), width as usize * height as usize * c);
    let (uw, uh) = unit(c);
    let levels = (1u32 << (rate - 1)) - 1; // the largest index
    let row = width as usize * c;
    bytes.par_chunks_mut(row * uh as usize).for_each(|band| {
        let rows = band.len() / row;
        for x0 in (0..width as usize).step_by(uw as usize) {
            let x1 = (x0 + uw as usize).min(width as usize);
            for k in 0..c {
                let at = |y: usize, x: usize| y * row + x * c + k;
                let (mut lo, mut hi) = (u8::MAX, 0u8);
                for y in 0..rows {
                    for x in x0..x1 {
                        lo = lo.min(band[at(y, x)]);
                        hi = hi.max(band[at(y, x)]);
                    }
                }
                let span = u32::from(hi - lo);
                if span <= levels {
                    continue; // every code is a level: stored exactly
                }
                for y in 0..rows {
                    for x in x0..x1 {
                        let v = &mut band[at(y, x)];
                        let i = (u32::from(*v - lo) * levels * 2 + span) / (2 * span); // round to nearest
                        *v = lo + ((i * span * 2 + levels) / (2 * levels)) as u8;
                    }
                }
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn units_hold_64_components_and_rates_set_the_bytes() {
        for f in [Format::R8, Format::Rg8, Format::Rgba8] {
            let n = f.components().len();
            let (w, h) = unit(n);
            assert_eq!(w as usize * h as usize * n, 64, "{f}");
            for r in RATES {
                // 16, 24 or 32 bytes per unit.
                assert_eq!(64 * r / 8, [16, 24, 32][(r - 2) as usize]);
                assert_eq!(bits_per_texel(f, r) * w * h, 64 * r);
            }
        }
        assert!(!eligible(Format::Rgba16F) && !eligible(Format::Rgb10A2) && !eligible(Format::Rgba8Snorm));
    }

    #[test]
    fn a_unit_within_its_levels_is_exact_and_a_two_value_unit_is_exact_at_every_rate() {
        // RGBA8, 8 × 4 pixels = two units; the first holds two values per component, the second 0..=3 (4 levels).
        let (w, h) = (8u32, 4u32);
        let mut bytes = vec![0u8; (w * h * 4) as usize];
        for y in 0..h {
            for x in 0..w {
                let i = ((y * w + x) * 4) as usize;
                let v = if x < 4 {
                    if (x + y) % 2 == 0 {
                        17
                    } else {
                        230
                    }
                } else {
                    ((x + y) % 4) as u8
                };
                bytes[i..i + 4].copy_from_slice(&[v, v, 255 - v, 9]);
            }
        }
        let want = bytes.clone();
        roundtrip(&mut bytes, Format::Rgba8, w, h, 3);
        assert_eq!(bytes, want, "two values per unit, or a range within 4 levels, are levels themselves");
        // At 2 bpc (one index bit), the 0..=3 unit keeps only its ends.
        roundtrip(&mut bytes, Format::Rgba8, w, h, 2);
        assert!(bytes.iter().zip(&want).all(|(a, b)| a == b || (*b == 1 || *b == 2 || *b == 253 || *b == 254)));
        assert_ne!(bytes, want);
    }

    #[test]
    fn a_layout_at_afrc_stores_its_eight_bit_targets_lossily_and_refuses_msaa() {
        use crate::layout::Layout;
        use crate::scene::{render, SceneName};
        let gb = render(SceneName::Room, 32, 16, 1).unwrap();
        let base = Layout::by_name("fat-20").unwrap();
        let l = Layout::by_name("fat-20@afrc2").unwrap();
        assert_eq!(l.name(), "fat-20@afrc2");
        // d24s8 (4 B) and four rgba8 targets at 2 bits per component (1 B each).
        assert_eq!((l.bytes_per_sample(), l.stored_bytes_per_sample()), (20, 8.0));
        assert_eq!(l.footprint_bytes(32, 16, 1), 32 * 16 * 8);
        // Each AFRC target is the plain packing coded at the rate; the others are untouched.
        let (plain, fixed) = (base.pack(&gb).unwrap(), l.pack(&gb).unwrap());
        let mut changed = false;
        for (t, (a, b)) in l.spec().targets.iter().zip(plain.targets.iter().zip(&fixed.targets)) {
            let mut want = a.bytes.clone();
            if t.afrc.is_some() {
                roundtrip(&mut want, a.format, 32, 16, 2);
                changed |= want != a.bytes;
            }
            assert_eq!(b.bytes, want, "{}", t.name);
        }
        assert!(changed, "2 bits per component loses something on the room");
        // The band-by-band roundtrip (what the report lights) decodes the same bytes as the whole-frame pack.
        let whole = l.unpack(&fixed, &gb).unwrap();
        let banded = l.roundtrip(&gb).unwrap();
        assert_eq!(whole.normal, banded.normal);
        assert_eq!(whole.albedo, banded.albedo);
        let msaa = render(SceneName::Room, 32, 16, 4).unwrap();
        let e = l.pack(&msaa).unwrap_err().to_string();
        assert!(e.contains("multisampled") && e.contains("4 samples"), "{e}");
        assert!(Layout::by_name("fat-20@afrc5").is_none() && Layout::by_name("lauritzen-15@afrc2").is_none());
    }

    proptest! {
        /// Every decoded code lies within its unit's range, at most half a level step from the input, and coding the
        /// decoded target again changes nothing (the levels are fixed points).
        #[test]
        fn error_is_within_half_a_level_and_decoding_is_idempotent(
            codes in proptest::collection::vec(any::<u8>(), 12 * 8 * 4),
            rate in 2u32..=4,
        ) {
            let (w, h) = (12u32, 8u32);
            let mut bytes = codes.clone();
            roundtrip(&mut bytes, Format::Rgba8, w, h, rate);
            let levels = f64::from((1u32 << (rate - 1)) - 1);
            for (y, x) in (0..h).flat_map(|y| (0..w).map(move |x| (y, x))) {
                let (ux, uy) = (x / 4 * 4, y / 4 * 4);
                for k in 0..4 {
                    let unit: Vec<u8> = (uy..uy + 4)
                        .flat_map(|yy| (ux..(ux + 4).min(w)).map(move |xx| (yy, xx)))
                        .map(|(yy, xx)| codes[((yy * w + xx) * 4 + k) as usize])
                        .collect();
                    let (lo, hi) = (*unit.iter().min().unwrap(), *unit.iter().max().unwrap());
                    let i = ((y * w + x) * 4 + k) as usize;
                    let step = f64::from(hi - lo) / levels;
                    prop_assert!(bytes[i] >= lo && bytes[i] <= hi);
                    prop_assert!((f64::from(bytes[i]) - f64::from(codes[i])).abs() <= step / 2.0 + 0.5 + 1e-9);
                }
            }
            let once = bytes.clone();
            roundtrip(&mut bytes, Format::Rgba8, w, h, rate);
            prop_assert_eq!(bytes, once);
        }
    }
}
