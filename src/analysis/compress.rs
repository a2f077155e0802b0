//! Streaming MSAA G-buffer compression (Kerzner & Salvi, "Streaming G-buffer compression for multi-sample
//! anti-aliasing", HPG 2014), simulated on a dump: each pixel keeps at most `K` surface *slots* — one set of the
//! layout's fields plus a coverage mask — instead of one set per sample, and the lighting pass shades each slot once.
//!
//! **Fragments.** A dump holds the visible samples, not the fragments a rasterizer streamed. A pixel's fragments are
//! rebuilt from them: the covered samples that share an identity — (object, primitive) IDs where the dump has
//! primitive IDs, else (object, material) or whichever IDs it has — or, without IDs, the geometric groups of
//! [`crate::analysis::surfaces`]. They stream in draw order as the IDs give it (ascending object, then primitive /
//! material ID); without IDs in sample order. A fragment's fields are those of its first covered sample (a
//! renderer writes the pixel centre's values; the first sample stands for it); its depth range is its samples' view
//! depths widened by the pixel's depth slope |∂z/∂x| + |∂z/∂y| (the authors' code keeps z at the centre ± that slope).
//!
//! **Insertion** (the authors' pixel shader, read in their repository `kerzner/streaming-g-buffer-compression`,
//! `StreamingGBufferNdi.fx` and `Merge.hlsl`; this is our own code): a fragment merges into the first slot, front to
//! back, whose coverage it does not overlap, whose depth range overlaps its own, and whose normal agrees with
//! |n₁·n₂| ≥ [`MERGE_DOT`]; otherwise it takes a free slot; with all `K` slots full, one of the `K + 1` candidates
//! is evicted — the one with the fewest fresh samples, ties to the farther — and the pixel is marked *discarded*.
//! Only visible fragments reach us, so coverages never overlap and every sample is fresh: their "occluder fusion"
//! test (a candidate wholly hidden by those in front) never fires here, and eviction drops the fragment covering the
//! fewest samples. Merged slots keep the coverage-weighted mean of the two slots' float fields (normals
//! renormalised; opposite normals keep the larger slot's) and the larger slot's IDs; the authors average 50/50 and
//! keep the nearer depth — a documented difference in favour of the better estimate.
//!
//! **Lighting** (their `StreamingResolve.fx`): each slot is shaded once and weighted by its covered samples; samples
//! no slot covers are background, except in a discarded pixel, whose colour is divided by the samples its slots
//! still cover (an evicted fragment's samples take the survivors' average instead of going black). Here the
//! compressed G-buffer is written back as a full one — every sample of a slot holding the slot's fields, evicted
//! samples background — and lit by the tiled resolve with one evaluation per pixel where one slot covers every
//! sample and per sample elsewhere (samples of a slot are equal, so they shade equally: one evaluation per slot
//! is what a GPU pays, and what [`Compressed::evaluations`] counts).
//!
//! **Footprint** ([`footprint`]): per pixel, `K` slots of the layout's bytes plus a coverage word (the coverage and
//! the depth-tested coverage masks, `2·samples` bits rounded up to 4 bytes), and 8 bytes of slot count and order —
//! the authors' 3 × (16 + 4) + 8 = 68 B against 16 × 8 = 128 B per pixel at 8× (their baseline G-buffer of 16 B per
//! sample; neither counts the depth buffer).
//!
//! **Aggregates** ([`aggregate`], after Crassin et al.'s AGAA): the same write-back and lighting with depth layers
//! of averaged fields instead of streamed slots. [`light_compressed`] compresses and lights a frame strip by strip
//! ([`STRIP_ROWS`] rows), so no compressed copy of the whole frame is held: what `gbuf pipelines` and the report use.

use crate::analysis::surfaces::MERGE_DOT;
use crate::base::mask::EdgeMask;
use crate::detect::{self, Detector};
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer, PlaneMapper, Sample, SamplesMut};
use crate::image::HdrImage;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// Bytes per pixel of slot bookkeeping: the slot count and the front-to-back order (two 32-bit words in the
/// authors' code).
pub const PIXEL_BOOKKEEPING_BYTES: u32 = 8;

