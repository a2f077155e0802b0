//! The shading schedule: per tile, gather the samples to shade into one packed work list (non-edge pixels
//! contribute their first covered sample, edge pixels every covered sample — Lauritzen 2010's rescheduling: the
//! per-sample work is packed densely instead of branching per pixel), cull lights against the list's bounds, shade
//! the list against the surviving lights with the batched kernel, and box-filter the results into the pixels.
//!
//! Tiles run in parallel on rayon's current thread pool; tiles are small (16×16 by default), so each thread takes
//! many and rayon balances them. Background samples contribute 0 (black sky) to the box filter; a non-edge pixel
//! takes its one shaded sample's value for the whole pixel (that sample stands for the pixel, as in the demo).

use super::config::{Culling, ResolveConfig, Schedule};
use super::culling::{light_sphere, quad_rects, Bounds};
use super::kernel::{finish_prepass, shade, Items, QuadSoa, Variant};
use super::lights::LightSoa;
use super::surface::{SanitizedCounts, SurfaceReader};
use crate::detect::EdgeMask;
use crate::light::Light;
use glam::Vec3;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Everything shared by the tiles of one resolve.
pub struct Frame<'a> {
    /// Sample reader.
    pub reader: SurfaceReader<'a>,
    /// Which pixels are shaded per sample.
    pub mask: &'a EdgeMask,
    /// Sanitised lights.
    pub lights: &'a [Light],
    /// Their kernel constants.
    pub soa: LightSoa,
    /// Culling spheres: centres and grown radii.
    pub spheres: Spheres,
    /// Quad rectangles (quad culling only).
    pub quads: QuadSoa,
    /// The configuration.
    pub cfg: ResolveConfig,
}

/// Light culling spheres as structure of arrays (so the per-tile test vectorises over lights).
#[derive(Clone, Debug, Default)]
pub struct Spheres {
    /// Centre x.
    pub x: Vec<f32>,
    /// Centre y.
    pub y: Vec<f32>,
    /// Centre z.
    pub z: Vec<f32>,
    /// Radius (∞ = never culled).
    pub r: Vec<f32>,
}

impl<'a> Frame<'a> {
    /// Prepares the per-light data for `cfg`.
    #[must_use]
    pub fn new(reader: SurfaceReader<'a>, mask: &'a EdgeMask, lights: &'a [Light], cfg: ResolveConfig) -> Self {
        let soa = LightSoa::new(lights, cfg.falloff);
        let mut spheres = Spheres::default();
        for l in lights {
            let (c, r) = light_sphere(l);
            spheres.x.push(c.x);
            spheres.y.push(c.y);
            spheres.z.push(c.z);
            spheres.r.push(r);
        }
        let quads = if cfg.culling == Culling::Quad { quad_rects(lights) } else { QuadSoa::default() };
        Frame { reader, mask, lights, soa, spheres, quads, cfg }
    }
}

/// The result of one tile.
#[derive(Clone, Debug, Default)]
pub struct TileOut {
    /// Left pixel column.
    pub x0: u32,
    /// Top pixel row.
    pub y0: u32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
    /// Pixel colours, row-major within the tile.
    pub rgb: Vec<Vec3>,
    /// Light evaluations per pixel (sum over its shaded samples).
    pub heat: Vec<u32>,
    /// Light-sample pairs that reached the shading loop.
    pub tested: u64,
    /// Pairs with a nonzero contribution.
    pub lit: u64,
    /// Samples shaded.
    pub evaluations: u64,
    /// Pixels shaded per sample.
    pub edge_pixels: u64,
    /// Values sanitised while reading.
    pub sanitized: SanitizedCounts,
    /// Time building the work list.
    pub t_gather: Duration,
    /// Time culling.
    pub t_cull: Duration,
    /// Time shading and filtering.
    pub t_shade: Duration,
}

/// Per-thread scratch buffers, reused from tile to tile.
#[derive(Default)]
struct Scratch {
    items: Items,
    sorted: Items,
    lights: LightSoa,
    quads: QuadSoa,
    tile_lights: Vec<u32>,
    mask: Vec<u8>,
    order: Vec<usize>,
}

