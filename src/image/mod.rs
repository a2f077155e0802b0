//! A linear HDR RGB image: what the resolve produces and what the measures compare; and its writers.
//!
//! - [`HdrImage::write_exr`]: lossless float EXR (channels `R`, `G`, `B`, f32), through [`crate::io::exr`].
//! - [`HdrImage::write_png`]: 8-bit sRGB PNG with a stated tone map ([`ToneMap`]).
//! - [`HdrImage::to_ldr_gamma22`]: the ISPC `deferred` sample's own output — clamp to [0, 1], `^(1/2.2)`, × 255,
//!   truncate — so results compare byte for byte with that sample.
//!
//! Pixels become PNG files through [`crate::base::picture`] (one sRGB, one PNG writer for the whole crate).
//!
//! Every writer is atomic (temporary file + rename).
//!
//! [`mlaa`]: morphological antialiasing (Reshetov 2009), the post-process alternative to MSAA.

pub mod file;
pub mod mlaa;

use crate::base::files::write_bytes_atomic;
use crate::base::lut::CodeLut;
use crate::base::picture::srgb_encode;
use crate::error::{Error, Result};
use crate::io::exr::{write_raw, RawChannel, RawData, RawImage};
use glam::Vec3;
use std::path::Path;

/// Linear RGB, row-major, row 0 at the top.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HdrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` linear RGB values.
    pub rgb: Vec<Vec3>,
}

/// How HDR values become [0, 1] before sRGB encoding in [`HdrImage::write_png`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToneMap {
    /// `clamp(exposure · x, 0, 1)` per channel.
    Clamp {
        /// Scale applied first.
        exposure: f32,
    },
    /// Reinhard per channel: `y = e·x / (1 + e·x)` with `e` the exposure (never saturates, keeps hue roughly).
    Reinhard {
        /// Scale applied first.
        exposure: f32,
    },
}

crate::named_enum! {
    /// The curve of a [`ToneMap`], without its exposure (what `--tonemap` names).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum ToneCurve: "tone map" {
        /// Reinhard per channel (the default).
        Reinhard => "reinhard",
        /// Clamp per channel.
        Clamp => "clamp",
    }
}

crate::named_enum! {
    /// An 8-bit encoding other than tone map + sRGB (what `--ldr` names).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum LdrEncoding: "LDR encoding" {
        /// The ISPC `deferred` sample's own: clamp, `^(1/2.2)`, × 255, truncate ([`HdrImage::to_ldr_gamma22`]).
        Gamma22 => "gamma2.2",
    }
}

impl ToneMap {
    /// The tone map of `curve` with `exposure`.
    #[must_use]
    pub fn new(curve: ToneCurve, exposure: f32) -> Self {
        match curve {
            ToneCurve::Reinhard => ToneMap::Reinhard { exposure },
            ToneCurve::Clamp => ToneMap::Clamp { exposure },
        }
    }
}

impl Default for ToneMap {
    /// Reinhard with exposure 1.
    fn default() -> Self {
        ToneMap::Reinhard { exposure: 1.0 }
    }
}

impl ToneMap {
    /// Maps one linear value to [0, 1] (NaN → 0).
    #[must_use]
    pub fn apply(self, x: f32) -> f32 {
        let y = match self {
            ToneMap::Clamp { exposure } => exposure * x,
            ToneMap::Reinhard { exposure } => {
                let v = (exposure * x).max(0.0);
                if v.is_infinite() {
                    1.0
                } else {
                    v / (1.0 + v)
                }
            }
        };
        if y.is_nan() {
            0.0
        } else {
            y.clamp(0.0, 1.0)
        }
    }
}