/// How a pixel's fragments were rebuilt and ordered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FragmentKey {
    /// Distinct (object, primitive) IDs, streamed by ascending object then primitive ID.
    ObjectPrimitive,
    /// Distinct (object, material) IDs (or whichever of the two the dump has), ascending.
    ObjectMaterial,
    /// No IDs: geometric groups (normal and depth agree), in sample order.
    Geometry,
}

/// How the compressed G-buffer was formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Kerzner & Salvi's streaming slots ([`compress`]).
    Streaming,
    /// AGAA-style depth-layer aggregates ([`aggregate`]).
    Aggregate,
}

/// Compression settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamingConfig {
    /// Surface slots per pixel (1..=samples).
    pub slots: u32,
    /// Merge fragments that agree (the authors' rule); `false` keeps every fragment in a slot of its own until
    /// eviction.
    pub merge: bool,
}

/// A compressed frame: what the slots hold, written back as a G-buffer the resolve lights, and what it cost.
#[derive(Clone, Debug)]
pub struct Compressed {
    /// The settings (for aggregates: `slots` is the aggregate count, `merge` false).
    pub config: StreamingConfig,
    /// Streaming slots or aggregates.
    pub method: Method,
    /// How fragments were rebuilt.
    pub key: FragmentKey,
    /// Slots in use per pixel (row-major).
    pub slots_per_pixel: Vec<u8>,
    /// Fragments streamed in (all pixels).
    pub fragments: u64,
    /// Fragments merged into a slot.
    pub merges: u64,
    /// Covered samples whose fragment was evicted.
    pub evicted_samples: u64,
    /// Pixels that evicted a fragment.
    pub discarded_pixels: u64,
    /// The compressed G-buffer written back per sample (evicted samples are background; a `position` plane is
    /// always present).
    pub gbuffer: GBuffer,
    /// One evaluation where one slot covers every sample of the pixel, per sample elsewhere.
    pub mask: EdgeMask,
    /// Per pixel, what the resolved colour is multiplied by: samples ÷ samples still covered in a discarded pixel,
    /// else 1.
    pub scale: Vec<f32>,
}

/// Footprint of a compressed G-buffer, bytes per pixel, and of the full MSAA G-buffer it replaces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Footprint {
    /// Bytes of one slot: the layout's fields plus the coverage word.
    pub slot_bytes: u32,
    /// `slots × slot_bytes + PIXEL_BOOKKEEPING_BYTES`.
    pub compressed_bytes_per_pixel: u32,
    /// `samples × layout bytes`.
    pub full_bytes_per_pixel: u32,
}

/// The footprint of `slots` slots of a layout of `bytes_per_sample` at `samples` per pixel (see the module notes).
#[must_use]
pub fn footprint(bytes_per_sample: u32, samples: u32, slots: u32) -> Footprint {
    let mask_bytes = (2 * samples).div_ceil(8).next_multiple_of(4);
    let slot_bytes = bytes_per_sample + mask_bytes;
    Footprint {
        slot_bytes,
        compressed_bytes_per_pixel: slots * slot_bytes + PIXEL_BOOKKEEPING_BYTES,
        full_bytes_per_pixel: samples * bytes_per_sample,
    }
}

/// One slot (or an incoming fragment) while a pixel is compressed.
#[derive(Clone, Copy, Debug)]
struct Slot {
    /// Covered samples of the pixel (bit k: sample k).
    mask: u64,
    /// The sample whose fields the slot started from.
    first: usize,
    /// View-depth range, widened by the pixel's slope.
    z: (f32, f32),
    /// Mean view depth (the front-to-back order).
    z_mean: f32,
    /// The normal the merge test reads.
    normal: Vec3,
    /// The merged fields, when the slot merged; `None`: the first sample's own.
    merged: Option<usize>,
}

/// What the compressors read: the input, its positions (the input's plane, or derived from depth), its view depth
/// and each pixel's depth slope.
struct Source<'a> {
    gb: &'a GBuffer,
    position: &'a [Vec3],
    depth: Option<&'a [f32]>,
    slope: &'a [f32],
}

impl Source<'_> {
    fn z(&self, i: usize) -> f32 {
        self.depth.map_or(0.0, |d| d[i])
    }
    fn normal(&self, i: usize) -> Vec3 {
        self.gb.normal.as_ref().map_or(Vec3::ZERO, |n| n[i])
    }
}

/// The fields of one slot: one sample's, or the coverage-weighted mean of merged ones (IDs of the larger part).
#[derive(Clone, Copy, Debug, Default)]
struct Fields {
    weight: f32,
    sample: Sample,
}

