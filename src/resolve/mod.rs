//! The CPU lighting resolve: light a (possibly packed) G-buffer the way a tiled deferred renderer would, and count
//! the work.
//!
//! Input: a [`GBuffer`](crate::GBuffer), view-space [`Light`]s, an [`EdgeMask`] (which pixels are shaded per sample) and a
//! [`ResolveConfig`]. Output: a linear HDR image plus [`ResolveStats`] (light-sample pairs tested and lit, shading
//! evaluations, sanitised values, milliseconds per stage) and the per-pixel light-evaluation counts for a heatmap.
//!
//! Stages (one file each): `lights.rs` sanitises lights and lays them out as arrays; `schedule.rs` builds each
//! tile's packed work list (non-edge pixels once, edge pixels per sample); `culling.rs` bounds the list and
//! keeps the lights that may reach it; `kernel.rs` shades the list against those lights (branch-free, vectorised);
//! the box filter writes pixels. [`reference()`] is the f64, every-sample, no-culling image the errors are measured
//! against, with the formulas of `brdf.rs` and `falloff.rs`.

mod brdf;
mod config;
mod culling;
mod falloff;
pub mod fixture;
mod kernel;
mod lights;
pub mod peak;
mod preview;
mod reference;
mod reference_lanes;
mod schedule;
mod simd;
mod split;
mod surface;
mod worklist;

pub use config::{
    Brdf, Culling, Falloff, Lighting, MsaaSchedule, ResolveConfig, Schedule, DEFAULT_DEPTH_SLICES, DEFAULT_TILE_SIZE,
    MAX_DEPTH_SLICES, MAX_TILE_SIZE,
};
pub use kernel::instruction_set;

/// Work-list entries per kernel vector: the "warp" of gbuf's CPU schedules (every instruction set pads lists to
/// this many).
#[must_use]
pub fn kernel_lanes() -> usize {
    simd::BLOCK
}
pub use falloff::{MIN_DISTANCE, MIN_RAMP_FRACTION};
pub use preview::{ImagePreview, LightPreview};
pub use reference::{check_meaningful, reference, reference_per_sample};
pub use schedule::Coarse;
pub use split::{ResolveInput, SplitSamples};
pub use surface::SanitizedCounts;

use crate::base::isa::Isa;
use crate::base::mask::EdgeMask;
use crate::base::timing::{ms, StageMs};
use crate::error::{Error, Result};
use crate::image::HdrImage;
use crate::light::Light;
use serde::Serialize;
use std::time::{Duration, Instant};

/// Work and time of one resolve.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ResolveStats {
    /// Lights used (after sanitising).
    pub lights: u64,
    /// Tiles processed.
    pub tiles: u64,
    /// Light-sample pairs that reached the shading loop (after culling).
    pub light_pairs_tested: u64,
    /// Pairs whose contribution was nonzero.
    pub light_pairs_lit: u64,
    /// Samples shaded.
    pub shading_evaluations: u64,
    /// Work-list entries run through the kernel, idle (padding) lanes included: `shading_evaluations /
    /// lane_steps` is the measured SIMD utilisation of the MSAA schedule.
    pub lane_steps: u64,
    /// `shading_evaluations / (pixels × samples)`.
    pub shading_fraction: f64,
    /// Pixels shaded per sample / pixels.
    pub edge_fraction: f64,
    /// `light_pairs_tested / shading_evaluations`: lights evaluated per shaded sample.
    pub lights_per_sample: f64,
    /// What was sanitised (G-buffer values among the samples read, lights dropped, output pixels zeroed).
    pub sanitized: SanitizedCounts,
    /// Milliseconds per stage (`decode` and `detect` are left 0 for the caller). `gather`, `cull` and `shade` run
    /// interleaved in parallel: the parallel section's wall time is split in proportion to their thread time (measured on
    /// one tile in eight).
    pub ms: StageMs,
}

