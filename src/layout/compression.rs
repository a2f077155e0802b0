//! Framebuffer compression, modelled: the bytes a packed render target would occupy once a GPU's lossless block
//! compressor has had it, under three models built from the vendors' **published constraints** — not any vendor's
//! compressor, whose ratios are not published per target. The point is the ranking of layouts and targets, and where
//! it differs from the nominal bytes.
//!
//! Input: a [`Packed`] frame. Output: per target, its nominal bytes and its bytes under each model, with a
//! general-purpose coder's size of the same blocks beside them.
//!
//! Every model codes a block as a base value per component plus, per texel, the difference from the block's
//! smallest value in as many bits as the block's range needs (the delta coding the vendors describe), on the
//! texel's bit fields as stored (floats by their bit patterns), and rounds the result to its output sizes:
//! - `dcc` (AMD Delta Color Compression): independent 256-byte blocks, stored as 64, 128, 192 or 256 bytes; a block
//!   all at the clear value (zero) is a fast clear (no bytes). One metadata byte per block.
//! - `ccs` (Intel Color Control Surface): 128-byte pairs of cache lines, stored as one line (64 bytes) when the
//!   pair's code fits it, else both; zero blocks are fast-cleared. Two metadata bits per pair.
//! - `afbc` (Arm Frame Buffer Compression): 16 × 16 superblocks with a 16-byte header, coded as 4 × 4 sub-blocks in
//!   whole bytes; a superblock of one value is its header alone. Single-sampled targets of at most 32 bits per texel
//!   only ([`super::limits::afbc`]); others report no size.
//!
//! MSAA targets are coded one sample plane at a time (sample `s` of every pixel, as hardware stores a multisampled
//! surface's planes). Beside the models, `zstd`: zstd at its highest level on each 256-byte block, alone. It is a
//! scale, not a bound: it codes bytes, so a smooth gradient that delta coding takes in a few bits per texel costs it
//! more; where a model is below it, the model exploits numeric structure a byte coder does not see.

use super::formats::Format;
use super::pack::Packed;
use serde::Serialize;

/// One model's verdict on one target.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SchemeBytes {
    /// `dcc`, `ccs` or `afbc`.
    pub scheme: &'static str,
    /// Bytes in memory, metadata included; `None` when the scheme cannot hold the target (AFBC with MSAA or wider
    /// than 32 bits).
    pub bytes: Option<u64>,
    /// Blocks coded, and how many of them were fast-cleared or a single value.
    pub blocks: u64,
    /// Blocks stored at their smallest size (fast clear or one value).
    pub cleared: u64,
}

/// One target's compressed sizes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TargetBytes {
    /// Target name.
    pub target: String,
    /// Its format.
    pub format: String,
    /// Uncompressed bytes (`width × height × samples × texel bytes`).
    pub nominal: u64,
    /// Per model.
    pub schemes: Vec<SchemeBytes>,
    /// zstd at its highest level on each 256-byte block alone (a scale, not a bound).
    pub zstd: u64,
}

/// The sizes of every target of `packed` under every model.
#[must_use]
pub fn compressed(packed: &Packed) -> Vec<TargetBytes> {
    packed
        .targets
        .iter()
        .map(|t| {
            let plane = Plane {
                bytes: &t.bytes,
                format: t.format,
                width: packed.width,
                height: packed.height,
                samples: packed.samples,
            };
            let afbc = match super::limits::afbc(t.format, packed.samples) {
                super::limits::Afbc::Never => SchemeBytes { scheme: "afbc", bytes: None, blocks: 0, cleared: 0 },
                _ => plane.afbc(),
            };
            TargetBytes {
                target: t.name.clone(),
                format: t.format.name().to_string(),
                nominal: t.bytes.len() as u64,
                schemes: vec![
                    plane.blocks("dcc", 256, &[64, 128, 192, 256], 1.0),
                    plane.blocks("ccs", 128, &[64, 128], 0.25),
                    afbc,
                ],
                zstd: plane.zstd(),
            }
        })
        .collect()
}

/// One target's bytes and shape.
struct Plane<'a> {
    bytes: &'a [u8],
    format: Format,
    width: u32,
    height: u32,
    samples: u32,
}

/// Texels `w × h` of a block of `bytes` bytes holding texels of `texel` bytes (a power-of-two count, at least 1).
fn block_shape(bytes: usize, texel: usize) -> (u32, u32) {
    let n = (bytes / texel.max(1)).max(1);
    let n = 1usize << (usize::BITS - 1 - n.leading_zeros()); // round down to a power of two
    let log = n.trailing_zeros();
    let w = 1u32 << log.div_ceil(2);
    (w, (n as u32 / w).max(1))
}

