//! Packing schemes for single attributes: every codec maps a value to an integer code of `bits()` bits (the low
//! bits of a `u64`) and back. Layouts place those codes into render-target words.
//!
//! Every codec documents its source, its error bound, its domain, and what it does with zero, NaN and infinite
//! input. No codec ever returns NaN. Decoders ignore the bits of a code above `bits()`.
//!
//! Codecs are found by name through the registry: [`normal_codec`] (`oct-16`, `oct-precise-24`,
//! `spheremap-cry-16`, `lambert-20`, `xyz-snorm-30`, …; see [`NormalScheme`]), [`scalar_codec`] (`unorm-8`,
//! `f16`, `log2-unorm-8`, …), [`color_codec`] (`unorm8`, `srgb8`, `r11g11b10f`, `rgb9e5`, `f16`, …) and
//! [`depth_codec`] (`f32`, `unorm24`, `unorm24-reversed`, `f32-reversed`, …). The `try_*` variants return an
//! error that lists the valid names.
//!
//! ```
//! let oct = gbuf::codec::normal_codec("oct-precise-16").unwrap();
//! let n = glam::Vec3::new(0.48, -0.6, 0.64).normalize();
//! let back = oct.decode(oct.encode(n));
//! assert!(gbuf::codec::angle_deg(n, back) <= oct.max_error_deg());
//! ```

use crate::error::{Error, Result};
use glam::Vec3;

pub mod color;
pub mod depth;
pub mod eval;
pub mod normal;
pub(crate) mod scalar;
pub mod simd;
#[cfg(test)]
pub(crate) mod strategies;

use crate::base::isa::Isa;
pub use color::color_codec;
pub use depth::depth_codec;
pub use normal::{angle_deg, normal_codec, NormalScheme};
pub use scalar::scalar_codec;

/// What every codec is: a value type, a name, a bit count, `encode`/`decode`, the decoder's cost, and the slice
/// paths. The four kinds ([`NormalCodec`], [`ScalarCodec`], [`ColorCodec`], [`DepthCodec`]) add what is particular
/// to their values (error bounds, domains) on top.
///
/// The slice methods are written once here for every codec; a codec with a vectorised body overrides
/// [`Self::encode_slice_isa`] / [`Self::decode_slice_isa`].
pub trait Codec: Send + Sync {
    /// What is encoded: `Vec3` for normals and colours, `f32` for scalars and depths.
    type Value: Copy + Send + Sync;
    /// Short kebab-case name including the bit count where it varies, e.g. `oct-16`, `unorm-8`, `srgb8`.
    fn name(&self) -> String;
    /// Total bits per value.
    fn bits(&self) -> u32;
    /// Encodes a value (see each kind for the domain and what happens outside it).
    fn encode(&self, v: Self::Value) -> u64;
    /// Decodes a code; always finite (a unit vector for normals, positive for depths).
    fn decode(&self, code: u64) -> Self::Value;
    /// Scalar arithmetic operations [`Self::decode`] performs per value, counted from its source by the rule in
    /// docs/CODECS.md ("Decode cost"): one per add, sub, mul, fma, div, sqrt, min, max, clamp, compare/select,
    /// shift, and, or, int↔float conversion and table lookup; [`TRANSCENDENTAL_OPS`] per exp2, log2, pow, sin,
    /// cos, atan2, …. No default: every codec states its own count.
    fn decode_ops(&self) -> u32;
    /// What a shader needs to reproduce this codec bit for bit (`layout::shader` emits it); `None` for codecs
    /// gbuf does not emit yet.
    fn recipe(&self) -> Option<Recipe> {
        None
    }
    /// Encodes a slice on the calling thread with the widest instruction set this CPU has ([`Isa::detect`]);
    /// bit-identical to [`Self::encode`] element by element. Panics if `out.len() != input.len()`. For all
    /// threads see [`simd::par_encode`].
    fn encode_slice(&self, input: &[Self::Value], out: &mut [u64]) {
        self.encode_slice_isa(Isa::detect(), input, out);
    }
    /// Decodes a slice on the calling thread (see [`Self::encode_slice`]). Panics if the lengths differ.
    fn decode_slice(&self, codes: &[u64], out: &mut [Self::Value]) {
        self.decode_slice_isa(Isa::detect(), codes, out);
    }
    /// [`Self::encode_slice`] compiled for `isa` (clamped to what the CPU has). The default runs
    /// [`Self::encode`] in a loop; the cheap codecs override it with a vectorised body.
    fn encode_slice_isa(&self, isa: Isa, input: &[Self::Value], out: &mut [u64]) {
        assert_eq!(input.len(), out.len(), "encode_slice: {} values into {} codes", input.len(), out.len());
        simd::run(isa, simd::MapKernel { input, out, f: simd::Encode(self) });
    }
    /// [`Self::decode_slice`] compiled for `isa` (see [`Self::encode_slice_isa`]).
    fn decode_slice_isa(&self, isa: Isa, codes: &[u64], out: &mut [Self::Value]) {
        assert_eq!(codes.len(), out.len(), "decode_slice: {} codes into {} values", codes.len(), out.len());
        simd::run(isa, simd::MapKernel { input: codes, out, f: simd::Decode(self) });
    }
}