/// The resolve's output.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Resolved {
    /// The lit image (linear HDR, every value finite).
    pub image: HdrImage,
    /// Work and time.
    pub stats: ResolveStats,
    /// Light evaluations spent on each pixel (sum over its shaded samples), row-major: the heatmap.
    pub lights_per_pixel: Vec<u32>,
}

/// Lights `gb` (a [`GBuffer`](crate::GBuffer), or a [`SplitSamples`] copy of one: the same image, faster for MSAA) with `lights`,
/// shading per sample where `mask` says so, as configured by `cfg`. Runs on rayon's current thread pool (install
/// a local pool to choose the thread count). Never returns NaN or Inf pixels.
pub fn resolve<'a>(
    gb: impl Into<ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    cfg: &ResolveConfig,
) -> Result<Resolved> {
    resolve_isa(Isa::detect(), gb, lights, mask, cfg)
}

/// [`resolve`] into `out`, reusing its image and heatmap storage: a renderer lighting frame after frame keeps one
/// `Resolved` and pays no allocation (and no first-touch page faults of fresh pages) per frame. Every pixel and
/// every statistic of `out` is overwritten; on error `out` is left unchanged.
pub fn resolve_into<'a>(
    gb: impl Into<ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    cfg: &ResolveConfig,
    out: &mut Resolved,
) -> Result<()> {
    resolve_into_isa(Isa::detect(), gb.into(), lights, mask, None, cfg, out)
}

/// [`resolve`] shading less than once per pixel where `coarse`'s shading-rate image says so: each coarse pixel's
/// non-edge pixels are shaded once, at its first one (in row order) with a covered sample, and the others take
/// that colour (`broadcast`) or that colour times their own albedo over the shaded one's (`lighting`). Pixels of
/// `mask` are shaded per sample whatever their tile's rate, as hardware composes coarse shading with MSAA. The
/// evaluations in the stats fall with the pixels shared ([`crate::detect::rate::evaluations`] counts them
/// beforehand); an all-1×1 SRI gives [`resolve`]'s image bit for bit. Fails when the SRI does not cover the frame
/// or a coarse pixel would cross a resolve tile ([`Coarse::check`]).
pub fn resolve_coarse<'a>(
    gb: impl Into<ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    coarse: Coarse<'_>,
    cfg: &ResolveConfig,
) -> Result<Resolved> {
    resolve_coarse_isa(Isa::detect(), gb, lights, mask, coarse, cfg)
}

/// [`resolve_coarse`] compiled for `isa` (as [`resolve_isa`]).
pub fn resolve_coarse_isa<'a>(
    isa: Isa,
    gb: impl Into<ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    coarse: Coarse<'_>,
    cfg: &ResolveConfig,
) -> Result<Resolved> {
    let mut out = Resolved::default();
    resolve_into_isa(isa, gb.into(), lights, mask, Some(coarse), cfg, &mut out)?;
    Ok(out)
}

/// [`resolve`] with every SIMD stage (work-list build, culling, light loop) compiled for `isa`, or for the widest
/// level below it that this CPU has — as the codecs' `encode_slice_isa`. For tests and measurements that compare
/// the vector paths: within one call every tile runs the same path, so the image's independence from culling, tile
/// size and thread count holds per path; paths differ from each other by rounding.
pub fn resolve_isa<'a>(
    isa: Isa,
    gb: impl Into<ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    cfg: &ResolveConfig,
) -> Result<Resolved> {
    let mut out = Resolved::default();
    resolve_into_isa(isa, gb.into(), lights, mask, None, cfg, &mut out)?;
    Ok(out)
}

/// Bands of tile rows a sampled timing runs: one in this many ([`time_sampled`]).
pub const TIMING_STRIDE: u32 = 8;

