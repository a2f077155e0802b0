//! Depth codecs: linear view depth in floats, or post-projection depth in unorm/float render targets.
//!
//! | name | bits | stores | domain | source |
//! |---|---|---|---|---|
//! | `f32` | 32 | view depth z | [f32::MIN_POSITIVE, f32::MAX] | R32F linear depth |
//! | `f16` | 16 | view depth z | [2^-24, 65504] | R16F linear depth |
//! | `unorm16`, `unorm24` | 16, 24 | d = f/(f−n)·(1 − n/z) | [n, f] | D3D depth (D16, D24S8) |
//! | `unorm16-reversed`, `unorm24-reversed` | 16, 24 | d = n/(f−n)·(f/z − 1) | [n, f] | reversed Z in a unorm buffer |
//! | `f32-reversed` | 32 | reversed d as f32 | [n, f] | D32F reversed Z (Reed, "Depth Precision Visualized", 2015) |
//! | `f32-standard` | 32 | standard d as f32 | [n, f] | D32F, for comparison: float precision is wasted near d = 1 |
//!
//! Error bound: exact for the linear f32; |z|·2^-11 + 2^-25 for f16; for post-projection storage, the
//! change in z when d moves by half a step (half an ulp of d for f32), evaluated exactly at the given depth
//! through the inverse projection, plus f32 rounding of the result. Precision of the standard mapping collapses
//! towards the far plane: with n = 0.1, f = 1000, unorm16 errs by ≈ 7% of z at the far plane, unorm24 by 0.03%.
//!
//! Defined results: NaN encodes as the far plane (the conventional "no surface"); +Inf and depths beyond the far
//! plane clamp to it; zero, negative depths and −Inf clamp to the near plane (linear codecs: to their smallest
//! positive value). Every decode is finite and positive.

use super::normal::{f16_to_finite, round_in_range_f64, F16_MAX, F16_TO_FINITE_OPS};
use super::simd::f32_to_f16_bits;
use super::{mask, Codec, DepthCodec};
use crate::camera::Camera;
use glam::{Vec2, Vec3};

/// Every valid name (for error messages).
pub const VALID_NAMES: &[&str] =
    &["f32", "f16", "unorm16", "unorm24", "unorm16-reversed", "unorm24-reversed", "f32-reversed", "f32-standard"];

/// Looks a depth codec up by name; `None` for unknown names or planes that are not finite with
/// 0 < znear < zfar.
#[must_use]
pub fn depth_codec(name: &str, znear: f32, zfar: f32) -> Option<Box<dyn DepthCodec>> {
    if !(znear.is_finite() && zfar.is_finite() && znear > 0.0 && zfar > znear) {
        return None;
    }
    let pp = |storage, reversed| -> Option<Box<dyn DepthCodec>> {
        Some(Box::new(PostProjection { n: f64::from(znear), f: f64::from(zfar), storage, reversed }))
    };
    match name {
        "f32" => Some(Box::new(LinearF32 { zfar })),
        "f16" => Some(Box::new(LinearF16 { zfar })),
        "unorm16" => pp(DepthStorage::Unorm(16), false),
        "unorm24" => pp(DepthStorage::Unorm(24), false),
        "unorm16-reversed" => pp(DepthStorage::Unorm(16), true),
        "unorm24-reversed" => pp(DepthStorage::Unorm(24), true),
        "f32-reversed" => pp(DepthStorage::F32, true),
        "f32-standard" => pp(DepthStorage::F32, false),
        _ => None,
    }
}

/// View-space position from a depth code: the camera ray through pixel coordinate `px` scaled to the decoded
/// depth (see [`Camera::view_position`]).
#[must_use]
pub fn reconstruct_position(
    camera: &Camera,
    codec: &dyn DepthCodec,
    code: u64,
    px: Vec2,
    width: u32,
    height: u32,
) -> Vec3 {
    camera.view_position(px, codec.decode(code), width, height)
}

/// Linear view depth in f32.
#[derive(Clone, Copy, Debug)]
pub struct LinearF32 {
    zfar: f32,
}

