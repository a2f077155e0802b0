//! Unit-normal codecs: every scheme a G-buffer designer weighs, at any sensible bit count.
//!
//! Most schemes are a *projection* of the sphere onto a square (octahedral, spheremap, Lambert, stereographic and
//! their full-sphere folded forms, spherical angles, xy-with-reconstructed-z) followed by a *quantizer* of the two plane coordinates
//! ([`Quant`]: snorm or unorm with k bits each, or IEEE half floats). [`Planar`] glues the two; each projection
//! lives in its own file with its source, its error bound and its domain. `xyz` stores all three components.
//!
//! Input handling shared by every scheme ([`sanitize`]): any finite non-zero vector is normalised first (scaling
//! by its largest component, so 1e-30, denormals and 1e30 are fine); the zero vector (±0.0) and any vector with a
//! NaN component encode as +Z (facing the camera); a vector with infinite components encodes as the direction of
//! its infinite components (`(∞, 1, 0)` → +X). No decoder returns NaN: every code decodes to a finite unit vector.
//!
//! Codes: component 0 sits in the low `k` bits, component 1 in the next `k`, and so on.

use super::simd::{f16_bits_to_f32, f32_to_f16_bits, run, BlockElement, BlockKernel, MapKernel, BLOCK};
use super::{mask, split_bits, Codec, NormalCodec};
use crate::base::isa::Isa;
use glam::{DVec3, Vec2, Vec3};

mod hemi;
mod lambert;
mod lambert_sphere;
mod oct;
mod spheremap;
mod spherical;
mod stereo;
mod stereo_sphere;
mod xyz;

pub use hemi::XyHemi;
pub use lambert::Lambert;
pub use lambert_sphere::{LambertSphere, LAMBERT_SPHERE_MAX_STRETCH};
pub use oct::{Oct, OctPrecise};
pub use spheremap::{ispc_spheremap_decode, ispc_spheremap_encode, SpheremapCry, SpheremapIspc};
pub use spherical::Spherical;
pub use stereo::Stereo;
pub use stereo_sphere::{StereoSphere, STEREO_SPHERE_MAX_STRETCH};
pub use xyz::{Xyz, XyzStorage};

/// Slack added to every analytic error bound for f32 rounding in the projection, the normalisation and the
/// measurement itself (a few ulp of a unit vector is ~3e-7 rad; this leaves a 10× margin).
pub const FLOAT_SLACK_RAD: f32 = 4e-6;

/// Every normal scheme, named without its bit count. `name()-bits` is the registry name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NormalScheme {
    /// xyz, three snorm components, renormalised on decode (Cigolle et al. 2014 "snorm").
    XyzSnorm,
    /// xyz, three unorm components storing `n·0.5+0.5` (the classic RGB normal map).
    XyzUnorm,
    /// xyz, three IEEE half floats (48 bits).
    XyzF16,
    /// xy snorm with z = +√(1−x²−y²): **hemisphere z ≥ 0 only**.
    XyHemi,
    /// xy in half floats with reconstructed z (32 bits): **hemisphere only**.
    XyHemiF16,
    /// Spherical angles (θ, φ), unorm.
    Spherical,
    /// CryEngine 3 spheremap transform (Mittring 2009), snorm.
    SpheremapCry,
    /// CryEngine 3 spheremap in half floats (32 bits).
    SpheremapCryF16,
    /// The same spheremap stored as unorm `g·0.5+0.5` and decoded as in Intel's ISPC deferred sample.
    SpheremapIspc,
    /// Lambert azimuthal equal-area projection centred on +Z, snorm.
    Lambert,
    /// Lambert azimuthal equal-area in half floats (32 bits).
    LambertF16,
    /// Stereographic projection from −Z, scaled by 1.7777 (Pranckevičius), snorm.
    Stereo,
    /// Stereographic projection in half floats, unscaled and unclamped (32 bits).
    StereoF16,
    /// Full-sphere Lambert equal-area: each hemisphere's azimuthal equal-area disc on the octahedral diamond
    /// (concentric map), the lower hemisphere folded into the corners; snorm.
    LambertSphere,
    /// Full-sphere stereographic: each hemisphere's stereographic disc stretched radially onto the octahedral
    /// diamond, the lower hemisphere folded into the corners; snorm.
    StereoSphere,
    /// Octahedral (Meyer et al. 2010, Cigolle et al. 2014), snorm, rounding to the nearest code.
    Oct,
    /// Precise octahedral: the best of the four neighbouring codes (Cigolle et al. 2014, "octP").
    OctPrecise,
    /// Octahedral in half floats (32 bits).
    OctF16,
    /// Octahedral stored as unorm `p·0.5 + 0.5` ([`Quant::UnormSigned`]): Cigolle et al. 2014's GLSL and the
    /// engines' form (e.g. an RGB10A2 target's R and G).
    OctUnorm,
    /// Lambert azimuthal equal-area stored as unorm `p·0.5 + 0.5`.
    LambertUnorm,
    /// xy with reconstructed z (hemisphere only), stored as unorm `p·0.5 + 0.5`.
    XyHemiUnorm,
    /// CryEngine 3 spheremap stored as unorm `g·0.5 + 0.5` (CryEngine's own storage).
    SpheremapCryUnorm,
    /// Stereographic (scaled) stored as unorm `p·0.5 + 0.5`.
    StereoUnorm,
    /// Full-sphere Lambert stored as unorm `p·0.5 + 0.5`.
    LambertSphereUnorm,
    /// Full-sphere stereographic stored as unorm `p·0.5 + 0.5`.
    StereoSphereUnorm,
}