impl Fields {
    fn of(src: &Source<'_>, i: usize, weight: f32) -> Self {
        let mut sample = src.gb.sample(i);
        sample.position = src.position[i];
        Fields { weight, sample }
    }

    /// The mean of the samples `members` (the first is the nearest: its IDs are kept), the specular power widened
    /// by Toksvig's factor where the normals disagree.
    fn mean(src: &Source<'_>, members: impl Iterator<Item = usize>) -> Self {
        let mut it = members;
        let first = it.next().expect("a layer has a sample");
        let mut sum = Fields::of(src, first, 1.0);
        let first_normal = sum.sample.normal;
        for i in it {
            sum.weight += 1.0;
            sum.sample = sum.sample.blend(1.0, &Fields::of(src, i, 1.0).sample, 1.0);
        }
        let mut mean = sum.sample.scaled(1.0 / sum.weight);
        let rho = mean.normal.length().min(1.0);
        let power = mean.specular_power;
        mean.normal = mean.normal.normalize_or(first_normal);
        if rho > 0.0 && power > 0.0 {
            mean.specular_power = rho * power / (rho + power * (1.0 - rho));
        }
        Fields { weight: sum.weight, sample: mean }
    }

    /// The coverage-weighted mean of `a` and `b`.
    fn merge(a: &Fields, b: &Fields) -> Fields {
        let w = a.weight + b.weight;
        let (ta, tb) = (a.weight / w, b.weight / w);
        let larger = if b.weight > a.weight { b } else { a };
        let (na, nb) = (a.sample.normal, b.sample.normal);
        let normal = if na.dot(nb) > 0.0 {
            (na * ta + nb * tb).normalize_or(larger.sample.normal)
        } else {
            larger.sample.normal
        };
        let ids = larger.sample;
        let sample = Sample {
            normal,
            material_id: ids.material_id,
            object_id: ids.object_id,
            primitive_id: ids.primitive_id,
            ..a.sample.blend(ta, &b.sample, tb)
        };
        Fields { weight: w, sample }
    }
}

/// One row of pixels of the compressed G-buffer being written: its samples (each plane the input has, and
/// position) and the row's per-pixel counts.
struct RowOut<'a> {
    samples: SamplesMut<'a>,
    slots: &'a mut [u8],
    shade_count: &'a mut [u8],
    scale: &'a mut [f32],
}

/// What one pixel's compression counted.
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    fragments: u64,
    merges: u64,
    evicted_samples: u64,
    discarded_pixels: u64,
}

impl std::ops::Add for Counts {
    type Output = Counts;
    fn add(self, o: Counts) -> Counts {
        Counts {
            fragments: self.fragments + o.fragments,
            merges: self.merges + o.merges,
            evicted_samples: self.evicted_samples + o.evicted_samples,
            discarded_pixels: self.discarded_pixels + o.discarded_pixels,
        }
    }
}

/// The input with what every pixel's compression reads: positions (the input's, or derived from depth: one plane,
/// the input is not copied), view depth and each pixel's depth slope.
struct Prepared<'a> {
    gb: &'a GBuffer,
    position: Cow<'a, [Vec3]>,
    depth: Option<Cow<'a, [f32]>>,
    slope: Vec<f32>,
}

/// Checks `slots` (1..=samples, at most 64 samples) and derives what [`run_rows`] reads.
fn prepare<'a>(gb: &'a GBuffer, slots: u32, what: &str) -> Result<Prepared<'a>> {
    check_slots(gb, slots, what)?;
    derive(gb)
}

/// Whether `gb` can be compressed into `slots` (1..=samples, at most 64 samples).
fn check_slots(gb: &GBuffer, slots: u32, what: &str) -> Result<()> {
    gb.validate()?;
    let s = gb.samples;
    if slots == 0 || slots > s {
        return Err(Error::Argument(format!("{slots} {what} for {s} samples per pixel: 1..={s}")));
    }
    if s > 64 {
        return Err(Error::Argument(format!("MSAA G-buffer compression masks hold 64 samples, not {s}")));
    }
    Ok(())
}

