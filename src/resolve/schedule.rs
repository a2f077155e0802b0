//! The shading schedule: per tile, gather the samples to shade into one packed work list (non-edge pixels
//! contribute their first covered sample, edge pixels every covered sample — Lauritzen 2010's rescheduling: the
//! per-sample work is packed densely instead of branching per pixel), cull lights against the list's bounds, shade
//! the list against the surviving lights with the batched kernel, and box-filter the results into the pixels.
//!
//! Tiles run in parallel on rayon's current thread pool; tiles are small (16×16 by default), so each thread takes
//! many and rayon balances them. Background samples contribute 0 (black sky) to the box filter; a non-edge pixel
//! takes its one shaded sample's value for the whole pixel (that sample stands for the pixel, as in the demo).
//!
//! With a shading-rate image ([`Coarse`]) the non-edge pixels of each coarse pixel are shaded once, at its
//! representative (the first of them in row order with a covered sample), and the others take its colour
//! (`broadcast`) or its colour remodulated by their own albedo (`lighting`) after the box filter. Edge pixels stay
//! per sample, as hardware composes coarse shading with MSAA. Tiles with no coarse pixel build the same list as
//! without an SRI.

use super::config::{Culling, MsaaSchedule, ResolveConfig, Schedule};
use super::culling::{quad_rects, Bounds};
use super::kernel::{finish_prepass, shade, Variant, BLOCK};
use super::lights::LightTable;
use super::simd::{lanes_for, Portable};
use super::surface::{position_from_depth, usable_position, Reads, SanitizedCounts, SurfaceReader};
use super::worklist::{Items, QuadSoa, PAD_PIXEL};
use crate::base::isa::Isa;
use crate::base::mask::EdgeMask;
use crate::detect::rate::{CoarseMode, Sri};
use crate::error::Result;
use crate::gbuffer::GBuffer;
use crate::layout::PackedFrame;
use crate::light::Light;
use glam::Vec3;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Everything shared by the tiles of one resolve.
pub struct Frame<'a> {
    /// Sample reader: of the frame's planes, or (when `packed` is given) only for the camera's rays.
    pub reader: SurfaceReader<'a>,
    /// The packed targets each band is decoded from, when the frame is lit from them.
    pub packed: Option<&'a PackedFrame<'a>>,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Which pixels are shaded per sample.
    pub mask: &'a EdgeMask,
    /// Sanitised lights (the light loop's).
    pub lights: &'a [Light],
    /// Hemisphere environments, added per sample after the light loop.
    pub environment: &'a [super::lights::Hemisphere],
    /// Their kernel constants and culling spheres.
    pub table: LightTable,
    /// Quad rectangles (quad culling only).
    pub quads: QuadSoa,
    /// The configuration.
    pub cfg: ResolveConfig,
    /// The instruction set every SIMD stage runs with (at most [`Isa::detect`]).
    pub isa: Isa,
    /// The attributes decoded from packed targets: what the BRDF reads.
    pub packed_reads: Vec<crate::gbuffer::Attribute>,
    /// Only every `band_stride`-th band of tile rows runs (1: all), and the outputs hold only those bands, one after
    /// the other ([`run_tiles`]). For estimating a frame's time from a sample of its bands.
    pub band_stride: u32,
    /// Coarse shading by a shading-rate image (`None`: every pixel at full rate).
    pub coarse: Option<Coarse<'a>>,
}

/// Coarse shading: one lighting evaluation per coarse pixel of `sri` (its coarse pixels never cross a resolve
/// tile: checked by [`Coarse::check`]).
#[derive(Clone, Copy, Debug)]
pub struct Coarse<'a> {
    /// The rates.
    pub sri: &'a Sri,
    /// How a coarse pixel's evaluation reaches its other pixels.
    pub mode: CoarseMode,
}

impl Coarse<'_> {
    /// Checks that the SRI covers a `width × height` frame and that every coarse pixel lies within one resolve tile
    /// of `tile_size` (coarse pixels are aligned to their own size).
    pub fn check(&self, width: u32, height: u32, tile_size: u32) -> Result<()> {
        let s = self.sri;
        if s.tile == 0 || s.cols != width.div_ceil(s.tile) || s.rows != height.div_ceil(s.tile) {
            return Err(crate::error::Error::Mismatch(format!(
                "the shading-rate image is {}×{} tiles of {} pixels, the frame {width}×{height}",
                s.cols, s.rows, s.tile
            )));
        }
        let (w, h) = s.rates.iter().fold((1, 1), |(w, h), r| (w.max(r.size().0), h.max(r.size().1)));
        if !tile_size.is_multiple_of(w) || !tile_size.is_multiple_of(h) || !s.tile.is_multiple_of(w.max(h)) {
            return Err(crate::error::Error::Mismatch(format!(
                "coarse pixels of {w}×{h} would cross resolve tiles of {tile_size} (or SRI tiles of {}): use a \
                 tile size that is a multiple of {}",
                s.tile,
                w.max(h)
            )));
        }
        Ok(())
    }
}

