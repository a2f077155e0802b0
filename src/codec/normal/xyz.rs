//! xyz: all three components, renormalised on decode.
//!
//! Source: the baseline of every survey; Cigolle et al. 2014 ("snorm8×3", "snorm10×3", JCGT 3(2), table 1).
//! Storages: snorm k bits (D3D SNORM semantics, value `max(s/(2^(k−1)−1), −1)`), unorm k bits storing
//! `n·0.5+0.5` (the RGB normal map), or three half floats.
//!
//! Error bound: every component is off by at most half a step Δ/2, so the stored vector is within √3·Δ/2 of the
//! unit input and the angle is ≤ asin(√3·Δ/2) (Δ = 1/(2^(k−1)−1) for snorm, 2/(2^k−1) for unorm, 2^-10 for f16
//! components ≤ 1): xyz-snorm-24 ≤ 0.391°, xyz-snorm-30 ≤ 0.0973°. Domain: the whole sphere.
//! Not idempotent: renormalising moves the decoded vector off the grid, so re-encoding it can land on a
//! neighbouring code (within the bound). The all-zero snorm code decodes to +Z.

use super::{
    finish, join_block, sanitize, split_block, with_quantizer, NormalCodec, Quant, Quantizer, FINISH_OPS,
    FLOAT_SLACK_RAD,
};
use crate::base::isa::Isa;
use crate::codec::simd::{run, BlockElement, BlockKernel, MapKernel, BLOCK};
use crate::codec::Codec;
use glam::Vec3;

/// How each xyz component is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum XyzStorage {
    /// k-bit snorm of n.
    Snorm(u32),
    /// k-bit unorm of n·0.5+0.5.
    Unorm(u32),
    /// Half float of n.
    F16,
}

/// Three-component normal codec.
#[derive(Clone, Copy, Debug)]
pub struct Xyz {
    storage: XyzStorage,
    quant: Quant,
}

impl Xyz {
    /// The codec for a storage.
    #[must_use]
    pub fn new(storage: XyzStorage) -> Self {
        let quant = match storage {
            XyzStorage::Snorm(k) => Quant::Snorm(k),
            XyzStorage::Unorm(k) => Quant::Unorm(k),
            XyzStorage::F16 => Quant::F16,
        };
        Xyz { storage, quant }
    }
}

/// How a stored component maps to a normal component: identity (snorm, f16) or `v·0.5+0.5` (unorm).
#[inline(always)]
fn n_to_stored(unorm: bool, v: f32) -> f32 {
    if unorm {
        v * 0.5 + 0.5
    } else {
        v
    }
}

#[inline(always)]
fn stored_to_n(unorm: bool, v: f32) -> f32 {
    if unorm {
        v * 2.0 - 1.0
    } else {
        v
    }
}

/// The per-element encode body shared by the scalar and slice paths: the three component codes (each ≤ 16 bits,
/// in 32-bit lanes so the vectorised loop stays 16 lanes wide).
#[inline(always)]
fn encode3<Q: Quantizer>(q: Q, unorm: bool, n: Vec3) -> [u32; 3] {
    let n = sanitize(n);
    let e = |v: f32| q.enc(n_to_stored(unorm, v));
    [e(n.x), e(n.y), e(n.z)]
}

#[inline(always)]
fn join3(k: u32, c: [u32; 3]) -> u64 {
    u64::from(c[0]) | (u64::from(c[1]) << k) | (u64::from(c[2]) << (2 * k))
}

#[inline(always)]
fn encode_with<Q: Quantizer>(q: Q, unorm: bool, n: Vec3) -> u64 {
    join3(q.bits(), encode3(q, unorm, n))
}

/// The per-element decode body shared by the scalar and slice paths, from the three component codes.
#[inline(always)]
fn decode3<Q: Quantizer>(q: Q, unorm: bool, c: [u32; 3]) -> Vec3 {
    let d = |c: u32| stored_to_n(unorm, q.dec(c));
    finish(Vec3::new(d(c[0]), d(c[1]), d(c[2])))
}

#[inline(always)]
fn split3(k: u32, code: u64) -> [u32; 3] {
    [code as u32, (code >> k) as u32, (code >> (2 * k)) as u32]
}

#[inline(always)]
fn decode_with<Q: Quantizer>(q: Q, unorm: bool, code: u64) -> Vec3 {
    decode3(q, unorm, split3(q.bits(), code))
}

/// The per-element bodies of [`Xyz`] for one quantizer, as [`BlockElement`]s (blocks split into component
/// arrays, as for the planar codecs).
#[derive(Clone, Copy)]
struct XyzBody<Q> {
    q: Q,
    unorm: bool,
}

