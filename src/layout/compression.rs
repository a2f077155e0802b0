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
    /// zstd at its highest level on each 256-byte block alone (a scale, not a bound); `None` when not asked for
    /// ([`compressed_models`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zstd: Option<u64>,
}

impl TargetBytes {
    /// Bytes in memory under `scheme`: the model's, or the nominal bytes where the model cannot hold the target (the
    /// hardware then stores it uncompressed).
    #[must_use]
    pub fn stored(&self, scheme: &str) -> u64 {
        self.schemes.iter().find(|s| s.scheme == scheme).and_then(|s| s.bytes).unwrap_or(self.nominal)
    }
}

/// The model names, in the order every output lists them.
pub const SCHEMES: [&str; 3] = ["dcc", "ccs", "afbc"];

/// A whole packed G-buffer's bytes per sample under each model ([`SCHEMES`] order): every target's
/// [`TargetBytes::stored`], summed, over the frame's samples.
#[must_use]
pub fn bytes_per_sample(targets: &[TargetBytes], samples: u64) -> [f64; 3] {
    SCHEMES.map(|s| targets.iter().map(|t| t.stored(s)).sum::<u64>() as f64 / samples.max(1) as f64)
}

/// The sizes of every target of `packed` under every model, and zstd's.
#[must_use]
pub fn compressed(packed: &Packed) -> Vec<TargetBytes> {
    sizes(packed, true)
}

/// [`compressed`] without zstd (its highest level costs most of the time): what every report row carries.
#[must_use]
pub fn compressed_models(packed: &Packed) -> Vec<TargetBytes> {
    sizes(packed, false)
}

/// An AFRC target (`TargetSpec::afrc`) is already stored at its fixed rate, which no lossless model changes: each
/// model's bytes for it become the fixed-rate bytes (the coding units' sizes, `layout::afrc`).
pub fn fixed_rate(targets: &mut [TargetBytes], layout: &super::Layout) {
    for ((t, spec), format) in targets.iter_mut().zip(&layout.spec().targets).zip(layout.formats()) {
        if let Some(rate) = spec.afrc {
            let texels = t.nominal / format.bytes() as u64;
            let fixed = (texels * u64::from(super::afrc::bits_per_texel(*format, rate))).div_ceil(8);
            for s in &mut t.schemes {
                s.bytes = Some(fixed);
            }
        }
    }
}

/// Rows per band of [`compressed_models_of`]: a multiple of every block height (16 at most), so the bands' blocks are
/// the whole frame's.
const BAND_ROWS: u32 = 64;

/// [`compressed_models`] of `layout`'s packing of `gb`, packed 64 rows at a time (never the whole frame at
/// once, for a layout lit from the input or a decoded copy): every block is the whole frame's, so the sizes are the
/// whole frame's but for the metadata's rounding up, at most a byte per band and target.
pub fn compressed_models_of(
    layout: &super::Layout,
    gb: &crate::gbuffer::GBuffer,
) -> crate::error::Result<Vec<TargetBytes>> {
    let mut total: Vec<TargetBytes> = Vec::new();
    layout.pack_bands(gb, BAND_ROWS, |band| {
        let part = sizes(band, false);
        if total.is_empty() {
            total = part;
            return;
        }
        for (t, p) in total.iter_mut().zip(part) {
            t.nominal += p.nominal;
            for (s, q) in t.schemes.iter_mut().zip(p.schemes) {
                s.bytes = s.bytes.zip(q.bytes).map(|(a, b)| a + b);
                s.blocks += q.blocks;
                s.cleared += q.cleared;
            }
        }
    })?;
    Ok(total)
}

