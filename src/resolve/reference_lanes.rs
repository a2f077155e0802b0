//! The f64 reference's light loop in lanes: [`LANES`] samples of one tile shaded against each of the tile's lights
//! at once, in structure-of-arrays form, so the compiler turns every operation into one f64 SIMD instruction per
//! lane group (8 lanes: one register on AVX-512, two on AVX2, four on SSE2 and NEON).
//!
//! Every lane evaluates exactly the scalar definition's operations, in the same order and without fused
//! multiply-adds (`brdf::shade`, `falloff`): Lambert and GGX give the scalar reference's bits, and
//! `lanes_equal_the_scalar_definition` checks it. The one difference is `powf` (Blinn-Phong's `(N·H)^p`), which
//! has no SIMD form in libm: [`pow`] here is within [`POW_REL_BOUND`] `· (1 + |y·log2 x|)` of libm's (relative),
//! which is tested, and far below what an f32 image can show.
//!
//! The lanes are the same operations on every instruction set, so the reference is bit-identical across
//! `GBUF_ISA` levels (tested).

use super::brdf::{DIELECTRIC_F0, MIN_ALPHA, MIN_HALF_LENGTH, MIN_NDOTV};
use super::config::{Brdf, Falloff};
use super::falloff::{cone_constants, MIN_DISTANCE, MIN_RAMP_FRACTION};
use super::worklist::Surface;
use crate::base::isa::Isa;
use crate::light::{Light, LightKind};
use std::f64::consts::PI;

/// Samples shaded together.
pub const LANES: usize = 8;

/// One f64 per lane.
type D = [f64; LANES];

/// Relative error bound of [`pow`] against libm's `powf`, per unit of `1 + |y·log2 x|` (the rounding of the
/// exponent grows with its size): tested by `pow_is_within_its_bound_of_libm`.
#[cfg_attr(not(test), allow(dead_code))]
pub const POW_REL_BOUND: f64 = 6e-16;

/// `lanes!([a, b, …] => expr)`: `expr` evaluated lane by lane with each named `D` array bound to its lane's value
/// (a loop the compiler turns into SIMD instructions). A macro, not a function taking a closure: a closure is a
/// separate function the compiler may leave out of line, compiled without the caller's instruction set.
macro_rules! lanes {
    ([$($v:ident),+] => $e:expr) => {{
        let mut out = [0.0f64; LANES];
        for (i, o) in out.iter_mut().enumerate() {
            $(let $v = $v[i];)+
            *o = $e;
        }
        out
    }};
}

/// [`LANES`] surfaces in structure-of-arrays form, with what each sample's shading needs that does not depend on
/// the light, computed as the scalar definition computes it per pair.
struct Block {
    p: [D; 3],
    n: [D; 3],
    albedo: [D; 3],
    /// `−p/|p|`.
    v: [D; 3],
    /// Blinn-Phong: specular power, and `specular · (p + 2) / 8`.
    power: D,
    spec_scale: D,
    /// Lambert: `albedo / π`.
    lambert: [D; 3],
    /// GGX: `α²`, `1 − α²`, `√(N·V² (1 − α²) + α²)`, `N·V`, F0 and the diffuse colour.
    a2: D,
    one_minus_a2: D,
    vis_v: D,
    nv: D,
    f0: [D; 3],
    c_diff: [D; 3],
}