impl Codec for LinearF32 {
    type Value = f32;
    fn name(&self) -> String {
        "f32".into()
    }
    fn bits(&self) -> u32 {
        32
    }
    #[inline(always)]
    fn encode(&self, depth: f32) -> u64 {
        let z = if depth.is_nan() { self.zfar } else { depth.clamp(f32::MIN_POSITIVE, f32::MAX) };
        u64::from(z.to_bits())
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        let z = f32::from_bits(code as u32);
        if z.is_nan() {
            self.zfar
        } else {
            z.clamp(f32::MIN_POSITIVE, f32::MAX)
        }
    }
    fn decode_ops(&self) -> u32 {
        // from_bits is free; NaN compare, select, clamp
        3
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::DepthLinearF32)
    }
}

impl DepthCodec for LinearF32 {
    fn error_bound(&self, _depth: f32) -> f32 {
        0.0
    }
}

/// Linear view depth in f16.
#[derive(Clone, Copy, Debug)]
pub struct LinearF16 {
    zfar: f32,
}

const F16_MIN_POSITIVE: f32 = 5.960_464_5e-8; // 2^-24, the smallest subnormal

impl Codec for LinearF16 {
    type Value = f32;
    fn name(&self) -> String {
        "f16".into()
    }
    fn bits(&self) -> u32 {
        16
    }
    #[inline(always)]
    fn encode(&self, depth: f32) -> u64 {
        let z = if depth.is_nan() { self.zfar } else { depth };
        u64::from(f32_to_f16_bits(z.clamp(F16_MIN_POSITIVE, F16_MAX)))
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        f16_to_finite((code & 0xffff) as u16).clamp(F16_MIN_POSITIVE, F16_MAX)
    }
    fn decode_ops(&self) -> u32 {
        // and, f16_to_finite, clamp
        2 + F16_TO_FINITE_OPS
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::DepthLinearF16)
    }
}

impl DepthCodec for LinearF16 {
    fn domain(&self) -> (f32, f32) {
        (F16_MIN_POSITIVE, F16_MAX)
    }
    fn error_bound(&self, depth: f32) -> f32 {
        depth.abs() * 2f32.powi(-11) + 2f32.powi(-25)
    }
}

/// How post-projection depth is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthStorage {
    /// Unsigned normalized integer of k bits.
    Unorm(u32),
    /// IEEE single float.
    F32,
}

/// Post-projection depth d ∈ [0, 1] of a perspective projection with planes n, f; arithmetic in f64.
#[derive(Clone, Copy, Debug)]
pub struct PostProjection {
    n: f64,
    f: f64,
    storage: DepthStorage,
    reversed: bool,
}

impl PostProjection {
    /// d of a view depth already clamped to [n, f].
    #[inline(always)]
    fn d_of(&self, z: f64) -> f64 {
        let (n, f) = (self.n, self.f);
        let d = if self.reversed { n / (f - n) * (f / z - 1.0) } else { f / (f - n) * (1.0 - n / z) };
        d.clamp(0.0, 1.0)
    }
    /// View depth of d ∈ [0, 1].
    #[inline(always)]
    fn z_of(&self, d: f64) -> f64 {
        let (n, f) = (self.n, self.f);
        let d = d.clamp(0.0, 1.0);
        let z = if self.reversed { n * f / (n + d * (f - n)) } else { n * f / (f - d * (f - n)) };
        z.clamp(n, f)
    }
    #[inline(always)]
    fn clamp_depth(&self, depth: f32) -> f64 {
        if depth.is_nan() {
            self.f
        } else {
            f64::from(depth).clamp(self.n, self.f)
        }
    }
    /// Largest |stored d − exact d| for this d.
    fn half_step(&self, d: f64) -> f64 {
        match self.storage {
            DepthStorage::Unorm(k) => 0.5 / mask(k) as f64,
            DepthStorage::F32 => {
                let df = d as f32;
                f64::from(f32::from_bits(df.to_bits() + 1) - df) * 0.5
            }
        }
    }
}