impl<'a> Frame<'a> {
    /// Prepares the per-light data for `cfg`, to run with `isa` (capped at what this CPU has).
    #[must_use]
    pub fn new(
        reader: SurfaceReader<'a>,
        packed: Option<&'a PackedFrame<'a>>,
        mask: &'a EdgeMask,
        lights: &'a [Light],
        environment: &'a [super::lights::Hemisphere],
        cfg: ResolveConfig,
        isa: Isa,
    ) -> Self {
        let table = LightTable::new(lights, cfg.falloff);
        let quads = if cfg.culling == Culling::Quad { quad_rects(lights) } else { QuadSoa::default() };
        let (width, height) = (reader.gbuffer().width, reader.gbuffer().height);
        Frame {
            reader,
            packed,
            width,
            height,
            mask,
            lights,
            environment,
            table,
            quads,
            cfg,
            isa: isa.min(Isa::detect()),
            band_stride: 1,
            coarse: None,
            packed_reads: Reads::of(cfg.brdf).attributes(),
        }
    }
}

/// Work counts and thread time of a group of tiles (summed).
#[derive(Clone, Debug, Default)]
pub struct TileStats {
    /// Tiles processed.
    pub tiles: u64,
    /// Light-sample pairs that reached the shading loop.
    pub tested: u64,
    /// Pairs with a nonzero contribution.
    pub lit: u64,
    /// Samples shaded.
    pub evaluations: u64,
    /// Work-list entries run through the kernel, idle (padding) lanes included.
    pub lane_steps: u64,
    /// Pixels shaded per sample.
    pub edge_pixels: u64,
    /// Values sanitised while reading.
    pub sanitized: SanitizedCounts,
    /// Time building work lists (measured on one tile in eight: use it as a share of the three).
    pub t_gather: Duration,
    /// Time culling (sampled as `t_gather`).
    pub t_cull: Duration,
    /// Time shading and filtering (sampled as `t_gather`).
    pub t_shade: Duration,
    /// Time decoding packed bands (every band: scale by `timed / tiles` to compare with the three above).
    pub t_decode: Duration,
    /// Tiles whose stages were timed.
    pub timed: u64,
}

impl TileStats {
    /// Sum of two.
    #[must_use]
    pub fn merged(mut self, o: TileStats) -> TileStats {
        self.tiles += o.tiles;
        self.tested += o.tested;
        self.lit += o.lit;
        self.evaluations += o.evaluations;
        self.lane_steps += o.lane_steps;
        self.edge_pixels += o.edge_pixels;
        self.sanitized.add(&o.sanitized);
        self.t_gather += o.t_gather;
        self.t_cull += o.t_cull;
        self.t_shade += o.t_shade;
        self.t_decode += o.t_decode;
        self.timed += o.timed;
        self
    }
}

/// The stage times are measured on one tile in this many (a sample of every band).
const TIME_EVERY: u64 = 8;

/// One tile's place in its band of rows.
#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
}

/// Per-thread scratch buffers, reused from tile to tile.
#[derive(Default)]
struct Scratch {
    items: Items,
    sorted: Items,
    lights: LightTable,
    quads: QuadSoa,
    tile_lights: Vec<u32>,
    order: Vec<usize>,
    /// Flat sample index of each work-list item.
    src: Vec<usize>,
    /// Edge pixels of the tile (column, row, whether sample 0 was taken by the first gather pass), listed by
    /// that pass.
    edge_px: Vec<(u32, u32, bool)>,
    /// Pixels of the tile with no usable sample (band-relative index), listed by the first gather pass.
    blank_px: Vec<u32>,
    /// The band's box-filtered colour and light evaluations (the band's rows of the outputs, in cache: tiles write
    /// here, and the band is copied to the outputs in one sequential pass).
    band_rgb: Vec<Vec3>,
    /// Light evaluations in f32 (whole numbers, exact below 2²⁴ like the kernel's counts), converted when the band
    /// is copied out.
    band_heat: Vec<f32>,
    /// The band decoded from packed targets (when the frame is lit from them).
    band_gb: GBuffer,
    /// Coarse shading: per pixel of the tile (row-major), whether it takes its coarse pixel's evaluation instead of
    /// being shaded.
    shared: Vec<bool>,
    /// Those pixels: (band index, its representative's band index, the flat indices of both's first covered
    /// samples).
    sharing: Vec<(u32, u32, usize, usize)>,
}

/// Runs every tile of `frame`, writing pixel colours into `rgb` and light evaluations per pixel into `heat`
/// (both row-major, `width × height`; with a [`Frame::band_stride`] of `s`, only the rows of bands 0, s, 2s, …, one
/// after the other). Bands of one tile row run in parallel on the current rayon pool; each band walks its tiles left
/// to right (fetching the next tile's rows ahead) and owns its rows of the outputs, so the result does not depend on
/// the thread count.
pub fn run_tiles(frame: &Frame<'_>, rgb: &mut [Vec3], heat: &mut [u32]) -> Result<TileStats> {
    let ts = frame.cfg.tile_size;
    let band_len = (frame.width * ts) as usize;
    if band_len == 0 {
        return Ok(TileStats::default());
    }
    let stride = frame.band_stride.max(1) as usize;
    rgb.par_chunks_mut(band_len)
        .zip(heat.par_chunks_mut(band_len))
        .enumerate()
        .map_init(Scratch::default, |sc, (k, (rgb, heat))| {
            let y0 = (k * stride) as u32 * ts;
            crate::base::isa::run(frame.isa, BandKernel { frame, y0, sc, rgb, heat })
        })
        .try_reduce(TileStats::default, |a, b| Ok(a.merged(b)))
}