/// What [`run_rows`] reads of `gb`, whatever the method and slot count: its positions, view depth and slopes.
fn derive(gb: &GBuffer) -> Result<Prepared<'_>> {
    gb.validate()?;
    // Positions for the lighting pass: the input's, or derived from depth (one plane; the input is not copied).
    let position: Cow<'_, [Vec3]> = match &gb.position {
        Some(p) => Cow::Borrowed(p),
        None => Cow::Owned(gb.derived_positions().ok_or_else(|| {
            Error::Mismatch(
                "MSAA G-buffer compression lights its slots: the G-buffer needs positions, or depth with a camera"
                    .into(),
            )
        })?),
    };
    let depth = detect::depth_plane(gb, Detector::Lauritzen).ok();
    let slope: Vec<f32> = match &depth {
        Some(_) => detect::lauritzen::neighbour_gradients(gb)?
            .iter()
            .map(|g| {
                let d = g.x.abs() + g.y.abs();
                if d.is_finite() {
                    d
                } else {
                    0.0
                }
            })
            .collect(),
        None => vec![0.0; gb.pixel_count()],
    };
    Ok(Prepared { gb, position, depth, slope })
}

/// What compresses one pixel: `pixel(src, p, scratch, slots)` fills `slots` — (coverage mask, fields) — for pixel
/// `p` (row-major, whole frame) and returns its counts and whether it evicted.
trait PixelFn<S>: Fn(&Source<'_>, usize, &mut S, &mut Vec<(u64, Fields)>) -> (Counts, bool) + Sync {}
impl<S, F: Fn(&Source<'_>, usize, &mut S, &mut Vec<(u64, Fields)>) -> (Counts, bool) + Sync> PixelFn<S> for F {}

/// Runs `pixel` on the pixels of rows `rows` (in parallel) and writes their slots into a new G-buffer of those rows
/// (its `height` the rows'): samples no slot covers are background (zero), every other sample holds its slot's
/// fields.
fn run_rows<S: Default + Send>(
    pre: &Prepared<'_>,
    rows: std::ops::Range<usize>,
    config: StreamingConfig,
    method: Method,
    pixel: &impl PixelFn<S>,
) -> Compressed {
    let gb = pre.gb;
    let src = Source { gb, position: &pre.position, depth: pre.depth.as_deref(), slope: &pre.slope };
    let s = gb.samples;
    let first_row = rows.start;
    // The output: the input's planes (and position), zero-filled, written row by row in parallel.
    let (w, h) = (gb.width as usize, rows.len());
    let n = w * h * s as usize;
    let row = w * s as usize;
    // Every plane the input has (and position), zero-filled: a plane mapper, so no list of planes here.
    struct Zeros(usize);
    impl PlaneMapper for Zeros {
        fn map<T: Copy + Default + Send + Sync>(&mut self, _: Attribute, _: &[T]) -> Option<Vec<T>> {
            Some(vec![T::default(); self.0])
        }
    }
    let mut out = gb.map_planes((gb.width, h as u32, s), gb.sample_positions.clone(), vec![false; n], &mut Zeros(n));
    if out.position.is_none() {
        out.position = Some(vec![Vec3::ZERO; n]);
    }
    let mut c = Compressed::empty(gb.width, h as u32, gb.samples, config, method, fragment_key(gb));
    let counts = {
        let rows: Vec<RowOut<'_>> = out
            .sample_runs_mut(row)
            .into_iter()
            .zip(c.slots_per_pixel.chunks_mut(w))
            .zip(c.mask.shade_count.chunks_mut(w))
            .zip(c.scale.chunks_mut(w))
            .map(|(((samples, slots), shade_count), scale)| RowOut { samples, slots, shade_count, scale })
            .collect();
        let su = s as usize;
        rows.into_par_iter()
            .enumerate()
            .map_init(
                || (S::default(), Vec::new()),
                |(state, slots), (y, mut o)| {
                    let mut total = Counts::default();
                    for x in 0..w {
                        let p = (first_row + y) * w + x;
                        slots.clear();
                        let (counts, discarded) = pixel(&src, p, state, slots);
                        total = total + counts;
                        let base = p * su;
                        let mut kept: u64 = 0;
                        for (mask, fields) in slots.iter() {
                            kept |= mask;
                            for j in 0..su {
                                if mask >> j & 1 == 1 {
                                    o.samples.set(x * su + j, &fields.sample);
                                }
                            }
                        }
                        let covered = gb.coverage[base..base + su].iter().filter(|&&c| c).count();
                        for j in 0..su {
                            o.samples.coverage[x * su + j] = kept >> j & 1 == 1;
                        }
                        let kept_n = kept.count_ones() as usize;
                        o.slots[x] = slots.len() as u8;
                        o.shade_count[x] = match slots.len() {
                            0 => 0,
                            1 if covered == su && kept_n == su => 1,
                            _ => su.min(usize::from(u8::MAX)) as u8,
                        };
                        if discarded {
                            total.discarded_pixels += 1;
                            if kept_n > 0 {
                                o.scale[x] = covered as f32 / kept_n as f32;
                            }
                        }
                    }
                    total
                },
            )
            .reduce(Counts::default, |a, b| a + b)
    };
    c.fragments = counts.fragments;
    c.merges = counts.merges;
    c.evicted_samples = counts.evicted_samples;
    c.discarded_pixels = counts.discarded_pixels;
    c.gbuffer = out;
    c
}

/// Per-thread scratch of [`compress`].
#[derive(Default)]
struct StreamScratch {
    frags: Vec<(u64, Slot)>,
    slots: Vec<Slot>,
    merged: Vec<Fields>,
}

/// Compresses `gb` into at most `cfg.slots` slots per pixel (see the module notes).
///
/// Errors when `slots` is 0 or above the sample count, when the G-buffer has more than 64 samples, or when no
/// position can be formed for the lighting pass (no position plane, and no depth with a camera).
pub fn compress(gb: &GBuffer, cfg: &StreamingConfig) -> Result<Compressed> {
    let pre = prepare(gb, cfg.slots, "surface slots")?;
    Ok(run_rows(&pre, 0..gb.height as usize, *cfg, Method::Streaming, &stream_pixel(gb, cfg)))
}

/// The streaming compressor of one pixel ([`compress`]).
fn stream_pixel<'g>(gb: &'g GBuffer, cfg: &StreamingConfig) -> impl PixelFn<StreamScratch> + 'g {
    let key = fragment_key(gb);
    // Merging reads depth (the plane, or derived from positions as `detect::depth_plane` does) and normals.
    let merge_geometry = cfg.merge && gb.normal.is_some() && (gb.depth.is_some() || gb.position.is_some());
    let k = cfg.slots as usize;
    let s = gb.samples as usize;
    move |src: &Source<'_>, p: usize, sc: &mut StreamScratch, out: &mut Vec<(u64, Fields)>| {
        let StreamScratch { frags, slots, merged } = sc;
        frags.clear();
        slots.clear();
        merged.clear();
        let mut counts = Counts::default();
        let base = p * s;
        let slope = src.slope[p];
        // Rebuild the fragments: covered samples grouped by key, each with its mask, first sample and depth range.
        for j in 0..s {
            let i = base + j;
            if !gb.coverage[i] {
                continue;
            }
            let order = order_key(gb, key, i, j);
            let joins = frags.iter().position(|(o, f)| match key {
                FragmentKey::Geometry => same_geometry(src.z(f.first), src.normal(f.first), src.z(i), src.normal(i)),
                _ => *o == order,
            });
            let z = src.z(i);
            match joins {
                Some(f) => {
                    let f = &mut frags[f].1;
                    f.mask |= 1 << j;
                    f.z = (f.z.0.min(z), f.z.1.max(z));
                }
                None => frags.push((
                    order,
                    Slot { mask: 1 << j, first: i, z: (z, z), z_mean: z, normal: src.normal(i), merged: None },
                )),
            }
        }
        frags.sort_by_key(|(o, _)| *o);
        let mut discarded = false;
        for &(_, mut f) in frags.iter() {
            counts.fragments += 1;
            f.z = (f.z.0 - slope, f.z.1 + slope);
            f.z_mean = mean_depth(f.mask, base, |i| src.z(i));
            // Merge into the first slot, front to back, that agrees.
            if merge_geometry {
                let target = slots.iter().position(|t| {
                    t.mask & f.mask == 0
                        && t.z.0 <= f.z.1
                        && f.z.0 <= t.z.1
                        && t.normal.dot(f.normal).abs() >= MERGE_DOT
                });
                if let Some(t) = target {
                    counts.merges += 1;
                    let t = &mut slots[t];
                    let a =
                        t.merged.map_or_else(|| Fields::of(src, t.first, t.mask.count_ones() as f32), |m| merged[m]);
                    let b = Fields::of(src, f.first, f.mask.count_ones() as f32);
                    let m = Fields::merge(&a, &b);
                    t.mask |= f.mask;
                    t.z = (t.z.0.min(f.z.0), t.z.1.max(f.z.1));
                    t.normal = m.sample.normal;
                    t.z_mean = mean_depth(t.mask, base, |i| src.z(i));
                    match t.merged {
                        Some(idx) => merged[idx] = m,
                        None => {
                            merged.push(m);
                            t.merged = Some(merged.len() - 1);
                        }
                    }
                    continue;
                }
            }
            let at = slots.iter().position(|t| t.z_mean > f.z_mean).unwrap_or(slots.len());
            slots.insert(at, f);
            if slots.len() > k {
                // Evict the candidate with the fewest samples (all are fresh: visible fragments do not overlap),
                // ties to the farther one.
                let victim =
                    (0..slots.len()).rev().min_by_key(|&v| slots[v].mask.count_ones()).expect("k + 1 candidates");
                counts.evicted_samples += u64::from(slots[victim].mask.count_ones());
                slots.remove(victim);
                discarded = true;
            }
        }
        out.extend(
            slots.iter().map(|t| (t.mask, t.merged.map_or_else(|| Fields::of(src, t.first, 0.0), |m| merged[m]))),
        );
        (counts, discarded)
    }
}