crate::named!(NormalScheme: "normal scheme" {
    XyzSnorm => "xyz-snorm",
    XyzUnorm => "xyz-unorm",
    XyzF16 => "xyz-f16",
    XyHemi => "xy-hemi",
    XyHemiF16 => "xy-hemi-f16",
    Spherical => "spherical",
    SpheremapCry => "spheremap-cry",
    SpheremapCryF16 => "spheremap-cry-f16",
    SpheremapIspc => "spheremap-ispc",
    Lambert => "lambert",
    LambertF16 => "lambert-f16",
    Stereo => "stereo",
    StereoF16 => "stereo-f16",
    LambertSphere => "lambert-sphere",
    StereoSphere => "stereo-sphere",
    Oct => "oct",
    OctPrecise => "oct-precise",
    OctF16 => "oct-f16",
    OctUnorm => "oct-unorm",
    LambertUnorm => "lambert-unorm",
    XyHemiUnorm => "xy-hemi-unorm",
    SpheremapCryUnorm => "spheremap-cry-unorm",
    StereoUnorm => "stereo-unorm",
    LambertSphereUnorm => "lambert-sphere-unorm",
    StereoSphereUnorm => "stereo-sphere-unorm",
});

impl NormalScheme {
    /// Stored components (2 or 3).
    #[must_use]
    pub fn components(self) -> u32 {
        match self {
            NormalScheme::XyzSnorm | NormalScheme::XyzUnorm | NormalScheme::XyzF16 => 3,
            _ => 2,
        }
    }

    /// Half-float storage (a single valid bit count)?
    #[must_use]
    pub fn is_f16(self) -> bool {
        matches!(
            self,
            NormalScheme::XyzF16
                | NormalScheme::XyHemiF16
                | NormalScheme::SpheremapCryF16
                | NormalScheme::LambertF16
                | NormalScheme::StereoF16
                | NormalScheme::OctF16
        )
    }

    /// Only meaningful on the hemisphere z ≥ 0?
    #[must_use]
    pub fn hemisphere_only(self) -> bool {
        matches!(self, NormalScheme::XyHemi | NormalScheme::XyHemiF16 | NormalScheme::XyHemiUnorm)
    }

    /// Every valid total bit count: `components × k` for k = 4..=16 bits per component, or the single f16 size.
    #[must_use]
    pub fn valid_bits(self) -> Vec<u32> {
        if self.is_f16() {
            return vec![16 * self.components()];
        }
        (MIN_COMPONENT_BITS..=MAX_COMPONENT_BITS).map(|k| k * self.components()).collect()
    }

    /// The bit counts a default sweep evaluates: 8, 10, 12 and 16 bits per component (or the f16 size).
    #[must_use]
    pub fn sweep_bits(self) -> Vec<u32> {
        if self.is_f16() {
            return self.valid_bits();
        }
        [8, 10, 12, 16].iter().map(|k| k * self.components()).collect()
    }

    /// The codec at `bits` total bits, if that count is valid for this scheme.
    #[must_use]
    pub fn codec(self, bits: u32) -> Option<Box<dyn NormalCodec>> {
        if !self.valid_bits().contains(&bits) {
            return None;
        }
        let k = bits / self.components();
        let q = if self.is_f16() { Quant::F16 } else { Quant::Snorm(k) };
        let qu = if self.is_f16() { Quant::F16 } else { Quant::Unorm(k) };
        let qs = Quant::UnormSigned(k);
        Some(match self {
            NormalScheme::XyzSnorm => Box::new(Xyz::new(XyzStorage::Snorm(k))),
            NormalScheme::XyzUnorm => Box::new(Xyz::new(XyzStorage::Unorm(k))),
            NormalScheme::XyzF16 => Box::new(Xyz::new(XyzStorage::F16)),
            NormalScheme::XyHemi | NormalScheme::XyHemiF16 => Box::new(Planar::new(XyHemi, q)),
            NormalScheme::Spherical => Box::new(Planar::new(Spherical, qu)),
            NormalScheme::SpheremapCry | NormalScheme::SpheremapCryF16 => Box::new(Planar::new(SpheremapCry, q)),
            NormalScheme::SpheremapIspc => Box::new(Planar::new(SpheremapIspc, qu)),
            NormalScheme::Lambert | NormalScheme::LambertF16 => Box::new(Planar::new(Lambert, q)),
            NormalScheme::Stereo => Box::new(Planar::new(Stereo::SCALED, q)),
            NormalScheme::StereoF16 => Box::new(Planar::new(Stereo::UNSCALED, q)),
            NormalScheme::LambertSphere => Box::new(Planar::new(LambertSphere, q)),
            NormalScheme::StereoSphere => Box::new(Planar::new(StereoSphere, q)),
            NormalScheme::Oct | NormalScheme::OctF16 => Box::new(Planar::new(Oct, q)),
            NormalScheme::OctPrecise => Box::new(OctPrecise::new(k)),
            NormalScheme::OctUnorm => Box::new(Planar::new(Oct, qs)),
            NormalScheme::LambertUnorm => Box::new(Planar::new(Lambert, qs)),
            NormalScheme::XyHemiUnorm => Box::new(Planar::new(XyHemi, qs)),
            NormalScheme::SpheremapCryUnorm => Box::new(Planar::new(SpheremapCry, qs)),
            NormalScheme::StereoUnorm => Box::new(Planar::new(Stereo::SCALED, qs)),
            NormalScheme::LambertSphereUnorm => Box::new(Planar::new(LambertSphere, qs)),
            NormalScheme::StereoSphereUnorm => Box::new(Planar::new(StereoSphere, qs)),
        })
    }
}

