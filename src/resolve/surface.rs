//! Reading one G-buffer sample as a shadable surface: attribute defaults, sanitisation and counting.
//!
//! The resolve and the reference read samples through the same [`SurfaceReader`], so a sanitised value is never
//! counted as error: it is reported in [`SanitizedCounts`] instead.
//!
//! Position: the `position` plane when present, else `depth` along the camera ray through the sample's sub-pixel
//! position. A covered sample whose position is not finite or not in front of the camera (depth ≤
//! [`MIN_VIEW_DEPTH`]) is treated as background and counted.
//!
//! Defaults for absent attributes: normal facing the camera (`+Z` in view space), albedo [`DEFAULT_ALBEDO`] grey,
//! specular amount [`DEFAULT_SPECULAR`], specular power [`DEFAULT_SPECULAR_POWER`], metallic 0; roughness, when
//! absent, is mapped from the specular power (see [`roughness_from_power`]).

use super::config::Brdf;
use super::simd::LANES;
use super::worklist::{Items, Surface};
use crate::base::isa::Isa;
use crate::camera::RayCaster;
use crate::error::{Error, Result};
use crate::gbuffer::GBuffer;
use glam::{Vec2, Vec3};
use serde::Serialize;

/// Albedo of samples whose dump has no albedo plane (linear grey).
pub const DEFAULT_ALBEDO: f32 = 0.8;
/// Specular amount when the dump has none (pure diffuse).
pub const DEFAULT_SPECULAR: f32 = 0.0;
/// Blinn-Phong specular power when the dump has none.
pub const DEFAULT_SPECULAR_POWER: f32 = 32.0;
/// Largest specular power kept (larger values are clamped and counted): beyond this the lobe is narrower than
/// f32 normals can resolve.
pub const MAX_SPECULAR_POWER: f32 = 1e6;
/// Samples closer to the eye plane than this (view units) cannot be projected and are treated as background.
pub const MIN_VIEW_DEPTH: f32 = 1e-6;

/// Whether the lighting can use view-space position `p`: finite, and in front of the eye beyond
/// [`MIN_VIEW_DEPTH`]. Branch-free (`abs() < ∞` is `is_finite`), so loops over whole rows vectorise.
#[inline(always)]
#[must_use]
pub fn usable_position(p: Vec3) -> bool {
    (p.x.abs() < f32::INFINITY) & (p.y.abs() < f32::INFINITY) & (p.z.abs() < f32::INFINITY) & (-p.z > MIN_VIEW_DEPTH)
}

/// The view-space position of the sample at offset `o` in pixel (`x`, `y`) with view depth `depth`: the camera ray
/// through it times the depth ([`crate::Camera::view_position`] and `GBuffer::fill_position_from_depth` bit for
/// bit, principal point included: an off-centre camera shifts the rays, it does not scale them).
#[inline(always)]
#[must_use]
pub(crate) fn position_from_depth(rays: &RayCaster, x: u32, y: u32, o: Vec2, depth: f32) -> Vec3 {
    rays.ray(Vec2::new(x as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y)) * depth
}

/// Perceptual roughness equivalent to a Blinn-Phong power: Beckmann-matched `α² = 2 / (p + 2)`, and glTF's
/// `α = roughness²`, so `roughness = (2 / (p + 2))^¼`. Power 0 gives roughness ≈ 1; power 10⁴ about 0.12.
#[must_use]
#[inline(always)]
pub fn roughness_from_power(p: f32) -> f32 {
    (2.0 / (p.max(0.0) + 2.0)).sqrt().sqrt()
}

/// How many values were replaced because they were NaN, infinite or out of range (per attribute), plus lights
/// dropped and output pixels that had to be zeroed. The resolve counts only the attributes its BRDF reads
/// (`Reads`); the reference reads and counts every attribute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SanitizedCounts {
    /// Covered samples treated as background: position NaN/Inf or not in front of the camera.
    pub position: u64,
    /// Normals NaN/Inf or zero-length (replaced by the default).
    pub normal: u64,
    /// Albedo samples with a NaN/Inf or negative component.
    pub albedo: u64,
    /// Specular amounts NaN/Inf or negative.
    pub specular: u64,
    /// Specular powers NaN/Inf, negative or above 1e6 (`MAX_SPECULAR_POWER`).
    pub specular_power: u64,
    /// Roughness NaN/Inf or outside [0, 1].
    pub roughness: u64,
    /// Metallic NaN/Inf or outside [0, 1].
    pub metallic: u64,
    /// Lights dropped (non-finite or negative fields, range ≤ 0, zero direction).
    pub lights: u64,
    /// Output pixels that were not finite and were written as 0 (should stay 0: a nonzero value is a bug).
    pub output: u64,
}

impl SanitizedCounts {
    /// Adds `o` into `self`.
    pub fn add(&mut self, o: &SanitizedCounts) {
        self.position += o.position;
        self.normal += o.normal;
        self.albedo += o.albedo;
        self.specular += o.specular;
        self.specular_power += o.specular_power;
        self.roughness += o.roughness;
        self.metallic += o.metallic;
        self.lights += o.lights;
        self.output += o.output;
    }