/// Aggregates in the manner of Crassin et al.'s AGAA (HPG 2015), simulated on a dump: each pixel's covered samples
/// are split into at most `count` depth layers — sorted by view depth and cut at the largest gaps that exceed the
/// pixel's depth slope (|∂z/∂x| + |∂z/∂y|, the span one surface covers across a pixel), so a pixel on one surface
/// keeps one aggregate — and each layer stores the mean of its samples' fields, shaded once. The normal is the
/// renormalised mean; where the normals disagree, the mean's length ρ < 1 widens the specular lobe (Toksvig 2005:
/// power s becomes ρs / (ρ + s(1 − ρ))), the filtering an aggregate needs to stand for several surfaces. IDs are
/// those of the layer's nearest sample. Footprint as [`footprint`] with `count` slots; nothing is evicted (every
/// covered sample belongs to a layer).
///
/// Errors as [`compress`].
pub fn aggregate(gb: &GBuffer, count: u32) -> Result<Compressed> {
    let pre = prepare(gb, count, "aggregates")?;
    let config = StreamingConfig { slots: count, merge: false };
    Ok(run_rows(&pre, 0..gb.height as usize, config, Method::Aggregate, &aggregate_pixel(gb, count)))
}

/// Per-thread scratch of [`aggregate`]: the samples by depth, the cuts, the layer ends.
type AggregateScratch = (Vec<(f32, usize)>, Vec<(f32, usize)>, Vec<usize>);