/// Fewest bits per component a scheme accepts.
pub const MIN_COMPONENT_BITS: u32 = 4;
/// Most bits per component: beyond 16 the f32 arithmetic of the projections, not the code, limits precision.
pub const MAX_COMPONENT_BITS: u32 = 16;

/// Looks a normal codec up by its registry name, `scheme-bits` (e.g. `oct-16`, `xyz-f16-48`); `None` when the
/// scheme is unknown or the bit count is not one of [`NormalScheme::valid_bits`].
#[must_use]
pub fn normal_codec(name: &str) -> Option<Box<dyn NormalCodec>> {
    let (prefix, bits) = split_bits(name)?;
    NormalScheme::from_name(prefix)?.codec(bits)
}

/// Angle between two vectors in degrees, computed in f64 as atan2(|a×b|, a·b) (accurate for tiny angles, where
/// acos of the dot product is not). Zero or non-finite input gives 180.
#[must_use]
pub fn angle_deg(a: Vec3, b: Vec3) -> f32 {
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    if !(a.is_finite() && b.is_finite()) || a == DVec3::ZERO || b == DVec3::ZERO {
        return 180.0;
    }
    a.cross(b).length().atan2(a.dot(b)).to_degrees() as f32
}

/// Cleans an input normal (see the module doc): a finite unit vector for any input. Branch-free (every case is
/// computed, then selected), so the slice paths vectorise it.
#[inline(always)]
#[must_use]
pub fn sanitize(n: Vec3) -> Vec3 {
    let nan = n.x.is_nan() | n.y.is_nan() | n.z.is_nan();
    let finite = n.x.is_finite() & n.y.is_finite() & n.z.is_finite();
    // Only the infinite components carry direction.
    let dir = |c: f32| if c.is_infinite() { 1.0f32.copysign(c) } else { 0.0 };
    let n = if finite { n } else { Vec3::new(dir(n.x), dir(n.y), dir(n.z)) };
    let m = n.abs().max_element();
    // Dividing by the largest magnitude first keeps the squared length away from overflow and underflow.
    let v = n / m;
    let v = v / v.length();
    if nan | (m == 0.0) {
        Vec3::Z
    } else {
        v
    }
}

/// Robust 2D normalisation; the zero vector gives +X (the documented choice where a direction is undefined).
/// Branch-free.
#[inline(always)]
#[must_use]
pub fn normalize2_or_x(v: Vec2) -> Vec2 {
    let m = v.abs().max_element();
    let u = v / m;
    let u = u / u.length();
    if m.is_nan() || m <= 0.0 || !m.is_finite() {
        Vec2::X
    } else {
        u
    }
}

/// `+1` for `v ≥ 0` including −0.0, else `−1` (Cigolle et al.'s `signNotZero`).
#[inline(always)]
#[must_use]
pub fn sign_not_zero(v: f32) -> f32 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// [`Codec::decode_ops`] of [`finish`]: squared length (3 mul, 2 add), sqrt, 3 div, 2 compares, and, 3 selects.
pub(crate) const FINISH_OPS: u32 = 15;

/// [`Codec::decode_ops`] of [`f16_to_finite`]: [`f16_bits_to_f32`] (and, shift, and, 3 int adds, fsub, 2
/// compares, 2 selects, and, shift, or: 14), then the NaN compare, its select and the clamp.
pub(crate) const F16_TO_FINITE_OPS: u32 = 17;

/// [`Codec::decode_ops`] of [`normalize2_or_x`]: 2 abs, max, 2 div, length (2 mul, add, sqrt), 2 div, 3 checks,
/// 2 or, 2 selects.
pub(crate) const NORMALIZE2_OPS: u32 = 18;

/// Final step of every decoder: a finite unit vector, +Z if the arithmetic degenerated.
#[inline(always)]
#[must_use]
pub(crate) fn finish(v: Vec3) -> Vec3 {
    let l2 = v.length_squared();
    let u = v / l2.sqrt();
    if l2 > 0.0 && l2.is_finite() {
        u
    } else {
        Vec3::Z
    }
}

/// Runs `$body` with `$q` bound to the [`Quantizer`] of a [`Quant`] (one monomorphised body per storage).
macro_rules! with_quantizer {
    ($quant:expr, |$q:ident| $body:expr) => {
        match $quant {
            $crate::codec::normal::Quant::Snorm(k) => {
                let $q = $crate::codec::normal::SnormQ::new(k);
                $body
            }
            $crate::codec::normal::Quant::Unorm(k) => {
                let $q = $crate::codec::normal::UnormQ::new(k);
                $body
            }
            $crate::codec::normal::Quant::UnormSigned(k) => {
                let $q = $crate::codec::normal::UnormSignedQ::new(k);
                $body
            }
            $crate::codec::normal::Quant::F16 => {
                let $q = $crate::codec::normal::F16Q;
                $body
            }
        }
    };
}
pub(crate) use with_quantizer;

/// The plane maps the shader emitter writes (`codec::Recipe::NormalPlanar`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneMap {
    /// [`Oct`].
    Oct,
    /// [`XyHemi`]: x and y, z = √max(1 − x² − y², 0).
    XyHemi,
    /// [`SpheremapCry`]: CryEngine 3's spheremap (Mittring 2009).
    SpheremapCry,
    /// [`Lambert`]: Lambert azimuthal equal-area centred on +Z, scaled to the unit disc.
    Lambert,
    /// [`SpheremapIspc`]: the spheremap as the ISPC `deferred` example stores it (`g·0.5 + 0.5`).
    SpheremapIspc,
    /// [`LambertSphere`]: Lambert equal-area of each hemisphere on the octahedral diamond (atan2 and sin: the
    /// driver's transcendentals, measured like [`PlaneMap::Spherical`]).
    LambertSphere,
    /// [`StereoSphere`]: stereographic of each hemisphere on the octahedral diamond (no transcendental).
    StereoSphere,
    /// [`Spherical`]: polar angle and azimuth (atan2; decoded with sin and cos: the driver's transcendentals, so
    /// not bit-exact on a GPU — docs/SHADERS.md gives the measured difference).
    Spherical,
    /// [`Stereo`]: stereographic from −Z; `scaled` is Pranckevičius's 1.7777 with the unit square, else scale 1
    /// up to 65504.
    Stereo {
        /// [`Stereo::SCALED`] (else [`Stereo::UNSCALED`]).
        scaled: bool,
    },
}