impl Plane<'_> {
    /// Texel `(x, y)` of sample plane `s`, as a little-endian word.
    fn texel(&self, x: u32, y: u32, s: u32) -> u128 {
        let tb = self.format.bytes();
        let i = ((y as usize * self.width as usize + x as usize) * self.samples as usize + s as usize) * tb;
        let mut word = [0u8; 16];
        word[..tb].copy_from_slice(&self.bytes[i..i + tb]);
        u128::from_le_bytes(word)
    }

    /// The texels of the block at `(x0, y0)` of `(bw, bh)` texels (clipped to the frame) of sample plane `s`.
    fn block(&self, x0: u32, y0: u32, (bw, bh): (u32, u32), s: u32, out: &mut Vec<u128>) {
        out.clear();
        for y in y0..(y0 + bh).min(self.height) {
            for x in x0..(x0 + bw).min(self.width) {
                out.push(self.texel(x, y, s));
            }
        }
    }

    /// `cost(scratch, x0, y0, sample)` of every block of `shape` (origin `x0, y0` in sample plane `sample`), summed,
    /// with the blocks and those `cost` calls cleared: rows of blocks in parallel on rayon's current pool, a scratch
    /// per thread.
    fn sum(
        &self,
        (bw, bh): (u32, u32),
        cost: impl Fn(&mut Scratch, u32, u32, u32) -> (u64, bool) + Sync,
    ) -> (u64, u64, u64) {
        use rayon::prelude::*;
        let rows: Vec<(u32, u32)> =
            (0..self.samples).flat_map(|s| (0..self.height.div_ceil(bh)).map(move |by| (s, by * bh))).collect();
        rows.par_iter()
            .map_init(Scratch::default, |sc, &(s, y0)| {
                let mut acc = (0u64, 0u64, 0u64);
                for x0 in (0..self.width).step_by(bw as usize) {
                    let (bytes, cleared) = cost(sc, x0, y0, s);
                    acc = (acc.0 + bytes, acc.1 + 1, acc.2 + u64::from(cleared));
                }
                acc
            })
            .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2))
    }

    /// A delta-coded block model of `block_bytes`-byte blocks stored at one of `sizes` (the last: uncompressed), zero
    /// blocks fast-cleared, plus `meta` bytes of metadata per block.
    fn blocks(&self, scheme: &'static str, block_bytes: usize, sizes: &[u64], meta: f64) -> SchemeBytes {
        let tb = self.format.bytes();
        let shape = block_shape(block_bytes, tb);
        let (mut total, blocks, cleared) = self.sum(shape, |sc, x0, y0, s| {
            self.block(x0, y0, shape, s, &mut sc.texels);
            let texels = &sc.texels;
            let raw = (texels.len() * tb) as u64;
            if texels.iter().all(|&t| t == 0) {
                return (0, true);
            }
            let code = delta_bits(self.format, texels).div_ceil(8);
            // The smallest output size that holds the code, scaled to a partial block; else the block as it is.
            let scale = raw as f64 / f64::from(shape.0 * shape.1) / tb as f64;
            let fit = sizes.iter().map(|&z| (z as f64 * scale).ceil() as u64).find(|&z| z >= code);
            (fit.unwrap_or(raw).min(raw), false)
        });
        total += (blocks as f64 * meta).ceil() as u64;
        SchemeBytes { scheme, bytes: Some(total), blocks, cleared }
    }

    /// The AFBC-like model: 16 × 16 superblocks, a 16-byte header each, 4 × 4 sub-blocks in whole bytes (at most
    /// their raw size); a superblock of one value is its header alone.
    fn afbc(&self) -> SchemeBytes {
        let tb = self.format.bytes() as u64;
        let (total, blocks, cleared) = self.sum((16, 16), |sc, x0, y0, s| {
            self.block(x0, y0, (16, 16), s, &mut sc.texels);
            if sc.texels.iter().all(|&t| t == sc.texels[0]) {
                return (16, true);
            }
            let mut bytes = 16;
            for sy in (y0..(y0 + 16).min(self.height)).step_by(4) {
                for sx in (x0..(x0 + 16).min(self.width)).step_by(4) {
                    self.block(sx, sy, (4, 4), s, &mut sc.sub);
                    bytes += delta_bits(self.format, &sc.sub).div_ceil(8).min(sc.sub.len() as u64 * tb);
                }
            }
            (bytes, false)
        });
        SchemeBytes { scheme: "afbc", bytes: Some(total), blocks, cleared }
    }

    /// zstd at its highest level on each 256-byte block of the `dcc` model alone.
    fn zstd(&self) -> u64 {
        let tb = self.format.bytes();
        let shape = block_shape(256, tb);
        self.sum(shape, |sc, x0, y0, s| {
            self.block(x0, y0, shape, s, &mut sc.texels);
            sc.raw.clear();
            for t in &sc.texels {
                sc.raw.extend_from_slice(&t.to_le_bytes()[..tb]);
            }
            let coder =
                sc.coder.get_or_insert_with(|| zstd::bulk::Compressor::new(zstd::zstd_safe::max_c_level()).ok());
            let size = coder.as_mut().and_then(|c| c.compress(&sc.raw).ok()).map_or(sc.raw.len(), |c| c.len());
            (size as u64, false)
        })
        .0
    }
}