    /// Sum of all counts.
    #[must_use]
    pub fn total(&self) -> u64 {
        self.position
            + self.normal
            + self.albedo
            + self.specular
            + self.specular_power
            + self.roughness
            + self.metallic
            + self.lights
            + self.output
    }
}

/// Reads samples of one G-buffer (attribute planes resolved once), whose planes are in either sample order (see
/// [`SampleOrder`]).
pub struct SurfaceReader<'a> {
    gb: &'a GBuffer,
    /// The camera's rays, its constants computed once: [`crate::camera::Camera::view_ray`] bit for bit, principal
    /// point included.
    rays: Option<RayCaster>,
    /// Where each sample sits in the planes.
    at: SampleIndex,
}

/// The order of a G-buffer's planes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleOrder {
    /// `(y·width + x)·samples + s`, a pixel's samples side by side: [`GBuffer`]'s own order.
    Interleaved,
    /// Sample 0 of every pixel first (`y·width + x`: a one-sample G-buffer), then samples `1..samples` of every
    /// pixel, side by side (`pixels + (y·width + x)·(samples − 1) + s − 1`). See [`super::SplitSamples`].
    Split,
}

/// Plane indices of samples in a [`SampleOrder`]: in both orders a pixel's samples `1..samples` are consecutive;
/// where sample 0 sits differs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleIndex {
    /// Step between the samples 0 of consecutive pixels.
    first: usize,
    /// Index of pixel 0's sample 1.
    rest_base: usize,
    /// Step between the samples 1 of consecutive pixels.
    rest: usize,
    /// Split order with more than one sample.
    split: bool,
    /// Pixel number of the planes' first pixel: 0 for a whole frame, the band's first pixel for a band of rows
    /// decoded on its own (pixel numbers stay the frame's).
    origin: usize,
}

impl SampleIndex {
    /// The indices of `order` for a G-buffer of `pixels` pixels and `samples` samples.
    #[must_use]
    pub fn new(order: SampleOrder, pixels: usize, samples: usize) -> Self {
        match order {
            SampleOrder::Interleaved => {
                SampleIndex { first: samples, rest_base: 1, rest: samples, split: false, origin: 0 }
            }
            SampleOrder::Split => SampleIndex {
                first: 1,
                rest_base: pixels,
                rest: samples.saturating_sub(1),
                split: samples > 1,
                origin: 0,
            },
        }
    }

    /// Plane index of sample 0 of pixel number `p` (row-major).
    #[inline(always)]
    #[must_use]
    pub fn first(&self, p: usize) -> usize {
        (p - self.origin) * self.first
    }

    /// Plane index of sample 1 of pixel number `p`; samples `2..` follow it.
    #[inline(always)]
    #[must_use]
    pub fn rest(&self, p: usize) -> usize {
        self.rest_base + (p - self.origin) * self.rest
    }

    /// Plane index of sample `s` of pixel number `p`.
    #[inline(always)]
    #[must_use]
    pub fn of(&self, p: usize, s: u32) -> usize {
        if s == 0 {
            self.first(p)
        } else {
            self.rest(p) + s as usize - 1
        }
    }

    /// Step between the samples 0 of consecutive pixels (1: a row's samples 0 are consecutive).
    #[inline(always)]
    #[must_use]
    pub fn first_stride(&self) -> usize {
        self.first
    }

    /// Whether a pixel's samples 1.. lie apart from its sample 0 (the split order, with more than one sample).
    #[inline(always)]
    #[must_use]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))] // read by the tile prefetch, x86-64 only
    pub fn split(&self) -> bool {
        self.split
    }
}

impl<'a> SurfaceReader<'a> {
    /// Prepares to read `gb` (in [`GBuffer`]'s own, interleaved order). Fails when covered samples exist but no
    /// position can be formed (no position plane, and not both depth and a camera).
    pub fn new(gb: &'a GBuffer) -> Result<Self> {
        Self::with_order(gb, SampleOrder::Interleaved)
    }

    /// Prepares to read `gb`, whose planes are in `order`. Fails as [`SurfaceReader::new`].
    pub fn with_order(gb: &'a GBuffer, order: SampleOrder) -> Result<Self> {
        gb.validate()?;
        let derivable = gb.depth.is_some() && gb.camera.is_some();
        if gb.position.is_none() && !derivable && gb.coverage.iter().any(|&c| c) {
            return Err(Error::Mismatch(
                "the resolve needs view-space positions: the G-buffer has no position plane, and no depth plane \
                 with a camera to derive one"
                    .into(),
            ));
        }
        let rays = gb.camera.map(|c| c.ray_caster(gb.width, gb.height));
        let at = SampleIndex::new(order, gb.pixel_count(), gb.samples as usize);
        Ok(SurfaceReader { gb, rays, at })
    }

    /// A reader of a packed frame's size and camera rays only (its planes, if any, are never read: each band is
    /// read through [`SurfaceReader::band`]); the caller has checked that the bands give positions.
    pub(crate) fn frame_rays(gb: &'a GBuffer) -> Result<Self> {
        gb.validate()?;
        let rays = gb.camera.map(|c| c.ray_caster(gb.width, gb.height));
        let at = SampleIndex::new(SampleOrder::Interleaved, gb.pixel_count(), gb.samples as usize);
        Ok(SurfaceReader { gb, rays, at })
    }