/// How the plane coordinates of a projection are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quant {
    /// Signed normalized integer of k bits, D3D/Vulkan SNORM semantics: two's complement `s`, value
    /// `max(s / (2^(k−1)−1), −1)`; 0 and ±1 are exact. For plane coordinates in [−1, 1].
    Snorm(u32),
    /// Unsigned normalized integer of k bits: value `u / (2^k − 1)`. For plane coordinates in [0, 1].
    Unorm(u32),
    /// A coordinate in [−1, 1] stored as unorm `p·0.5 + 0.5` (k bits): value `2·u / (2^k − 1) − 1`. The form of
    /// Cigolle et al. 2014's published GLSL and of most engines (an octahedral normal in the R and G of an
    /// RGB10A2 or RGBA8 target). Encoding rounds `(p·0.5 + 0.5)·(2^k − 1)` to the nearest integer, as D3D and
    /// Vulkan convert a float written to a UNORM target. Neither 0 nor the axes are exact (2^k − 1 is odd),
    /// which is what it costs against snorm.
    UnormSigned(u32),
    /// IEEE 754 binary16 (the `half` crate), 16 bits per coordinate; magnitudes clamp to 65504.
    F16,
}

impl Quant {
    /// Bits per coordinate.
    #[must_use]
    pub fn bits(self) -> u32 {
        match self {
            Quant::Snorm(k) | Quant::Unorm(k) | Quant::UnormSigned(k) => k,
            Quant::F16 => 16,
        }
    }

    /// Largest error of one stored coordinate of magnitude ≤ `mag` (half a step; for f16 half an ulp).
    #[must_use]
    pub fn half_step(self, mag: f32) -> f32 {
        match self {
            Quant::Snorm(k) => 0.5 / ((1u32 << (k - 1)) - 1) as f32,
            Quant::Unorm(k) => 0.5 / ((1u64 << k) - 1) as f32,
            // Half a unorm step, doubled by `2·u − 1`.
            Quant::UnormSigned(k) => 1.0 / ((1u64 << k) - 1) as f32,
            // Rounding to nearest: relative error ≤ 2^-11, plus half the smallest subnormal.
            Quant::F16 => mag * 2f32.powi(-11) + 2f32.powi(-25),
        }
    }

    /// Quantizes one coordinate (NaN → 0; out-of-range values clamp).
    #[inline]
    #[must_use]
    pub fn encode(self, v: f32) -> u64 {
        u64::from(with_quantizer!(self, |q| q.enc(v)))
    }

    /// [`Codec::decode_ops`] of [`Self::decode`] (see [`Quantizer::dec_ops`]).
    #[must_use]
    pub fn decode_ops(self) -> u32 {
        with_quantizer!(self, |q| q.dec_ops())
    }

    /// Dequantizes one coordinate (only the low `bits()` bits of `c` are read). Always finite.
    #[inline]
    #[must_use]
    pub fn decode(self, c: u64) -> f32 {
        // Bits above `bits()` ≤ 16 are ignored, so truncating to u32 first changes nothing.
        with_quantizer!(self, |q| q.dec(c as u32))
    }
}

/// A [`Quant`] with its constants precomputed: the form the per-element bodies (scalar and slice paths alike)
/// are generic over, so the storage choice is made once per slice, not per element.
pub trait Quantizer: Copy + Send + Sync + 'static {
    /// Bits per coordinate (≤ 16).
    fn bits(self) -> u32;
    /// Quantizes one coordinate (NaN → 0; out-of-range values clamp); the code fits in `bits()` bits.
    fn enc(self, v: f32) -> u32;
    /// Dequantizes the low `bits()` bits of `c`; always finite.
    fn dec(self, c: u32) -> f32;
    /// [`Codec::decode_ops`] of [`Self::dec`].
    fn dec_ops(self) -> u32;
}

/// [`Quant::Snorm`] with its scale and mask.
#[derive(Clone, Copy, Debug)]
pub struct SnormQ {
    k: u32,
    m: f32,
    mask: u32,
}

impl SnormQ {
    /// Snorm with `k` bits (2..=16).
    #[inline(always)]
    #[must_use]
    pub fn new(k: u32) -> Self {
        SnormQ { k, m: ((1u32 << (k - 1)) - 1) as f32, mask: mask(k) as u32 }
    }
}

impl Quantizer for SnormQ {
    #[inline(always)]
    fn bits(self) -> u32 {
        self.k
    }
    #[inline(always)]
    fn enc(self, v: f32) -> u32 {
        let v = if v.is_nan() { 0.0 } else { v };
        (round_in_range(v.clamp(-1.0, 1.0) * self.m) as u32) & self.mask
    }
    #[inline(always)]
    fn dec(self, c: u32) -> f32 {
        // Sign-extend k bits.
        let s = (((c & self.mask) << (32 - self.k)) as i32) >> (32 - self.k);
        (s as f32 / self.m).max(-1.0)
    }
    fn dec_ops(self) -> u32 {
        6 // and, shl, sar, int→float, div, max
    }
}