/// The aggregate builder of one pixel ([`aggregate`]).
fn aggregate_pixel(gb: &GBuffer, count: u32) -> impl PixelFn<AggregateScratch> + '_ {
    let s = gb.samples as usize;
    move |src: &Source<'_>, p: usize, sc: &mut AggregateScratch, out: &mut Vec<(u64, Fields)>| {
        let (order, cuts, at) = sc;
        let base = p * s;
        order.clear();
        for j in 0..s {
            if gb.coverage[base + j] {
                order.push((src.z(base + j), j));
            }
        }
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // The largest gaps (beyond one surface's span) become the cuts between layers, in depth order.
        cuts.clear();
        for w in 0..order.len().saturating_sub(1) {
            let gap = order[w + 1].0 - order[w].0;
            if gap > 2.0 * src.slope[p] {
                cuts.push((gap, w + 1));
            }
        }
        cuts.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        cuts.truncate(count as usize - 1);
        at.clear();
        at.extend(cuts.iter().map(|c| c.1));
        at.sort_unstable();
        at.push(order.len());
        let mut start = 0;
        for &end in at.iter() {
            if end > start {
                let members = &order[start..end];
                let mask = members.iter().fold(0u64, |m, &(_, j)| m | 1 << j);
                out.push((mask, Fields::mean(src, members.iter().map(|&(_, j)| base + j))));
            }
            start = end;
        }
        (Counts { fragments: order.len() as u64, ..Counts::default() }, false)
    }
}