    /// Reads `band`, rows `y0..y0 + band.height` of a frame decoded on their own (interleaved order, see
    /// [`crate::layout::PackedFrame::decode_rows`]), with the frame's pixel coordinates: `rays` are the frame's
    /// (positions derived from depth are the whole frame's bit for bit).
    pub(crate) fn band(band: &'a GBuffer, rays: Option<RayCaster>, y0: u32) -> Self {
        let mut at = SampleIndex::new(SampleOrder::Interleaved, band.pixel_count(), band.samples as usize);
        at.origin = y0 as usize * band.width as usize;
        SurfaceReader { gb: band, rays, at }
    }

    /// The camera rays positions are derived with.
    #[must_use]
    pub(crate) fn rays(&self) -> Option<RayCaster> {
        self.rays
    }

    /// Plane index of sample `s` of pixel (`x`, `y`), in the reader's sample order.
    #[inline(always)]
    #[must_use]
    pub fn index(&self, x: u32, y: u32, s: u32) -> usize {
        debug_assert!(x < self.gb.width && s < self.gb.samples);
        self.at.of(y as usize * self.gb.width as usize + x as usize, s)
    }

    /// Where each sample sits in the planes.
    #[inline(always)]
    #[must_use]
    pub fn sample_index(&self) -> SampleIndex {
        self.at
    }