/// Operations [`Codec::decode_ops`] counts for one transcendental call (exp2, log2, pow, sin, cos, atan2, acos,
/// …): about what a libm or vectorised polynomial implementation spends (range reduction, a degree-6 to -8
/// polynomial, reconstruction). One fixed weight so that counts compare across codecs.
pub const TRANSCENDENTAL_OPS: u32 = 20;

/// A unit-normal encoding: [`Codec`] over `Vec3` whose `decode` is always a finite unit vector.
pub trait NormalCodec: Codec<Value = Vec3> {
    /// Documented upper bound, in degrees, on the angle between a unit input inside [`Self::in_domain`] and its
    /// decoded code. Tests hold every codec to it.
    fn max_error_deg(&self) -> f32 {
        180.0
    }
    /// Is this unit vector inside the region where [`Self::max_error_deg`] holds? (Hemisphere-only and clamped
    /// schemes say no for part of the sphere; the rest of the sphere still encodes to a defined, finite result.)
    fn in_domain(&self, n: Vec3) -> bool {
        let _ = n;
        true
    }
    /// Does `decode(encode(decode(c))) == decode(c)` hold exactly for every code? False for schemes whose decoder
    /// renormalises a quantized vector (xyz), where re-encoding may move to a neighbouring code within the bound.
    fn is_idempotent(&self) -> bool {
        true
    }
}