impl Block {
    /// The block of `surfaces` (1 to [`LANES`]); missing lanes repeat the last surface.
    #[inline(always)]
    fn new(surfaces: &[Surface]) -> Block {
        assert!(!surfaces.is_empty() && surfaces.len() <= LANES);
        let last = surfaces.len() - 1;
        let mut p = [[0.0; LANES]; 3];
        let mut n = [[0.0; LANES]; 3];
        let mut albedo = [[0.0; LANES]; 3];
        let (mut power, mut specular, mut roughness, mut metallic) =
            ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for i in 0..LANES {
            let s = &surfaces[i.min(last)];
            for (c, (q, (m, a))) in p.iter_mut().zip(n.iter_mut().zip(albedo.iter_mut())).enumerate() {
                q[i] = f64::from(s.p[c]);
                m[i] = f64::from(s.n[c]);
                a[i] = f64::from(s.albedo[c]);
            }
            power[i] = f64::from(s.power);
            specular[i] = f64::from(s.specular);
            roughness[i] = f64::from(s.roughness);
            metallic[i] = f64::from(s.metallic);
        }
        let [px, py, pz] = p;
        let [nx, ny, nz] = n;
        let [a0, a1, a2c] = albedo;
        let len = lanes!([px, py, pz] => (px * px + py * py + pz * pz).sqrt());
        let v = [lanes!([px, len] => -px / len), lanes!([py, len] => -py / len), lanes!([pz, len] => -pz / len)];
        let [vx, vy, vz] = v;
        let spec_scale = lanes!([specular, power] => specular * (power + 2.0) / 8.0);
        let lambert = [lanes!([a0] => a0 / PI), lanes!([a1] => a1 / PI), lanes!([a2c] => a2c / PI)];
        let a2 = lanes!([roughness] => {
            let alpha = roughness.powi(2).max(f64::from(MIN_ALPHA));
            alpha * alpha
        });
        let one_minus_a2 = lanes!([a2] => 1.0 - a2);
        let nv = lanes!([nx, ny, nz, vx, vy, vz] => (nx * vx + ny * vy + nz * vz).max(f64::from(MIN_NDOTV)));
        let vis_v = lanes!([nv, a2] => (nv * nv * (1.0 - a2) + a2).sqrt());
        let f0d = f64::from(DIELECTRIC_F0);
        let f0 = [
            lanes!([a0, metallic] => f0d * (1.0 - metallic) + a0 * metallic),
            lanes!([a1, metallic] => f0d * (1.0 - metallic) + a1 * metallic),
            lanes!([a2c, metallic] => f0d * (1.0 - metallic) + a2c * metallic),
        ];
        let c_diff = [
            lanes!([a0, metallic] => a0 * (1.0 - metallic)),
            lanes!([a1, metallic] => a1 * (1.0 - metallic)),
            lanes!([a2c, metallic] => a2c * (1.0 - metallic)),
        ];
        Block { p, n, albedo, v, power, spec_scale, lambert, a2, one_minus_a2, vis_v, nv, f0, c_diff }
    }
}

/// What one light needs per pair, computed once as the scalar definition computes it per pair.
#[derive(Clone, Copy, Debug)]
pub struct LightLanes {
    positional: bool,
    /// Position (positional) or the direction to the light (`−direction`, directional).
    at: [f64; 3],
    range: f64,
    /// glTF falloff: `1 / range⁴` (0 for an unbounded light).
    inv_r4: f64,
    /// Linear falloff: the ramp's end is finite, and its width.
    linear_bounded: bool,
    width: f64,
    /// Spot: axis, and the cone's `(scale, offset)`.
    spot: Option<([f64; 3], f64, f64)>,
    /// Colour × intensity.
    c: [f64; 3],
}

impl LightLanes {
    /// The constants of a sanitized punctual light.
    #[must_use]
    pub fn new(light: &Light) -> LightLanes {
        let (positional, at) = match light.kind {
            LightKind::Directional { direction } => (false, (-direction.as_dvec3()).to_array()),
            _ => (true, light.position.as_dvec3().to_array()),
        };
        let range = f64::from(light.range);
        let begin = f64::from(light.begin);
        let spot = match light.kind {
            LightKind::Spot { direction, inner_cone_angle, outer_cone_angle } => {
                let (scale, offset) = cone_constants(inner_cone_angle, outer_cone_angle);
                Some((direction.as_dvec3().to_array(), f64::from(scale), f64::from(offset)))
            }
            _ => None,
        };
        let c = (light.color.as_dvec3() * f64::from(light.intensity)).to_array();
        LightLanes {
            positional,
            at,
            range,
            inv_r4: if range.is_finite() { 1.0 / range.powi(4) } else { 0.0 },
            linear_bounded: range.is_finite(),
            width: (range - begin).max(range * f64::from(MIN_RAMP_FRACTION)),
            spot,
            c,
        }
    }
}