/// Rows per strip of [`light_compressed`]: a strip's compressed G-buffer is a few MB at 1080p (4 tile rows of 16).
pub const STRIP_ROWS: usize = 64;

/// A compressed frame lit strip by strip ([`light_compressed`]): the image and what the compression counted.
#[derive(Clone, Debug)]
pub struct LitCompressed {
    /// How the pixels' fragments were rebuilt.
    pub key: FragmentKey,
    /// The lit image (every discarded pixel's colour rescaled as [`Compressed::light`] does).
    pub image: HdrImage,
    /// Shading evaluations: one per slot in use.
    pub evaluations: u64,
    /// Pixels by slots in use (0..=slots).
    pub slot_histogram: Vec<u64>,
    /// Fragments streamed in.
    pub fragments: u64,
    /// Fragments merged into a slot.
    pub merges: u64,
    /// Covered samples whose fragment was evicted.
    pub evicted_samples: u64,
    /// Pixels that evicted a fragment.
    pub discarded_pixels: u64,
}

/// What every compression of one frame reads (its positions, derived from depth when it has none, its view depth
/// and depth slopes), derived once ([`CompressFrame::new`]) for all the methods and slot counts
/// [`light_compressed`] runs on the frame.
pub struct CompressFrame<'a>(Prepared<'a>);

impl<'a> CompressFrame<'a> {
    /// Derives what the compressors read of `gb`; fails when it has no positions and no depth with a camera.
    pub fn new(gb: &'a GBuffer) -> Result<Self> {
        derive(gb).map(CompressFrame)
    }
}

/// Compresses the frame ([`compress`] for [`Method::Streaming`], [`aggregate`] with `cfg.slots` layers for
/// [`Method::Aggregate`]) and lights it, `strip_rows` rows at a time: the same image as compressing the whole frame
/// and calling [`Compressed::light`] (the resolve reads the slots' positions, so a strip lights as the frame does;
/// tested), without the whole compressed G-buffer in memory.
pub fn light_compressed(
    frame: &CompressFrame<'_>,
    method: Method,
    cfg: &StreamingConfig,
    lights: &[crate::light::Light],
    rc: &crate::resolve::ResolveConfig,
    strip_rows: usize,
) -> Result<LitCompressed> {
    let (pre, gb) = (&frame.0, frame.0.gb);
    match method {
        Method::Streaming => {
            check_slots(gb, cfg.slots, "surface slots")?;
            strips(pre, *cfg, method, &stream_pixel(gb, cfg), lights, rc, strip_rows)
        }
        Method::Aggregate => {
            check_slots(gb, cfg.slots, "aggregates")?;
            let config = StreamingConfig { slots: cfg.slots, merge: false };
            strips(pre, config, method, &aggregate_pixel(gb, cfg.slots), lights, rc, strip_rows)
        }
    }
}

fn strips<S: Default + Send>(
    pre: &Prepared<'_>,
    config: StreamingConfig,
    method: Method,
    pixel: &impl PixelFn<S>,
    lights: &[crate::light::Light],
    rc: &crate::resolve::ResolveConfig,
    strip_rows: usize,
) -> Result<LitCompressed> {
    let gb = pre.gb;
    let (w, h) = (gb.width as usize, gb.height as usize);
    let mut lit = LitCompressed {
        key: fragment_key(gb),
        image: HdrImage { width: gb.width, height: gb.height, rgb: vec![Vec3::ZERO; w * h] },
        evaluations: 0,
        slot_histogram: vec![0; config.slots as usize + 1],
        fragments: 0,
        merges: 0,
        evicted_samples: 0,
        discarded_pixels: 0,
    };
    let step = strip_rows.max(1);
    for y0 in (0..h).step_by(step) {
        let c = run_rows(pre, y0..(y0 + step).min(h), config, method, pixel);
        let r = c.light(lights, rc)?;
        lit.image.rgb[y0 * w..y0 * w + r.image.rgb.len()].copy_from_slice(&r.image.rgb);
        lit.evaluations += c.evaluations();
        for (a, b) in lit.slot_histogram.iter_mut().zip(c.slot_histogram()) {
            *a += b;
        }
        lit.fragments += c.fragments;
        lit.merges += c.merges;
        lit.evicted_samples += c.evicted_samples;
        lit.discarded_pixels += c.discarded_pixels;
    }
    Ok(lit)
}