/// An estimate of [`resolve`]'s wall time (ms) on this input from a systematic sample of it: the per-frame
/// preparation (reader, lights, culling tables) in full, then every [`TIMING_STRIDE`]-th band of tile rows (the
/// others skipped) scaled by the stride. Bands are lit exactly as in a full resolve; the sample spreads over the
/// whole frame, so sparse and dense regions weigh as they do in it. For repeated timing runs (`gbuf report`): the
/// first run lights the whole frame, the others sample it. `benches/report.rs` compares the estimate with the
/// full time.
pub fn time_sampled<'a>(
    gb: impl Into<ResolveInput<'a>>,
    lights: &[Light],
    mask: &EdgeMask,
    cfg: &ResolveConfig,
) -> Result<f64> {
    let t_start = Instant::now();
    let gb = gb.into();
    let packed = gb.packed();
    let (reader, gb) = prepare(gb, mask, cfg)?;
    let clean = lights::sanitize(lights);
    let mut frame = schedule::Frame::new(reader, packed, mask, &clean.lights, &clean.environment, *cfg, Isa::detect());
    frame.band_stride = TIMING_STRIDE;
    // The outputs of the sampled bands only (every band full but perhaps the last), thrown away.
    let bands = gb.height.div_ceil(cfg.tile_size).max(1);
    let sampled = bands.div_ceil(TIMING_STRIDE);
    let last = (sampled - 1) * TIMING_STRIDE;
    let rows = (sampled - 1) * cfg.tile_size + cfg.tile_size.min(gb.height - last * cfg.tile_size);
    let n = rows as usize * gb.width as usize;
    let (mut rgb, mut heat) = (crate::base::memory::zeroed_vec3(n), vec![0u32; n]);
    let t_prep = t_start.elapsed();
    let t_par = Instant::now();
    schedule::run_tiles(&frame, &mut rgb, &mut heat)?;
    Ok(ms(t_prep) + ms(t_par.elapsed()) * f64::from(bands) / f64::from(sampled))
}

fn resolve_into_isa(
    isa: Isa,
    gb: ResolveInput<'_>,
    lights: &[Light],
    mask: &EdgeMask,
    coarse: Option<Coarse<'_>>,
    cfg: &ResolveConfig,
    out: &mut Resolved,
) -> Result<()> {
    let t_start = Instant::now();
    let packed = gb.packed();
    let (reader, gb) = prepare(gb, mask, cfg)?;
    if let Some(c) = &coarse {
        c.check(gb.width, gb.height, cfg.tile_size)?;
    }
    let clean = lights::sanitize(lights);
    let mut frame = schedule::Frame::new(reader, packed, mask, &clean.lights, &clean.environment, *cfg, isa);
    frame.coarse = coarse;
    let t_prep = t_start.elapsed();

    let t_par = Instant::now();
    // Every pixel is written by its tile, so reused storage needs no clearing.
    let n = gb.pixel_count();
    let mut image = std::mem::take(&mut out.image);
    (image.width, image.height) = (gb.width, gb.height);
    // Fresh outputs come from zeroed memory (`calloc`: pages the tiles' writes fault in, not a serial fill first).
    if image.rgb.is_empty() {
        image.rgb = crate::base::memory::zeroed_vec3(n);
    } else {
        image.rgb.resize(n, glam::Vec3::ZERO);
    }
    let mut heat = std::mem::take(&mut out.lights_per_pixel);
    if heat.is_empty() {
        heat = crate::base::memory::zeroed_on_huge_pages(n);
    } else {
        heat.resize(n, 0);
    }
    let t = match schedule::run_tiles(&frame, &mut image.rgb, &mut heat) {
        Ok(t) => t,
        Err(e) => {
            (out.image, out.lights_per_pixel) = (image, heat);
            return Err(e);
        }
    };
    let par_wall = t_par.elapsed();

    let mut stats = ResolveStats { lights: clean.lights.len() as u64, tiles: t.tiles, ..Default::default() };
    stats.sanitized = t.sanitized;
    stats.sanitized.lights = clean.dropped;
    stats.light_pairs_tested = t.tested;
    stats.light_pairs_lit = t.lit;
    stats.shading_evaluations = t.evaluations;
    stats.lane_steps = t.lane_steps;
    let edge_pixels = t.edge_pixels;
    let (tg, tc, tsh) = (t.t_gather, t.t_cull, t.t_shade);
    let total_samples = gb.len() as f64;
    stats.shading_fraction = if total_samples > 0.0 { stats.shading_evaluations as f64 / total_samples } else { 0.0 };
    let pixels = gb.pixel_count() as f64;
    stats.edge_fraction = if pixels > 0.0 { edge_pixels as f64 / pixels } else { 0.0 };
    stats.lights_per_sample = if stats.shading_evaluations > 0 {
        stats.light_pairs_tested as f64 / stats.shading_evaluations as f64
    } else {
        0.0
    };
    // The band decode is timed on every band, the tile stages on a sample of the tiles: on the same scale first.
    let td = if t.tiles > 0 { t.t_decode.mul_f64(t.timed as f64 / t.tiles as f64) } else { Duration::ZERO };
    let busy = (tg + tc + tsh + td).as_secs_f64();
    let share = |d: Duration| if busy > 0.0 { ms(par_wall) * d.as_secs_f64() / busy } else { 0.0 };
    stats.ms.decode = share(td);
    stats.ms.gather = share(tg);
    stats.ms.cull = ms(t_prep) + share(tc);
    stats.ms.shade = share(tsh);
    stats.ms.total = ms(t_start.elapsed());
    *out = Resolved { image, stats, lights_per_pixel: heat };
    Ok(())
}

