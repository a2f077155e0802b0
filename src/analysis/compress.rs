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

use crate::analysis::surfaces::MERGE_DOT;
use crate::base::mask::EdgeMask;
use crate::detect::{self, Detector};
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

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

/// Float fields of a merged slot (coverage-weighted means), and the IDs of its larger part.
#[derive(Clone, Copy, Debug, Default)]
struct Fields {
    weight: f32,
    depth: f32,
    position: Vec3,
    normal: Vec3,
    albedo: Vec3,
    specular: f32,
    specular_power: f32,
    roughness: f32,
    metallic: f32,
    motion: Vec2,
    /// Material, object and primitive ID of the larger part's first sample.
    ids: [u32; 3],
}

impl Fields {
    fn of(gb: &GBuffer, i: usize, weight: f32) -> Self {
        let f = |p: &Option<Vec<f32>>| p.as_ref().map_or(0.0, |v| v[i]);
        let v = |p: &Option<Vec<Vec3>>| p.as_ref().map_or(Vec3::ZERO, |v| v[i]);
        Fields {
            weight,
            depth: f(&gb.depth),
            position: v(&gb.position),
            normal: v(&gb.normal),
            albedo: v(&gb.albedo),
            specular: f(&gb.specular),
            specular_power: f(&gb.specular_power),
            roughness: f(&gb.roughness),
            metallic: f(&gb.metallic),
            motion: gb.motion.as_ref().map_or(Vec2::ZERO, |v| v[i]),
            ids: [&gb.material_id, &gb.object_id, &gb.primitive_id].map(|p| p.as_ref().map_or(0, |v| v[i])),
        }
    }

    /// The mean of the samples `members` (the first is the nearest: its IDs are kept), the specular power widened
    /// by Toksvig's factor where the normals disagree.
    fn mean(gb: &GBuffer, members: impl Iterator<Item = usize> + Clone) -> Self {
        let mut it = members.clone();
        let first = it.next().expect("a layer has a sample");
        let mut sum = Fields::of(gb, first, 1.0);
        for i in it {
            let f = Fields::of(gb, i, 1.0);
            sum.weight += 1.0;
            sum.depth += f.depth;
            sum.position += f.position;
            sum.normal += f.normal;
            sum.albedo += f.albedo;
            sum.specular += f.specular;
            sum.specular_power += f.specular_power;
            sum.roughness += f.roughness;
            sum.metallic += f.metallic;
            sum.motion += f.motion;
        }
        let inv = 1.0 / sum.weight;
        let mean_normal = sum.normal * inv;
        let rho = mean_normal.length().min(1.0);
        let power = sum.specular_power * inv;
        Fields {
            weight: sum.weight,
            depth: sum.depth * inv,
            position: sum.position * inv,
            normal: mean_normal.normalize_or(Fields::of(gb, first, 1.0).normal),
            albedo: sum.albedo * inv,
            specular: sum.specular * inv,
            specular_power: if rho > 0.0 && power > 0.0 { rho * power / (rho + power * (1.0 - rho)) } else { power },
            roughness: sum.roughness * inv,
            metallic: sum.metallic * inv,
            motion: sum.motion * inv,
            ids: sum.ids,
        }
    }

    /// The coverage-weighted mean of `a` and `b`.
    fn merge(a: &Fields, b: &Fields) -> Fields {
        let w = a.weight + b.weight;
        let (ta, tb) = (a.weight / w, b.weight / w);
        let larger = if b.weight > a.weight { b } else { a };
        let normal = if a.normal.dot(b.normal) > 0.0 {
            (a.normal * ta + b.normal * tb).normalize_or(larger.normal)
        } else {
            larger.normal
        };
        Fields {
            weight: w,
            depth: a.depth * ta + b.depth * tb,
            position: a.position * ta + b.position * tb,
            normal,
            albedo: a.albedo * ta + b.albedo * tb,
            specular: a.specular * ta + b.specular * tb,
            specular_power: a.specular_power * ta + b.specular_power * tb,
            roughness: a.roughness * ta + b.roughness * tb,
            metallic: a.metallic * ta + b.metallic * tb,
            motion: a.motion * ta + b.motion * tb,
            ids: larger.ids,
        }
    }