    /// The G-buffer being read.
    #[must_use]
    pub fn gbuffer(&self) -> &'a GBuffer {
        self.gb
    }

    /// The albedo sample `i` is shaded with (sanitised as the work list sanitises it, not counted).
    pub(crate) fn albedo(&self, i: usize) -> Vec3 {
        self.gb.albedo.as_ref().map_or(Vec3::splat(DEFAULT_ALBEDO), |a| albedo_clamped(a[i]).0)
    }

    /// Sample `s` of pixel (`x`, `y`); `None` for background (or an unusable position, counted).
    #[inline]
    pub fn read(&self, x: u32, y: u32, s: u32, counts: &mut SanitizedCounts) -> Option<Surface> {
        let i = self.index(x, y, s);
        let p = self.position(x, y, s, i, counts)?;
        Some(self.attributes(i, p, counts))
    }

    /// View-space position of sample `s` of pixel (`x`, `y`) (flat index `i`); `None` for background or an
    /// unusable position (counted).
    #[inline(always)]
    pub fn position(&self, x: u32, y: u32, s: u32, i: usize, counts: &mut SanitizedCounts) -> Option<Vec3> {
        let gb = self.gb;
        if !gb.coverage[i] {
            return None;
        }
        let p = match (&gb.position, &gb.depth, &self.rays) {
            (Some(pos), _, _) => pos[i],
            (None, Some(depth), Some(rays)) => {
                position_from_depth(rays, x, y, gb.sample_positions[s as usize], depth[i])
            }
            _ => Vec3::NAN,
        };
        if !usable_position(p) {
            counts.position += 1;
            return None;
        }
        Some(p)
    }

    /// The attributes of sample `i` (position `p` already read), with defaults and sanitisation.
    #[inline]
    fn attributes(&self, i: usize, p: Vec3, counts: &mut SanitizedCounts) -> Surface {
        let gb = self.gb;
        let n = gb.normal.as_ref().map_or(Vec3::Z, |nn| clean_normal(nn[i], &mut counts.normal));
        let albedo = gb.albedo.as_ref().map_or(Vec3::splat(DEFAULT_ALBEDO), |a| clean_albedo(a[i], &mut counts.albedo));
        let specular = scalar(gb.specular.as_deref(), i, DEFAULT_SPECULAR, 0.0, f32::MAX, &mut counts.specular);
        let power = scalar(
            gb.specular_power.as_deref(),
            i,
            DEFAULT_SPECULAR_POWER,
            0.0,
            MAX_SPECULAR_POWER,
            &mut counts.specular_power,
        );
        let roughness = match &gb.roughness {
            Some(_) => scalar(gb.roughness.as_deref(), i, roughness_from_power(power), 0.0, 1.0, &mut counts.roughness),
            None => roughness_from_power(power),
        };
        let metallic = scalar(gb.metallic.as_deref(), i, 0.0, 0.0, 1.0, &mut counts.metallic);
        Surface { p, n, albedo, specular, power, roughness, metallic }
    }

    /// Batch form of [`SurfaceReader::read`]'s attribute part for a work list: the positions, pixels and weights
    /// of `it` are set and `src[j]` is item `j`'s flat sample index (`src.len()` a multiple of [`LANES`]); fills
    /// the other surface arrays `brdf` reads (see [`Reads`]) with the same defaults, sanitisation and counts as
    /// `read`; the arrays it does not read keep whatever they held, and their planes are neither read nor counted.
    /// Works a vector of items at a time: a vector whose samples are consecutive (a tile row at one sample per
    /// pixel) is read as one slice (in AVX-512 vectors when `isa` is AVX-512), other vectors gather; the sanitising
    /// arithmetic has no branches.
    #[inline(always)]
    pub fn fill_attributes(&self, isa: Isa, src: &[usize], it: &mut Items, brdf: Brdf, counts: &mut SanitizedCounts) {
        #[cfg(target_arch = "x86_64")]
        let vector = isa.min(Isa::detect()) == Isa::Avx512;
        #[cfg(not(target_arch = "x86_64"))]
        let vector = {
            let _ = isa;
            false
        };
        self.fill_with(vector, src, it, brdf, counts);
    }

    /// [`SurfaceReader::fill_attributes`], with the AVX-512 vectors for runs of consecutive samples (`vector`: only
    /// where the CPU has them) or lane by lane. (Other vectors stay lane by lane: copying their samples together
    /// first, or hardware gathers, made the 4×-MSAA work-list build 1.1× and 2.6× slower.)
    #[inline(always)]
    fn fill_with(&self, vector: bool, src: &[usize], it: &mut Items, brdf: Brdf, counts: &mut SanitizedCounts) {
        let gb = self.gb;
        let reads = Reads::of(brdf);
        let n = src.len();
        debug_assert!(it.len() == n && n.is_multiple_of(LANES));
        it.resize(n);
        let mut bad = SanitizedCounts::default();
        for (c, idx) in src.chunks_exact(LANES).enumerate() {
            let r = c * LANES..(c + 1) * LANES;
            let run = idx.windows(2).all(|w| w[1] == w[0] + 1);
            // Consecutive samples on an AVX-512 CPU: whole vectors (the same arithmetic, see `avx512`); else lane
            // by lane.
            if !(run && vector && fill_run_avx512(gb, idx[0], reads, it, r.clone(), &mut bad)) {
                match &gb.normal {
                    Some(plane) => {
                        let v = gather(plane, idx, run);
                        let (x, y, z) = (&mut it.nx[r.clone()], &mut it.ny[r.clone()], &mut it.nz[r.clone()]);
                        // Counted in 32 bits within the vector: 64-bit sums kept the AVX2 loop scalar.
                        let mut nbad = 0u32;
                        for k in 0..LANES {
                            let (n, ok) = normalized(v[k]);
                            nbad += u32::from(!ok);
                            (x[k], y[k], z[k]) = (n.x, n.y, n.z);
                        }
                        bad.normal += u64::from(nbad);
                    }
                    None => {
                        it.nx[r.clone()].fill(0.0);
                        it.ny[r.clone()].fill(0.0);
                        it.nz[r.clone()].fill(1.0);
                    }
                }
                match &gb.albedo {
                    Some(plane) => {
                        let v = gather(plane, idx, run);
                        let (x, y, z) = (&mut it.ar[r.clone()], &mut it.ag[r.clone()], &mut it.ab[r.clone()]);
                        let mut nbad = 0u32;
                        for k in 0..LANES {
                            let (a, ok) = albedo_clamped(v[k]);
                            nbad += u32::from(!ok);
                            (x[k], y[k], z[k]) = (a.x, a.y, a.z);
                        }
                        bad.albedo += u64::from(nbad);
                    }
                    None => {
                        it.ar[r.clone()].fill(DEFAULT_ALBEDO);
                        it.ag[r.clone()].fill(DEFAULT_ALBEDO);
                        it.ab[r.clone()].fill(DEFAULT_ALBEDO);
                    }
                }
                if reads.specular {
                    let spec = [DEFAULT_SPECULAR; LANES];
                    fill_scalars(
                        &mut it.spec[r.clone()],
                        gb.specular.as_ref(),
                        idx,
                        run,
                        &spec,
                        0.0,
                        f32::MAX,
                        &mut bad.specular,
                    );
                }
                if reads.power {
                    let power = [DEFAULT_SPECULAR_POWER; LANES];
                    let p_hi = MAX_SPECULAR_POWER;
                    let out = &mut it.pw[r.clone()];
                    fill_scalars(out, gb.specular_power.as_ref(), idx, run, &power, 0.0, p_hi, &mut bad.specular_power);
                }
            }
            if reads.metal_rough {
                let mut rough = [0.0; LANES];
                for (o, &p) in rough.iter_mut().zip(&it.pw[r.clone()]) {
                    *o = roughness_from_power(p);
                }
                fill_scalars(
                    &mut it.rough[r.clone()],
                    gb.roughness.as_ref(),
                    idx,
                    run,
                    &rough,
                    0.0,
                    1.0,
                    &mut bad.roughness,
                );
                let zero = [0.0; LANES];
                fill_scalars(&mut it.metal[r], gb.metallic.as_ref(), idx, run, &zero, 0.0, 1.0, &mut bad.metallic);
            }
        }
        counts.add(&bad);
    }
}