/// What each light of `lights` sends towards the eye from each of `surfaces` (1 to [`LANES`]), summed per channel
/// in the lights' order as `brdf::shade` would sum them pair by pair; lanes past `surfaces.len()` are to be
/// ignored. `isa` caps the instruction set (`None`: the portable lanes).
#[must_use]
pub fn shade(isa: Option<Isa>, surfaces: &[Surface], lights: &[LightLanes], brdf: Brdf, falloff: Falloff) -> [D; 3] {
    /// [`shade_lanes`] under [`crate::base::isa::run`].
    struct ShadeKernel<'a> {
        surfaces: &'a [Surface],
        lights: &'a [LightLanes],
        brdf: Brdf,
        falloff: Falloff,
    }
    impl crate::base::isa::Kernel for ShadeKernel<'_> {
        type Output = [D; 3];
        #[inline(always)]
        fn run(self, _: Isa) -> [D; 3] {
            shade_lanes(self.surfaces, self.lights, self.brdf, self.falloff)
        }
    }
    crate::base::isa::run(isa.unwrap_or(Isa::Baseline), ShadeKernel { surfaces, lights, brdf, falloff })
}

#[inline(always)]
fn shade_lanes(surfaces: &[Surface], lights: &[LightLanes], brdf: Brdf, falloff: Falloff) -> [D; 3] {
    let b = Block::new(surfaces);
    let mut sum = [[0.0; LANES]; 3];
    match (brdf, falloff) {
        (Brdf::Lambert, Falloff::Gltf) => light_loop::<0, 0>(&b, lights, &mut sum),
        (Brdf::Lambert, Falloff::Linear) => light_loop::<0, 1>(&b, lights, &mut sum),
        (Brdf::BlinnPhong, Falloff::Gltf) => light_loop::<1, 0>(&b, lights, &mut sum),
        (Brdf::BlinnPhong, Falloff::Linear) => light_loop::<1, 1>(&b, lights, &mut sum),
        (Brdf::Ggx, Falloff::Gltf) => light_loop::<2, 0>(&b, lights, &mut sum),
        (Brdf::Ggx, Falloff::Linear) => light_loop::<2, 1>(&b, lights, &mut sum),
    }
    sum
}