/// [`Quant::Unorm`] with its scale and mask.
#[derive(Clone, Copy, Debug)]
pub struct UnormQ {
    k: u32,
    m: f32,
    mask: u32,
}

impl UnormQ {
    /// Unorm with `k` bits (1..=16).
    #[inline(always)]
    #[must_use]
    pub fn new(k: u32) -> Self {
        UnormQ { k, m: mask(k) as f32, mask: mask(k) as u32 }
    }
}

impl Quantizer for UnormQ {
    #[inline(always)]
    fn bits(self) -> u32 {
        self.k
    }
    #[inline(always)]
    fn enc(self, v: f32) -> u32 {
        let v = if v.is_nan() { 0.0 } else { v };
        round_in_range(v.clamp(0.0, 1.0) * self.m) as u32
    }
    #[inline(always)]
    fn dec(self, c: u32) -> f32 {
        (c & self.mask) as f32 / self.m
    }
    fn dec_ops(self) -> u32 {
        3 // and, int→float, div
    }
}

/// [`Quant::UnormSigned`] with its scale and mask.
#[derive(Clone, Copy, Debug)]
pub struct UnormSignedQ {
    k: u32,
    m: f32,
    mask: u32,
}

impl UnormSignedQ {
    /// Unorm `p·0.5 + 0.5` with `k` bits (1..=16).
    #[inline(always)]
    #[must_use]
    pub fn new(k: u32) -> Self {
        UnormSignedQ { k, m: mask(k) as f32, mask: mask(k) as u32 }
    }
}

impl Quantizer for UnormSignedQ {
    #[inline(always)]
    fn bits(self) -> u32 {
        self.k
    }
    #[inline(always)]
    fn enc(self, v: f32) -> u32 {
        let v = if v.is_nan() { 0.0 } else { v };
        round_in_range((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * self.m) as u32
    }
    #[inline(always)]
    fn dec(self, c: u32) -> f32 {
        // The engine's `t * 2.0 - 1.0` on the unorm value t = u / (2^k − 1).
        ((c & self.mask) as f32 / self.m) * 2.0 - 1.0
    }
    fn dec_ops(self) -> u32 {
        5 // and, int→float, div, mul, sub
    }
}

/// [`Quant::F16`].
#[derive(Clone, Copy, Debug)]
pub struct F16Q;

impl Quantizer for F16Q {
    #[inline(always)]
    fn bits(self) -> u32 {
        16
    }
    #[inline(always)]
    fn enc(self, v: f32) -> u32 {
        let v = if v.is_nan() { 0.0 } else { v };
        u32::from(f32_to_f16_bits(v.clamp(-F16_MAX, F16_MAX)))
    }
    #[inline(always)]
    fn dec(self, c: u32) -> f32 {
        f16_to_finite(c as u16)
    }
    fn dec_ops(self) -> u32 {
        F16_TO_FINITE_OPS
    }
}

/// The tests' second route to `v.round() as i32` (|v| < 2^31), which `round_in_range` must match: truncate, then
/// step away from zero when the fraction, which `v − trunc(v)` gives exactly, is at least one half.
#[cfg(test)]
#[must_use]
fn round_half_away(v: f32) -> i32 {
    let t = v as i32;
    let f = v - t as f32;
    t + i32::from(f >= 0.5) - i32::from(f <= -0.5)
}

/// [`round_half_away`] for f64 (saturating beyond ±2^31, NaN → 0, like `as`): the tests' second route to
/// `round_in_range_f64`.
#[cfg(test)]
#[must_use]
fn round_half_away_f64(v: f64) -> i32 {
    let t = v as i32;
    let f = v - f64::from(t);
    t + i32::from(f >= 0.5) - i32::from(f <= -0.5)
}

/// `v.round() as i32` for a code before rounding (a unorm/snorm/depth code the caller has clamped to
/// |v| ≤ 2^24): the truncation skips the saturating checks of `as`, which otherwise turn the vectorised loop back
/// into one scalar conversion per element. Safe for every input: NaN gives 0 and values beyond ±2^24 are clamped
/// there first (a select and a min/max, which stay in vector lanes), so the unchecked truncation always fits.
/// Equal to `f64::round` on |v| ≤ 2^24 (tested, with NaN and out-of-range inputs).
#[inline(always)]
#[must_use]
pub fn round_in_range_f64(v: f64) -> i32 {
    const LIMIT: f64 = 16_777_216.0;
    let v = if v.is_nan() { 0.0 } else { v.clamp(-LIMIT, LIMIT) };
    // SAFETY: `v` is finite with |v| ≤ 2^24, so its truncation fits an i32.
    let t: i32 = unsafe { v.to_int_unchecked() };
    let f = v - f64::from(t);
    t + i32::from(f >= 0.5) - i32::from(f <= -0.5)
}

/// [`round_half_away`] for a clamped, scaled coordinate (|v| ≤ 2^16 at the call sites): the truncation skips the
/// saturating checks of `as`, which keeps the vectorised loop at one conversion. Safe for every input: NaN gives 0
/// and values beyond ±2^24 are clamped there first. Equal to [`round_half_away`] on |v| ≤ 2^24 (tested).
#[inline(always)]
pub(crate) fn round_in_range(v: f32) -> i32 {
    const LIMIT: f32 = 16_777_216.0;
    let v = if v.is_nan() { 0.0 } else { v.clamp(-LIMIT, LIMIT) };
    // SAFETY: `v` is finite with |v| ≤ 2^24, so its truncation fits an i32.
    let t: i32 = unsafe { v.to_int_unchecked() };
    let f = v - t as f32;
    t + i32::from(f >= 0.5) - i32::from(f <= -0.5)
}

/// Largest finite half float.
pub const F16_MAX: f32 = 65504.0;

/// Decodes half-float bits to a finite f32: NaN → 0, ±Inf → ±65504.
#[inline(always)]
#[must_use]
pub fn f16_to_finite(bits: u16) -> f32 {
    let v = f16_bits_to_f32(bits);
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-F16_MAX, F16_MAX)
    }
}