/// Runs every tile of `frame` in parallel (on the current rayon pool) and returns the tile results in row-major
/// tile order.
pub fn run_tiles(frame: &Frame<'_>) -> Vec<TileOut> {
    let gb = frame.reader.gbuffer();
    let ts = frame.cfg.tile_size;
    let (nx, ny) = (gb.width.div_ceil(ts), gb.height.div_ceil(ts));
    (0..nx * ny)
        .into_par_iter()
        .map_init(Scratch::default, |scratch, t| {
            let (x0, y0) = ((t % nx) * ts, (t / nx) * ts);
            let (w, h) = (ts.min(gb.width - x0), ts.min(gb.height - y0));
            run_tile(frame, x0, y0, w, h, scratch)
        })
        .collect()
}

fn run_tile(frame: &Frame<'_>, x0: u32, y0: u32, w: u32, h: u32, sc: &mut Scratch) -> TileOut {
    let t0 = Instant::now();
    let mut out = TileOut { x0, y0, w, h, ..Default::default() };
    gather(frame, &mut out, sc);
    let t1 = Instant::now();
    out.t_gather = t1 - t0;
    let n_real = sc.items.len();
    out.rgb = vec![Vec3::ZERO; (w * h) as usize];
    out.heat = vec![0; (w * h) as usize];
    if n_real == 0 {
        return out;
    }
    sc.items.pad_to_lanes(n_real - 1);
    let n = sc.items.len();
    let variant = Variant {
        brdf: frame.cfg.brdf,
        falloff: frame.cfg.falloff,
        quad: frame.cfg.culling == Culling::Quad,
        prepass: frame.cfg.schedule == Schedule::LightPrepass,
    };
    let mut t_cull = Duration::ZERO;
    let mut t_shade = Duration::ZERO;
    let items = match frame.cfg.culling {
        Culling::None => {
            let t = Instant::now();
            shade(&mut sc.items, 0..n, &frame.soa, &frame.quads, variant);
            t_shade += t.elapsed();
            &mut sc.items
        }
        Culling::Tiled | Culling::Quad => {
            let t = Instant::now();
            let bounds = Bounds::of_items(&sc.items, 0..n).expect("nonempty");
            cull_into(frame, &bounds, None, sc);
            t_cull += t.elapsed();
            let t = Instant::now();
            shade(&mut sc.items, 0..n, &sc.lights, &sc.quads, variant);
            t_shade += t.elapsed();
            &mut sc.items
        }
        Culling::Clustered => {
            let t = Instant::now();
            let bounds = Bounds::of_items(&sc.items, 0..n).expect("nonempty");
            cull_tile_list(frame, &bounds, sc);
            let ranges = sort_by_slice(&bounds, frame.cfg.depth_slices, n_real, sc);
            t_cull += t.elapsed();
            for range in ranges {
                let t = Instant::now();
                let b = Bounds::of_items(&sc.sorted, range.clone()).expect("nonempty slice");
                let list = std::mem::take(&mut sc.tile_lights);
                cull_into(frame, &b, Some(&list), sc);
                sc.tile_lights = list;
                t_cull += t.elapsed();
                let t = Instant::now();
                shade(&mut sc.sorted, range, &sc.lights, &sc.quads, variant);
                t_shade += t.elapsed();
            }
            // Back to tile order, so the box filter adds samples in the same order whatever the culling.
            let (it, so) = (&mut sc.items, &sc.sorted);
            for (j, &k) in sc.order.iter().enumerate() {
                (it.or[j], it.og[j], it.ob[j], it.ls[j]) = (so.or[k], so.og[k], so.ob[k], so.ls[k]);
                (it.tested[j], it.lit[j]) = (so.tested[k], so.lit[k]);
            }
            &mut sc.items
        }
    };
    let t = Instant::now();
    if variant.prepass {
        finish_prepass(items, frame.cfg.brdf);
    }
    for j in 0..n_real {
        let px = items.pixel[j] as usize;
        let c = Vec3::new(items.or[j], items.og[j], items.ob[j]) * items.weight[j];
        out.rgb[px] += c;
        out.heat[px] += items.tested[j];
        out.tested += u64::from(items.tested[j]);
        out.lit += u64::from(items.lit[j]);
    }
    out.evaluations = n_real as u64;
    t_shade += t.elapsed();
    out.t_cull = t_cull;
    out.t_shade = t_shade;
    out
}