/// A codec as the shader emitter sees it: the family and its constants, from which `layout::shader` writes code
/// that gives the codec's bits (encode) and values (decode) exactly, arithmetic for arithmetic.
#[derive(Clone, Debug, PartialEq)]
pub enum Recipe {
    /// Scalar unorm over [lo, hi], f64 arithmetic (`scalar::Unorm`).
    ScalarUnorm {
        /// Bits.
        bits: u32,
        /// Value of code 0.
        lo: f32,
        /// Value of the largest code.
        hi: f32,
    },
    /// Scalar snorm over [−range, range], f64 arithmetic (`scalar::Snorm`).
    ScalarSnorm {
        /// Bits.
        bits: u32,
        /// Value of the largest code.
        range: f32,
    },
    /// A half float (NaN → 0, clamped to ±65504).
    ScalarF16,
    /// An IEEE single (NaN → 0, ±Inf → ±f32::MAX).
    ScalarF32,
    /// Three linear unorm channels of `bits` bits, f32 arithmetic.
    ColorUnorm {
        /// Bits per channel.
        bits: u32,
    },
    /// srgb8: encode by its 255 thresholds (code = how many are ≤ the clamped value), decode by its 256 values.
    ColorSrgb8 {
        /// Smallest value of each code 1..=255.
        thresholds: Vec<f32>,
        /// The decoded value of each code.
        decoded: Vec<f32>,
    },
    /// Three half floats.
    ColorF16,
    /// Three IEEE singles.
    ColorF32,
    /// `R11G11B10_FLOAT`: unsigned small floats (5-bit exponent; 6, 6, 5 mantissa bits), round to nearest (ties
    /// away from zero), NaN and negatives → 0, beyond the range → the largest value.
    ColorR11G11B10F,
    /// `RGB9E5`: three 9-bit mantissas under a shared 5-bit exponent (`EXT_texture_shared_exponent`, rounding
    /// to nearest).
    ColorRgb9e5,
    /// A monotonic scalar codec of at most [`TABLE_RECIPE_BITS`] bits through tables: encode counts the
    /// thresholds at or below the value (after `lo`/`hi` clamping, NaN as `nan`), decode looks the value up.
    ScalarTable {
        /// Bits.
        bits: u32,
        /// Inputs are clamped to [lo, hi] first.
        lo: f32,
        /// Upper clamp.
        hi: f32,
        /// What NaN encodes as.
        nan: f32,
        /// Smallest input of each code 1..2^bits.
        thresholds: Vec<f32>,
        /// The decoded value of each code.
        decoded: Vec<f32>,
    },
    /// `log2-unorm` wider than [`TABLE_RECIPE_BITS`]: `log2(p)/12` as a unorm of `bits` bits (f64 rounding), decoded
    /// with `exp2`. The driver's `log2`/`exp2` are not libm's: not bit-exact (docs/SHADERS.md gives the measured
    /// difference).
    ScalarLog2 {
        /// Bits.
        bits: u32,
    },
    /// Two-component normal: a plane map, its coordinates stored as `quant`.
    NormalPlanar {
        /// The map from the sphere to the plane.
        map: normal::PlaneMap,
        /// Storage of each plane coordinate.
        quant: normal::Quant,
    },
    /// Precise octahedral (Cigolle et al. 2014, "octP"): of the four snorm codes of `k` bits around the projected
    /// point, the one whose decoded normal is nearest (squared chord, first of equals in the order (0,0), (1,0),
    /// (0,1), (1,1)).
    NormalOctPrecise {
        /// Bits per component.
        k: u32,
    },
    /// xyz normal: three coordinates stored as `quant` (`unorm`: `n·0.5 + 0.5`).
    NormalXyz {
        /// Storage of each coordinate.
        quant: normal::Quant,
        /// Unorm storage of `n·0.5 + 0.5`.
        unorm: bool,
    },
    /// Linear view depth as an IEEE single (NaN → far plane).
    DepthLinearF32,
    /// Linear view depth as a half float.
    DepthLinearF16,
    /// Post-projection depth with the camera's near/far, f64 arithmetic.
    DepthPost {
        /// Storage.
        storage: depth::DepthStorage,
        /// Reversed Z (1 at the near plane).
        reversed: bool,
    },
}

impl Recipe {
    /// Does the emitted code give the CPU's bits on any conforming driver? Not for the recipes that call the
    /// driver's transcendentals (`spherical`, `lambert-sphere`: atan2, sin, cos; wide `log2-unorm`: log2, exp2).
    #[must_use]
    pub fn is_exact(&self) -> bool {
        !matches!(
            self,
            Recipe::ScalarLog2 { .. }
                | Recipe::NormalPlanar { map: normal::PlaneMap::Spherical | normal::PlaneMap::LambertSphere, .. }
        )
    }
}

/// Widest codec [`Recipe::ScalarTable`] describes (a table of 2^12 values).
pub const TABLE_RECIPE_BITS: u32 = 12;

/// The smallest input of each code 1..2^bits of a codec monotonic on [lo, hi] (bisection over the f32 bit
/// patterns, which order like the values on [0, ∞)): what [`Recipe::ScalarTable`] and sRGB encode with.
#[must_use]
pub fn code_thresholds(bits: u32, lo: f32, hi: f32, code: impl Fn(f32) -> u64) -> Vec<f32> {
    assert!(lo >= 0.0 && hi >= lo, "thresholds are bisected over non-negative f32 bit patterns");
    (1..1u64 << bits)
        .map(|c| {
            let (mut a, mut b) = (lo.to_bits(), hi.to_bits());
            if code(hi) < c {
                return f32::INFINITY;
            }
            while a < b {
                let mid = a + (b - a) / 2;
                if code(f32::from_bits(mid)) >= c {
                    b = mid;
                } else {
                    a = mid + 1;
                }
            }
            f32::from_bits(a)
        })
        .collect()
}