/// A map from the unit sphere to a square of plane coordinates and back.
pub trait Projection: Send + Sync + Copy + 'static {
    /// Registry prefix for a quantizer (e.g. `oct` / `oct-f16`).
    fn scheme_name(&self, q: Quant) -> &'static str;
    /// Plane coordinates of a unit vector (already [`sanitize`]d).
    fn encode_plane(&self, n: Vec3) -> Vec2;
    /// Unit vector of any plane point (finite input; coordinates outside the square are clamped/handled).
    fn decode_plane(&self, p: Vec2) -> Vec3;
    /// [`Codec::decode_ops`] of [`Self::decode_plane`] (both arms of a select counted, as a branch-free decoder
    /// computes them).
    fn decode_ops(&self) -> u32;
    /// Angular error bound in radians when each plane coordinate is off by at most `hx`, `hy`, for inputs in
    /// [`Self::in_domain`]; `q` is passed for projections whose bound depends on the storage.
    fn bound_rad(&self, hx: f32, hy: f32, q: Quant) -> f32;
    /// Largest magnitude of a plane coordinate (sets the f16 rounding error).
    fn plane_extent(&self) -> f32 {
        1.0
    }
    /// Which [`PlaneMap`] this is, for the maps `layout::shader` emits.
    fn plane_map(&self) -> Option<PlaneMap> {
        None
    }
    /// Where the bound holds.
    fn in_domain(&self, n: Vec3) -> bool {
        let _ = n;
        true
    }
    /// See [`NormalCodec::is_idempotent`] (`q` is the storage). Default: exact for snorm/unorm storage; not for
    /// f16, whose resolution near 0 (down to 2^-24) is finer than the absolute f32 rounding of the projection
    /// arithmetic, so re-encoding a decoded normal can move a tiny coordinate by an f16 ulp (within the bound);
    /// nor for unorm `p·0.5 + 0.5`, whose grid has no 0: a corner of the octahedral fold decodes to x = 0 and
    /// re-encodes one code away (within the bound).
    fn is_idempotent(&self, q: Quant) -> bool {
        matches!(q, Quant::Snorm(_) | Quant::Unorm(_))
    }
}

/// A projection followed by a quantizer: the shape of every two-component normal codec.
#[derive(Clone, Copy, Debug)]
pub struct Planar<P: Projection> {
    proj: P,
    quant: Quant,
}

impl<P: Projection> Planar<P> {
    /// The codec for a projection and a quantizer.
    #[must_use]
    pub fn new(proj: P, quant: Quant) -> Self {
        Planar { proj, quant }
    }

    /// The projection.
    #[must_use]
    pub fn projection(&self) -> P {
        self.proj
    }

    /// The storage of the plane coordinates.
    #[must_use]
    pub fn quant(&self) -> Quant {
        self.quant
    }

    /// The two stored plane coordinates of a code.
    #[inline(always)]
    #[must_use]
    pub fn plane_of(&self, code: u64) -> Vec2 {
        let k = self.quant.bits();
        Vec2::new(self.quant.decode(code), self.quant.decode(code >> k))
    }
}

impl<P: Projection> Planar<P> {
    /// The per-element encode body shared by the scalar and slice paths (two coordinates of ≤ 16 bits: the
    /// code fits in 32 bits, which keeps the vectorised loop in 32-bit lanes).
    #[inline(always)]
    fn encode32<Q: Quantizer>(proj: P, q: Q, n: Vec3) -> u32 {
        let p = proj.encode_plane(sanitize(n));
        q.enc(p.x) | (q.enc(p.y) << q.bits())
    }

    #[inline(always)]
    fn encode_with<Q: Quantizer>(proj: P, q: Q, n: Vec3) -> u64 {
        u64::from(Self::encode32(proj, q, n))
    }

    /// The per-element decode body shared by the scalar and slice paths (only the low 32 bits matter).
    #[inline(always)]
    fn decode32<Q: Quantizer>(proj: P, q: Q, c: u32) -> Vec3 {
        finish(proj.decode_plane(Vec2::new(q.dec(c), q.dec(c >> q.bits()))))
    }

    #[inline(always)]
    fn decode_with<Q: Quantizer>(proj: P, q: Q, code: u64) -> Vec3 {
        Self::decode32(proj, q, code as u32)
    }
}

/// The per-element bodies of a [`Planar`] codec for one quantizer, as [`BlockElement`]s: blocks of [`BLOCK`]
/// normals are split into x, y, z arrays first so the arithmetic runs on unit-stride lanes.
#[derive(Clone, Copy)]
struct PlanarBody<P, Q> {
    proj: P,
    q: Q,
}

impl<P: Projection, Q: Quantizer> BlockElement<Vec3, u64> for PlanarBody<P, Q> {
    #[inline(always)]
    fn apply(&self, n: &Vec3) -> u64 {
        Planar::encode_with(self.proj, self.q, *n)
    }
    #[inline(always)]
    fn apply_block(&self, i: &[Vec3], o: &mut [u64]) {
        let (x, y, z) = split_block(i);
        // 32-bit codes first (16 f32 lanes per AVX-512 vector instead of 8), widened afterwards.
        let mut c = [0u32; BLOCK];
        for j in 0..BLOCK {
            c[j] = Planar::encode32(self.proj, self.q, Vec3::new(x[j], y[j], z[j]));
        }
        for j in 0..BLOCK {
            o[j] = u64::from(c[j]);
        }
    }
}