    /// Writes the fields into sample `i` of `out` (the planes `out` has).
    fn write(&self, out: &mut GBuffer, i: usize) {
        let put = |p: &mut Option<Vec<f32>>, x: f32| {
            if let Some(v) = p.as_mut() {
                v[i] = x;
            }
        };
        put(&mut out.depth, self.depth);
        put(&mut out.specular, self.specular);
        put(&mut out.specular_power, self.specular_power);
        put(&mut out.roughness, self.roughness);
        put(&mut out.metallic, self.metallic);
        for (p, x) in
            [(&mut out.position, self.position), (&mut out.normal, self.normal), (&mut out.albedo, self.albedo)]
        {
            if let Some(v) = p.as_mut() {
                v[i] = x;
            }
        }
        if let Some(v) = out.motion.as_mut() {
            v[i] = self.motion;
        }
        for (o, id) in [&mut out.material_id, &mut out.object_id, &mut out.primitive_id].into_iter().zip(self.ids) {
            if let Some(o) = o.as_mut() {
                o[i] = id;
            }
        }
    }
}

/// Compresses `gb` into at most `cfg.slots` slots per pixel (see the module notes).
///
/// Errors when `slots` is 0 or above the sample count, when the G-buffer has more than 64 samples, or when no
/// position can be formed for the lighting pass (no position plane, and no depth with a camera).
pub fn compress(gb: &GBuffer, cfg: &StreamingConfig) -> Result<Compressed> {
    let (mut out, depth, slope) = prepare(gb, cfg.slots, "surface slots")?;
    let s = gb.samples as usize;
    let key = fragment_key(gb);
    let merge_geometry = cfg.merge && depth.is_some() && gb.normal.is_some();
    let k = cfg.slots as usize;
    let mut c = Compressed::empty(gb, *cfg, Method::Streaming, key);
    let mut frags: Vec<(u64, Slot)> = Vec::with_capacity(s);
    let mut slots: Vec<Slot> = Vec::with_capacity(k + 1);
    let mut merged: Vec<Fields> = Vec::new();
    for (p, &slope) in slope.iter().enumerate() {
        let base = p * s;
        frags.clear();
        slots.clear();
        merged.clear();
        let z_of = |i: usize| depth.as_ref().map_or(0.0, |d| d[i]);
        let n_of = |i: usize| gb.normal.as_ref().map_or(Vec3::ZERO, |n| n[i]);
        // Rebuild the fragments: covered samples grouped by key, each with its mask, first sample and depth range.
        for j in 0..s {
            let i = base + j;
            if !gb.coverage[i] {
                continue;
            }
            let order = order_key(gb, key, i, j);
            let joins = frags.iter().position(|(o, f)| match key {
                FragmentKey::Geometry => same_geometry(z_of(f.first), n_of(f.first), z_of(i), n_of(i)),
                _ => *o == order,
            });
            match joins {
                Some(f) => {
                    let f = &mut frags[f].1;
                    f.mask |= 1 << j;
                    let z = z_of(i);
                    f.z = (f.z.0.min(z), f.z.1.max(z));
                }
                None => {
                    let z = z_of(i);
                    frags.push((
                        order,
                        Slot { mask: 1 << j, first: i, z: (z, z), z_mean: z, normal: n_of(i), merged: None },
                    ));
                }
            }
        }
        frags.sort_by_key(|(o, _)| *o);
        let mut discarded = false;
        for &(_, mut f) in frags.iter() {
            c.fragments += 1;
            f.z = (f.z.0 - slope, f.z.1 + slope);
            f.z_mean = mean_depth(&f, base, &z_of);
            // Merge into the first slot, front to back, that agrees.
            if merge_geometry {
                let target = slots.iter().position(|t| {
                    t.mask & f.mask == 0
                        && t.z.0 <= f.z.1
                        && f.z.0 <= t.z.1
                        && t.normal.dot(f.normal).abs() >= MERGE_DOT
                });
                if let Some(t) = target {
                    c.merges += 1;
                    let t = &mut slots[t];
                    let a =
                        t.merged.map_or_else(|| Fields::of(&out, t.first, t.mask.count_ones() as f32), |m| merged[m]);
                    let b = Fields::of(&out, f.first, f.mask.count_ones() as f32);
                    let m = Fields::merge(&a, &b);
                    t.mask |= f.mask;
                    t.z = (t.z.0.min(f.z.0), t.z.1.max(f.z.1));
                    t.normal = m.normal;
                    t.z_mean = m.depth;
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
                c.evicted_samples += u64::from(slots[victim].mask.count_ones());
                slots.remove(victim);
                discarded = true;
            }
        }
        // Write the slots back per sample (every slot's fields read before any sample is written); evicted
        // samples become background.
        let fields: Vec<(u64, Fields)> = slots
            .iter()
            .map(|t| (t.mask, t.merged.map_or_else(|| Fields::of(&out, t.first, 0.0), |m| merged[m])))
            .collect();
        write_pixel(gb, &mut out, &mut c, p, &fields, discarded);
    }
    out.zero_background();
    c.gbuffer = out;
    Ok(c)
}

/// Writes pixel `p`'s slots (coverage mask, fields) into `out`, samples no slot covers becoming background, and
/// sets the pixel's slot count, mask entry and (when `discarded`) its colour scale in `c`.
fn write_pixel(
    gb: &GBuffer,
    out: &mut GBuffer,
    c: &mut Compressed,
    p: usize,
    slots: &[(u64, Fields)],
    discarded: bool,
) {
    let s = gb.samples as usize;
    let base = p * s;
    let mut kept: u64 = 0;
    for (mask, fields) in slots {
        kept |= mask;
        for j in 0..s {
            if mask >> j & 1 == 1 {
                fields.write(out, base + j);
            }
        }
    }
    let covered = gb.coverage[base..base + s].iter().filter(|&&c| c).count();
    for j in 0..s {
        if gb.coverage[base + j] && kept >> j & 1 == 0 {
            out.coverage[base + j] = false;
        }
    }
    let kept_n = kept.count_ones() as usize;
    c.slots_per_pixel[p] = slots.len() as u8;
    c.mask.shade_count[p] = match slots.len() {
        0 => 0,
        1 if covered == s && kept_n == s => 1,
        _ => s.min(usize::from(u8::MAX)) as u8,
    };
    if discarded {
        c.discarded_pixels += 1;
        if kept_n > 0 {
            c.scale[p] = covered as f32 / kept_n as f32;
        }
    }
}

/// Aggregates in the manner of Crassin et al.'s AGAA (HPG 2015), simulated on a dump: each pixel's covered samples
/// are split into at most `count` depth layers — sorted by view depth and cut at the largest gaps that exceed the
/// pixel's depth slope (|∂z/∂x| + |∂z/∂y|, the span one surface covers across a pixel), so a pixel on one surface
/// keeps one aggregate — and each layer stores the coverage-weighted mean of its samples' fields, shaded once. The
/// normal is the renormalised mean; where the normals disagree, the mean's length ρ < 1 widens the specular lobe
/// (Toksvig 2005: power s becomes ρs / (ρ + s(1 − ρ))), the filtering an aggregate needs to stand for several
/// surfaces. IDs are those of the layer's nearest sample. Footprint as [`footprint`] with `count` slots; nothing
/// is evicted (every covered sample belongs to a layer).
///
/// Errors as [`compress`].
pub fn aggregate(gb: &GBuffer, count: u32) -> Result<Compressed> {
    let (mut out, depth, slope) = prepare(gb, count, "aggregates")?;
    let s = gb.samples as usize;
    let mut c =
        Compressed::empty(gb, StreamingConfig { slots: count, merge: false }, Method::Aggregate, fragment_key(gb));
    let mut order: Vec<(f32, usize)> = Vec::with_capacity(s);
    let mut cuts: Vec<(f32, usize)> = Vec::with_capacity(s);
    for (p, &slope) in slope.iter().enumerate() {
        let base = p * s;
        order.clear();
        for j in 0..s {
            if gb.coverage[base + j] {
                order.push((depth.as_ref().map_or(0.0, |d| d[base + j]), j));
            }
        }
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // The largest gaps (beyond one surface's span) become the cuts between layers, in depth order.
        cuts.clear();
        for w in 0..order.len().saturating_sub(1) {
            let gap = order[w + 1].0 - order[w].0;
            if gap > 2.0 * slope {
                cuts.push((gap, w + 1));
            }
        }
        cuts.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        cuts.truncate(count as usize - 1);
        let mut at: Vec<usize> = cuts.iter().map(|c| c.1).collect();
        at.sort_unstable();
        at.push(order.len());
        c.fragments += order.len() as u64;
        let mut start = 0;
        let mut layers: Vec<(u64, Fields)> = Vec::with_capacity(at.len());
        for &end in &at {
            if end > start {
                let members = &order[start..end];
                let mask = members.iter().fold(0u64, |m, &(_, j)| m | 1 << j);
                layers.push((mask, Fields::mean(&out, members.iter().map(|&(_, j)| base + j))));
            }
            start = end;
        }
        write_pixel(gb, &mut out, &mut c, p, &layers, false);
    }
    out.zero_background();
    c.gbuffer = out;
    Ok(c)
}

/// Checks `slots` (1..=samples, at most 64 samples) and returns the copy slots are written into (with a position
/// plane), the view-depth plane and each pixel's depth slope |∂z/∂x| + |∂z/∂y| (0 where unknown).
fn prepare(gb: &GBuffer, slots: u32, what: &str) -> Result<(GBuffer, Option<Vec<f32>>, Vec<f32>)> {
    gb.validate()?;
    let s = gb.samples;
    if slots == 0 || slots > s {
        return Err(Error::Argument(format!("{slots} {what} for {s} samples per pixel: 1..={s}")));
    }
    if s > 64 {
        return Err(Error::Argument(format!("MSAA G-buffer compression masks hold 64 samples, not {s}")));
    }
    // The one copy: slots are written back into it pixel by pixel (a pixel's slots are read before its samples are
    // written, and no pixel reads another's samples).
    let mut out = gb.clone();
    if out.position.is_none() {
        out.fill_position_from_depth();
    }
    if out.position.is_none() && gb.coverage.iter().any(|&c| c) {
        return Err(Error::Mismatch(
            "MSAA G-buffer compression lights its slots: the G-buffer needs positions, or depth with a camera".into(),
        ));
    }
    let depth: Option<Vec<f32>> = detect::depth_plane(&out, Detector::Lauritzen).ok().map(|d| d.into_owned());
    let slope: Vec<f32> = match &depth {
        Some(_) => detect::lauritzen::neighbour_gradients(&out)?
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
    Ok((out, depth, slope))
}

impl Compressed {
    fn empty(gb: &GBuffer, config: StreamingConfig, method: Method, key: FragmentKey) -> Self {
        let pixels = gb.pixel_count();
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
            mask: EdgeMask::filled(gb.width, gb.height, gb.samples, 0),
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

/// Mean view depth of a fragment's samples.
fn mean_depth(f: &Slot, base: usize, z_of: &impl Fn(usize) -> f32) -> f32 {
    let (mut sum, mut n) = (0.0f32, 0u32);
    let mut m = f.mask;
    while m != 0 {
        let j = m.trailing_zeros() as usize;
        sum += z_of(base + j);
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