impl HdrImage {
    /// A black image.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        HdrImage { width, height, rgb: crate::base::memory::zeroed_vec3(width as usize * height as usize) }
    }

    /// The rectangle `(x0, y0, width, height)` of this image, which must hold it, as an image of its own.
    #[must_use]
    pub fn crop(&self, (x0, y0, cw, ch): (u32, u32, u32, u32)) -> HdrImage {
        let mut out = HdrImage::new(cw, ch);
        for y in 0..ch {
            let row = ((y0 + y) * self.width + x0) as usize;
            out.rgb[(y * cw) as usize..((y + 1) * cw) as usize].copy_from_slice(&self.rgb[row..row + cw as usize]);
        }
        out
    }

    /// 8-bit sRGB bytes (RGB, row-major) after `tone`, rounded to nearest.
    #[must_use]
    pub fn to_srgb8(&self, tone: ToneMap) -> Vec<u8> {
        // The tone map's output is in [0, 1] (NaN → 0): the table gives `srgb8_shown`'s code without a `powf`.
        let lut = srgb8_shown_table();
        self.encode_rgb8(|x| lut.encode_unit(tone.apply(x)))
    }

    /// Interleaved RGB bytes, `enc` applied to every channel, rows in parallel.
    fn encode_rgb8(&self, enc: impl Fn(f32) -> u8 + Sync) -> Vec<u8> {
        use rayon::prelude::*;
        let mut out = vec![0u8; 3 * self.rgb.len()];
        let row = self.width.max(1) as usize;
        out.par_chunks_mut(3 * row).zip(self.rgb.par_chunks(row)).for_each(|(o, px)| {
            for (o, c) in o.chunks_exact_mut(3).zip(px) {
                o.copy_from_slice(&[enc(c.x), enc(c.y), enc(c.z)]);
            }
        });
        out
    }

    /// The ISPC `deferred` sample's 8-bit output: `(u8)(pow(clamp(x, 0, 1), 1/2.2) · 255)` per channel (truncation,
    /// not rounding, exactly as its `Float32ToUnorm8`). NaN becomes 0.
    #[must_use]
    pub fn to_ldr_gamma22(&self) -> Vec<u8> {
        // Rows in parallel: a fixed cost of every `gbuf resolve --png`.
        use rayon::prelude::*;
        let lut = Gamma22Lut::get();
        let mut out = crate::base::memory::zeroed_on_huge_pages(3 * self.rgb.len());
        // The pixels' channels in memory order are the bytes' order.
        let channels: &[f32] = bytemuck::cast_slice(&self.rgb);
        let band = 3 * 16 * self.width.max(1) as usize;
        out.par_chunks_mut(band).zip(channels.par_chunks(band)).for_each(|(o, c)| lut.0.encode_clamped(c, o));
        out
    }

    /// A tone-mapped sRGB PNG ([`HdrImage::to_srgb8`]), encoded in memory.
    pub fn png(&self, tone: ToneMap) -> Result<Vec<u8>> {
        crate::base::png::encode_rgb8(self.width, self.height, &self.to_srgb8(tone))
    }

    /// The demo's gamma-2.2 LDR output ([`HdrImage::to_ldr_gamma22`]) as a PNG, encoded in memory.
    pub fn ldr_gamma22_png(&self) -> Result<Vec<u8>> {
        crate::base::png::encode_rgb8(self.width, self.height, &self.to_ldr_gamma22())
    }

    /// Writes a tone-mapped sRGB PNG ([`HdrImage::png`]), atomically.
    pub fn write_png(&self, path: &Path, tone: ToneMap) -> Result<()> {
        write_bytes_atomic(path, &self.png(tone).map_err(|e| Error::invalid(path, e.to_string()))?)
    }

    /// Writes the demo's gamma-2.2 LDR output ([`HdrImage::ldr_gamma22_png`]) as a PNG, atomically.
    pub fn write_ldr_gamma22_png(&self, path: &Path) -> Result<()> {
        write_bytes_atomic(path, &self.ldr_gamma22_png().map_err(|e| Error::invalid(path, e.to_string()))?)
    }

    /// Writes a lossless EXR with f32 channels `R`, `G`, `B`.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        write_raw(path, &self.raw(path)?)
    }

    /// The file [`HdrImage::write_exr`] writes, as bytes (`name` names it in errors): for outputs staged until all
    /// of a command's are ready.
    pub fn exr_bytes(&self, name: &Path) -> Result<Vec<u8>> {
        crate::io::exr::raw_to_bytes(name, &self.raw(name)?)
    }

    /// The image as EXR channels `R`, `G`, `B` (f32).
    fn raw(&self, path: &Path) -> Result<RawImage> {
        if self.width == 0 || self.height == 0 {
            return Err(Error::Argument(format!("{}: cannot write an empty image", path.display())));
        }
        let chan = |name: &str, k: usize| RawChannel {
            name: name.into(),
            data: RawData::F32(self.rgb.iter().map(|c| c[k]).collect()),
        };
        Ok(RawImage {
            width: self.width,
            height: self.height,
            channels: vec![chan("R", 0), chan("G", 1), chan("B", 2)],
            ..Default::default()
        })
    }
}