impl<P: Projection, Q: Quantizer> BlockElement<u64, Vec3> for PlanarBody<P, Q> {
    #[inline(always)]
    fn apply(&self, c: &u64) -> Vec3 {
        Planar::decode_with(self.proj, self.q, *c)
    }
    #[inline(always)]
    fn apply_block(&self, c: &[u64], o: &mut [Vec3]) {
        let mut c32 = [0u32; BLOCK];
        for j in 0..BLOCK {
            c32[j] = c[j] as u32;
        }
        let (mut x, mut y, mut z) = ([0f32; BLOCK], [0f32; BLOCK], [0f32; BLOCK]);
        for j in 0..BLOCK {
            let v = Planar::decode32(self.proj, self.q, c32[j]);
            (x[j], y[j], z[j]) = (v.x, v.y, v.z);
        }
        join_block(&x, &y, &z, o);
    }
}

/// One block of vectors as three component arrays.
#[inline(always)]
pub(crate) fn split_block(v: &[Vec3]) -> ([f32; BLOCK], [f32; BLOCK], [f32; BLOCK]) {
    let (mut x, mut y, mut z) = ([0f32; BLOCK], [0f32; BLOCK], [0f32; BLOCK]);
    for (j, n) in v[..BLOCK].iter().enumerate() {
        (x[j], y[j], z[j]) = (n.x, n.y, n.z);
    }
    (x, y, z)
}

/// Three component arrays back into one block of vectors.
#[inline(always)]
pub(crate) fn join_block(x: &[f32; BLOCK], y: &[f32; BLOCK], z: &[f32; BLOCK], out: &mut [Vec3]) {
    for (j, o) in out[..BLOCK].iter_mut().enumerate() {
        *o = Vec3::new(x[j], y[j], z[j]);
    }
}

impl<P: Projection + std::fmt::Debug> Codec for Planar<P> {
    type Value = Vec3;
    fn name(&self) -> String {
        let storage = if matches!(self.quant, Quant::UnormSigned(_)) { "-unorm" } else { "" };
        format!("{}{storage}-{}", self.proj.scheme_name(self.quant), self.bits())
    }
    fn bits(&self) -> u32 {
        2 * self.quant.bits()
    }
    #[inline]
    fn encode(&self, n: Vec3) -> u64 {
        with_quantizer!(self.quant, |q| Self::encode_with(self.proj, q, n))
    }
    #[inline]
    fn decode(&self, code: u64) -> Vec3 {
        with_quantizer!(self.quant, |q| Self::decode_with(self.proj, q, code))
    }
    fn decode_ops(&self) -> u32 {
        // A shift splits the code, two coordinates dequantize, the projection inverts, `finish` normalises.
        1 + 2 * self.quant.decode_ops() + self.proj.decode_ops() + FINISH_OPS
    }
    fn recipe(&self) -> Option<crate::codec::Recipe> {
        self.proj.plane_map().map(|map| crate::codec::Recipe::NormalPlanar { map, quant: self.quant })
    }
    fn encode_slice_isa(&self, isa: Isa, input: &[Vec3], out: &mut [u64]) {
        assert_eq!(input.len(), out.len(), "encode_slice: {} normals into {} codes", input.len(), out.len());
        with_quantizer!(self.quant, |q| run(
            isa,
            BlockKernel(MapKernel { input, out, f: PlanarBody { proj: self.proj, q } })
        ))
    }
    fn decode_slice_isa(&self, isa: Isa, codes: &[u64], out: &mut [Vec3]) {
        assert_eq!(codes.len(), out.len(), "decode_slice: {} codes into {} normals", codes.len(), out.len());
        let input = codes;
        with_quantizer!(self.quant, |q| run(
            isa,
            BlockKernel(MapKernel { input, out, f: PlanarBody { proj: self.proj, q } })
        ))
    }
}