/// The normal, albedo, specular and power of 16 consecutive samples from `start` into items `r` with the AVX-512
/// vectors (the caller checked the CPU has them); returns true. Elsewhere returns false: the caller fills them
/// lane by lane.
#[inline(always)]
fn fill_run_avx512(
    gb: &GBuffer,
    start: usize,
    reads: Reads,
    it: &mut Items,
    r: std::ops::Range<usize>,
    bad: &mut SanitizedCounts,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        fn part<T>(plane: &Option<Vec<T>>, start: usize) -> Option<&[T]> {
            plane.as_deref().map(|p| &p[start..start + LANES])
        }
        // SAFETY: the caller only asks where the CPU has AVX-512F.
        unsafe {
            let n = [&mut it.nx[r.clone()], &mut it.ny[r.clone()], &mut it.nz[r.clone()]];
            avx512::normals(part(&gb.normal, start), n, &mut bad.normal);
            let a = [&mut it.ar[r.clone()], &mut it.ag[r.clone()], &mut it.ab[r.clone()]];
            avx512::albedo(part(&gb.albedo, start), a, &mut bad.albedo);
            if reads.specular {
                let range = (DEFAULT_SPECULAR, 0.0, f32::MAX);
                avx512::clamped(part(&gb.specular, start), &mut it.spec[r.clone()], range, &mut bad.specular);
            }
            if reads.power {
                let range = (DEFAULT_SPECULAR_POWER, 0.0, MAX_SPECULAR_POWER);
                avx512::clamped(part(&gb.specular_power, start), &mut it.pw[r], range, &mut bad.specular_power);
            }
        }
        true
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (gb, start, reads, it, r, bad);
        false
    }
}

/// Which scalar attributes a BRDF reads (all read the normal and the albedo). The resolve reads, sanitises and
/// counts only these: Lambert none, Blinn-Phong the specular amount and power, GGX roughness and metallic (and the
/// specular power, from which a missing roughness is mapped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reads {
    /// Specular amount.
    pub specular: bool,
    /// Specular power.
    pub power: bool,
    /// Roughness and metallic.
    pub metal_rough: bool,
}

impl Reads {
    /// What `brdf` reads.
    #[must_use]
    pub fn of(brdf: Brdf) -> Self {
        match brdf {
            Brdf::Lambert => Reads { specular: false, power: false, metal_rough: false },
            Brdf::BlinnPhong => Reads { specular: true, power: true, metal_rough: false },
            Brdf::Ggx => Reads { specular: false, power: true, metal_rough: true },
        }
    }

    /// The attributes a resolve with these reads decodes from packed targets: position (or depth), normal, albedo
    /// and the BRDF's parameters.
    #[must_use]
    pub fn attributes(self) -> Vec<crate::gbuffer::Attribute> {
        use crate::gbuffer::Attribute as A;
        let mut v = vec![A::Depth, A::Position, A::Normal, A::Albedo];
        if self.specular {
            v.push(A::Specular);
        }
        if self.power {
            v.push(A::SpecularPower);
        }
        if self.metal_rough {
            v.extend([A::Roughness, A::Metallic]);
        }
        v
    }
}

/// One vector of a scalar attribute: `plane[idx[k]]` sanitised into `out` ([`clamped`]), or the defaults.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn fill_scalars(
    out: &mut [f32],
    plane: Option<&Vec<f32>>,
    idx: &[usize],
    run: bool,
    dflt: &[f32; LANES],
    lo: f32,
    hi: f32,
    count: &mut u64,
) {
    let Some(plane) = plane else {
        out.copy_from_slice(dflt);
        return;
    };
    let v = gather(plane, idx, run);
    let mut nbad = 0u32;
    for k in 0..LANES {
        let (x, ok) = clamped(v[k], dflt[k], lo, hi);
        nbad += u32::from(!ok);
        out[k] = x;
    }
    *count += u64::from(nbad);
}

/// Values `plane[idx[k]]` for one vector of items: a slice copy when the indices are consecutive.
#[inline(always)]
fn gather<T: Copy + Default>(plane: &[T], idx: &[usize], consecutive: bool) -> [T; LANES] {
    let mut out = [T::default(); LANES];
    if consecutive {
        out.copy_from_slice(&plane[idx[0]..idx[0] + LANES]);
    } else {
        for (o, &i) in out.iter_mut().zip(idx) {
            *o = plane[i];
        }
    }
    out
}

/// `n` made unit length and true; `(+Z, false)` when that is impossible (NaN/Inf or zero length). The same
/// arithmetic as `Vec3::try_normalize`, without a branch.
#[inline(always)]
fn normalized(n: Vec3) -> (Vec3, bool) {
    let rcp = 1.0 / n.length();
    let ok = rcp.is_finite() & (rcp > 0.0);
    (if ok { n * rcp } else { Vec3::Z }, ok)
}

/// Albedo with NaN/Inf and negative components replaced by 0, and whether it was already clean.
#[inline(always)]
fn albedo_clamped(a: Vec3) -> (Vec3, bool) {
    let c = |v: f32| if v.is_finite() & (v >= 0.0) { v } else { 0.0 };
    let out = Vec3::new(c(a.x), c(a.y), c(a.z));
    let ok = a.x.is_finite() & a.y.is_finite() & a.z.is_finite() & (a.min_element() >= 0.0);
    (out, ok)
}

/// A scalar: NaN/Inf → `default`, out of `[lo, hi]` → clamped; and whether it was already clean.
#[inline(always)]
fn clamped(v: f32, default: f32, lo: f32, hi: f32) -> (f32, bool) {
    let c = v.max(lo).min(hi);
    let finite = v.is_finite();
    (if finite { c } else { default }, finite & (c == v))
}

/// A stored normal made unit length; NaN/Inf or zero length → `+Z` (facing the camera), counted.
#[inline]
fn clean_normal(n: Vec3, count: &mut u64) -> Vec3 {
    let (v, ok) = normalized(n);
    *count += u64::from(!ok);
    v
}