/// One band of tiles starting at row `y0`, left to right: from the frame's planes, or decoded from the packed
/// targets first into the thread's band buffer (one tile row: it stays in the last-level cache while its tiles read
/// it). Compiled once per instruction set (below) so the work-list build and the box filter vectorise too; the
/// shading kernel dispatches on its own.
#[inline(always)]
fn run_band(frame: &Frame<'_>, y0: u32, sc: &mut Scratch, rgb: &mut [Vec3], heat: &mut [u32]) -> Result<TileStats> {
    let Some(packed) = frame.packed else {
        return Ok(run_band_tiles(frame, &frame.reader, y0, sc, rgb, heat));
    };
    let h = frame.cfg.tile_size.min(frame.height - y0);
    let t = Instant::now();
    let mut band = std::mem::take(&mut sc.band_gb);
    let decoded = packed.decode_rows_only(y0..y0 + h, &mut band, &frame.packed_reads);
    let t_decode = t.elapsed();
    // No closure: one would be compiled apart, for the baseline.
    let st = match decoded {
        Ok(()) => {
            let rd = SurfaceReader::band(&band, frame.reader.rays(), y0);
            let mut st = run_band_tiles(frame, &rd, y0, sc, rgb, heat);
            st.t_decode += t_decode;
            Ok(st)
        }
        Err(e) => Err(e),
    };
    sc.band_gb = band;
    st
}

/// The tiles of the band at row `y0`, read through `rd`.
#[inline(always)]
fn run_band_tiles(
    frame: &Frame<'_>,
    rd: &SurfaceReader<'_>,
    y0: u32,
    sc: &mut Scratch,
    rgb: &mut [Vec3],
    heat: &mut [u32],
) -> TileStats {
    let (width, height) = (frame.width, frame.height);
    let ts = frame.cfg.tile_size;
    let h = ts.min(height - y0);
    let mut st = TileStats::default();
    // Every pixel of the band is written by its tile: no clearing.
    let n = rgb.len();
    sc.band_rgb.resize(n, Vec3::ZERO);
    sc.band_heat.resize(n, 0.0);
    // The band's rows of the edge mask (one byte per pixel, a few kB) first: the prefetch of each next tile reads
    // them.
    let w = width as usize;
    for row in frame.mask.shade_count[y0 as usize * w..(y0 + h) as usize * w].chunks(64) {
        std::hint::black_box(row[0]);
    }
    let planes = planes_read(frame, rd);
    let mut x0 = 0;
    while x0 < width {
        let w = ts.min(width - x0);
        let next = x0 + w;
        if next < width {
            prefetch_tile(frame, rd, &planes, next, y0, ts.min(width - next), h);
        }
        run_tile(frame, rd, Tile { x0, y0, w, h }, sc, &mut st);
        x0 = next;
    }
    // To the outputs, replacing any non-finite colour by black (counted).
    let mut bad = 0u64;
    for (o, &c) in rgb.iter_mut().zip(&sc.band_rgb[..n]) {
        let ok = c.is_finite();
        bad += u64::from(!ok);
        *o = if ok { c } else { Vec3::ZERO };
    }
    for (o, &h) in heat.iter_mut().zip(&sc.band_heat[..n]) {
        *o = h as u32;
    }
    st.sanitized.output += bad;
    st
}

/// [`run_band`] under [`crate::base::isa::run`]: compiled once per instruction set so the work-list build and the
/// box filter vectorise too.
struct BandKernel<'a, 'f> {
    frame: &'a Frame<'f>,
    y0: u32,
    sc: &'a mut Scratch,
    rgb: &'a mut [Vec3],
    heat: &'a mut [u32],
}

impl crate::base::isa::Kernel for BandKernel<'_, '_> {
    type Output = Result<TileStats>;
    #[inline(always)]
    fn run(self, _: Isa) -> Result<TileStats> {
        run_band(self.frame, self.y0, self.sc, self.rgb, self.heat)
    }
}

/// The planes the resolve reads for `frame`'s BRDF, as (start, bytes per sample): what [`prefetch_tile`] fetches.
fn planes_read(frame: &Frame<'_>, rd: &SurfaceReader<'_>) -> [Option<(*const i8, usize)>; 8] {
    fn raw<T>(p: Option<&[T]>) -> Option<(*const i8, usize)> {
        p.map(|p| (p.as_ptr().cast::<i8>(), std::mem::size_of::<T>()))
    }
    let gb = rd.gbuffer();
    let reads = Reads::of(frame.cfg.brdf);
    let only = |read: bool, p: &Option<Vec<f32>>| if read { raw(p.as_deref()) } else { None };
    [
        raw(Some(&gb.coverage[..])),
        if gb.position.is_some() { raw(gb.position.as_deref()) } else { raw(gb.depth.as_deref()) },
        raw(gb.normal.as_deref()),
        raw(gb.albedo.as_deref()),
        only(reads.specular, &gb.specular),
        only(reads.power, &gb.specular_power),
        only(reads.metal_rough, &gb.roughness),
        only(reads.metal_rough, &gb.metallic),
    ]
}

