//! The shading work of the pipelines other than tiled deferred, counted on a G-buffer's own samples: forward
//! shading at 2×2-quad granularity (helper lanes included), the visibility buffer's per-tile fragment lists, and
//! the SIMD lane utilisation of the MSAA shading schedules.
//!
//! Input: a [`GBuffer`] with primitive IDs (and object IDs where primitive IDs restart per draw call) and an
//! [`EdgeMask`]. Output: counts ([`QuadShading`], [`FragmentLists`], [`Utilisation`]) that
//! [`crate::analysis::pipelines`] turns into a table.
//!
//! **Forward at quad granularity.** A rasterizer shades a triangle in 2×2 pixel quads: every quad holding at least
//! one covered sample of the triangle runs four fragment-shader lanes, the uncovered ones as helper lanes (they
//! exist so that derivatives work). So forward MSAA shades `4 × |{(triangle, quad)}|` lanes, where a triangle
//! covers a pixel when it covers any of its samples, and forward without MSAA the same with one sample per pixel.
//! The G-buffer holds the visible surface of every sample, so these are the counts of forward shading with a
//! perfect depth pre-pass (no overdraw): a lower bound of what a forward renderer without one shades.
//!
//! **Visibility buffer.** A visibility buffer stores a triangle ID and depth per sample; its deferred pass lists,
//! per screen tile, the unique (triangle, quad) pairs that contribute coverage and shades them in quads (the
//! seeds' pseudo-code). With tiles of even size the quads never straddle tiles, so its lanes equal forward MSAA's;
//! what it adds is the per-tile list, whose length and bytes [`fragment_lists`] measures.
//!
//! **Schedules.** A GPU runs pixels in warps of W lanes; [`utilisation`] models each MSAA schedule's useful
//! lane-steps over issued lane-steps from the edge mask alone (see [`MsaaSchedule`]).

use crate::base::mask::EdgeMask;
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
pub use crate::resolve::MsaaSchedule;
use serde::{Deserialize, Serialize};

/// Which samples a forward pass would rasterise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ForwardSamples {
    /// Every covered sample (forward MSAA): a triangle covers a pixel when it covers any of its samples.
    Msaa,
    /// One sample per pixel (forward without MSAA). Exact on a 1-sample dump; on an MSAA dump this sample stands
    /// in for the pixel centre, which the dump does not hold, so the counts are an estimate.
    Single {
        /// The sample index used.
        sample: u32,
    },
}

/// Forward shading work at quad granularity.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct QuadShading {
    /// Distinct triangles (object ID, primitive ID) with a covered sample.
    pub triangles: u64,
    /// Distinct (triangle, 2×2 quad) pairs: the quads the rasterizer launches.
    pub quads: u64,
    /// Fragment-shader lanes: 4 × `quads` (helper lanes included; quads at the image border count 4 too).
    pub lanes: u64,
    /// Lanes whose pixel the triangle covers: distinct (triangle, pixel) pairs.
    pub covered_lanes: u64,
    /// `lanes − covered_lanes`: lanes that run only for the quad's derivatives.
    pub helper_lanes: u64,
    /// `helper_lanes / lanes`.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub helper_fraction: f64,
    /// Is this an estimate ([`ForwardSamples::Single`] on an MSAA dump)?
    pub estimated: bool,
    /// Lanes run for each pixel (row-major): the "shading computations per pixel" heatmap.
    #[serde(skip)]
    pub lanes_per_pixel: Vec<u32>,
}

/// One triangle: its object ID in the high half (0 when the dump has none), its primitive ID in the low half.
fn triangle_keys<'a>(gb: &'a GBuffer, what: &str) -> Result<impl Fn(usize) -> u64 + 'a> {
    let prim = gb.primitive_id.as_deref().ok_or_else(|| {
        let have: Vec<&str> = gb.attributes().iter().map(|a| a.name()).collect();
        Error::Mismatch(format!("{what} needs primitive IDs; the G-buffer has: {}", have.join(", ")))
    })?;
    let obj = gb.object_id.as_deref();
    Ok(move |i: usize| (u64::from(obj.map_or(0, |o| o[i])) << 32) | u64::from(prim[i]))
}