/// [`HdrImage::to_ldr_gamma22`]'s encode without a `powf` per channel: a `CodeLut` (`base::lut`) of the ISPC sample's
/// `(x^(1/2.2) · 255) as u8` (the test sweeps every threshold's neighbourhood and a dense grid of [0, 1]).
pub struct Gamma22Lut(CodeLut);

impl Gamma22Lut {
    /// The formula the table reproduces (the ISPC sample's `Float32ToUnorm8` of `pow(x, 1/2.2)`).
    #[must_use]
    pub fn formula(x: f32) -> u8 {
        let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        (x.powf(1.0 / 2.2) * 255.0) as u8
    }

    /// The table, built once per process.
    pub fn get() -> &'static Gamma22Lut {
        static LUT: std::sync::OnceLock<Gamma22Lut> = std::sync::OnceLock::new();
        LUT.get_or_init(|| Gamma22Lut(CodeLut::build(Self::formula)))
    }

    /// The 8-bit code of linear `x` (NaN → 0, clamped to [0, 1]).
    #[inline]
    #[must_use]
    pub fn encode(&self, x: f32) -> u8 {
        self.0.encode_unit(if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) })
    }
}

/// [`HdrImage::to_srgb8`]'s code of a tone-mapped channel `y` in [0, 1]: `srgb_encode(y) · 255`, rounded half up.
fn srgb8_shown(y: f32) -> u8 {
    (srgb_encode(y) * 255.0 + 0.5) as u8
}