/// A scalar encoding (specular, roughness, metallic, AO, specular power): [`Codec`] over `f32`.
pub trait ScalarCodec: Codec<Value = f32> {
    /// The closed interval of values this codec represents; inputs outside are clamped into it.
    fn domain(&self) -> (f32, f32) {
        (f32::MIN, f32::MAX)
    }
    /// Documented bound on `|decode(encode(v)) − v|` for a finite `v` inside [`Self::domain`].
    fn error_bound(&self, v: f32) -> f32 {
        let _ = v;
        f32::INFINITY
    }
}

/// An RGB colour encoding: [`Codec`] over linear RGB `Vec3`.
pub trait ColorCodec: Codec<Value = Vec3> {
    /// The closed interval every channel is clamped into before encoding.
    fn domain(&self) -> (f32, f32) {
        (f32::MIN, f32::MAX)
    }
    /// Documented per-channel bound on `|decode_wide(encode_wide(c)) − c|` for a finite `c` inside
    /// [`Self::domain`].
    fn error_bound(&self, c: Vec3) -> Vec3 {
        let _ = c;
        Vec3::INFINITY
    }
    /// Encodes into a code of up to 128 bits. Codecs wider than 64 bits (`f32`, 96 bits) must be used through
    /// this pair; for the others it equals [`Codec::encode`].
    fn encode_wide(&self, c: Vec3) -> u128 {
        u128::from(self.encode(c))
    }
    /// Decodes a code of up to 128 bits (see [`Self::encode_wide`]).
    fn decode_wide(&self, code: u128) -> Vec3 {
        self.decode(code as u64)
    }
}

/// A view-depth encoding: [`Codec`] over positive view depths. Codecs that depend on the projection are built
/// with the near/far planes.
pub trait DepthCodec: Codec<Value = f32> {
    /// The closed interval of depths this codec represents; inputs outside are clamped into it.
    fn domain(&self) -> (f32, f32) {
        (f32::MIN_POSITIVE, f32::MAX)
    }
    /// Documented bound on `|decode(encode(d)) − d|` for a depth `d` inside [`Self::domain`].
    fn error_bound(&self, depth: f32) -> f32 {
        let _ = depth;
        f32::INFINITY
    }
    /// The code a depth buffer holds where no surface was drawn (what it is cleared to): the far plane of a
    /// post-projection depth (1.0 or all ones standard, 0 reversed), 0 for a linear view depth. `Layout::pack`
    /// writes it at background samples and the packed-target reader takes it for "no surface".
    fn clear_code(&self) -> u64 {
        0
    }
}

/// Like [`normal_codec`], but an unknown name is an error listing the valid ones.
pub fn try_normal_codec(name: &str) -> Result<Box<dyn NormalCodec>> {
    normal_codec(name).ok_or_else(|| {
        let valid: Vec<String> =
            NormalScheme::ALL.iter().map(|s| format!("{}-{{{}}}", s.name(), join(&s.valid_bits()))).collect();
        let every: Vec<String> = NormalScheme::ALL
            .iter()
            .flat_map(|s| s.valid_bits().into_iter().map(move |b| format!("{}-{b}", s.name())))
            .collect();
        let every: Vec<&str> = every.iter().map(String::as_str).collect();
        Error::UnknownName(crate::base::names::unknown("normal codec", name, &every, &valid.join(", ")))
    })
}

/// Like [`scalar_codec`], but an unknown name is an error listing the valid ones.
pub fn try_scalar_codec(name: &str) -> Result<Box<dyn ScalarCodec>> {
    scalar_codec(name).ok_or_else(|| {
        Error::UnknownName(crate::base::names::unknown(
            "scalar codec",
            name,
            scalar::VALID_NAMES,
            &scalar::VALID_NAMES.join(", "),
        ))
    })
}

/// Like [`color_codec`], but an unknown name is an error listing the valid ones.
pub fn try_color_codec(name: &str) -> Result<Box<dyn ColorCodec>> {
    color_codec(name).ok_or_else(|| {
        Error::UnknownName(crate::base::names::unknown(
            "colour codec",
            name,
            color::VALID_NAMES,
            &color::VALID_NAMES.join(", "),
        ))
    })
}