/// The light loop for BRDF `B` (0 Lambert, 1 Blinn-Phong, 2 GGX) and falloff `F` (0 glTF, 1 linear).
#[inline(always)]
fn light_loop<const B: u8, const F: u8>(b: &Block, lights: &[LightLanes], sum: &mut [D; 3]) {
    let [px, py, pz] = b.p;
    let [nx, ny, nz] = b.n;
    let [vx, vy, vz] = b.v;
    let (spec_scale, power, a2, one_minus_a2, vis_v, nv) = (b.spec_scale, b.power, b.a2, b.one_minus_a2, b.vis_v, b.nv);
    for l in lights {
        // pair_geometry: the vector to the light and its length.
        let [ax, ay, az] = l.at;
        let (lvx, lvy, lvz) = if l.positional {
            (lanes!([px] => ax - px), lanes!([py] => ay - py), lanes!([pz] => az - pz))
        } else {
            ([ax; LANES], [ay; LANES], [az; LANES])
        };
        let d = lanes!([lvx, lvy, lvz] => (lvx * lvx + lvy * lvy + lvz * lvz).sqrt());
        // Out of range: exactly 0 for both falloffs; the scalar definition returns early.
        let range = l.range;
        let live = if l.positional { lanes!([d] => if d < range { 1.0 } else { 0.0 }) } else { [1.0; LANES] };
        if live.iter().all(|&x| x == 0.0) {
            continue;
        }
        let dl = lanes!([d] => d.max(f64::from(MIN_DISTANCE)));
        let lx = lanes!([lvx, dl] => lvx / dl);
        let ly = lanes!([lvy, dl] => lvy / dl);
        let lz = lanes!([lvz, dl] => lvz / dl);
        let mut e = if !l.positional {
            [1.0; LANES]
        } else if F == 0 {
            let inv_r4 = l.inv_r4;
            lanes!([dl] => {
                let window = (1.0 - dl.powi(4) * inv_r4).clamp(0.0, 1.0);
                window * window / (dl * dl)
            })
        } else if l.linear_bounded {
            let width = l.width;
            lanes!([dl] => ((range - dl) / width).clamp(0.0, 1.0))
        } else {
            [1.0; LANES]
        };
        if let Some(([sx, sy, sz], scale, offset)) = l.spot {
            e = lanes!([e, lx, ly, lz] => {
                let t = (-(sx * lx + sy * ly + sz * lz) * scale + offset).clamp(0.0, 1.0);
                e * (t * t)
            });
        }
        let [cr, cg, cb] = l.c;
        let (rr, rg, rb) = (lanes!([e] => cr * e), lanes!([e] => cg * e), lanes!([e] => cb * e));
        let ndl = lanes!([nx, ny, nz, lx, ly, lz] => (nx * lx + ny * ly + nz * lz).max(0.0));
        // shade: N·L ≤ 0 (or out of range) adds exactly 0.
        let on = lanes!([live, ndl] => if live != 0.0 && ndl > 0.0 { 1.0 } else { 0.0 });
        if on.iter().all(|&x| x == 0.0) {
            continue;
        }
        let [s0, s1, s2] = sum;
        let (c0, c1, c2) = if B == 0 {
            let [a0, a1, a2] = b.lambert;
            (
                lanes!([a0, rr, ndl] => a0 * rr * ndl),
                lanes!([a1, rg, ndl] => a1 * rg * ndl),
                lanes!([a2, rb, ndl] => a2 * rb * ndl),
            )
        } else {
            let hx = lanes!([lx, vx] => lx + vx);
            let hy = lanes!([ly, vy] => ly + vy);
            let hz = lanes!([lz, vz] => lz + vz);
            let hl = lanes!([hx, hy, hz] => (hx * hx + hy * hy + hz * hz).sqrt().max(f64::from(MIN_HALF_LENGTH)));
            let (hx, hy, hz) = (lanes!([hx, hl] => hx / hl), lanes!([hy, hl] => hy / hl), lanes!([hz, hl] => hz / hl));
            let ndh = lanes!([nx, ny, nz, hx, hy, hz] => (nx * hx + ny * hy + nz * hz).max(0.0));
            if B == 1 {
                let k = lanes!([ndl, spec_scale, ndh, power] => ndl * (1.0 + spec_scale * pow(ndh, power)));
                let [a0, a1, a2] = b.albedo;
                (
                    lanes!([a0, rr, k] => a0 * rr * k),
                    lanes!([a1, rg, k] => a1 * rg * k),
                    lanes!([a2, rb, k] => a2 * rb * k),
                )
            } else {
                let q = lanes!([vx, vy, vz, hx, hy, hz] => (1.0 - (vx * hx + vy * hy + vz * hz).max(0.0)).powi(5));
                let dv = lanes!([ndh, a2, one_minus_a2, ndl, vis_v, nv] => {
                    let t = ndh * ndh * (a2 - 1.0) + 1.0;
                    let d = a2 / (PI * t * t);
                    let vis_den = ndl * vis_v + nv * (ndl * ndl * one_minus_a2 + a2).sqrt();
                    d * (0.5 / vis_den.max(1e-12))
                });
                let [f00, f01, f02] = b.f0;
                let [cd0, cd1, cd2] = b.c_diff;
                let ggx0 = lanes!([f00, q, cd0, dv, rr, ndl] => {
                    let f = f00 + (1.0 - f00) * q;
                    rr * ((1.0 - f) * cd0 / PI + f * dv) * ndl
                });
                let ggx1 = lanes!([f01, q, cd1, dv, rg, ndl] => {
                    let f = f01 + (1.0 - f01) * q;
                    rg * ((1.0 - f) * cd1 / PI + f * dv) * ndl
                });
                let ggx2 = lanes!([f02, q, cd2, dv, rb, ndl] => {
                    let f = f02 + (1.0 - f02) * q;
                    rb * ((1.0 - f) * cd2 / PI + f * dv) * ndl
                });
                (ggx0, ggx1, ggx2)
            }
        };
        for (s, c) in [(s0, c0), (s1, c1), (s2, c2)] {
            for i in 0..LANES {
                s[i] += if on[i] != 0.0 { c[i] } else { 0.0 };
            }
        }
    }
}

/// `1/(2k + 1)`, k = 0..=10: the `atanh` series to below 2⁻⁵⁴ for `|t| ≤ 0.1716`.
const ATANH: [f64; 11] = {
    let mut c = [0.0; 11];
    let mut k = 0;
    while k < 11 {
        c[k] = 1.0 / (2 * k + 1) as f64;
        k += 1;
    }
    c
};

/// `1/k!`, k = 0..=13: the exponential series to below 2⁻⁵⁴ for `|r| ≤ ln 2 / 2`.
const EXP: [f64; 14] = {
    let mut c = [0.0; 14];
    let mut fact = 1.0;
    let mut k = 0;
    while k < 14 {
        if k > 0 {
            fact *= k as f64;
        }
        c[k] = 1.0 / fact;
        k += 1;
    }
    c
};