/// A stored albedo with NaN/Inf components → 0 and negative ones clamped to 0, counted once per sample.
#[inline]
fn clean_albedo(a: Vec3, count: &mut u64) -> Vec3 {
    let (v, ok) = albedo_clamped(a);
    *count += u64::from(!ok);
    v
}

/// Value `i` of an optional plane: the default when absent; NaN/Inf → default and out-of-range → clamped, both
/// counted.
#[inline]
fn scalar(plane: Option<&[f32]>, i: usize, default: f32, lo: f32, hi: f32, count: &mut u64) -> f32 {
    let Some(plane) = plane else { return default };
    let (v, ok) = clamped(plane[i], default, lo, hi);
    *count += u64::from(!ok);
    v
}

/// The attribute sanitising of [`SurfaceReader::fill_attributes`] for 16 consecutive samples in AVX-512 vectors:
/// the same IEEE operations in the same order as [`normalized`], [`albedo_clamped`] and [`clamped`] (a test checks
/// the two paths agree on every kind of bad value).
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{Vec3, LANES};
    use std::arch::x86_64::*;

    /// Lane `k` of component `q` of 16 `Vec3` sits at float `3k + q`: `permutex2var` indices taking what lies in
    /// the first two registers (floats 0..32), then the rest from the third.
    const fn indices(q: usize) -> ([i32; 16], [i32; 16]) {
        let (mut a, mut b) = ([0i32; 16], [0i32; 16]);
        let mut k = 0;
        while k < 16 {
            let f = 3 * k + q;
            if f < 32 {
                a[k] = f as i32;
                b[k] = k as i32;
            } else {
                b[k] = (16 + f - 32) as i32;
            }
            k += 1;
        }
        (a, b)
    }
    const IDX: [([i32; 16], [i32; 16]); 3] = [indices(0), indices(1), indices(2)];

    /// The x, y, z components of 16 `Vec3`.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
    #[inline]
    unsafe fn load3(v: &[Vec3]) -> [__m512; 3] {
        let v = &v[..LANES];
        // SAFETY (this function and the ones below): `Vec3` is three f32 (`#[repr(C)]`), so 16 of them are 48
        // floats, read by three unaligned loads; stores go to slices checked to hold 16 lanes.
        let f = v.as_ptr().cast::<f32>();
        let (r0, r1, r2) = (_mm512_loadu_ps(f), _mm512_loadu_ps(f.add(16)), _mm512_loadu_ps(f.add(32)));
        IDX.map(|(a, b)| {
            let t = _mm512_permutex2var_ps(r0, _mm512_loadu_si512(a.as_ptr().cast()), r1);
            _mm512_permutex2var_ps(t, _mm512_loadu_si512(b.as_ptr().cast()), r2)
        })
    }

    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
    #[inline]
    unsafe fn store(v: __m512, out: &mut [f32]) {
        _mm512_storeu_ps(out[..LANES].as_mut_ptr(), v);
    }

    /// `v` finite and ≥ 0 (false for NaN).
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
    #[inline]
    unsafe fn finite_nonneg(v: __m512) -> __mmask16 {
        _mm512_cmp_ps_mask::<_CMP_GE_OQ>(v, _mm512_setzero_ps())
            & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(v, _mm512_set1_ps(f32::INFINITY))
    }

    /// Normals made unit length; NaN/Inf or zero length → +Z, counted. Absent plane: +Z.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
    #[inline]
    pub unsafe fn normals(plane: Option<&[Vec3]>, out: [&mut [f32]; 3], count: &mut u64) {
        let [ox, oy, oz] = out;
        let Some(plane) = plane else {
            store(_mm512_setzero_ps(), ox);
            store(_mm512_setzero_ps(), oy);
            store(_mm512_set1_ps(1.0), oz);
            return;
        };
        let [x, y, z] = load3(plane);
        // (x·x + y·y) + z·z, as glam's `dot` (no fused multiply-add), then 1/√.
        let len2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(x, x), _mm512_mul_ps(y, y)), _mm512_mul_ps(z, z));
        let rcp = _mm512_div_ps(_mm512_set1_ps(1.0), _mm512_sqrt_ps(len2));
        let ok = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(rcp, _mm512_setzero_ps())
            & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(rcp, _mm512_set1_ps(f32::INFINITY));
        *count += u64::from((!ok).count_ones());
        store(_mm512_maskz_mov_ps(ok, _mm512_mul_ps(x, rcp)), ox);
        store(_mm512_maskz_mov_ps(ok, _mm512_mul_ps(y, rcp)), oy);
        store(_mm512_mask_mov_ps(_mm512_set1_ps(1.0), ok, _mm512_mul_ps(z, rcp)), oz);
    }

    /// Albedo with NaN/Inf and negative components → 0, counted once per sample. Absent plane: the default grey.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
    #[inline]
    pub unsafe fn albedo(plane: Option<&[Vec3]>, out: [&mut [f32]; 3], count: &mut u64) {
        let Some(plane) = plane else {
            for o in out {
                store(_mm512_set1_ps(super::DEFAULT_ALBEDO), o);
            }
            return;
        };
        let mut all = 0xffff;
        for (v, o) in load3(plane).into_iter().zip(out) {
            let ok = finite_nonneg(v);
            all &= ok;
            store(_mm512_maskz_mov_ps(ok, v), o);
        }
        *count += u64::from((!all).count_ones());
    }

    /// A scalar: NaN/Inf → default, out of `[lo, hi]` → clamped, both counted. Absent plane: the default.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
    #[inline]
    pub unsafe fn clamped(plane: Option<&[f32]>, out: &mut [f32], (default, lo, hi): (f32, f32, f32), count: &mut u64) {
        let Some(plane) = plane else {
            store(_mm512_set1_ps(default), out);
            return;
        };
        let v = _mm512_loadu_ps(plane[..LANES].as_ptr());
        let c = _mm512_min_ps(_mm512_max_ps(v, _mm512_set1_ps(lo)), _mm512_set1_ps(hi));
        let finite = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_abs_ps(v), _mm512_set1_ps(f32::INFINITY));
        let ok = finite & _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(c, v);
        *count += u64::from((!ok).count_ones());
        store(_mm512_mask_mov_ps(_mm512_set1_ps(default), finite, c), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;

    fn one_pixel() -> GBuffer {
        let mut g = GBuffer::new(1, 1, 1).unwrap();
        g.coverage[0] = true;
        g.position = Some(vec![Vec3::new(0.0, 0.0, -2.0)]);
        g
    }

    #[test]
    fn defaults_fill_absent_attributes() {
        let g = one_pixel();
        let r = SurfaceReader::new(&g).unwrap();
        let mut c = SanitizedCounts::default();
        let s = r.read(0, 0, 0, &mut c).unwrap();
        assert_eq!(s.n, Vec3::Z);
        assert_eq!(s.albedo, Vec3::splat(DEFAULT_ALBEDO));
        assert_eq!(s.power, DEFAULT_SPECULAR_POWER);
        assert_eq!(s.roughness, roughness_from_power(DEFAULT_SPECULAR_POWER));
        assert_eq!(c.total(), 0);
    }

    #[test]
    fn nan_and_inf_are_replaced_and_counted() {
        let mut g = one_pixel();
        g.normal = Some(vec![Vec3::new(f32::NAN, 0.0, 1.0)]);
        g.albedo = Some(vec![Vec3::new(f32::INFINITY, -1.0, 0.5)]);
        g.specular_power = Some(vec![f32::NAN]);
        g.roughness = Some(vec![7.0]);
        let r = SurfaceReader::new(&g).unwrap();
        let mut c = SanitizedCounts::default();
        let s = r.read(0, 0, 0, &mut c).unwrap();
        assert_eq!(s.n, Vec3::Z);
        assert_eq!(s.albedo, Vec3::new(0.0, 0.0, 0.5));
        assert_eq!(s.power, DEFAULT_SPECULAR_POWER);
        assert_eq!(s.roughness, 1.0);
        assert_eq!((c.normal, c.albedo, c.specular_power, c.roughness), (1, 1, 1, 1));
        g.position = Some(vec![Vec3::new(0.0, f32::NAN, -1.0)]);
        let r = SurfaceReader::new(&g).unwrap();
        assert!(r.read(0, 0, 0, &mut c).is_none());
        assert_eq!(c.position, 1);
    }

    #[test]
    fn position_is_derived_from_depth_and_camera_or_refused() {
        let mut g = GBuffer::new(2, 2, 1).unwrap();
        g.coverage = vec![true; 4];
        g.depth = Some(vec![3.0; 4]);
        assert!(SurfaceReader::new(&g).is_err());
        g.camera = Some(Camera::identity(1.0, 1.0, 0.1, 100.0));
        let r = SurfaceReader::new(&g).unwrap();
        let s = r.read(1, 0, 0, &mut SanitizedCounts::default()).unwrap();
        assert!((s.p.z + 3.0).abs() < 1e-6 && s.p.x > 0.0 && s.p.y > 0.0, "{}", s.p);
    }

    /// A position derived from depth is the camera's own (`Camera::view_position`, and the plane
    /// `GBuffer::fill_position_from_depth` writes) bit for bit, for every sample of a multisampled off-centre
    /// camera: the principal point shifts the rays (before, it scaled them: wrong positions for a sidecar's
    /// intrinsics).
    #[test]
    fn derived_positions_are_the_cameras_own_with_an_off_centre_principal_point() {
        let (w, h) = (7u32, 5u32);
        let mut g = GBuffer::new(w, h, 4).unwrap();
        g.coverage = vec![true; g.len()];
        g.depth = Some((0..g.len()).map(|i| 1.0 + 0.37 * i as f32).collect());
        let mut cam = Camera::identity(0.9, 1.6, 0.1, 100.0);
        cam.principal = Vec2::new(0.3, -0.2);
        g.camera = Some(cam);
        let mut filled = g.clone();
        filled.fill_position_from_depth();
        let r = SurfaceReader::new(&g).unwrap();
        let mut counts = SanitizedCounts::default();
        for y in 0..h {
            for x in 0..w {
                for s in 0..4 {
                    let i = r.index(x, y, s);
                    let o = g.sample_positions[s as usize];
                    let px = Vec2::new(x as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y);
                    let want = cam.view_position(px, g.depth.as_ref().unwrap()[i], w, h);
                    let got = r.read(x, y, s, &mut counts).unwrap().p;
                    assert_eq!(got.to_array(), want.to_array(), "({x}, {y}) sample {s}");
                    assert_eq!(got.to_array(), filled.position.as_ref().unwrap()[i].to_array());
                }
            }
        }
        // The centre of the image is on the principal point's side: x = 0 at ndc 0.3, not at ndc 0.
        let centre = cam.view_position(Vec2::new(0.65 * w as f32, 0.6 * h as f32), 1.0, w, h);
        assert!(centre.x.abs() < 1e-6 && centre.y.abs() < 1e-6, "{centre}");
        assert_eq!(counts, SanitizedCounts::default());
    }

    #[test]
    fn batch_fill_matches_read_for_every_kind_of_value() {
        // 48 samples in a row; the work list takes two runs of 16 consecutive samples (the whole-vector path on
        // AVX-512 CPUs) and one shuffled vector (the lane-by-lane path).
        let n = 48;
        let mut g = GBuffer::new(n as u32, 1, 1).unwrap();
        g.coverage = vec![true; n];
        g.position = Some(vec![Vec3::new(0.0, 0.0, -2.0); n]);
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        let pick = |i: usize, v: &[f32]| v[i % v.len()];
        let normals = [
            Vec3::new(0.3, -0.2, 0.9),
            Vec3::ZERO,
            Vec3::new(nan, 0.0, 1.0),
            Vec3::new(inf, 1.0, 0.0),
            Vec3::new(1e-30, 0.0, 0.0),
            Vec3::new(-2.0, 5.0, 1e3),
        ];
        g.normal = Some((0..n).map(|i| normals[i % normals.len()]).collect());
        let al = [0.5, -0.1, nan, inf, -0.0, 2.0, -inf];
        g.albedo = Some((0..n).map(|i| Vec3::new(pick(i, &al), pick(i + 1, &al), pick(i + 3, &al))).collect());
        g.specular = Some((0..n).map(|i| pick(i, &[0.5, -1.0, nan, inf, 1e38, -0.0, 3.0])).collect());
        g.specular_power = Some((0..n).map(|i| pick(i, &[16.0, 2e6, nan, -3.0, 0.0, -inf, 1e4, 7.5])).collect());
        g.roughness = Some((0..n).map(|i| pick(i, &[0.5, 1.5, nan, -0.2, inf])).collect());
        g.metallic = Some((0..n).map(|i| pick(i, &[1.0, 0.0, nan, 7.0, -inf, 0.25])).collect());
        let r = SurfaceReader::new(&g).unwrap();
        let mut src: Vec<usize> = (0..32).collect();
        src.extend([47, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 32]);
        #[cfg(target_arch = "x86_64")]
        let vector = crate::base::isa::Isa::detect() == crate::base::isa::Isa::Avx512;
        #[cfg(not(target_arch = "x86_64"))]
        let vector = false;
        let paths = if vector { &[false, true][..] } else { &[false][..] };
        for (&path, brdf) in paths.iter().flat_map(|p| [Brdf::Lambert, Brdf::BlinnPhong, Brdf::Ggx].map(|b| (p, b))) {
            let reads = Reads::of(brdf);
            let mut it = Items::default();
            it.resize(src.len());
            let mut got = SanitizedCounts::default();
            r.fill_with(path, &src, &mut it, brdf, &mut got);
            let mut want = SanitizedCounts::default();
            for (j, &i) in src.iter().enumerate() {
                let s = r.read(i as u32, 0, 0, &mut want).unwrap();
                let ctx = format!("{brdf:?} vector path {path}, item {j} (sample {i})");
                // `==`: a clamped −0 may come out as +0 on one path (no effect on the lighting).
                assert!(Vec3::new(it.nx[j], it.ny[j], it.nz[j]) == s.n, "{ctx}: normal");
                assert!(Vec3::new(it.ar[j], it.ag[j], it.ab[j]) == s.albedo, "{ctx}: albedo");
                if reads.specular {
                    assert!(it.spec[j] == s.specular, "{ctx}: specular");
                }
                if reads.power {
                    assert!(it.pw[j] == s.power, "{ctx}: power");
                }
                if reads.metal_rough {
                    assert!(it.rough[j] == s.roughness && it.metal[j] == s.metallic, "{ctx}: roughness/metallic");
                }
            }
            assert_eq!((got.normal, got.albedo), (want.normal, want.albedo), "{brdf:?}");
            assert!(got.normal > 0 && got.albedo > 0 && want.specular > 0, "the data has bad values of every kind");
            if reads.specular {
                assert_eq!(got.specular, want.specular, "{brdf:?}");
            }
            if reads.power {
                assert_eq!(got.specular_power, want.specular_power, "{brdf:?}");
            }
            if reads.metal_rough {
                assert_eq!((got.roughness, got.metallic), (want.roughness, want.metallic), "{brdf:?}");
            }
        }
    }

    #[test]
    fn roughness_mapping_is_monotonic_and_bounded() {
        assert!((roughness_from_power(0.0) - 1.0).abs() < 1e-6);
        let mut last = 1.0;
        for p in [1.0, 8.0, 64.0, 1e3, 1e4] {
            let r = roughness_from_power(p);
            assert!(r < last && r > 0.0, "{p} -> {r}");
            last = r;
        }
    }
}