/// Like [`depth_codec`], but an unknown name or invalid planes give an error saying which.
pub fn try_depth_codec(name: &str, znear: f32, zfar: f32) -> Result<Box<dyn DepthCodec>> {
    if !(znear.is_finite() && zfar.is_finite() && znear > 0.0 && zfar > znear) {
        return Err(Error::Argument(format!(
            "depth codec {name:?}: need finite planes with 0 < znear < zfar, got znear={znear}, zfar={zfar}"
        )));
    }
    depth_codec(name, znear, zfar).ok_or_else(|| {
        Error::UnknownName(crate::base::names::unknown(
            "depth codec",
            name,
            depth::VALID_NAMES,
            &depth::VALID_NAMES.join(", "),
        ))
    })
}

fn join(bits: &[u32]) -> String {
    bits.iter().map(u32::to_string).collect::<Vec<_>>().join(",")
}

/// Splits `scheme-N` into (`scheme`, N) at the last `-`.
pub(crate) fn split_bits(name: &str) -> Option<(&str, u32)> {
    let (prefix, bits) = name.rsplit_once('-')?;
    if bits.is_empty() || !bits.bytes().all(|b| b.is_ascii_digit()) || bits.len() > 3 {
        return None;
    }
    Some((prefix, bits.parse().ok()?))
}

