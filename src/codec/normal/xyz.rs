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

use super::{finish, sanitize, NormalCodec, Quant, FLOAT_SLACK_RAD};
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

    #[inline]
    fn n_to_stored(self, v: f32) -> f32 {
        match self.storage {
            XyzStorage::Unorm(_) => v * 0.5 + 0.5,
            _ => v,
        }
    }

    #[inline]
    fn stored_to_n(self, v: f32) -> f32 {
        match self.storage {
            XyzStorage::Unorm(_) => v * 2.0 - 1.0,
            _ => v,
        }
    }
}

impl NormalCodec for Xyz {
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
        let n = sanitize(n);
        let k = self.quant.bits();
        let q = |v: f32| self.quant.encode(self.n_to_stored(v));
        q(n.x) | (q(n.y) << k) | (q(n.z) << (2 * k))
    }
    #[inline]
    fn decode(&self, code: u64) -> Vec3 {
        let k = self.quant.bits();
        let d = |c: u64| self.stored_to_n(self.quant.decode(c));
        finish(Vec3::new(d(code), d(code >> k), d(code >> (2 * k))))
    }
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