/// What every resolve checks and builds first: the configuration valid, the mask the frame's size, and the reader
/// (of the planes, or of a packed frame's camera rays after [`packed_reader`]'s check). Returns it with the frame's
/// G-buffer (for a packed frame, the one its size and coverage come from).
fn prepare<'a>(
    input: ResolveInput<'a>,
    mask: &EdgeMask,
    cfg: &ResolveConfig,
) -> Result<(surface::SurfaceReader<'a>, &'a crate::gbuffer::GBuffer)> {
    let packed = input.packed();
    let (gb, order) = input.planes();
    cfg.validate()?;
    if mask.width != gb.width || mask.height != gb.height || mask.shade_count.len() != gb.pixel_count() {
        return Err(Error::Mismatch(format!(
            "edge mask is {}×{} ({} entries) but the G-buffer is {}×{}",
            mask.width,
            mask.height,
            mask.shade_count.len(),
            gb.width,
            gb.height
        )));
    }
    let reader = match packed {
        None => surface::SurfaceReader::with_order(gb, order)?,
        Some(p) => packed_reader(p)?,
    };
    Ok((reader, gb))
}

/// The reader of a packed frame's camera rays, after checking that its bands can be lit: the decoded planes give a
/// position (a position plane, or depth with the frame's camera), as [`surface::SurfaceReader::with_order`]
/// demands of planes.
fn packed_reader<'a>(p: &'a crate::layout::PackedFrame<'a>) -> Result<surface::SurfaceReader<'a>> {
    let like = p.like();
    let mut probe = crate::gbuffer::GBuffer::default();
    p.decode_rows_only(0..like.height.min(1), &mut probe, &[crate::gbuffer::Attribute::Depth])?;
    let derivable = probe.depth.is_some() && like.camera.is_some();
    if probe.position.is_none() && !derivable && like.coverage.iter().any(|&c| c) {
        return Err(Error::Mismatch(format!(
            "the resolve needs view-space positions: {} stores no position, and no depth with a camera to derive \
             one",
            p.describe()
        )));
    }
    // Only the camera's rays and the frame's size are read through it: every band is decoded on its own.
    surface::SurfaceReader::frame_rays(like)
}