/// The distinct (triangle, pixel) pairs of `gb` for `which`, as (triangle key, pixel index), sorted.
fn covered_pairs(gb: &GBuffer, which: ForwardSamples, what: &str) -> Result<Vec<(u64, u32)>> {
    let key = triangle_keys(gb, what)?;
    let s = gb.samples as usize;
    let samples: std::ops::Range<usize> = match which {
        ForwardSamples::Msaa => 0..s,
        ForwardSamples::Single { sample } if (sample as usize) < s => sample as usize..sample as usize + 1,
        ForwardSamples::Single { sample } => {
            return Err(Error::Argument(format!("{what}: sample {sample} of a {s}-sample G-buffer")));
        }
    };
    let mut pairs = Vec::with_capacity(gb.pixel_count());
    let mut seen = Vec::with_capacity(s);
    for p in 0..gb.pixel_count() {
        seen.clear();
        for i in samples.clone().map(|k| p * s + k) {
            if gb.coverage[i] {
                let k = key(i);
                if !seen.contains(&k) {
                    seen.push(k);
                    pairs.push((k, p as u32));
                }
            }
        }
    }
    pairs.sort_unstable();
    Ok(pairs)
}

/// The quad (x / 2, y / 2) of pixel `p` on a `width`-wide image, as one index.
fn quad_of(p: u32, width: u32) -> u32 {
    let (x, y) = (p % width, p / width);
    (y / 2) * width.div_ceil(2) + x / 2
}

/// Forward shading work of `gb` at quad granularity. Needs primitive IDs.
pub fn forward_quads(gb: &GBuffer, which: ForwardSamples) -> Result<QuadShading> {
    let what = "forward shading at quad granularity";
    let pairs = covered_pairs(gb, which, what)?;
    let w = gb.width;
    let mut quads: Vec<(u64, u32)> = pairs.iter().map(|&(k, p)| (k, quad_of(p, w))).collect();
    quads.dedup();
    // `pairs` is sorted by (triangle, pixel); quads of one triangle may interleave across rows, so sort again.
    quads.sort_unstable();
    quads.dedup();
    let mut triangles = 0u64;
    let mut last = None;
    for &(k, _) in &pairs {
        if last != Some(k) {
            triangles += 1;
            last = Some(k);
        }
    }
    let (qw, h) = (w.div_ceil(2), gb.height);
    let mut lanes_per_pixel = vec![0u32; gb.pixel_count()];
    for &(_, q) in &quads {
        let (x0, y0) = ((q % qw) * 2, (q / qw) * 2);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            if x0 + dx < w && y0 + dy < h {
                lanes_per_pixel[((y0 + dy) * w + x0 + dx) as usize] += 1;
            }
        }
    }
    let lanes = 4 * quads.len() as u64;
    let covered_lanes = pairs.len() as u64;
    let helper_lanes = lanes - covered_lanes;
    Ok(QuadShading {
        triangles,
        quads: quads.len() as u64,
        lanes,
        covered_lanes,
        helper_lanes,
        helper_fraction: if lanes > 0 { helper_lanes as f64 / lanes as f64 } else { 0.0 },
        estimated: matches!(which, ForwardSamples::Single { .. }) && gb.samples > 1,
        lanes_per_pixel,
    })
}

/// A visibility buffer's per-tile lists of fragments to shade.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FragmentLists {
    /// Tile edge in pixels (even).
    pub tile_size: u32,
    /// Tiles of the image.
    pub tiles: u64,
    /// Tiles with at least one fragment.
    pub tiles_with_fragments: u64,
    /// Entries over all lists: unique (triangle, quad) pairs per tile.
    pub entries: u64,
    /// Longest list.
    pub max_entries: u64,
    /// Bytes of the lists at [`FragmentLists::ENTRY_BYTES`] per entry.
    pub bytes: u64,
}

impl FragmentLists {
    /// One entry: a 32-bit triangle ID and a 32-bit quad index (what a GPU list would hold).
    pub const ENTRY_BYTES: u64 = 8;
}

/// The visibility buffer's per-tile fragment lists on `gb` with square tiles of `tile_size` pixels (rounded up to
/// even, so quads stay inside tiles). Needs primitive IDs.
pub fn fragment_lists(gb: &GBuffer, tile_size: u32) -> Result<FragmentLists> {
    let ts = tile_size.max(2).next_multiple_of(2);
    let pairs = covered_pairs(gb, ForwardSamples::Msaa, "the visibility buffer's fragment lists")?;
    let (w, h) = (gb.width, gb.height);
    let tiles_x = w.div_ceil(ts);
    let mut per_tile: Vec<(u32, u64, u32)> = pairs
        .iter()
        .map(|&(k, p)| {
            let (x, y) = (p % w, p / w);
            ((y / ts) * tiles_x + x / ts, k, quad_of(p, w))
        })
        .collect();
    per_tile.sort_unstable();
    per_tile.dedup();
    let mut counts = vec![0u64; tiles_x as usize * h.div_ceil(ts) as usize];
    for &(t, _, _) in &per_tile {
        counts[t as usize] += 1;
    }
    let entries = per_tile.len() as u64;
    Ok(FragmentLists {
        tile_size: ts,
        tiles: counts.len() as u64,
        tiles_with_fragments: counts.iter().filter(|&&c| c > 0).count() as u64,
        entries,
        max_entries: counts.iter().copied().max().unwrap_or(0),
        bytes: entries * FragmentLists::ENTRY_BYTES,
    })
}