/// [`srgb8_shown`] by its thresholds (`base::lut`), built once per process: the displayed copy of every image
/// LDR-FLIP compares and every A/B view paid a `powf` per channel.
fn srgb8_shown_table() -> &'static CodeLut {
    static LUT: std::sync::OnceLock<CodeLut> = std::sync::OnceLock::new();
    LUT.get_or_init(|| CodeLut::build(srgb8_shown))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The displayed copy's table gives the formula's code: every threshold and 64 bit patterns either side, every
    /// 97th bit pattern of [0, 1]; and `to_srgb8` equals the formula on an image with out-of-range, negative and
    /// non-finite channels under both tone curves.
    #[test]
    fn shown_table_equals_the_formula() {
        let lut = srgb8_shown_table();
        let clean = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        let diff = lut.first_difference(|x| lut.encode_unit(clean(x)), |x| srgb8_shown(clean(x)), 64, 97);
        assert_eq!(diff, None, "the table and the formula differ at {diff:?}");
        let xs: Vec<f32> = (0..=u32::MAX).step_by(65_537).map(f32::from_bits).collect();
        let specials = [0.0, -0.0, 1.0, 1e30, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE];
        let all: Vec<f32> = xs.iter().copied().chain(specials).collect();
        let mut img = HdrImage::new(all.len().div_ceil(3) as u32, 1);
        for (p, c) in img.rgb.iter_mut().zip(all.chunks(3)) {
            *p = Vec3::new(c[0], c.get(1).copied().unwrap_or(0.5), c.get(2).copied().unwrap_or(2.0));
        }
        for tone in [ToneMap::Reinhard { exposure: 1.7 }, ToneMap::Clamp { exposure: 0.3 }] {
            let got = img.to_srgb8(tone);
            let want: Vec<u8> = img.rgb.iter().flat_map(|p| p.to_array()).map(|x| srgb8_shown(tone.apply(x))).collect();
            assert_eq!(got, want, "{tone:?}");
        }
    }

    #[test]
    fn gamma22_table_equals_the_formula() {
        let lut = Gamma22Lut::get();
        // Every threshold and 64 bit patterns either side, every 97th bit pattern of [0, 1] (about 11 M values),
        // the ends and out-of-range input.
        let diff = lut.0.first_difference(|x| lut.encode(x), Gamma22Lut::formula, 64, 97);
        assert_eq!(diff, None, "the table and the formula differ at {diff:?}");
        // The slice encoder (the 8-bit picture's) is the same function: every 4099th bit pattern of all f32,
        // the ends and the special values.
        let mut xs: Vec<f32> = (0..=u32::MAX).step_by(4099).map(f32::from_bits).collect();
        xs.extend([0.0, -0.0, 1.0, f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE, 2.0]);
        let mut codes = vec![0u8; xs.len()];
        lut.0.encode_clamped(&xs, &mut codes);
        for (&x, &c) in xs.iter().zip(&codes) {
            assert_eq!(c, Gamma22Lut::formula(x), "{x:e} ({:#x})", x.to_bits());
        }
    }
    use crate::io::exr::{read_raw, ReadLimits};

    #[test]
    fn ldr_gamma22_truncates_like_the_demo() {
        let mut img = HdrImage::new(2, 1);
        img.rgb = vec![Vec3::new(0.5, 2.0, -1.0), Vec3::new(f32::NAN, 1.0, 0.001)];
        let b = img.to_ldr_gamma22();
        let want = |x: f32| (x.powf(1.0 / 2.2) * 255.0) as u8;
        assert_eq!(b, vec![want(0.5), 255, 0, 0, 255, want(0.001)]);
        assert_eq!(want(0.5), 186); // 0.7297 · 255 = 186.08, truncated
    }

    #[test]
    fn tone_maps_are_bounded_and_monotonic() {
        for tone in [ToneMap::default(), ToneMap::Clamp { exposure: 2.0 }] {
            let mut last = -1.0;
            for x in [0.0, 0.01, 0.5, 1.0, 10.0, 1e30, f32::INFINITY] {
                let y = tone.apply(x);
                assert!((0.0..=1.0).contains(&y) && y >= last, "{tone:?}({x}) = {y}");
                last = y;
            }
            assert_eq!(tone.apply(f32::NAN), 0.0);
        }
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert_eq!(srgb_encode(0.0), 0.0);
    }

    #[test]
    fn exr_and_png_writers_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = HdrImage::new(3, 2);
        img.rgb[4] = Vec3::new(1.5, 0.25, 1e-3);
        let p = dir.path().join("o.exr");
        img.write_exr(&p).unwrap();
        let raw = read_raw(&p, &ReadLimits::default()).unwrap();
        assert_eq!(raw.channel("G").unwrap().data.f32_at(4), 0.25);
        let png = dir.path().join("o.png");
        img.write_png(&png, ToneMap::default()).unwrap();
        let back = image::open(&png).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), (3, 2));
        assert_eq!(back.get_pixel(1, 1).0[0], (srgb_encode(0.6) * 255.0 + 0.5) as u8);
        assert!(HdrImage::new(0, 0).write_png(&png, ToneMap::default()).is_err());
    }
}