/// All-ones mask of the low `bits` bits.
#[must_use]
pub(crate) const fn mask(bits: u32) -> u64 {
    if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table recipes are the codec: each threshold is the first input of its code (the input one ulp below
    /// encodes to the code before), and the decoded values are `decode` of every code.
    #[test]
    fn table_recipes_are_exactly_the_codec() {
        for name in ["log2-unorm-4", "log2-unorm-8", "log2-unorm-12"] {
            let c = scalar_codec(name).unwrap();
            let Some(Recipe::ScalarTable { thresholds, decoded, .. }) = c.recipe() else { panic!("{name}") };
            for (i, &t) in thresholds.iter().enumerate() {
                let code = i as u64 + 1;
                assert_eq!(c.encode(t), code, "{name}: threshold of {code}");
                assert_eq!(c.encode(f32::from_bits(t.to_bits() - 1)), code - 1, "{name}: below {code}");
            }
            assert!(decoded.iter().enumerate().all(|(k, v)| v.to_bits() == c.decode(k as u64).to_bits()), "{name}");
        }
        let srgb = color_codec("srgb8").unwrap();
        let Some(Recipe::ColorSrgb8 { thresholds, .. }) = srgb.recipe() else { panic!("srgb8") };
        for (i, &t) in thresholds.iter().enumerate() {
            let code = i as u64 + 1;
            assert_eq!(srgb.encode(glam::Vec3::splat(t)) & 0xff, code);
            assert_eq!(srgb.encode(glam::Vec3::splat(f32::from_bits(t.to_bits() - 1))) & 0xff, code - 1);
        }
    }

    #[test]
    fn unknown_names_are_errors_listing_valid_names() {
        // A typo gets the nearest name instead of the whole list; a stranger gets the list.
        let e = try_normal_codec("oct-17").err().unwrap().to_string();
        assert!(e.contains("did you mean \"oct-1"), "{e}");
        let e = try_normal_codec("quaternion").err().unwrap().to_string();
        assert!(e.contains("oct-{") && e.contains("oct-precise-{"), "{e}");
        assert!(try_scalar_codec("unorm-99").is_err());
        assert!(try_color_codec("srgb9").is_err());
        assert!(try_depth_codec("unorm24", 1.0, 0.5).err().unwrap().to_string().contains("znear < zfar"));
        assert!(try_depth_codec("unorm23", 0.1, 100.0).err().unwrap().to_string().contains("unorm24-reversed"));
    }

    /// Every name the four registries accept (each bit count of each pattern).
    fn every_codec() -> Vec<(String, u32)> {
        let mut all = Vec::new();
        for s in NormalScheme::ALL {
            for b in s.valid_bits() {
                let c = normal_codec(&format!("{}-{b}", s.name())).unwrap();
                all.push((c.name(), c.decode_ops()));
            }
        }
        let mut scalars: Vec<String> = ["f16", "f32", "snorm-8:32"].map(String::from).to_vec();
        for n in 1..=24 {
            scalars.extend(["unorm", "snorm", "log2-unorm", "specpow-unorm"].map(|p| format!("{p}-{n}")));
        }
        all.extend(
            scalars.iter().filter_map(|n| scalar_codec(n)).map(|c| (format!("scalar {}", c.name()), c.decode_ops())),
        );
        let mut colors: Vec<String> =
            ["unorm8", "srgb8", "r11g11b10f", "rgb9e5", "f16", "f32"].map(String::from).to_vec();
        colors.extend((1..=16).map(|n| format!("unorm-{n}")));
        all.extend(
            colors.iter().map(|n| color_codec(n).unwrap()).map(|c| (format!("colour {}", c.name()), c.decode_ops())),
        );
        for n in depth::VALID_NAMES {
            let c = depth_codec(n, 0.1, 100.0).unwrap();
            all.push((format!("depth {}", c.name()), c.decode_ops()));
        }
        all
    }

    #[test]
    fn every_codec_counts_its_decode_ops() {
        let all = every_codec();
        assert!(all.len() > 200, "{} codecs", all.len());
        for (name, ops) in &all {
            assert!(*ops > 0, "{name}: decode_ops = 0");
        }
        let ops = |kind: &str, name: &str| -> u32 {
            let key = if kind.is_empty() { name.to_string() } else { format!("{kind} {name}") };
            all.iter().find(|(n, _)| *n == key).unwrap_or_else(|| panic!("{key} missing")).1
        };
        // Identity-like decoders are cheaper than any projection that has to rebuild a unit vector.
        let identities = [ops("depth", "f32"), ops("scalar", "f32"), ops("colour", "f32")];
        for n in ["oct-16", "oct-precise-16", "spheremap-cry-16", "spheremap-ispc-16", "lambert-16", "stereo-16"]
            .into_iter()
            .chain(["lambert-sphere-16", "stereo-sphere-16"])
        {
            for id in identities {
                assert!(id < ops("", n), "identity {id} vs {n} {}", ops("", n));
            }
        }
        // Monotone where one decoder does the other's work and more.
        assert!(ops("", "oct-precise-16") >= ops("", "oct-16"));
        assert!(ops("", "oct-f16-32") > ops("", "oct-16"), "f16 storage needs the half-float decode");
        assert!(ops("", "spherical-16") > ops("", "oct-16"), "spherical needs sin and cos");
        assert!(ops("scalar", "log2-unorm-8") > ops("scalar", "unorm-8"), "log2 decodes unorm and then exp2");
        assert!(ops("depth", "unorm24") > ops("depth", "f32"), "post-projection depth inverts the projection");
        assert!(ops("colour", "f16") > ops("colour", "unorm8"));
        assert!(ops("", "xyz-f16-48") > ops("", "xyz-snorm-48"));
        // The table in docs/CODECS.md ("Decode cost").
        assert!(ops("", "lambert-sphere-16") > ops("", "stereo-sphere-16"), "the equal-area map needs two sines");
        for (name, want) in [("oct-16", 45), ("spheremap-cry-16", 64), ("spherical-16", 115), ("xyz-unorm-30", 32)] {
            assert_eq!(ops("", name), want, "{name}: docs/CODECS.md says {want}");
        }
        for (name, want) in [("lambert-sphere-16", 102), ("stereo-sphere-24", 60)] {
            assert_eq!(ops("", name), want, "{name}: docs/CODECS.md says {want}");
        }
        for (name, want) in [("scalar unorm-8", 6), ("colour r11g11b10f", 106), ("depth unorm24", 9)] {
            assert_eq!(ops("", name), want, "{name}: docs/CODECS.md says {want}");
        }
    }

    #[test]
    fn split_bits_parses_the_last_number() {
        assert_eq!(split_bits("xyz-f16-48"), Some(("xyz-f16", 48)));
        assert_eq!(split_bits("oct-16"), Some(("oct", 16)));
        assert_eq!(split_bits("oct"), None);
        assert_eq!(split_bits("oct-"), None);
        assert_eq!(split_bits("oct-+1"), None);
    }
}