impl<P: Projection + std::fmt::Debug> NormalCodec for Planar<P> {
    fn max_error_deg(&self) -> f32 {
        let h = self.quant.half_step(self.proj.plane_extent());
        (self.proj.bound_rad(h, h, self.quant) + FLOAT_SLACK_RAD).to_degrees().min(180.0)
    }
    fn in_domain(&self, n: Vec3) -> bool {
        self.proj.in_domain(n)
    }
    fn is_idempotent(&self) -> bool {
        self.proj.is_idempotent(self.quant)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registry_round_trips_every_scheme_and_bit_count() {
        for s in NormalScheme::ALL {
            assert_eq!(NormalScheme::from_name(s.name()), Some(s));
            for b in s.valid_bits() {
                let name = format!("{}-{b}", s.name());
                let c = normal_codec(&name).unwrap_or_else(|| panic!("{name} missing"));
                assert_eq!(c.name(), name);
                assert_eq!(c.bits(), b);
            }
            assert!(s.codec(s.valid_bits()[0] + 1).is_none() || s.components() == 1);
        }
        for name in ["oct-16", "oct-precise-24", "spheremap-cry-16", "lambert-20", "spherical-16", "stereo-16"] {
            assert!(normal_codec(name).is_some(), "{name}");
        }
        for name in ["lambert-sphere-16", "lambert-sphere-32", "stereo-sphere-20", "stereo-sphere-24"] {
            assert!(normal_codec(name).is_some(), "{name}");
        }
        for name in ["xyz-snorm-30", "xy-hemi-16", "xyz-f16-48", "oct-f16-32", "spheremap-ispc-32"] {
            assert!(normal_codec(name).is_some(), "{name}");
        }
        for name in ["oct-15", "oct-f16-16", "oct", "xyz-snorm-32", "nope-16", "oct-0", "oct-99999999999"] {
            assert!(normal_codec(name).is_none(), "{name}");
        }
        for name in ["lambert-sphere-f16-32", "stereo-sphere-15", "lambert-sphere"] {
            assert!(normal_codec(name).is_none(), "{name}");
        }
    }

    #[test]
    fn sanitize_handles_degenerate_input() {
        assert_eq!(sanitize(Vec3::ZERO), Vec3::Z);
        assert_eq!(sanitize(Vec3::new(-0.0, -0.0, -0.0)), Vec3::Z);
        assert_eq!(sanitize(Vec3::new(f32::NAN, 1.0, 0.0)), Vec3::Z);
        assert_eq!(sanitize(Vec3::new(f32::INFINITY, 1.0, 0.0)), Vec3::X);
        assert_eq!(sanitize(Vec3::new(0.0, f32::NEG_INFINITY, 5.0)), Vec3::NEG_Y);
        let big = sanitize(Vec3::new(1e30, 1e30, 0.0));
        assert!((big - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6, "{big}");
        let tiny = sanitize(Vec3::new(0.0, 1e-40, -1e-40));
        assert!((tiny - Vec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-6, "{tiny}");
    }

    #[test]
    fn snorm_quantizer_matches_d3d_semantics() {
        let q = Quant::Snorm(8);
        assert_eq!(q.encode(1.0), 127);
        assert_eq!(q.encode(-1.0), 0x81);
        assert_eq!(q.encode(0.0), 0);
        assert_eq!(q.encode(-0.0), 0);
        assert_eq!(q.decode(0x80), -1.0); // −128 clamps to −1
        assert_eq!(q.decode(0x81), -1.0);
        assert_eq!(q.decode(0x17f), 1.0); // high bits ignored
        let u = Quant::Unorm(10);
        assert_eq!(u.encode(2.0), 1023);
        assert_eq!(u.decode(1023), 1.0);
        assert_eq!(Quant::F16.encode(1e9), u64::from(half::f16::MAX.to_bits()));
        assert_eq!(Quant::F16.decode(0x7c00), F16_MAX); // +Inf bits
        assert_eq!(Quant::F16.decode(0x7e00), 0.0); // NaN bits
    }

    #[test]
    fn round_half_away_matches_round() {
        let mut rng = crate::base::rng::SplitMix64::new(5);
        for v in [0.5f32, -0.5, 1.5, -2.5, 0.499_999_97, -0.499_999_97, 0.0, -0.0, 32767.5, 1e7 + 0.5] {
            assert_eq!(round_half_away(v), v.round() as i32, "{v}");
        }
        for _ in 0..100_000 {
            let v = rng.range_f32(-70_000.0, 70_000.0);
            assert_eq!(round_half_away(v), v.round() as i32, "{v}");
        }
    }

    #[test]
    fn round_half_away_f64_matches_round() {
        let mut rng = crate::base::rng::SplitMix64::new(6);
        let specials =
            [0.5f64, -0.5, 1.5, -2.5, 0.499_999_999_999_999_94, 16_777_214.5, 16_777_215.0, 8_388_606.5, 0.0];
        for v in specials.into_iter().chain([-0.0, 1e-300, -8_388_607.5]) {
            assert_eq!(round_half_away_f64(v), v.round() as i32, "{v}");
        }
        for _ in 0..100_000 {
            let v = f64::from(rng.range_f32(-1.0, 1.0)) * f64::from(rng.range_f32(0.0, 16_777_215.0));
            assert_eq!(round_half_away_f64(v), v.round() as i32, "{v}");
            assert_eq!(round_in_range_f64(v), v.round() as i32, "{v}");
            let k = (rng.next_u64() % (1 << 24)) as f64 + 0.5;
            assert_eq!(round_half_away_f64(k), k.round() as i32, "{k}");
        }
    }

    /// The unchecked roundings are safe on every input (NaN, ±Inf, beyond ±2^24, the extremes of f32/f64) and
    /// equal to the saturating roundings on their documented range (every f32 of a dense sweep up to 2^24).
    #[test]
    fn in_range_roundings_are_total() {
        const LIMIT: i32 = 1 << 24;
        for v in [f64::NAN, -f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MAX, f64::MIN, 1e30, -1e30, 3e9, -3e9] {
            let want = if v.is_nan() {
                0
            } else if v > 0.0 {
                LIMIT
            } else {
                -LIMIT
            };
            assert_eq!(round_in_range_f64(v), want, "{v}");
        }
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, f32::MIN, 1e30, -1e30, 3e9, -3e9] {
            let want = if v.is_nan() {
                0
            } else if v > 0.0 {
                LIMIT
            } else {
                -LIMIT
            };
            assert_eq!(round_in_range(v), want, "{v}");
        }
        let mut v = 0.25f32;
        while v <= 16_777_216.0 {
            for x in [v, -v, v + 0.5, -v - 0.5] {
                assert_eq!(round_in_range(x), round_half_away(x), "{x}");
                assert_eq!(round_in_range_f64(f64::from(x)), round_half_away_f64(f64::from(x)), "{x}");
            }
            v = v * 1.0009 + 0.25;
        }
    }

    #[test]
    fn angle_is_accurate_for_tiny_angles() {
        let a = Vec3::Z;
        let b = Vec3::new(1e-6, 0.0, 1.0).normalize();
        let d = angle_deg(a, b);
        assert!((d - 1e-6f32.to_degrees()).abs() < 1e-9, "{d}");
        assert_eq!(angle_deg(Vec3::ZERO, a), 180.0);
    }
}