/// Asks the CPU to start loading a tile's G-buffer samples into cache (a hint: prefetches never fault). A
/// tile's 16 row segments of 7 or so planes are too many short streams for the hardware prefetcher; without this
/// the work-list build waits on memory. Interleaved order: every sample of the tile's rows. Split order: sample 0
/// of the rows, and the other samples of the edge pixels only (their own lines: issued a tile ahead, the misses
/// overlap).
fn prefetch_tile(
    frame: &Frame<'_>,
    rd: &SurfaceReader<'_>,
    planes: &[Option<(*const i8, usize)>],
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
) {
    #[cfg(target_arch = "x86_64")]
    {
        // Into L2 (the next tile's: not needed at once).
        let span = |base: *const i8, a: usize, b: usize| crate::base::memory::prefetch(base.cast(), a, b, false);
        let gb = rd.gbuffer();
        if w == 0 || h == 0 {
            return;
        }
        let at = rd.sample_index();
        let width = gb.width as usize;
        // Interleaved: through the last sample of the row's last pixel.
        let tail = if at.split() { 1 } else { gb.samples as usize };
        for &(base, size) in planes.iter().flatten() {
            for y in y0..y0 + h {
                let p = y as usize * width + x0 as usize;
                span(base, at.first(p) * size, (at.first(p + w as usize - 1) + tail) * size);
            }
        }
        if at.split() {
            let others = gb.samples as usize - 1;
            for y in y0..y0 + h {
                let row = y as usize * width + x0 as usize;
                for (k, _) in frame.mask.shade_count[row..row + w as usize].iter().enumerate().filter(|(_, &c)| c > 1) {
                    let i = at.rest(row + k);
                    for &(base, size) in planes.iter().flatten() {
                        span(base, i * size, (i + others) * size);
                    }
                }
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (frame, rd, planes, x0, y0, w, h);
}

/// Gathers, culls and shades one tile, box-filtering into the band's buffers (every pixel of the tile is
/// written; pixels with nothing to shade are black) and adding the work to `st`.
#[inline(always)]
fn run_tile(frame: &Frame<'_>, rd: &SurfaceReader<'_>, tile: Tile, sc: &mut Scratch, st: &mut TileStats) {
    // One clock reading per stage boundary (`lap`: the time since the previous one), on one tile in
    // [`TIME_EVERY`]: the readings cost about 2% of the frame on every tile, and the stage times are only used as
    // shares of the parallel section's wall time.
    let mut last = st.tiles.is_multiple_of(TIME_EVERY).then(Instant::now);
    st.timed += u64::from(last.is_some());
    let mut lap = || {
        let Some(l) = &mut last else { return Duration::ZERO };
        let now = Instant::now();
        let d = now - *l;
        *l = now;
        d
    };
    st.tiles += 1;
    let coarse = plan_coarse(frame, rd, tile, sc);
    let (n_first, n_real) = gather(frame, rd, tile, sc, st, coarse);
    st.t_gather += lap();
    // Pixels with no sample are black; edge pixels add their samples from 0.
    let width = rd.gbuffer().width as usize;
    for &px in &sc.blank_px {
        sc.band_rgb[px as usize] = Vec3::ZERO;
        sc.band_heat[px as usize] = 0.0;
    }
    for &(x, y, _) in &sc.edge_px {
        let px = (y - tile.y0) as usize * width + x as usize;
        sc.band_rgb[px] = Vec3::ZERO;
        sc.band_heat[px] = 0.0;
    }
    if n_real == 0 {
        share_coarse(frame, rd, sc);
        return;
    }
    let n = sc.items.len();
    let variant = Variant {
        brdf: frame.cfg.brdf,
        falloff: frame.cfg.falloff,
        quad: frame.cfg.culling == Culling::Quad,
        prepass: frame.cfg.schedule == Schedule::LightPrepass,
    };
    let mut t_cull = lap();
    let mut t_shade = Duration::ZERO;
    let spread_out =
        frame.cfg.msaa != MsaaSchedule::Packed && n_real > n_first && frame.cfg.culling != Culling::Clustered;
    let items = if spread_out {
        let ranges = spread(frame.cfg.msaa, n_first, n_real, sc);
        let culled = frame.cfg.culling != Culling::None;
        let per_range = frame.cfg.msaa == MsaaSchedule::TwoPass;
        if culled && !per_range {
            let bounds = tile_bounds(frame.isa, &sc.items, 0..n).expect("nonempty");
            cull_into(frame, &bounds, None, sc);
        }
        t_cull += lap();
        for range in ranges {
            if culled && per_range {
                let b = tile_bounds(frame.isa, &sc.sorted, range.clone()).expect("nonempty pass");
                cull_into(frame, &b, None, sc);
                t_cull += lap();
            }
            st.lane_steps += range.len() as u64;
            if culled {
                shade(frame.isa, &mut sc.sorted, range, &sc.lights, &sc.quads, variant);
            } else {
                shade(frame.isa, &mut sc.sorted, range, &frame.table, &frame.quads, variant);
            }
            t_shade += lap();
        }
        copy_back(n_real, sc);
        &mut sc.items
    } else {
        match frame.cfg.culling {
            Culling::None => {
                st.lane_steps += n as u64;
                shade(frame.isa, &mut sc.items, 0..n, &frame.table, &frame.quads, variant);
                t_shade += lap();
                &mut sc.items
            }
            Culling::Tiled | Culling::Quad => {
                let bounds = tile_bounds(frame.isa, &sc.items, 0..n).expect("nonempty");
                cull_into(frame, &bounds, None, sc);
                t_cull += lap();
                st.lane_steps += n as u64;
                shade(frame.isa, &mut sc.items, 0..n, &sc.lights, &sc.quads, variant);
                t_shade += lap();
                &mut sc.items
            }
            Culling::Clustered => {
                let bounds = tile_bounds(frame.isa, &sc.items, 0..n).expect("nonempty");
                cull_tile_list(frame, &bounds, sc);
                let ranges = sort_by_slice(&bounds, frame.cfg.depth_slices, n_real, sc);
                t_cull += lap();
                for range in ranges {
                    let b = tile_bounds(frame.isa, &sc.sorted, range.clone()).expect("nonempty slice");
                    let list = std::mem::take(&mut sc.tile_lights);
                    cull_into(frame, &b, Some(&list), sc);
                    sc.tile_lights = list;
                    t_cull += lap();
                    st.lane_steps += range.len() as u64;
                    shade(frame.isa, &mut sc.sorted, range, &sc.lights, &sc.quads, variant);
                    t_shade += lap();
                }
                copy_back(n_real, sc);
                &mut sc.items
            }
        }
    };
    if variant.prepass {
        finish_prepass(items, frame.cfg.brdf);
    }
    super::kernel::add_environment(items, n_real, frame.environment, frame.cfg.brdf);
    // The box filter into the band's buffers (`pixel` indexes them). Items `0..n_first` are the first sample of
    // their pixel: stored (times the weight, 1 for a pixel shaded once: exact). The rest are edge pixels' other
    // samples, added (edge pixels were zeroed above, for those whose sample 0 is unusable).
    let (acc, acc_heat) = (&mut sc.band_rgb, &mut sc.band_heat);
    let out = |r: std::ops::Range<usize>| {
        let it = &*items;
        let cols = it.or[r.clone()].iter().zip(&it.og[r.clone()]).zip(&it.ob[r.clone()]);
        it.pixel[r.clone()].iter().zip(cols).zip(&it.tested[r.clone()]).zip(&it.weight[r])
    };
    for (((&px, ((&r, &g), &b)), &t), &w) in out(0..n_first) {
        acc[px as usize] = Vec3::new(r, g, b) * w;
        acc_heat[px as usize] = t;
    }
    for (((&px, ((&r, &g), &b)), &t), &w) in out(n_first..n_real) {
        acc[px as usize] += Vec3::new(r, g, b) * w;
        acc_heat[px as usize] += t;
    }
    // Counts are whole numbers (exact in f32 below 2²⁴), summed as integers.
    st.tested += items.tested[..n_real].iter().map(|&t| t as u64).sum::<u64>();
    st.lit += items.lit[..n_real].iter().map(|&t| t as u64).sum::<u64>();
    st.evaluations += n_real as u64;
    share_coarse(frame, rd, sc);
    t_shade += lap();
    st.t_cull += t_cull;
    st.t_shade += t_shade;
}

/// Lists the tile's pixels that take their coarse pixel's evaluation (`sc.shared`, `sc.sharing`); whether there
/// are any. A coarse pixel's representative is its first non-edge pixel in row order with a covered sample; its
/// other non-edge covered pixels share it (uncovered pixels stay black, edge pixels per sample).
fn plan_coarse(frame: &Frame<'_>, rd: &SurfaceReader<'_>, tile: Tile, sc: &mut Scratch) -> bool {
    sc.sharing.clear();
    let Some(c) = frame.coarse else { return false };
    let gb = rd.gbuffer();
    let (width, samples) = (gb.width, gb.samples);
    let at = rd.sample_index();
    let t = c.sri.tile;
    let (x_end, y_end) = (tile.x0 + tile.w, tile.y0 + tile.h);
    sc.shared.clear();
    sc.shared.resize((tile.w * tile.h) as usize, false);
    for sy in tile.y0 / t..=(y_end - 1) / t {
        for sx in tile.x0 / t..=(x_end - 1) / t {
            let (rw, rh) = c.sri.rates[(sy * c.sri.cols + sx) as usize].size();
            if rw * rh == 1 {
                continue;
            }
            let (xa, xb) = ((sx * t).max(tile.x0), ((sx + 1) * t).min(x_end));
            let (ya, yb) = ((sy * t).max(tile.y0), ((sy + 1) * t).min(y_end));
            for cy in (ya..yb).step_by(rh as usize) {
                for cx in (xa..xb).step_by(rw as usize) {
                    let mut rep: Option<(u32, usize)> = None;
                    for y in cy..(cy + rh).min(yb) {
                        for x in cx..(cx + rw).min(xb) {
                            let p = y as usize * width as usize + x as usize;
                            if frame.mask.shade_count[p] > 1 {
                                continue;
                            }
                            let Some(i) = (0..samples).map(|s| at.of(p, s)).find(|&i| gb.coverage[i]) else {
                                continue;
                            };
                            let band = (y - tile.y0) * width + x;
                            match rep {
                                None => rep = Some((band, i)),
                                Some((r, ri)) => {
                                    sc.sharing.push((band, r, i, ri));
                                    sc.shared[((y - tile.y0) * tile.w + x - tile.x0) as usize] = true;
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    !sc.sharing.is_empty()
}

/// Writes the pixels listed by [`plan_coarse`] from their representatives (after the box filter): its colour, or
/// in `lighting` mode its colour times the pixel's albedo over its own, per channel (a channel whose
/// representative albedo is under 1/1024 keeps the colour: there is no lighting to recover). They spent no light
/// evaluation.
fn share_coarse(frame: &Frame<'_>, rd: &SurfaceReader<'_>, sc: &mut Scratch) {
    let Some(c) = frame.coarse else { return };
    for &(px, rep, i, ri) in &sc.sharing {
        let colour = sc.band_rgb[rep as usize];
        sc.band_rgb[px as usize] = match c.mode {
            CoarseMode::Broadcast => colour,
            CoarseMode::Lighting => {
                let (own, theirs) = (rd.albedo(i), rd.albedo(ri));
                let ratio = |o: f32, t: f32| if t >= 1.0 / 1024.0 { o / t } else { 1.0 };
                colour * Vec3::new(ratio(own.x, theirs.x), ratio(own.y, theirs.y), ratio(own.z, theirs.z))
            }
        };
        sc.band_heat[px as usize] = 0.0;
    }
}

/// Copies the shading results of `sc.sorted` back to tile order (`sc.order[j]`: where item `j` went), so the box
/// filter adds samples in the same order whatever the culling or the MSAA schedule.
#[inline(always)]
fn copy_back(n_real: usize, sc: &mut Scratch) {
    let (it, so) = (&mut sc.items, &sc.sorted);
    for (j, &k) in sc.order[..n_real].iter().enumerate() {
        (it.or[j], it.og[j], it.ob[j], it.ls[j]) = (so.or[k], so.og[k], so.ob[k], so.ls[k]);
        (it.tested[j], it.lit[j]) = (so.tested[k], so.lit[k]);
    }
}

/// Lays the tile's items out in `sc.sorted` for a non-packed MSAA schedule (`sc.order[j]`: where item `j` went) and
/// returns the ranges to shade, each a whole number of vectors.
///
/// - `two-pass`: the pixels' first samples (`0..n_first`), then the edge pixels' other samples, each padded.
/// - `per-pixel`: a pixel per lane, [`BLOCK`] pixels per group in list order; step `k` of a group holds each
///   pixel's `k`-th item, or an idle lane (a copy that goes nowhere) when the pixel has fewer: the group runs as
///   many steps as its pixel with the most samples.
fn spread(msaa: MsaaSchedule, n_first: usize, n_real: usize, sc: &mut Scratch) -> Vec<std::ops::Range<usize>> {
    sc.sorted.clear();
    sc.order.clear();
    sc.order.resize(n_real, 0);
    if msaa != MsaaSchedule::PerPixel {
        let mut ranges = Vec::with_capacity(2);
        for r in [0..n_first, n_first..n_real] {
            if r.is_empty() {
                continue;
            }
            let start = sc.sorted.len();
            for j in r {
                sc.order[j] = sc.sorted.len();
                sc.sorted.push_from(&sc.items, j);
            }
            sc.sorted.pad_to_lanes(sc.sorted.len() - 1);
            ranges.push(start..sc.sorted.len());
        }
        return ranges;
    }
    // Each pixel's items: its first sample, then its other samples (contiguous after `n_first`); a pixel whose
    // sample 0 could not be used has only the latter.
    let mut others: std::collections::HashMap<u32, (usize, usize)> = std::collections::HashMap::new();
    let mut j = n_first;
    while j < n_real {
        let p = sc.items.pixel[j];
        let start = j;
        while j < n_real && sc.items.pixel[j] == p {
            j += 1;
        }
        others.insert(p, (start, j));
    }
    let mut streams: Vec<(Option<usize>, (usize, usize))> = Vec::with_capacity(n_first + others.len());
    for j in 0..n_first {
        streams.push((Some(j), others.remove(&sc.items.pixel[j]).unwrap_or((0, 0))));
    }
    let mut rest: Vec<(usize, usize)> = others.into_values().collect();
    rest.sort_unstable();
    streams.extend(rest.into_iter().map(|r| (None, r)));
    let len = |s: &(Option<usize>, (usize, usize))| usize::from(s.0.is_some()) + (s.1 .1 - s.1 .0);
    let item = |s: &(Option<usize>, (usize, usize)), k: usize| match s.0 {
        Some(f) if k == 0 => f,
        Some(_) => s.1 .0 + k - 1,
        None => s.1 .0 + k,
    };
    for group in streams.chunks(BLOCK) {
        let steps = group.iter().map(len).max().unwrap_or(0);
        let template = item(&group[0], 0);
        for k in 0..steps {
            for lane in 0..BLOCK {
                match group.get(lane).filter(|s| k < len(s)) {
                    Some(s) => {
                        let j = item(s, k);
                        sc.order[j] = sc.sorted.len();
                        sc.sorted.push_from(&sc.items, j);
                    }
                    None => {
                        sc.sorted.push_from(&sc.items, template);
                        let last = sc.sorted.len() - 1;
                        sc.sorted.pixel[last] = PAD_PIXEL;
                        sc.sorted.weight[last] = 0.0;
                    }
                }
            }
        }
    }
    std::iter::once(0..sc.sorted.len()).collect()
}

/// Builds the tile's work list: first one sample per pixel, in one pass over the tile that also lists the edge
/// pixels (a pixel shaded once: its first usable sample, weight 1; an edge pixel: its sample 0 when usable, weight
/// 1/samples), then the edge pixels' other samples, packed. Positions are read pixel by pixel (they decide which
/// samples are shaded); the other attributes are then read plane by plane for the whole list. `pixel` is the index
/// within the band's rows (`(y − band top) · width + x`); pixels with no usable sample are listed in `blank_px`.
/// Returns how many items are the first sample of their pixel (they come first) and how many are real (the rest
/// pad the list to whole vectors).
#[inline(always)]
fn gather(
    frame: &Frame<'_>,
    rd: &SurfaceReader<'_>,
    tile: Tile,
    sc: &mut Scratch,
    st: &mut TileStats,
    coarse: bool,
) -> (usize, usize) {
    let gb = rd.gbuffer();
    let samples = gb.samples;
    let weight = 1.0 / samples as f32;
    let it = &mut sc.items;
    // Only the arrays filled here are emptied: `fill_attributes` and the kernel overwrite the others, which keep
    // their storage (no zero-filling per tile).
    for v in [&mut it.px, &mut it.py, &mut it.pz, &mut it.weight] {
        v.clear();
    }
    it.pixel.clear();
    sc.src.clear();
    sc.edge_px.clear();
    sc.blank_px.clear();
    let counts = &mut st.sanitized;
    let push = |it: &mut Items, src: &mut Vec<usize>, p: glam::Vec3, i: usize, local: u32, w: f32| {
        it.px.push(p.x);
        it.py.push(p.y);
        it.pz.push(p.z);
        it.pixel.push(local);
        it.weight.push(w);
        src.push(i);
    };
    let width = gb.width as usize;
    let (x0, tw) = (tile.x0 as usize, tile.w as usize);
    let cap = (tile.w * tile.h * samples) as usize + BLOCK;
    for v in [&mut it.px, &mut it.py, &mut it.pz, &mut it.weight] {
        v.reserve(cap);
    }
    it.pixel.reserve(cap);
    sc.src.reserve(cap);
    let plane = gb.position.as_deref();
    // Where samples sit (either order): a row's samples 0 are `stride` apart.
    let at = rd.sample_index();
    let stride = at.first_stride();
    for y in tile.y0..tile.y0 + tile.h {
        let row = y as usize * width;
        let local_row = (y - tile.y0) as usize * width + x0;
        let counts_row = &frame.mask.shade_count[row + x0..row + x0 + tw];
        // Pixels that take their coarse pixel's evaluation (none without an SRI).
        let shared_row = if coarse {
            let r = (y - tile.y0) as usize * tw;
            Some(&sc.shared[r..r + tw]).filter(|r| r.contains(&true))
        } else {
            None
        };
        // The common case first, a whole row at once: every pixel's sample 0 covered with a usable position,
        // stored or derived from depth (checked without branches). Otherwise pixel by pixel below.
        let first = at.first(row + x0);
        let end = first + (tw - 1) * stride + 1;
        let n = it.px.len();
        let taken = match (plane, gb.depth.as_deref(), rd.rays()) {
            _ if shared_row.is_some() => false,
            (Some(plane), ..) => {
                let (pos, cov) = (&plane[first..end], &gb.coverage[first..end]);
                let usable = |a: bool, (&p, &c): (&Vec3, &bool)| a & c & usable_position(p);
                let ok = if stride == 1 {
                    pos.iter().zip(cov).fold(true, usable)
                } else {
                    pos.iter().step_by(stride).zip(cov.iter().step_by(stride)).fold(true, usable)
                };
                if ok {
                    for v in [&mut it.px, &mut it.py, &mut it.pz] {
                        v.resize(n + tw, 0.0);
                    }
                    let (dx, dy, dz) = (&mut it.px[n..], &mut it.py[n..], &mut it.pz[n..]);
                    if stride == 1 {
                        for (((p, x), y), z) in pos.iter().zip(dx).zip(dy).zip(dz) {
                            (*x, *y, *z) = (p.x, p.y, p.z);
                        }
                    } else {
                        for (((p, x), y), z) in pos.iter().step_by(stride).zip(dx).zip(dy).zip(dz) {
                            (*x, *y, *z) = (p.x, p.y, p.z);
                        }
                    }
                }
                ok
            }
            (None, Some(depth), Some(rays)) => {
                // `SurfaceReader::position`'s derivation for sample 0 of each pixel, written tentatively: dropped
                // again when some pixel's is unusable.
                let o = gb.sample_positions[0];
                for v in [&mut it.px, &mut it.py, &mut it.pz] {
                    v.resize(n + tw, 0.0);
                }
                let (dx, dy, dz) = (&mut it.px[n..], &mut it.py[n..], &mut it.pz[n..]);
                let mut ok = true;
                for (k, ((px, py), pz)) in dx.iter_mut().zip(dy).zip(dz).enumerate() {
                    let i = first + k * stride;
                    let p = position_from_depth(&rays, (x0 + k) as u32, y, o, depth[i]);
                    ok &= gb.coverage[i] & usable_position(p);
                    (*px, *py, *pz) = (p.x, p.y, p.z);
                }
                if !ok {
                    for v in [&mut it.px, &mut it.py, &mut it.pz] {
                        v.truncate(n);
                    }
                }
                ok
            }
            _ => false,
        };
        if taken {
            it.pixel.extend(local_row as u32..(local_row + tw) as u32);
            sc.src.extend((first..end).step_by(stride));
            if counts_row.iter().fold(true, |a, &c| a & (c <= 1)) {
                it.weight.resize(n + tw, 1.0);
            } else {
                it.weight.extend(counts_row.iter().map(|&c| if c > 1 { weight } else { 1.0 }));
                for (k, _) in counts_row.iter().enumerate().filter(|&(_, &c)| c > 1) {
                    sc.edge_px.push(((x0 + k) as u32, y, true));
                }
            }
            continue;
        }
        for (k, &count) in counts_row.iter().enumerate() {
            let x = (x0 + k) as u32;
            let first = at.first(row + x0 + k);
            let local = (local_row + k) as u32;
            if count > 1 {
                // An edge pixel: sample 0 now, when usable; the others after the tile's single samples.
                let pos = rd.position(x, y, 0, first, counts);
                if let Some(pos) = pos {
                    push(it, &mut sc.src, pos, first, local, weight);
                }
                sc.edge_px.push((x, y, pos.is_some()));
                continue;
            }
            // A non-edge pixel: its first usable sample stands for the whole pixel, unless its coarse pixel's does.
            if shared_row.is_some_and(|r| r[k]) {
                continue;
            }
            if let Some(plane) = plane {
                // The common case first: sample 0 covered, with a usable stored position (else the loop below
                // looks at every sample again, counting what it must).
                let p = plane[first];
                if gb.coverage[first] && usable_position(p) {
                    push(it, &mut sc.src, p, first, local, 1.0);
                    continue;
                }
            }
            let found = (0..samples).any(|s| {
                let i = at.of(row + x0 + k, s);
                let pos = rd.position(x, y, s, i, counts);
                if let Some(pos) = pos {
                    push(it, &mut sc.src, pos, i, local, 1.0);
                }
                pos.is_some()
            });
            if !found {
                sc.blank_px.push(local);
            }
        }
    }
    let n_first = sc.src.len();
    for &(x, y, taken) in &sc.edge_px {
        let rest = at.rest(y as usize * width + x as usize);
        let local = ((y - tile.y0) as usize * width + x as usize) as u32;
        let before = sc.src.len();
        for s in 1..samples {
            let i = rest + s as usize - 1;
            if let Some(pos) = rd.position(x, y, s, i, counts) {
                push(it, &mut sc.src, pos, i, local, weight);
            }
        }
        st.edge_pixels += u64::from(taken || sc.src.len() > before);
    }
    let n_real = sc.src.len();
    if n_real > 0 {
        // Pad to whole vectors with copies of the last item that go nowhere (weight 0).
        while !sc.src.len().is_multiple_of(BLOCK) {
            let (i, p) = (sc.src[n_real - 1], glam::Vec3::new(it.px[n_real - 1], it.py[n_real - 1], it.pz[n_real - 1]));
            push(it, &mut sc.src, p, i, PAD_PIXEL, 0.0);
        }
        rd.fill_attributes(frame.isa, &sc.src, it, frame.cfg.brdf, counts);
    }
    (n_first, n_real)
}

/// Tests every light's sphere against `bounds` (branch-free over lights, vectorised for the CPU at hand), writing
/// survivors' indices into `sc.tile_lights`.
fn cull_tile_list(frame: &Frame<'_>, b: &Bounds, sc: &mut Scratch) {
    sc.tile_lights.clear();
    crate::base::isa::run(frame.isa, TouchingKernel { b, s: &frame.table, out: &mut sc.tile_lights });
}

/// [`Bounds::touching`] under [`crate::base::isa::run`], with the lanes of the level it is compiled for (the
/// portable lanes below AVX2, NEON included).
struct TouchingKernel<'a> {
    b: &'a Bounds,
    s: &'a LightTable,
    out: &'a mut Vec<u32>,
}

impl crate::base::isa::Kernel for TouchingKernel<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self, isa: Isa) {
        let TouchingKernel { b, s, out } = self;
        lanes_for!(isa, Portable<false>, |V| b.touching::<V>(&s.x, &s.y, &s.z, &s.r, out))
    }
}

/// [`Bounds::of_items_in`] with the AVX-512 lanes where `isa` is AVX-512 (at most [`Isa::detect`]), else the scalar
/// [`Bounds::of_items`].
fn tile_bounds(isa: Isa, it: &Items, range: std::ops::Range<usize>) -> Option<Bounds> {
    /// The bounds under [`crate::base::isa::run`].
    struct BoundsKernel<'a> {
        it: &'a Items,
        range: std::ops::Range<usize>,
    }
    impl crate::base::isa::Kernel for BoundsKernel<'_> {
        type Output = Option<Bounds>;
        #[inline(always)]
        fn run(self, isa: Isa) -> Option<Bounds> {
            #[cfg(target_arch = "x86_64")]
            if isa == Isa::Avx512 {
                return Bounds::of_items_in::<super::simd::Avx512>(self.it, self.range);
            }
            let _ = isa;
            Bounds::of_items(self.it, self.range)
        }
    }
    if isa == Isa::Avx512 {
        crate::base::isa::run(isa, BoundsKernel { it, range })
    } else {
        Bounds::of_items(it, range)
    }
}

/// Culls lights (all, or only those in `subset`) against `b` and gathers the survivors' constants into
/// `sc.lights` / `sc.quads`, in increasing light order.
fn cull_into(frame: &Frame<'_>, b: &Bounds, subset: Option<&[u32]>, sc: &mut Scratch) {
    sc.lights.clear();
    sc.quads.clear();
    let quad = frame.cfg.culling == Culling::Quad;
    let keep = |i: usize, sc: &mut Scratch| {
        sc.lights.push_from(&frame.table, i);
        if quad {
            sc.quads.push_from(&frame.quads, i);
        }
    };
    match subset {
        Some(list) => {
            let s = &frame.table;
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
        let k = (((sc.items.depth(j) / b.d0).ln() * scale) as u32).min(slices - 1);
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