impl<Q: Quantizer> BlockElement<Vec3, u64> for XyzBody<Q> {
    #[inline(always)]
    fn apply(&self, n: &Vec3) -> u64 {
        encode_with(self.q, self.unorm, *n)
    }
    #[inline(always)]
    fn apply_block(&self, i: &[Vec3], o: &mut [u64]) {
        let (q, unorm) = (self.q, self.unorm);
        let k = q.bits();
        let (x, y, z) = split_block(i);
        let (mut cx, mut cy, mut cz) = ([0u32; BLOCK], [0u32; BLOCK], [0u32; BLOCK]);
        for j in 0..BLOCK {
            [cx[j], cy[j], cz[j]] = encode3(q, unorm, Vec3::new(x[j], y[j], z[j]));
        }
        for j in 0..BLOCK {
            o[j] = join3(k, [cx[j], cy[j], cz[j]]);
        }
    }
}

impl<Q: Quantizer> BlockElement<u64, Vec3> for XyzBody<Q> {
    #[inline(always)]
    fn apply(&self, c: &u64) -> Vec3 {
        decode_with(self.q, self.unorm, *c)
    }
    #[inline(always)]
    fn apply_block(&self, c: &[u64], o: &mut [Vec3]) {
        let (q, unorm) = (self.q, self.unorm);
        let k = q.bits();
        let (mut cx, mut cy, mut cz) = ([0u32; BLOCK], [0u32; BLOCK], [0u32; BLOCK]);
        for j in 0..BLOCK {
            [cx[j], cy[j], cz[j]] = split3(k, c[j]);
        }
        let (mut x, mut y, mut z) = ([0f32; BLOCK], [0f32; BLOCK], [0f32; BLOCK]);
        for j in 0..BLOCK {
            let v = decode3(q, unorm, [cx[j], cy[j], cz[j]]);
            (x[j], y[j], z[j]) = (v.x, v.y, v.z);
        }
        join_block(&x, &y, &z, o);
    }
}

impl Xyz {
    fn is_unorm(&self) -> bool {
        matches!(self.storage, XyzStorage::Unorm(_))
    }
}

impl Codec for Xyz {
    type Value = Vec3;
    fn name(&self) -> String {
        match self.storage {
            XyzStorage::Snorm(k) => format!("xyz-snorm-{}", 3 * k),
            XyzStorage::Unorm(k) => format!("xyz-unorm-{}", 3 * k),
            XyzStorage::F16 => "xyz-f16-48".to_string(),
        }
    }
    fn bits(&self) -> u32 {
        3 * self.quant.bits()
    }
    #[inline]
    fn encode(&self, n: Vec3) -> u64 {
        let unorm = self.is_unorm();
        with_quantizer!(self.quant, |q| encode_with(q, unorm, n))
    }
    #[inline]
    fn decode(&self, code: u64) -> Vec3 {
        let unorm = self.is_unorm();
        with_quantizer!(self.quant, |q| decode_with(q, unorm, code))
    }
    fn decode_ops(&self) -> u32 {
        // Two shifts split the code; per component the dequantizer plus, for unorm, `v·2 − 1`; then `finish`.
        let per_component = self.quant.decode_ops() + if self.is_unorm() { 2 } else { 0 };
        2 + 3 * per_component + FINISH_OPS
    }
    fn recipe(&self) -> Option<crate::codec::Recipe> {
        Some(crate::codec::Recipe::NormalXyz { quant: self.quant, unorm: self.is_unorm() })
    }
    fn encode_slice_isa(&self, isa: Isa, input: &[Vec3], out: &mut [u64]) {
        assert_eq!(input.len(), out.len(), "encode_slice: {} normals into {} codes", input.len(), out.len());
        let unorm = self.is_unorm();
        with_quantizer!(self.quant, |q| run(isa, BlockKernel(MapKernel { input, out, f: XyzBody { q, unorm } })))
    }
    fn decode_slice_isa(&self, isa: Isa, codes: &[u64], out: &mut [Vec3]) {
        assert_eq!(codes.len(), out.len(), "decode_slice: {} codes into {} normals", codes.len(), out.len());
        let (input, unorm) = (codes, self.is_unorm());
        with_quantizer!(self.quant, |q| run(isa, BlockKernel(MapKernel { input, out, f: XyzBody { q, unorm } })))
    }
}

impl NormalCodec for Xyz {
    fn max_error_deg(&self) -> f32 {
        // Half a step in n units: unorm steps are twice as large in n = 2v − 1.
        let h = match self.storage {
            XyzStorage::Unorm(_) => 2.0 * self.quant.half_step(1.0),
            _ => self.quant.half_step(1.0),
        };
        ((3f32.sqrt() * h).min(1.0).asin() + FLOAT_SLACK_RAD).to_degrees()
    }
    fn is_idempotent(&self) -> bool {
        false
    }
}