/// Useful and issued lane-steps of one schedule at one warp width.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Utilisation {
    /// The schedule.
    pub schedule: Option<MsaaSchedule>,
    /// Lanes per warp.
    pub warp: u32,
    /// Lane-steps doing a shading evaluation the mask asks for.
    pub useful: u64,
    /// Lane-steps issued (useful + idle).
    pub issued: u64,
    /// `useful / issued` (1 when nothing is issued).
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub ratio: f64,
}

/// The pixel block a warp of `warp` lanes covers (GPU rasterizers walk pixels in small 2D blocks): 8 → 4×2,
/// 16 → 4×4, 32 → 8×4, 64 → 8×8; other widths: a row of `warp` pixels.
#[must_use]
fn warp_block(warp: u32) -> (u32, u32) {
    match warp {
        8 => (4, 2),
        16 => (4, 4),
        32 => (8, 4),
        64 => (8, 8),
        w => (w.max(1), 1),
    }
}

/// The lane utilisation of `schedule` on `mask` with GPU warps of `warp` lanes, modelled from the mask alone:
/// `packed` fills warps from each tile's list (`tile_size` pixels square), idle lanes only in a tile's last warp;
/// `per-pixel` runs a warp over a block of pixels (`warp_block`) for as many steps as its pixel with the most
/// evaluations; `two-pass` launches the 2×2 quads that pass each pass's stencil test (pass 1: any covered pixel;
/// pass 2: any edge pixel, at sample frequency, samples 1..), packed into warps per tile. The resolve runs the same
/// three schedules on the CPU ([`crate::resolve::MsaaSchedule`]) and counts its own lane steps.
#[must_use]
pub fn utilisation(mask: &EdgeMask, schedule: MsaaSchedule, warp: u32, tile_size: u32) -> Utilisation {
    let warp = warp.max(1);
    let (w, h) = (mask.width, mask.height);
    let count = |x: u32, y: u32| u64::from(mask.shade_count[(y * w + x) as usize]);
    let useful: u64 = mask.shade_count.iter().map(|&c| u64::from(c)).sum();
    // Visits every block of `bw × bh` pixels (clipped at the image border) with its pixels' counts.
    let blocks = |bw: u32, bh: u32, f: &mut dyn FnMut(&[u64])| {
        let mut counts = Vec::with_capacity((bw * bh) as usize);
        for by in (0..h).step_by(bh.max(1) as usize) {
            for bx in (0..w).step_by(bw.max(1) as usize) {
                counts.clear();
                for y in by..(by + bh).min(h) {
                    for x in bx..(bx + bw).min(w) {
                        counts.push(count(x, y));
                    }
                }
                f(&counts);
            }
        }
    };
    let mut issued = 0u64;
    match schedule {
        MsaaSchedule::Packed => {
            let ts = tile_size.max(1);
            blocks(ts, ts, &mut |c| issued += c.iter().sum::<u64>().next_multiple_of(u64::from(warp)));
        }
        MsaaSchedule::PerPixel => {
            let (bw, bh) = warp_block(warp);
            blocks(bw, bh, &mut |c| issued += u64::from(warp) * c.iter().copied().max().unwrap_or(0));
        }
        MsaaSchedule::TwoPass => {
            // Per tile, the quads that pass each pass's stencil test, four lanes each, packed into warps.
            let others = u64::from(mask.samples.max(1) - 1);
            let ts = tile_size.max(2).next_multiple_of(2);
            let wp = u64::from(warp);
            for ty in (0..h).step_by(ts as usize) {
                for tx in (0..w).step_by(ts as usize) {
                    let (mut covered, mut edge) = (0u64, 0u64);
                    for qy in (ty..(ty + ts).min(h)).step_by(2) {
                        for qx in (tx..(tx + ts).min(w)).step_by(2) {
                            let mut c = [0u64; 4];
                            for (k, (dx, dy)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
                                if qx + dx < w && qy + dy < h {
                                    c[k] = count(qx + dx, qy + dy);
                                }
                            }
                            covered += u64::from(c.iter().any(|&n| n > 0));
                            edge += u64::from(c.iter().any(|&n| n > 1));
                        }
                    }
                    issued += (4 * covered).next_multiple_of(wp) + (4 * others * edge).next_multiple_of(wp);
                }
            }
        }
    }
    Utilisation {
        schedule: Some(schedule),
        warp,
        useful,
        issued,
        ratio: if issued > 0 { useful as f64 / issued as f64 } else { 1.0 },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4×2, 2-sample G-buffer: triangle 7 covers pixels 0 and 1 fully, triangle 9 covers sample 1 of pixel 1
    /// (so pixel 1 has two triangles) and pixel 5.
    fn small() -> GBuffer {
        let mut gb = GBuffer::new(4, 2, 2).unwrap();
        let mut prim = vec![0u32; gb.len()];
        gb.coverage = vec![false; gb.len()];
        for (i, t) in [(0, 7), (1, 7), (2, 7), (3, 9), (10, 9)] {
            gb.coverage[i] = true;
            prim[i] = t;
        }
        gb.primitive_id = Some(prim);
        gb
    }

    #[test]
    fn quads_count_triangles_per_two_by_two_block_with_helpers() {
        let q = forward_quads(&small(), ForwardSamples::Msaa).unwrap();
        // Triangle 7: pixels 0, 1 → quad 0. Triangle 9: pixel 1 (quad 0) and pixel 5 = (1, 1) (quad 0).
        assert_eq!((q.triangles, q.quads, q.lanes), (2, 2, 8));
        assert_eq!((q.covered_lanes, q.helper_lanes), (4, 4));
        assert_eq!(q.lanes_per_pixel, vec![2, 2, 0, 0, 2, 2, 0, 0]);
        assert!(!q.estimated);
        // Sample 0 only: pixel 1's sample 0 is triangle 7, pixel 5's is triangle 9 → still two quads.
        let s = forward_quads(&small(), ForwardSamples::Single { sample: 0 }).unwrap();
        assert_eq!((s.triangles, s.quads, s.covered_lanes), (2, 2, 3));
        assert!(s.estimated);
        assert!(forward_quads(&small(), ForwardSamples::Single { sample: 2 }).is_err());
    }

    #[test]
    fn object_ids_separate_primitives_numbered_per_draw() {
        let mut gb = small();
        // Pixel 5's triangle becomes (object 1, primitive 7): a third triangle.
        let mut obj = vec![0u32; gb.len()];
        obj[10] = 1;
        gb.object_id = Some(obj);
        gb.primitive_id.as_mut().unwrap()[10] = 7;
        let q = forward_quads(&gb, ForwardSamples::Msaa).unwrap();
        assert_eq!((q.triangles, q.quads), (3, 3));
        let mut none = small();
        none.primitive_id = None;
        let e = forward_quads(&none, ForwardSamples::Msaa).unwrap_err().to_string();
        assert!(e.contains("primitive IDs"), "{e}");
    }

    #[test]
    fn fragment_lists_count_pairs_per_tile() {
        let f = fragment_lists(&small(), 2).unwrap();
        // Tiles of 2×2: tile 0 holds quad 0 with both triangles; tile 1 (pixels 2, 3, 6, 7) is empty.
        assert_eq!((f.tiles, f.tiles_with_fragments, f.entries, f.max_entries), (2, 1, 2, 2));
        assert_eq!(f.bytes, 16);
    }

    #[test]
    fn utilisation_of_each_schedule_on_a_known_mask() {
        // 4×4 pixels, 4 samples: one edge pixel (4), the rest shaded once, one background pixel.
        let mut m = EdgeMask::filled(4, 4, 4, 1);
        m.shade_count[5] = 4;
        m.shade_count[0] = 0;
        let useful = 14 + 4;
        let packed = utilisation(&m, MsaaSchedule::Packed, 16, 16);
        assert_eq!((packed.useful, packed.issued), (useful, 32));
        // One 4×4 block; it runs 4 steps of 16 lanes.
        let pp = utilisation(&m, MsaaSchedule::PerPixel, 16, 16);
        assert_eq!((pp.useful, pp.issued), (useful, 64));
        // Pass 1: 4 quads of 4 lanes; pass 2: the edge pixel's quad, 4 lanes × 3 more samples, in one warp of 16.
        let tp = utilisation(&m, MsaaSchedule::TwoPass, 16, 16);
        assert_eq!((tp.useful, tp.issued), (useful, 16 + 16));
        // Warps of 8: pass 2's 12 lanes take two.
        assert_eq!(utilisation(&m, MsaaSchedule::TwoPass, 8, 16).issued, 16 + 16);
        assert_eq!(utilisation(&m, MsaaSchedule::TwoPass, 4, 16).issued, 16 + 12);
        assert!((pp.ratio - 18.0 / 64.0).abs() < 1e-12);
        // With no edge the per-pixel and two-pass schedules issue one step per block.
        let flat = EdgeMask::filled(8, 8, 4, 1);
        for s in [MsaaSchedule::PerPixel, MsaaSchedule::TwoPass] {
            for warp in [8, 16, 32, 64] {
                let u = utilisation(&flat, s, warp, 16);
                assert_eq!((u.useful, u.issued), (64, 64), "{s} at {warp}");
            }
        }
    }
}