impl Compressed {
    fn empty(width: u32, height: u32, samples: u32, config: StreamingConfig, method: Method, key: FragmentKey) -> Self {
        let pixels = width as usize * height as usize;
        Compressed {
            config,
            method,
            key,
            slots_per_pixel: vec![0; pixels],
            fragments: 0,
            merges: 0,
            evicted_samples: 0,
            discarded_pixels: 0,
            gbuffer: GBuffer::default(),
            mask: EdgeMask::filled(width, height, samples, 0),
            scale: vec![1.0; pixels],
        }
    }

    /// Shading evaluations a GPU pays: one per slot in use.
    #[must_use]
    pub fn evaluations(&self) -> u64 {
        self.slots_per_pixel.iter().map(|&n| u64::from(n)).sum()
    }

    /// Histogram of slots in use: pixels with 0, 1, …, `slots` slots.
    #[must_use]
    pub fn slot_histogram(&self) -> Vec<u64> {
        let mut h = vec![0u64; self.config.slots as usize + 1];
        for &n in &self.slots_per_pixel {
            h[usize::from(n)] += 1;
        }
        h
    }

    /// Lights the compressed G-buffer with `lights`: the tiled resolve over [`Self::gbuffer`] with [`Self::mask`],
    /// each discarded pixel's colour then divided by the share of its covered samples its slots still hold.
    pub fn light(
        &self,
        lights: &[crate::light::Light],
        cfg: &crate::resolve::ResolveConfig,
    ) -> Result<crate::resolve::Resolved> {
        let mut r = crate::resolve::resolve(&self.gbuffer, lights, &self.mask, cfg)?;
        for (c, &k) in r.image.rgb.iter_mut().zip(&self.scale) {
            if k != 1.0 {
                *c *= k;
            }
        }
        Ok(r)
    }
}

/// How `gb`'s fragments are rebuilt.
fn fragment_key(gb: &GBuffer) -> FragmentKey {
    if gb.primitive_id.is_some() {
        FragmentKey::ObjectPrimitive
    } else if gb.object_id.is_some() || gb.material_id.is_some() {
        FragmentKey::ObjectMaterial
    } else {
        FragmentKey::Geometry
    }
}

/// The streaming-order key of sample `i` (sample `j` of its pixel): its IDs, or its sample index without IDs.
fn order_key(gb: &GBuffer, key: FragmentKey, i: usize, j: usize) -> u64 {
    let id = |p: &Option<Vec<u32>>| p.as_ref().map_or(0, |v| u64::from(v[i]));
    match key {
        FragmentKey::ObjectPrimitive => id(&gb.object_id) << 32 | id(&gb.primitive_id),
        FragmentKey::ObjectMaterial => id(&gb.object_id) << 32 | id(&gb.material_id),
        FragmentKey::Geometry => j as u64,
    }
}

/// Do two samples lie on one surface by [`crate::analysis::surfaces`]'s geometric rule?
fn same_geometry(z0: f32, n0: Vec3, z1: f32, n1: Vec3) -> bool {
    let near = z0.abs().min(z1.abs());
    n0.dot(n1).abs() >= MERGE_DOT && (z0 - z1).abs() <= crate::analysis::surfaces::MERGE_DEPTH_RELATIVE * near
}

/// Mean view depth of the samples of `mask` in the pixel starting at sample `base`.
fn mean_depth(mask: u64, base: usize, z: impl Fn(usize) -> f32) -> f32 {
    let (mut sum, mut n) = (0.0f32, 0u32);
    let mut m = mask;
    while m != 0 {
        let j = m.trailing_zeros() as usize;
        sum += z(base + j);
        n += 1;
        m &= m - 1;
    }
    sum / n.max(1) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_authors_footprint_at_8x() {
        // Kerzner & Salvi's configuration: a 16-byte G-buffer, 3 slots at 8×.
        let f = footprint(16, 8, 3);
        assert_eq!((f.slot_bytes, f.compressed_bytes_per_pixel, f.full_bytes_per_pixel), (20, 68, 128));
        assert_eq!(footprint(20, 4, 4).compressed_bytes_per_pixel, 4 * 24 + 8);
        assert_eq!(footprint(8, 16, 2).slot_bytes, 12);
        assert_eq!(footprint(8, 32, 2).slot_bytes, 16);
    }
}