/// `x^y` in f64 without libm, in operations the compiler vectorises: `2^(y·log2 x)`, with `log2` from the
/// `atanh` series on a mantissa in `[√½, √2)` and `2^f` from its Taylor series on `[−½, ½]`, both to below
/// 2⁻⁵⁴. Within [`POW_REL_BOUND`] `· (1 + |y·log2 x|)` of libm's `powf` (relative) where the result is a
/// normal number; results below 2⁻¹⁰²² are 0. The special cases follow IEEE 754 `pow` for `x ≥ 0`: `x⁰ = 1`,
/// `1^y = 1`, `0^y` is 0 for `y > 0` and ∞ for `y < 0`; a negative or NaN `x` gives NaN.
#[inline(always)]
#[must_use]
pub fn pow(x: f64, y: f64) -> f64 {
    const TWO52: f64 = 4_503_599_627_370_496.0;
    const TWO54: f64 = 18_014_398_509_481_984.0;
    let sub = x < f64::MIN_POSITIVE;
    let xs = if sub { x * TWO54 } else { x };
    let bits = xs.to_bits();
    // The biased exponent as a float without an integer conversion: 2^52 + e, exactly.
    let e = f64::from_bits(0x4330_0000_0000_0000 | ((bits >> 52) & 0x7ff)) - (TWO52 + 1023.0);
    let e = if sub { e - 54.0 } else { e };
    let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = m > std::f64::consts::SQRT_2;
    let m = if big { m * 0.5 } else { m };
    let e = if big { e + 1.0 } else { e };
    // ln m = 2 atanh t = 2 (t + t³/3 + t⁵/5 + …), |t| ≤ 0.1716.
    let t = (m - 1.0) / (m + 1.0);
    let t2 = t * t;
    // Estrin's scheme: a shorter chain of dependent operations than Horner's, for the same terms.
    let c = &ATANH;
    let (u, u2) = (t2, t2 * t2);
    let (u4, u8) = (u2 * u2, u2 * u2 * (u2 * u2));
    let s = (c[0] + c[1] * u)
        + u2 * (c[2] + c[3] * u)
        + u4 * ((c[4] + c[5] * u) + u2 * (c[6] + c[7] * u))
        + u8 * ((c[8] + c[9] * u) + u2 * c[10]);
    let log2m = 2.0 * t * s * std::f64::consts::LOG2_E;
    let z = y * (e + log2m);
    // 2^z = 2^n · e^(f ln 2), n = round(z), |f| ≤ ½.
    // 2^1023 < 2^z < 2^1024 is 2 · 2^(z − 1): the scale 2^n stays a normal number.
    let top = z > 1023.0;
    let zc = if top { z - 1.0 } else { z };
    let zc = if zc > -1022.0 { zc } else { -1022.0 };
    let zc = if zc < 1023.0 { zc } else { 1023.0 };
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52: adding it rounds to an integer
    let tmp = zc + MAGIC;
    let n = tmp - MAGIC;
    let ni = tmp.to_bits().wrapping_sub(MAGIC.to_bits());
    let r = (zc - n) * std::f64::consts::LN_2;
    let c = &EXP;
    let (r2, r4) = (r * r, r * r * (r * r));
    let r8 = r4 * r4;
    let (q0, q2, q4, q6) = (c[0] + c[1] * r, c[2] + c[3] * r, c[4] + c[5] * r, c[6] + c[7] * r);
    let (q8, q10, q12) = (c[8] + c[9] * r, c[10] + c[11] * r, c[12] + c[13] * r);
    let p = (q0 + q2 * r2) + r4 * (q4 + q6 * r2) + r8 * ((q8 + q10 * r2) + r4 * q12);
    let scale = f64::from_bits(ni.wrapping_add(1023) << 52);
    let v = p * scale;
    let v = if top { v * 2.0 } else { v };
    let v = if z < -1022.0 { 0.0 } else { v };
    let v = if z > 1024.0 { f64::INFINITY } else { v };
    let v = if z.is_nan() { f64::NAN } else { v };
    let zero = if y > 0.0 {
        0.0
    } else if y < 0.0 {
        f64::INFINITY
    } else {
        1.0
    };
    let v = if x == 0.0 { zero } else { v };
    let inf = if y > 0.0 {
        f64::INFINITY
    } else if y < 0.0 {
        0.0
    } else {
        1.0
    };
    let v = if x == f64::INFINITY { inf } else { v };
    let v = if x < 0.0 || x.is_nan() { f64::NAN } else { v };
    if y == 0.0 || x == 1.0 {
        1.0
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Relative distance of `got` from libm's `x.powf(y)`, in units of `1 + |y·log2 x|`; 0 when both are equal
    /// (infinities, zeros) and when libm's result is below the normal range (where `pow` gives 0 or a value
    /// within 2⁻¹⁰²² of it).
    fn scaled_error(x: f64, y: f64) -> f64 {
        let (got, want) = (pow(x, y), x.powf(y));
        if got == want || (want.is_nan() && got.is_nan()) {
            return 0.0;
        }
        if want < f64::MIN_POSITIVE && got.abs() <= f64::MIN_POSITIVE {
            return 0.0;
        }
        ((got - want) / want).abs() / (1.0 + (y * x.log2()).abs())
    }

    #[test]
    fn pow_special_cases_follow_ieee() {
        for y in [0.0, -0.0] {
            for x in [0.0, 0.5, 1.0, 7.0, f64::INFINITY, f64::NAN, -2.0] {
                assert_eq!(pow(x, y), 1.0, "{x}^{y}");
            }
        }
        for y in [0.5, 1.0, 3.0, 1e6, f64::INFINITY, f64::NAN, -1.0] {
            assert_eq!(pow(1.0, y), 1.0, "1^{y}");
        }
        assert_eq!(pow(0.0, 2.0), 0.0);
        assert_eq!(pow(0.0, 1e6), 0.0);
        assert_eq!(pow(0.0, -1.0), f64::INFINITY);
        assert_eq!(pow(f64::INFINITY, 2.0), f64::INFINITY);
        assert_eq!(pow(f64::INFINITY, -2.0), 0.0);
        assert!(pow(-0.5, 2.5).is_nan() && pow(f64::NAN, 2.0).is_nan() && pow(0.5, f64::NAN).is_nan());
        // Exact where the exponent is an integer and the result representable: powers of two.
        assert_eq!(pow(0.5, 10.0), 2f64.powi(-10));
        // Just below the top of the range.
        assert!(scaled_error(2.0, 1023.5) <= POW_REL_BOUND && pow(2.0, 1023.5).is_finite());
        // Below the normal range: 0; above it: infinity.
        assert_eq!(pow(0.5, 1100.0), 0.0);
        assert_eq!(pow(2.0, 1100.0), f64::INFINITY);
        // Subnormal bases.
        assert!(scaled_error(1e-310, 0.001) <= POW_REL_BOUND, "{}", scaled_error(1e-310, 0.001));
    }

    /// Blinn-Phong's arguments: N·H in [0, 1] (mostly near 1) and powers up to `MAX_SPECULAR_POWER`; and a wide
    /// sweep of both.
    #[test]
    fn pow_is_within_its_bound_of_libm_on_a_grid() {
        let mut worst = (0.0f64, 0.0, 0.0);
        let mut check = |x: f64, y: f64| {
            let e = scaled_error(x, y);
            if e > worst.0 {
                worst = (e, x, y);
            }
        };
        for i in 0..=2000 {
            let x = f64::from(i) / 2000.0;
            for y in [0.25, 1.0, 2.5, 16.0, 64.0, 255.0, 1000.0, 4096.0, 1e6] {
                check(x, y);
                check(1.0 - x * 1e-6, y);
                check(1.0 + x * 3.0, y);
                check(x * 1e-300, y * 1e-3);
            }
        }
        eprintln!("worst scaled error {:e} at {}^{}", worst.0, worst.1, worst.2);
        assert!(worst.0 <= POW_REL_BOUND, "worst {:e} at {}^{}", worst.0, worst.1, worst.2);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn pow_is_within_its_bound_of_libm(x in 0.0f64..1.5, y in 0.0f64..5000.0) {
            let e = scaled_error(x, y);
            prop_assert!(e <= POW_REL_BOUND, "{x}^{y}: {e:e}");
        }

        #[test]
        fn pow_is_within_its_bound_for_any_exponent(x in 1e-300f64..1e300, y in -64.0f64..64.0) {
            let e = scaled_error(x, y);
            prop_assert!(e <= POW_REL_BOUND, "{x}^{y}: {e:e}");
        }
    }
}