impl Codec for PostProjection {
    type Value = f32;
    fn name(&self) -> String {
        let base = match self.storage {
            DepthStorage::Unorm(k) => format!("unorm{k}"),
            DepthStorage::F32 if self.reversed => return "f32-reversed".into(),
            DepthStorage::F32 => return "f32-standard".into(),
        };
        if self.reversed {
            format!("{base}-reversed")
        } else {
            base
        }
    }
    fn bits(&self) -> u32 {
        match self.storage {
            DepthStorage::Unorm(k) => k,
            DepthStorage::F32 => 32,
        }
    }
    #[inline(always)]
    fn encode(&self, depth: f32) -> u64 {
        let d = self.d_of(self.clamp_depth(depth));
        match self.storage {
            // d·mask < 2^24: i32 lanes hold it (and vectorise).
            DepthStorage::Unorm(k) => round_in_range_f64(d * mask(k) as f64) as u64,
            DepthStorage::F32 => u64::from((d as f32).to_bits()),
        }
    }
    #[inline(always)]
    fn decode(&self, code: u64) -> f32 {
        let d = match self.storage {
            DepthStorage::Unorm(k) => f64::from((code & mask(k)) as i32) / mask(k) as f64,
            DepthStorage::F32 => {
                let d = f32::from_bits(code as u32);
                // NaN reads as the far plane, like NaN input.
                if d.is_nan() {
                    self.d_of(self.f)
                } else {
                    f64::from(d)
                }
            }
        };
        self.z_of(d) as f32
    }
    fn decode_ops(&self) -> u32 {
        // unorm: and, int→f64, div (3); f32: NaN compare, select, f32→f64 (3; d_of(f) is a constant);
        // z_of: clamp, mul, add or sub, div (n·f and f − n are constants), clamp (5); f64→f32 (1)
        9
    }
    fn recipe(&self) -> Option<super::Recipe> {
        Some(super::Recipe::DepthPost { storage: self.storage, reversed: self.reversed })
    }
}

impl DepthCodec for PostProjection {
    fn domain(&self) -> (f32, f32) {
        (self.n as f32, self.f as f32)
    }
    fn error_bound(&self, depth: f32) -> f32 {
        let z = self.clamp_depth(depth);
        let d = self.d_of(z);
        let h = self.half_step(d);
        let e = (self.z_of(d - h) - z).abs().max((self.z_of(d + h) - z).abs());
        (e + z * 2f64.powi(-23)) as f32
    }
    fn clear_code(&self) -> u64 {
        self.encode(f32::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clear_codes_are_the_far_plane_or_zero() {
        let code = |n: &str| depth_codec(n, 0.1, 100.0).unwrap().clear_code();
        assert_eq!(code("unorm24"), (1 << 24) - 1);
        assert_eq!(code("unorm16"), (1 << 16) - 1);
        assert_eq!(code("f32-standard"), u64::from(1f32.to_bits()));
        for n in ["unorm24-reversed", "unorm16-reversed", "f32-reversed", "f32", "f16"] {
            assert_eq!(code(n), 0, "{n}");
        }
    }

    #[test]
    fn planes_map_to_the_ends_of_the_range() {
        let c = depth_codec("unorm24", 0.1, 100.0).unwrap();
        assert_eq!(c.encode(0.1), 0);
        assert_eq!(c.encode(100.0), mask(24));
        let r = depth_codec("unorm24-reversed", 0.1, 100.0).unwrap();
        assert_eq!(r.encode(0.1), mask(24));
        assert_eq!(r.encode(100.0), 0);
        let f = depth_codec("f32-reversed", 0.1, 100.0).unwrap();
        assert_eq!(f.encode(100.0), 0);
        assert_eq!(f32::from_bits(f.encode(0.1) as u32), 1.0);
        assert!(depth_codec("f32", 0.0, 1.0).is_none());
        assert!(depth_codec("f32", 1.0, f32::INFINITY).is_none());
    }

    #[test]
    fn reversed_float_beats_standard_float_far_away() {
        let rev = depth_codec("f32-reversed", 0.1, 10_000.0).unwrap();
        let std = depth_codec("f32-standard", 0.1, 10_000.0).unwrap();
        let z = 5_000.0;
        let e_rev = (rev.decode(rev.encode(z)) - z).abs();
        let e_std = (std.decode(std.encode(z)) - z).abs();
        assert!(e_rev * 100.0 < e_std.max(1e-3), "reversed {e_rev} vs standard {e_std}");
    }

    #[test]
    fn position_reconstruction_recovers_the_point() {
        let cam = Camera::identity(1.0, 1.5, 0.1, 100.0);
        let c = depth_codec("unorm24", cam.znear, cam.zfar).unwrap();
        let (w, h) = (192, 128);
        let p = Vec3::new(1.5, -0.75, -12.0);
        let px = cam.project(p, w, h).unwrap();
        let q = reconstruct_position(&cam, c.as_ref(), c.encode(-p.z), px, w, h);
        let tol = c.error_bound(12.0) * 2.0 + 1e-4;
        assert!((q - p).length() < tol, "{q} vs {p} (tol {tol})");
    }
}