/// Builds the tile's work list: first the single samples of non-edge pixels, then the packed samples of edge
/// pixels.
fn gather(frame: &Frame<'_>, out: &mut TileOut, sc: &mut Scratch) {
    let gb = frame.reader.gbuffer();
    let samples = gb.samples;
    let weight = 1.0 / samples as f32;
    sc.items.clear();
    let counts = &mut out.sanitized;
    for pass_edges in [false, true] {
        for y in out.y0..out.y0 + out.h {
            for x in out.x0..out.x0 + out.w {
                let p = y as usize * gb.width as usize + x as usize;
                let local = (y - out.y0) * out.w + (x - out.x0);
                let edge = frame.mask.is_edge(p);
                if edge != pass_edges {
                    continue;
                }
                if edge {
                    let before = sc.items.len();
                    for s in 0..samples {
                        if let Some(surf) = frame.reader.read(x, y, s, counts) {
                            sc.items.push(&surf, local, weight);
                        }
                    }
                    out.edge_pixels += u64::from(sc.items.len() > before);
                } else if let Some(surf) = (0..samples).find_map(|s| frame.reader.read(x, y, s, counts)) {
                    sc.items.push(&surf, local, 1.0);
                }
            }
        }
    }
}

/// Tests every light's sphere against `bounds` (branch-free over lights), writing survivors' indices into
/// `sc.tile_lights`.
fn cull_tile_list(frame: &Frame<'_>, b: &Bounds, sc: &mut Scratch) {
    let s = &frame.spheres;
    let n = s.x.len();
    sc.mask.clear();
    sc.mask.resize(n, 0);
    let probe = |c: Vec3, r: f32| b.may_touch(c, r);
    for (i, m) in sc.mask.iter_mut().enumerate() {
        *m = u8::from(probe(Vec3::new(s.x[i], s.y[i], s.z[i]), s.r[i]));
    }
    sc.tile_lights.clear();
    sc.tile_lights.extend(sc.mask.iter().enumerate().filter(|(_, &m)| m != 0).map(|(i, _)| i as u32));
}

/// Culls lights (all, or only those in `subset`) against `b` and gathers the survivors' constants into
/// `sc.lights` / `sc.quads`, in increasing light order.
fn cull_into(frame: &Frame<'_>, b: &Bounds, subset: Option<&[u32]>, sc: &mut Scratch) {
    sc.lights.clear();
    sc.quads.clear();
    let quad = frame.cfg.culling == Culling::Quad;
    let keep = |i: usize, sc: &mut Scratch| {
        sc.lights.push_from(&frame.soa, i);
        if quad {
            sc.quads.push_from(&frame.quads, i);
        }
    };
    match subset {
        Some(list) => {
            let s = &frame.spheres;
            for &i in list {
                let i = i as usize;
                if b.may_touch(Vec3::new(s.x[i], s.y[i], s.z[i]), s.r[i]) {
                    keep(i, sc);
                }
            }
        }
        None if quad => {
            for i in 0..frame.lights.len() {
                if b.overlaps_quad(&frame.quads, i) {
                    keep(i, sc);
                }
            }
        }
        None => {
            cull_tile_list(frame, b, sc);
            let list = std::mem::take(&mut sc.tile_lights);
            for &i in &list {
                keep(i as usize, sc);
            }
            sc.tile_lights = list;
        }
    }
}

/// Assigns every real item (`0..n_real`) to one of `slices` depth slices (log-spaced between the tile's min and
/// max depth), copies the work list slice by slice into `sc.sorted` (each slice padded to whole vectors), sets
/// `sc.order[j]` to item `j`'s position there, and returns the non-empty slices' ranges.
fn sort_by_slice(b: &Bounds, slices: u32, n_real: usize, sc: &mut Scratch) -> Vec<std::ops::Range<usize>> {
    let ratio = (b.d1 / b.d0).ln();
    let scale = if ratio > 1e-6 && ratio.is_finite() { slices as f32 / ratio } else { 0.0 };
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); slices as usize];
    for j in 0..n_real {
        let k = (((sc.items.dep[j] / b.d0).ln() * scale) as u32).min(slices - 1);
        members[k as usize].push(j);
    }
    sc.sorted.clear();
    sc.order.clear();
    sc.order.resize(n_real, 0);
    let mut ranges = Vec::new();
    for list in members.iter().filter(|l| !l.is_empty()) {
        let start = sc.sorted.len();
        for &j in list {
            sc.order[j] = sc.sorted.len();
            sc.sorted.push_from(&sc.items, j);
        }
        sc.sorted.pad_to_lanes(sc.sorted.len() - 1);
        ranges.push(start..sc.sorted.len());
    }
    ranges
}