/// A thread's buffers while it codes blocks.
#[derive(Default)]
struct Scratch {
    texels: Vec<u128>,
    sub: Vec<u128>,
    raw: Vec<u8>,
    /// The thread's zstd context (`Some(None)`: zstd could not start; blocks then count raw).
    coder: Option<Option<zstd::bulk::Compressor<'static>>>,
}

/// Bits of a block coded as a base per component plus each texel's difference from it in the bits the block's range
/// needs.
fn delta_bits(format: Format, texels: &[u128]) -> u64 {
    let mut bits = 0u64;
    for c in format.components() {
        let mask = if c.bits >= 128 { u128::MAX } else { (1u128 << c.bits) - 1 };
        let (mut lo, mut hi) = (u128::MAX, 0u128);
        for &t in texels {
            let v = (t >> c.offset) & mask;
            (lo, hi) = (lo.min(v), hi.max(v));
        }
        let range = hi.saturating_sub(lo);
        let need = u64::from(u128::BITS - range.leading_zeros());
        bits += u64::from(c.bits) + texels.len() as u64 * need;
    }
    bits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::pack::TargetPlane;

    fn packed(format: Format, w: u32, h: u32, samples: u32, mut texel: impl FnMut(u32, u32, u32) -> u128) -> Packed {
        let tb = format.bytes();
        let mut bytes = Vec::with_capacity((w * h * samples) as usize * tb);
        for y in 0..h {
            for x in 0..w {
                for s in 0..samples {
                    bytes.extend_from_slice(&texel(x, y, s).to_le_bytes()[..tb]);
                }
            }
        }
        Packed {
            layout: "t".into(),
            width: w,
            height: h,
            samples,
            targets: vec![TargetPlane { name: "t".into(), format, bytes }],
            material_table: None,
            depth_range: [0.1, 100.0],
            present: vec![],
        }
    }

    fn bytes(t: &TargetBytes, scheme: &str) -> Option<u64> {
        t.schemes.iter().find(|s| s.scheme == scheme).unwrap().bytes
    }

    #[test]
    fn cleared_targets_cost_metadata_and_noise_costs_its_size() {
        let zero = &compressed(&packed(Format::Rgba8, 64, 32, 1, |_, _, _| 0))[0];
        assert_eq!(zero.nominal, 64 * 32 * 4);
        // 32 DCC blocks of 8 × 8: one metadata byte each; 64 CCS pairs: 2 bits each; 8 AFBC headers.
        assert_eq!((bytes(zero, "dcc"), bytes(zero, "ccs"), bytes(zero, "afbc")), (Some(32), Some(16), Some(8 * 16)));
        let mut rng = crate::base::rng::SplitMix64::new(4);
        let noise = &compressed(&packed(Format::Rgba8, 64, 32, 1, |_, _, _| u128::from(rng.next_u64() as u32)))[0];
        for s in ["dcc", "ccs", "afbc"] {
            let b = bytes(noise, s).unwrap();
            assert!(b >= noise.nominal && b <= noise.nominal + noise.nominal / 8, "{s}: {b} of {}", noise.nominal);
        }
        assert!(noise.zstd >= noise.nominal, "zstd cannot shrink noise: {}", noise.zstd);
    }

    #[test]
    fn smooth_data_compresses_by_the_range_it_spans() {
        // A gradient of 0..63 in red over 8 × 8 blocks: 6 bits per texel for red, constant elsewhere: DCC stores
        // each 256-byte block as 64 bytes, CCS each 128-byte pair as one line.
        let grad = &compressed(&packed(Format::Rgba8, 64, 64, 1, |x, y, _| {
            u128::from((x % 8 + 8 * (y % 8)) as u8) | 0xff00_0000
        }))[0];
        assert_eq!(bytes(grad, "dcc"), Some(64 * 64 + 64));
        assert_eq!(bytes(grad, "ccs"), Some(128 * 64 + 32));
        // AFBC: per 4 × 4 sub-block, 8-bit bases ×4 + 16 texels × (4 red bits… its range) bytes, under the raw 64.
        let afbc = bytes(grad, "afbc").unwrap();
        assert!(afbc < grad.nominal / 2, "{afbc}");
        // MSAA or a wide format: no AFBC.
        let msaa = &compressed(&packed(Format::Rgba8, 16, 16, 4, |_, _, _| 1))[0];
        assert_eq!(bytes(msaa, "afbc"), None);
        assert_eq!(bytes(&compressed(&packed(Format::Rgba16F, 16, 16, 1, |_, _, _| 1))[0], "afbc"), None);
        // A single value that is not the clear value: one base per block, the smallest size.
        let one = &compressed(&packed(Format::Rgba8, 16, 16, 4, |_, _, _| 7))[0];
        assert_eq!(bytes(one, "dcc"), Some(4 * 4 * 64 + 16));
    }

    #[test]
    fn block_shapes_hold_the_block_bytes() {
        for (tb, want) in [(1, (16, 16)), (2, (16, 8)), (4, (8, 8)), (8, (8, 4)), (16, (4, 4)), (3, (8, 8))] {
            assert_eq!(block_shape(256, tb), want, "{tb}");
        }
        assert_eq!(block_shape(128, 4), (8, 4));
    }
}