fn sizes(packed: &Packed, zstd: bool) -> Vec<TargetBytes> {
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
                schemes: {
                    let (dcc, ccs) = plane.dcc_ccs();
                    vec![dcc, ccs, afbc]
                },
                zstd: zstd.then(|| plane.zstd()),
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

    /// Per component, the smallest and largest value in the block at `(x0, y0)` of `(bw, bh)` texels (clipped to the
    /// frame) of sample plane `s`, into `out`; returns the texel count. What every delta-coded model needs, in one
    /// pass over the texels as stored.
    fn ranges(&self, x0: u32, y0: u32, shape: (u32, u32), s: u32, comps: &[(u32, u64)], out: &mut [(u64, u64)]) -> u64 {
        // The component count as a constant, so the per-texel loop unrolls.
        match comps.len() {
            1 => self.ranges_n::<1>(x0, y0, shape, s, comps, out),
            2 => self.ranges_n::<2>(x0, y0, shape, s, comps, out),
            3 => self.ranges_n::<3>(x0, y0, shape, s, comps, out),
            4 => self.ranges_n::<4>(x0, y0, shape, s, comps, out),
            _ => self.ranges_n::<0>(x0, y0, shape, s, comps, out),
        }
    }

    /// [`Plane::ranges`] for `N` components (0: any number).
    #[inline(always)]
    fn ranges_n<const N: usize>(
        &self,
        x0: u32,
        y0: u32,
        (bw, bh): (u32, u32),
        s: u32,
        comps: &[(u32, u64)],
        out: &mut [(u64, u64)],
    ) -> u64 {
        let tb = self.format.bytes();
        let stride = self.samples as usize * tb;
        let comps = if N == 0 { comps } else { &comps[..N] };
        let out = if N == 0 { out } else { &mut out[..N] };
        out.fill((u64::MAX, 0));
        let (x1, y1) = ((x0 + bw).min(self.width), (y0 + bh).min(self.height));
        for y in y0..y1 {
            let start = ((y as usize * self.width as usize + x0 as usize) * self.samples as usize + s as usize) * tb;
            let row = &self.bytes[start..start + (x1 - x0 - 1) as usize * stride + tb];
            for t in row.chunks(stride) {
                let t = read_texel(&t[..tb]);
                for (&(offset, mask), r) in comps.iter().zip(out.iter_mut()) {
                    let v = (t >> offset) as u64 & mask;
                    *r = (r.0.min(v), r.1.max(v));
                }
            }
        }
        u64::from((x1 - x0) * (y1 - y0))
    }

    /// The components' offsets and masks (no component is wider than 64 bits).
    fn comps(&self) -> Vec<(u32, u64)> {
        self.format
            .components()
            .iter()
            .map(|c| (c.offset, if c.bits >= 64 { u64::MAX } else { (1u64 << c.bits) - 1 }))
            .collect()
    }

    /// A delta-coded block model of `block_bytes`-byte blocks stored at one of `sizes` (the last: uncompressed), zero
    /// blocks fast-cleared, plus `meta` bytes of metadata per block: the plain statement of what [`Plane::dcc_ccs`]
    /// computes in one pass, kept as its test's reference.
    #[cfg(test)]
    fn blocks(&self, scheme: &'static str, block_bytes: usize, sizes: &[u64], meta: f64) -> SchemeBytes {
        let tb = self.format.bytes();
        let shape = block_shape(block_bytes, tb);
        let comps = self.comps();
        let (mut total, blocks, cleared) = self.sum(shape, |sc, x0, y0, s| {
            sc.ranges.resize(comps.len(), (0, 0));
            let n = self.ranges(x0, y0, shape, s, &comps, &mut sc.ranges);
            let raw = n * tb as u64;
            if sc.ranges.iter().all(|r| r.1 == 0) {
                return (0, true);
            }
            let code = delta_bits(self.format, n, &sc.ranges).div_ceil(8);
            // The smallest output size that holds the code, scaled to a partial block; else the block as it is.
            let scale = raw as f64 / f64::from(shape.0 * shape.1) / tb as f64;
            let fit = sizes.iter().map(|&z| (z as f64 * scale).ceil() as u64).find(|&z| z >= code);
            (fit.unwrap_or(raw).min(raw), false)
        });
        total += (blocks as f64 * meta).ceil() as u64;
        SchemeBytes { scheme, bytes: Some(total), blocks, cleared }
    }

    /// The `dcc` model (256-byte blocks stored as 64/128/192/256 bytes, a metadata byte each) and the `ccs` model
    /// (128-byte pairs stored as 64 or 128 bytes, two metadata bits each) in one pass over the texels: a `ccs` pair is
    /// half a `dcc` block (its shape halved across its longer side), so each texel updates the ranges of its half, for
    /// every sample of the pixel at once (a pixel's samples are adjacent in memory). Equal to [`Plane::blocks`] with
    /// those parameters (tested).
    fn dcc_ccs(&self) -> (SchemeBytes, SchemeBytes) {
        use rayon::prelude::*;
        let tb = self.format.bytes();
        let (bw, bh) = block_shape(256, tb);
        let (hw, hh) = block_shape(128, tb);
        debug_assert!((hw, hh) == (bw / 2, bh) || (hw, hh) == (bw, bh / 2));
        let comps = self.comps();
        let nc = comps.len();
        let samples = self.samples as usize;
        let fit = |n: u64, ranges: &[(u64, u64)], full: u32, sizes: &[u64]| -> u64 {
            let raw = n * tb as u64;
            let code = delta_bits(self.format, n, ranges).div_ceil(8);
            let scale = raw as f64 / f64::from(full) / tb as f64;
            sizes.iter().map(|&z| (z as f64 * scale).ceil() as u64).find(|&z| z >= code).unwrap_or(raw).min(raw)
        };
        // Per block row: (dcc bytes, dcc blocks, dcc cleared, ccs bytes, ccs blocks, ccs cleared).
        let totals = (0..self.height.div_ceil(bh))
            .into_par_iter()
            .map(|by| {
                let y0 = by * bh;
                let y1 = (y0 + bh).min(self.height);
                let mut acc = [0u64; 6];
                // ranges[(s * 2 + half) * nc + c]
                let mut ranges = vec![(u64::MAX, 0u64); samples * 2 * nc];
                let mut merged = vec![(0u64, 0u64); nc];
                for x0 in (0..self.width).step_by(bw as usize) {
                    let x1 = (x0 + bw).min(self.width);
                    ranges.fill((u64::MAX, 0));
                    let mut count = [0u64; 2];
                    for y in y0..y1 {
                        let start = (y as usize * self.width as usize + x0 as usize) * samples * tb;
                        let row = &self.bytes[start..start + (x1 - x0) as usize * samples * tb];
                        // The row's pixels in the first half and in the second: split across the row, or the whole
                        // row in the half of its line.
                        let split = if hw < bw { (hw as usize).min(row.len() / (samples * tb)) } else { 0 };
                        let (first, second) = row.split_at(split * samples * tb);
                        let halves = if hw < bw {
                            [(first, 0), (second, 1)]
                        } else {
                            [(first, 0), (second, usize::from(y - y0 >= hh))]
                        };
                        for (texels, half) in halves {
                            count[half] += (texels.len() / (samples * tb)) as u64;
                            widen_ranges(texels, tb, samples, half, &comps, &mut ranges);
                        }
                    }
                    for s in 0..samples {
                        let h0 = &ranges[s * 2 * nc..(s * 2 + 1) * nc];
                        let h1 = &ranges[(s * 2 + 1) * nc..(s * 2 + 2) * nc];
                        for ((m, a), b) in merged.iter_mut().zip(h0).zip(h1) {
                            *m = (a.0.min(b.0), a.1.max(b.1));
                        }
                        let n = count[0] + count[1];
                        acc[1] += 1;
                        if merged.iter().all(|r| r.1 == 0) {
                            acc[2] += 1;
                        } else {
                            acc[0] += fit(n, &merged, bw * bh, &[64, 128, 192, 256]);
                        }
                        for (half, h) in [h0, h1].into_iter().enumerate() {
                            if count[half] == 0 {
                                continue;
                            }
                            acc[4] += 1;
                            if h.iter().all(|r| r.1 == 0) {
                                acc[5] += 1;
                            } else {
                                acc[3] += fit(count[half], h, hw * hh, &[64, 128]);
                            }
                        }
                    }
                }
                acc
            })
            .reduce(|| [0u64; 6], |a, b| std::array::from_fn(|i| a[i] + b[i]));
        let scheme = |scheme, bytes: u64, blocks: u64, cleared, meta: f64| SchemeBytes {
            scheme,
            bytes: Some(bytes + (blocks as f64 * meta).ceil() as u64),
            blocks,
            cleared,
        };
        (scheme("dcc", totals[0], totals[1], totals[2], 1.0), scheme("ccs", totals[3], totals[4], totals[5], 0.25))
    }

    /// The AFBC-like model: 16 × 16 superblocks, a 16-byte header each, 4 × 4 sub-blocks in whole bytes (at most
    /// their raw size); a superblock of one value is its header alone.
    fn afbc(&self) -> SchemeBytes {
        let tb = self.format.bytes() as u64;
        let comps = self.comps();
        let (total, blocks, cleared) = self.sum((16, 16), |sc, x0, y0, s| {
            sc.ranges.resize(comps.len(), (0, 0));
            self.ranges(x0, y0, (16, 16), s, &comps, &mut sc.ranges);
            if sc.ranges.iter().all(|r| r.0 == r.1) {
                return (16, true);
            }
            let mut bytes = 16;
            for sy in (y0..(y0 + 16).min(self.height)).step_by(4) {
                for sx in (x0..(x0 + 16).min(self.width)).step_by(4) {
                    let n = self.ranges(sx, sy, (4, 4), s, &comps, &mut sc.ranges);
                    bytes += delta_bits(self.format, n, &sc.ranges).div_ceil(8).min(n * tb);
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
    ranges: Vec<(u64, u64)>,
    raw: Vec<u8>,
    /// The thread's zstd context (`Some(None)`: zstd could not start; blocks then count raw).
    coder: Option<Option<zstd::bulk::Compressor<'static>>>,
}

/// Bits of a block of `n` texels coded as a base per component plus each texel's difference from it in the bits the
/// block's range needs (`ranges`: each component's smallest and largest value, in the format's component order).
fn delta_bits(format: Format, n: u64, ranges: &[(u64, u64)]) -> u64 {
    format
        .components()
        .iter()
        .zip(ranges)
        .map(|(c, &(lo, hi))| u64::from(c.bits) + n * u64::from(u64::BITS - hi.saturating_sub(lo).leading_zeros()))
        .sum()
}

/// Widens `ranges` (`[(sample * 2 + half) * components + component]`, each component's smallest and largest value)
/// by every texel of `texels`: whole pixels of `samples` texels of `tb` bytes, all in block half `half`. Specialised
/// on the texel size and the component count, so that a texel is one load and a shift, a mask, a min and a max per
/// component (the generic loop, a match per texel and 128-bit shifts, was most of the report's `dcc`/`ccs` models).
fn widen_ranges(
    texels: &[u8],
    tb: usize,
    samples: usize,
    half: usize,
    comps: &[(u32, u64)],
    ranges: &mut [(u64, u64)],
) {
    macro_rules! by_components {
        ($tb:literal) => {
            match comps.len() {
                1 => widen::<$tb, 1>(texels, tb, samples, half, comps, ranges),
                2 => widen::<$tb, 2>(texels, tb, samples, half, comps, ranges),
                3 => widen::<$tb, 3>(texels, tb, samples, half, comps, ranges),
                4 => widen::<$tb, 4>(texels, tb, samples, half, comps, ranges),
                n => unreachable!("a format of {n} components (every format has 1 to 4)"),
            }
        };
    }
    match tb {
        1 => by_components!(1),
        2 => by_components!(2),
        4 => by_components!(4),
        8 => by_components!(8),
        16 => by_components!(16),
        _ => by_components!(0),
    }
}

/// [`widen_ranges`] for texels of `TB` bytes (`0`: `tb`, a size chosen at run time) with `NC` components.
#[inline(always)]
fn widen<const TB: usize, const NC: usize>(
    texels: &[u8],
    tb: usize,
    samples: usize,
    half: usize,
    comps: &[(u32, u64)],
    ranges: &mut [(u64, u64)],
) {
    let tb = if TB == 0 { tb } else { TB };
    let comps: [(u32, u64); NC] = std::array::from_fn(|c| comps[c]);
    #[inline(always)]
    fn widen_texel<const NC: usize>(r: &mut [(u64, u64)], comps: &[(u32, u64); NC], shifted: impl Fn(u32) -> u64) {
        for ((offset, mask), r) in comps.iter().zip(r.iter_mut()) {
            let v = shifted(*offset) & mask;
            *r = (r.0.min(v), r.1.max(v));
        }
    }
    for pixel in texels.chunks_exact(samples * tb) {
        for (s, t) in pixel.chunks_exact(tb).enumerate() {
            let r = &mut ranges[(s * 2 + half) * NC..(s * 2 + half + 1) * NC];
            if TB != 0 && TB <= 8 {
                // A word of at most 8 bytes: 64-bit shifts.
                let mut word = [0u8; 8];
                word[..TB.min(8)].copy_from_slice(&t[..TB.min(8)]);
                let t = u64::from_le_bytes(word);
                widen_texel(r, &comps, |offset| t.checked_shr(offset).unwrap_or(0));
            } else {
                let t = read_texel(t);
                widen_texel(r, &comps, |offset| (t >> offset) as u64);
            }
        }
    }
}

/// A texel's little-endian bytes (1 to 16) as a word.
#[inline(always)]
fn read_texel(b: &[u8]) -> u128 {
    match *b {
        [a] => u128::from(a),
        [a, b] => u128::from(u16::from_le_bytes([a, b])),
        [a, b, c, d] => u128::from(u32::from_le_bytes([a, b, c, d])),
        _ => {
            let mut word = [0u8; 16];
            word[..b.len()].copy_from_slice(b);
            u128::from_le_bytes(word)
        }
    }
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
        assert!(noise.zstd.unwrap() >= noise.nominal, "zstd cannot shrink noise: {:?}", noise.zstd);
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
    fn the_fused_dcc_and_ccs_pass_equals_each_model_alone() {
        // Every texel size and component count the pass is specialised for, and a 3-byte texel it is not.
        assert!(Format::ALL.iter().all(|f| (1..=4).contains(&f.components().len())), "1 to 4 components");
        let mut rng = crate::base::rng::SplitMix64::new(9);
        for (format, w, h, samples) in [
            (Format::Rgba8, 37, 21, 4),
            (Format::R8, 50, 35, 1),
            (Format::Rg16F, 19, 9, 2),
            (Format::Rgba32F, 13, 7, 1),
            (Format::Rgba16F, 23, 17, 8),
            (Format::R11G11B10F, 17, 30, 2),
            (Format::Rgb8, 11, 13, 4),
            (Format::R16F, 40, 3, 1),
        ] {
            let p = packed(format, w, h, samples, |x, y, s| {
                // Smooth, noisy and cleared regions.
                match (x / 8 + y / 8) % 3 {
                    0 => 0,
                    1 => u128::from(x + 3 * y + s),
                    _ => u128::from(rng.next_u64()) << 64 | u128::from(rng.next_u64()),
                }
            });
            let plane = Plane { bytes: &p.targets[0].bytes, format, width: w, height: h, samples };
            let (dcc, ccs) = plane.dcc_ccs();
            assert_eq!(dcc, plane.blocks("dcc", 256, &[64, 128, 192, 256], 1.0), "{format}");
            assert_eq!(ccs, plane.blocks("ccs", 128, &[64, 128], 0.25), "{format}");
        }
    }

    #[test]
    fn block_shapes_hold_the_block_bytes() {
        for (tb, want) in [(1, (16, 16)), (2, (16, 8)), (4, (8, 8)), (8, (8, 4)), (16, (4, 4)), (3, (8, 8))] {
            assert_eq!(block_shape(256, tb), want, "{tb}");
        }
        assert_eq!(block_shape(128, 4), (8, 4));
    }

    proptest::proptest! {
        /// One 8 × 8 RGBA8 block (a DCC block, two CCS pairs, one AFBC superblock's 4 sub-blocks of 4 × 4): whatever
        /// its texels, each model stores the closed form of its components' ranges. Blocks are drawn as a base plus
        /// bounded noise per component, so cleared, constant, two-value, gradient-like and noisy blocks all occur.
        #[test]
        fn every_model_stores_the_closed_form_of_its_blocks(
            base in proptest::array::uniform4(0u8..=255),
            spread in proptest::array::uniform4(0u8..=8),
            two_values in proptest::bool::ANY,
            seed in proptest::prelude::any::<u64>(),
        ) {
            let mut rng = crate::base::rng::SplitMix64::new(seed);
            let mut texels = [[0u8; 4]; 64];
            for t in &mut texels {
                for c in 0..4 {
                    let m = if spread[c] == 0 { 0 } else { 1u64 << (spread[c] - 1) };
                    let d = if two_values { (rng.next_u64() & 1) * m } else { rng.next_u64() % (2 * m.max(1)) };
                    t[c] = base[c].saturating_add(d.min(255) as u8);
                }
            }
            let p = packed(Format::Rgba8, 8, 8, 1, |x, y, _| u128::from(u32::from_le_bytes(texels[(y * 8 + x) as usize])));
            let got = &compressed_models(&p)[0];
            // Per component over `idx`: 8 base bits plus, per texel, the bits of the range.
            let code = |idx: &[usize]| -> u64 {
                (0..4)
                    .map(|c| {
                        let (lo, hi) = idx.iter().fold((255u8, 0u8), |(l, h), &i| (l.min(texels[i][c]), h.max(texels[i][c])));
                        8 + idx.len() as u64 * u64::from(8 - (hi - lo).leading_zeros())
                    })
                    .sum::<u64>()
                    .div_ceil(8)
            };
            let all: Vec<usize> = (0..64).collect();
            let zero = texels.iter().all(|t| *t == [0; 4]);
            let fit = |c: u64, sizes: &[u64]| *sizes.iter().find(|&&z| z >= c).unwrap_or(sizes.last().unwrap());
            let dcc = if zero { 0 } else { fit(code(&all), &[64, 128, 192, 256]) } + 1;
            proptest::prop_assert_eq!(bytes(got, "dcc"), Some(dcc));
            let (top, bottom): (Vec<usize>, Vec<usize>) = all.iter().partition(|&&i| i < 32);
            let pair = |idx: &[usize]| if idx.iter().all(|&i| texels[i] == [0; 4]) { 0 } else { fit(code(idx), &[64, 128]) };
            proptest::prop_assert_eq!(bytes(got, "ccs"), Some(pair(&top) + pair(&bottom) + 1));
            let uniform = texels.iter().all(|t| *t == texels[0]);
            let afbc = if uniform {
                16
            } else {
                16 + (0..4)
                    .map(|q| {
                        let sub: Vec<usize> = (0..16).map(|i| (q / 2 * 4 + i / 4) * 8 + q % 2 * 4 + i % 4).collect();
                        code(&sub).min(64)
                    })
                    .sum::<u64>()
            };
            proptest::prop_assert_eq!(bytes(got, "afbc"), Some(afbc));
        }
    }
}
