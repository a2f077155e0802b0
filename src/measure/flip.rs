//! FLIP and HDR-FLIP image difference evaluators.
//!
//! An independent Rust implementation of
//!
//! * **LDR-FLIP**: P. Andersson, J. Nilsson, T. Akenine-Möller, M. Oskarsson, K. Åström,
//!   M. D. Fairchild, "FLIP: A Difference Evaluator for Alternating Images", HPG 2020.
//! * **HDR-FLIP**: P. Andersson, J. Nilsson, P. Shirley, T. Akenine-Möller,
//!   "Visualizing Errors in Rendered High Dynamic Range Images", Eurographics 2021.
//!
//! Constants, filter construction, colour transforms, exposure selection and the
//! magma colour map follow NVIDIA's reference implementation (NVlabs/flip v1.6,
//! PyPI `flip-evaluator` 1.7), so that results agree with it to float precision
//! (checked against `flip-evaluator` in CI: tests/measure_flip.rs compares means and maps on the fixtures' images;
//! the agreement is stated there and in docs/DECISIONS.md).
//!
//! Images are `f32`, interleaved RGB (`len == width * height * 3`), row 0 at the top.
//! The error map has one value per pixel in `[0, 1]`.
//!
//! Implementation notes:
//! * All filters are separable: the achromatic and red-green CSF filters are single
//!   Gaussians, the blue-yellow CSF filter is a sum of two Gaussians and is split
//!   into two separable filters (as in the reference's `separatedConvolutions.pdf`);
//!   the edge/point detectors are products of a 1D Gaussian and its 1st/2nd
//!   derivative. Borders are clamp-to-edge, as in the reference.
//! * The image is cut into horizontal bands processed in parallel with rayon, and
//!   each band into 256-column tiles. Horizontally filtered rows of a tile live in a
//!   small ring buffer (~300 KB, L2-resident) from which the vertical pass produces
//!   two output rows at a time; there are no full-size intermediate images.
//! * Inner loops are plain `f32` code on 8-lane blocks (including branch-free
//!   `log2`/`exp2`-based `pow` and cube root), compiled three times, generic, with
//!   AVX2 and with AVX-512 enabled (where LLVM joins neighbouring blocks into 16-lane
//!   registers: 1.3× the AVX2 build on Zen 5), and picked at run time. No FMA
//!   contraction is used, so every path gives identical results (tested).
//! * Filter taps are accumulated in the same order as the reference, so filtered
//!   values match it bit for bit. The cube root is correctly rounded; `pow` has a
//!   relative error of ~1e-6. Per-pixel differences to the reference are ~1e-5 or
//!   less (larger only where reference and test differ by float noise, because
//!   HyAB^0.7 amplifies tiny differences). The mean is summed in `f64` (the
//!   reference sums in `f32`; see [`FlipMap::mean_f32_sequential`]).

// Constants are kept with the reference's decimals (they round to the same f32).
#![allow(clippy::excessive_precision, clippy::needless_range_loop, clippy::too_many_arguments)]

use crate::base::fastmath;
use crate::base::isa::Isa;
use rayon::prelude::*;

// ---------------------------------------------------------------------------
// Public API
// ---------------------------------------------------------------------------

/// Viewing conditions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipOptions {
    /// Pixels per degree of visual angle. Default: [`default_ppd`]
    /// (0.7 m from a 0.7 m wide, 3840 pixel wide monitor, ≈ 67.02).
    pub pixels_per_degree: f32,
}

impl Default for FlipOptions {
    fn default() -> Self {
        FlipOptions { pixels_per_degree: default_ppd() }
    }
}

impl FlipOptions {
    /// Options for a viewer at `distance_m` metres from a monitor `monitor_width_m`
    /// metres wide showing `resolution_x` pixels horizontally.
    pub fn from_viewing_conditions(distance_m: f32, resolution_x: f32, monitor_width_m: f32) -> Self {
        FlipOptions { pixels_per_degree: pixels_per_degree(distance_m, resolution_x, monitor_width_m) }
    }
}

/// Pixels per degree for the given viewing conditions, as the reference computes it
/// (`distance * (resolution / width) * pi / 180`, small-angle form, in `f32`).
pub fn pixels_per_degree(distance_m: f32, resolution_x: f32, monitor_width_m: f32) -> f32 {
    distance_m * (resolution_x / monitor_width_m) * (PI / 180.0)
}

/// The reference default pixels per degree: `pixels_per_degree(0.7, 3840.0, 0.7)` ≈ 67.0206.
pub fn default_ppd() -> f32 {
    pixels_per_degree(0.7, 3840.0, 0.7)
}

/// A FLIP error map.
#[derive(Clone, Debug)]
pub struct FlipMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` errors in `[0, 1]`, row 0 at the top.
    pub values: Vec<f32>,
    /// Mean of `values` (summed in `f64`; 0 for an empty image).
    pub mean: f64,
}

impl FlipMap {
    /// The mean as the reference tool reports it: a sequential `f32` sum in row-major
    /// order divided by the pixel count. For large images this drifts from the exact
    /// mean (by ~8e-4 at 1920x1080 for a mean of 0.1); use it only to reproduce numbers
    /// printed by NVIDIA's tools.
    pub fn mean_f32_sequential(&self) -> f32 {
        if self.values.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0f32;
        for &v in &self.values {
            sum += v;
        }
        sum / (self.width * self.height) as f32
    }
}

/// Tone mappers available to HDR-FLIP (ACES is the reference default).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ToneMapper {
    /// Reinhard on luminance: `c / (1 + L)`.
    Reinhard,
    /// Narkowicz' ACES fit, with the 0.6 pre-exposure cancelled (reference default).
    #[default]
    Aces,
    /// Hable's filmic curve (rational fit used by the reference).
    Hable,
}

/// Exposure settings for HDR-FLIP. `None` means "computed as the reference does".
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HdrParams {
    /// Start exposure `c_start` (stops). Default: `log2(x_max / Y_max)` of the reference.
    pub start_exposure: Option<f32>,
    /// Stop exposure `c_stop` (stops). Default: `log2(x_max / Y_median)` of the reference.
    pub stop_exposure: Option<f32>,
    /// Number of exposures. Default: `max(2, ceil(c_stop - c_start))`.
    pub num_exposures: Option<usize>,
    /// The tone mapper applied at each exposure (ACES by default, as the reference).
    pub tone_mapper: ToneMapper,
}

/// Result of HDR-FLIP.
#[derive(Clone, Debug)]
pub struct HdrFlip {
    /// Per-pixel maximum of the LDR-FLIP maps over all exposures, and its mean.
    pub map: FlipMap,
    /// The exposures (in stops) that were evaluated, in order.
    pub exposures: Vec<f32>,
    /// The start exposure used (stops).
    pub start_exposure: f32,
    /// The stop exposure used (stops).
    pub stop_exposure: f32,
    /// The tone mapper used.
    pub tone_mapper: ToneMapper,
    /// Per pixel, `i / (n - 1)` for the exposure index `i` that gave the maximum error
    /// (0 where every exposure gave 0), as the reference's exposure map.
    pub exposure_map: Vec<f32>,
}

impl HdrFlip {
    /// Mean HDR-FLIP error (same as `map.mean`).
    pub fn mean(&self) -> f64 {
        self.map.mean
    }
}

/// LDR-FLIP of two **sRGB-encoded** images (display values; values are decoded
/// with the sRGB transfer function and clamped to `[0, 1]` in linear RGB).
///
/// This is what `flip_evaluator.evaluate(ref, test, "LDR")` computes.
pub fn ldr_flip(reference_srgb: &[f32], test_srgb: &[f32], width: usize, height: usize, opts: &FlipOptions) -> FlipMap {
    ldr_common(reference_srgb, test_srgb, width, height, opts, Encoding::Srgb)
}

/// LDR-FLIP of two images given in **linear** RGB, clamped to `[0, 1]`
/// (`flip_evaluator.evaluate(ref, test, "LDR", inputsRGB=False)`).
pub fn ldr_flip_linear(
    reference_linear: &[f32],
    test_linear: &[f32],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> FlipMap {
    ldr_common(reference_linear, test_linear, width, height, opts, Encoding::Linear)
}

/// HDR-FLIP of two linear-RGB HDR images (non-negative values) with the reference
/// defaults: ACES tone mapping, start/stop exposures and their number computed from
/// the reference image's luminance (`flip_evaluator.evaluate(ref, test, "HDR")`).
pub fn hdr_flip(
    reference_linear: &[f32],
    test_linear: &[f32],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> HdrFlip {
    hdr_flip_with(reference_linear, test_linear, width, height, opts, &HdrParams::default())
}

/// HDR-FLIP with explicit exposure / tone mapper settings.
///
/// Panics if `start_exposure > stop_exposure` or if `num_exposures == Some(0)`.
pub fn hdr_flip_with(
    reference_linear: &[f32],
    test_linear: &[f32],
    width: usize,
    height: usize,
    opts: &FlipOptions,
    params: &HdrParams,
) -> HdrFlip {
    check_sizes(reference_linear, test_linear, width, height);
    let tm = params.tone_mapper;
    let (start, stop) = match (params.start_exposure, params.stop_exposure) {
        (Some(a), Some(b)) => (a, b),
        (a, b) => {
            let (s0, s1) = compute_exposures(reference_linear, tm);
            (a.unwrap_or(s0), b.unwrap_or(s1))
        }
    };
    assert!(start <= stop, "HDR-FLIP: start exposure ({start}) must not exceed stop exposure ({stop})");
    let n = params.num_exposures.unwrap_or_else(|| exposure_count(start, stop));
    assert!(n >= 1, "HDR-FLIP: need at least one exposure");
    let exposures = exposure_list(start, stop, n);

    let npix = width * height;
    let mut maxes = vec![vec![0.0f32; npix]];
    let mut tags = vec![vec![0.0f32; npix]];
    let encs = hdr_encodings(&exposures, tm);
    let (r, t) = (Pixels::F32(reference_linear), [Pixels::F32(test_linear)]);
    let sums = run_flip(width, height, opts, r, &t, &encs, Maps::Frame(&mut maxes, Some(&mut tags)));
    let (max_map, exposure_map) = (maxes.remove(0), tags.remove(0));
    let mean = mean_of(&sums[0], npix);
    HdrFlip {
        map: FlipMap { width, height, values: max_map, mean },
        exposures,
        start_exposure: start,
        stop_exposure: stop,
        tone_mapper: tm,
        exposure_map,
    }
}

/// How many exposures HDR-FLIP runs for `reference_linear` (interleaved linear RGB) with the default tone mapper:
/// each is one pass over the image, like the LDR one.
#[must_use]
pub fn hdr_exposure_count(reference_linear: &[f32]) -> usize {
    let (start, stop) = compute_exposures(reference_linear, ToneMapper::default());
    exposure_count(start, stop)
}

/// The reference's default number of exposures between `start` and `stop` (at least 2).
fn exposure_count(start: f32, stop: f32) -> usize {
    (stop - start).clamp(0.0, MAX_EXPOSURE_RANGE).ceil().max(2.0) as usize
}

/// `n` exposures evenly from `start` to `stop`. With n == 1 the reference divides by zero (step = inf/NaN); we
/// evaluate `start` only.
fn exposure_list(start: f32, stop: f32, n: usize) -> Vec<f32> {
    let step = if n > 1 { (stop - start) / (n - 1) as f32 } else { 0.0 };
    (0..n).map(|i| start + i as f32 * step).collect()
}

/// Maps error values in `[0, 1]` to sRGB-encoded RGB8 with the magma colour map,
/// exactly as the reference does (index `int(255 v + 0.5)`; values outside `[0, 1]`
/// are clamped). Returns `values.len() * 3` bytes, ready to be written as a PNG.
pub fn magma_rgb8(values: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(values.len() * 3);
    for &v in values {
        out.extend_from_slice(&MAGMA_RGB8[magma_index(v)]);
    }
    out
}

/// Convenience: [`magma_rgb8`] of a [`FlipMap`].
pub fn flip_map_to_magma_rgb8(map: &FlipMap) -> Vec<u8> {
    magma_rgb8(&map.values)
}

/// The magma colour map as sRGB RGB8 (256 entries; matplotlib's magma as tabulated by the reference).
pub fn magma_lut() -> &'static [[u8; 3]; 256] {
    &MAGMA_RGB8
}

#[inline]
fn magma_index(v: f32) -> usize {
    let v = if v > 0.0 {
        if v < 1.0 {
            v
        } else {
            1.0
        }
    } else {
        0.0
    }; // NaN -> 0
    ((v * 255.0 + 0.5) as usize) & 255
}

// ---------------------------------------------------------------------------
// Constants (from the papers / reference implementation)
// ---------------------------------------------------------------------------

// The reference's 3.14159265358979f is this same f32 value.
const PI: f32 = std::f32::consts::PI;

// Colour pipeline parameters.
const GQC: f32 = 0.7; // exponent on HyAB distance
const GPC: f32 = 0.4; // breakpoint fraction of cmax
const GPT: f32 = 0.95; // error value at breakpoint
const GW: f32 = 0.082; // feature detector width (degrees)
                       // gqf = 0.5: feature difference exponent, implemented as sqrt.

// CSF as sums of Gaussians: a1, b1 (first) and a2, b2 (second) for Y, Cx, Cz.
const GA1: [f32; 3] = [1.0, 1.0, 34.1];
const GB1: [f32; 3] = [0.0047, 0.0053, 0.04];
const GA2: [f32; 3] = [0.0, 0.0, 13.5];
const GB2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];

// D65 white in XYZ and its inverse.
const ILL: [f32; 3] = [0.950428545, 1.000000000, 1.088900371];
const INV_ILL: [f32; 3] = [1.052156925, 1.000000000, 0.918357670];

// Linear sRGB -> XYZ (D65), exact rational form.
const RGB2XYZ: [[f32; 3]; 3] = [
    [10135552.0 / 24577794.0, 8788810.0 / 24577794.0, 4435075.0 / 24577794.0],
    [2613072.0 / 12288897.0, 8788810.0 / 12288897.0, 887015.0 / 12288897.0],
    [1425312.0 / 73733382.0, 8788810.0 / 73733382.0, 70074185.0 / 73733382.0],
];
// XYZ -> linear sRGB (D65).
const XYZ2RGB: [[f32; 3]; 3] = [
    [3.241003275, -1.537398934, -0.498615861],
    [-0.969224334, 1.875930071, 0.041554224],
    [0.055639423, -0.204011202, 1.057148933],
];

// CIELab constants.
const LAB_DELTA: f32 = 6.0 / 29.0;
const LAB_DELTA_SQ: f32 = LAB_DELTA * LAB_DELTA;
const LAB_DELTA_CUBE: f32 = LAB_DELTA * LAB_DELTA_SQ;
const LAB_FACTOR: f32 = 1.0 / (3.0 * LAB_DELTA_SQ);
const LAB_TERM: f32 = 4.0 / 29.0;
const ONE_THIRD: f32 = 1.0 / 3.0;

// Tone mapper rational coefficients (c^2 t0 + c t1 + t2) / (c^2 t3 + c t4 + t5).
const TM_REINHARD: [f32; 6] = [0.0, 1.0, 0.0, 0.0, 1.0, 1.0];
const TM_ACES: [f32; 6] = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14];
const TM_HABLE: [f32; 6] = [0.231683, 0.013791, 0.0, 0.18, 0.3, 0.018];

impl ToneMapper {
    fn coefficients(self) -> [f32; 6] {
        match self {
            ToneMapper::Reinhard => TM_REINHARD,
            ToneMapper::Aces => TM_ACES,
            ToneMapper::Hable => TM_HABLE,
        }
    }
}

// ---------------------------------------------------------------------------
// Driver
// ---------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
enum Encoding {
    /// sRGB-encoded input: decode, clamp.
    Srgb,
    /// Linear input: clamp.
    Linear,
    /// Linear HDR input: multiply by `scale = 2^exposure`, tone map, clamp.
    Hdr { scale: f32, tm: ToneMapper },
}

fn check_sizes(r: &[f32], t: &[f32], w: usize, h: usize) {
    let n = w.checked_mul(h).and_then(|n| n.checked_mul(3)).expect("FLIP: image size overflows usize");
    assert_eq!(r.len(), n, "FLIP: reference image must have width * height * 3 values");
    assert_eq!(t.len(), n, "FLIP: test image must have width * height * 3 values");
}

fn ldr_common(r: &[f32], t: &[f32], w: usize, h: usize, opts: &FlipOptions, enc: Encoding) -> FlipMap {
    check_sizes(r, t, w, h);
    let mut maps = vec![vec![0.0f32; w * h]];
    let sums = run_flip(w, h, opts, Pixels::F32(r), &[Pixels::F32(t)], &[enc], Maps::Frame(&mut maps, None));
    let values = maps.remove(0);
    FlipMap { width: w, height: h, values, mean: mean_of(&sums[0], w * h) }
}

/// A map's mean from its row sums ([`run_bands`]): the rows summed in order, so that a mean is the same bits
/// whichever bands and threads made it, and whether or not the map was kept.
fn mean_of(row_sums: &[f64], npix: usize) -> f64 {
    if npix == 0 {
        return 0.0;
    }
    row_sums.iter().sum::<f64>() / npix as f64
}

/// Start/stop exposures from the reference image, as in the HDR-FLIP paper (Sec. 4.2)
/// and the reference code: `x_max` solves `tm(x) = 0.85`; `c_start = log2(x_max / Y_max)`,
/// `c_stop = log2(x_max / Y_median)` (median = element `n/2` of the sorted luminances).
///
/// Where the reference code breaks — a median luminance of 0 (more than half the image black, as a G-buffer's
/// background often is) makes `c_stop` infinite and its exposure count overflow — the median is taken over the
/// pixels with positive luminance instead; a reference with no positive pixel gets the single exposure 0. The
/// range is capped at [`MAX_EXPOSURE_RANGE`] stops.
fn compute_exposures(img: &[f32], tm: ToneMapper) -> (f32, f32) {
    let tc = tm.coefficients();
    let t = 0.85f32;
    let a = tc[0] - t * tc[3];
    let b = tc[1] - t * tc[4];
    let c = tc[2] - t * tc[5];
    let x_max = if a == 0.0 {
        -c / b
    } else {
        let d1 = -0.5 * (b / a);
        let d2 = (d1 * d1 - c / a).sqrt();
        d1 + d2
    };
    let mut lum: Vec<f32> = img.par_chunks_exact(3).map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]).collect();
    if lum.is_empty() {
        return (0.0, 0.0);
    }
    let y_max = lum.par_iter().copied().reduce(|| -1e30f32, |a, b| if a > b { a } else { b });
    if !(y_max > 0.0 && y_max.is_finite()) {
        return (0.0, 0.0);
    }
    let mid = lum.len() / 2;
    let (_, &mut mut y_median, _) = lum.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    if y_median <= 0.0 || !y_median.is_finite() {
        lum.retain(|&y| y > 0.0 && y.is_finite());
        let mid = lum.len() / 2;
        y_median = *lum.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    }
    let start = ((x_max / y_max) as f64).log2() as f32;
    let stop = ((x_max / y_median) as f64).log2() as f32;
    (start, stop.min(start + MAX_EXPOSURE_RANGE))
}

/// The widest exposure range HDR-FLIP sweeps, in stops (f32 spans about 277 stops; real images a few dozen).
pub const MAX_EXPOSURE_RANGE: f32 = 64.0;

/// Number of f32 planes per horizontally filtered row of an image: Y*gY, Cx*gCx, Cz*gCz1, Cz*gCz2 (CSF),
/// Yn*dG, Yn*ddG, Yn*G (features).
const NH: usize = 7;
const HP_Y: usize = 0;
const HP_CX: usize = 1;
const HP_CZ1: usize = 2;
const HP_CZ2: usize = 3;
const HP_DX: usize = 4;
const HP_DDX: usize = 5;
const HP_G: usize = 6;

struct Ctx {
    w: usize,
    h: usize,
    /// CSF filter radius, feature filter radius, max of both.
    rs: usize,
    rf: usize,
    rmax: usize,
    /// Ring size (rows) = 2 * rmax + 2 (two output rows per vertical pass).
    ring: usize,
    sy: Vec<f32>,
    scx: Vec<f32>,
    scz1: Vec<f32>,
    scz2: Vec<f32>,
    fg: Vec<f32>,
    fdg: Vec<f32>,
    fddg: Vec<f32>,
    /// Taps either side of the centre that the Y and Cx filters keep ([`negligible_taps`]: the rest weigh less than
    /// the f32 rounding of their sums).
    ryc: usize,
    /// Per tap: [sy, scx] (the `2 ryc + 1` taps kept), [scz1, scz2] and [fg, fdg, fddg].
    ws_ycx: Vec<[f32; 2]>,
    ws_cz: Vec<[f32; 2]>,
    wf: Vec<[f32; 3]>,
    cmax: f32,
    pccmax: f32,
}

impl Ctx {
    fn new(w: usize, h: usize, ppd: f32) -> Ctx {
        assert!(ppd > 0.0 && ppd.is_finite(), "FLIP: pixels per degree must be positive");
        let pi_sq = PI * PI;

        // CSF (spatial) filters. Radius from the widest Gaussian.
        let mut max_b = GB1[0];
        for &b in GB1.iter().chain(GB2.iter()) {
            max_b = max_b.max(b);
        }
        let rs = (3.0 * (max_b / (2.0 * pi_sq)).sqrt() * ppd).ceil() as usize;
        let gauss = |x2: f32, a: f32, b: f32| a * (PI / b).sqrt() * (-pi_sq * x2 / b).exp();
        let gauss_sqrt = |x2: f32, a: f32, b: f32| (a * (PI / b).sqrt()).sqrt() * (-pi_sq * x2 / b).exp();
        let ns = 2 * rs + 1;
        let dx = 1.0 / ppd;
        let (mut sy, mut scx, mut scz1, mut scz2) = (vec![0.0; ns], vec![0.0; ns], vec![0.0; ns], vec![0.0; ns]);
        let (mut sum_y, mut sum_cx, mut sum_cz1, mut sum_cz2) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for i in 0..ns {
            let ix = (i as i32 - rs as i32) as f32 * dx;
            let ix2 = ix * ix;
            sy[i] = gauss(ix2, GA1[0], GB1[0]);
            scx[i] = gauss(ix2, GA1[1], GB1[1]);
            scz1[i] = gauss_sqrt(ix2, GA1[2], GB1[2]);
            scz2[i] = gauss_sqrt(ix2, GA2[2], GB2[2]);
            sum_y += sy[i];
            sum_cx += scx[i];
            sum_cz1 += scz1[i];
            sum_cz2 += scz2[i];
        }
        // Y and Cx: 1D weights sum to 1. Cz: the 2D filter g1(x)g1(y) + g2(x)g2(y) sums to 1.
        let (ny, ncx) = (1.0 / sum_y, 1.0 / sum_cx);
        let ncz = 1.0 / (sum_cz1 * sum_cz1 + sum_cz2 * sum_cz2).sqrt();
        sy.iter_mut().for_each(|v| *v *= ny);
        scx.iter_mut().for_each(|v| *v *= ncx);
        scz1.iter_mut().for_each(|v| *v *= ncz);
        scz2.iter_mut().for_each(|v| *v *= ncz);

        // Feature filters: Gaussian and its 1st/2nd derivatives, sd = gw/2 degrees.
        let sd = 0.5 * GW * ppd;
        let rf = (3.0 * sd).ceil() as usize;
        let nf = 2 * rf + 1;
        let (mut fg, mut fdg, mut fddg) = (vec![0.0f32; nf], vec![0.0f32; nf], vec![0.0f32; nf]);
        let (mut g_sum, mut dg_neg, mut dg_pos, mut ddg_neg, mut ddg_pos) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for i in 0..nf {
            let x = (i as i32 - rf as i32) as f32;
            let g = (-(x * x) / (2.0 * sd * sd)).exp();
            g_sum += g;
            let dg = -x * g;
            if dg > 0.0 {
                dg_pos += dg;
            } else {
                dg_neg -= dg;
            }
            let ddg = (x * x / (sd * sd) - 1.0) * g;
            if ddg > 0.0 {
                ddg_pos += ddg;
            } else {
                ddg_neg -= ddg;
            }
            fg[i] = g;
            fdg[i] = dg;
            fddg[i] = ddg;
        }
        // Gaussian sums to 1; positive / negative lobes of the derivatives sum to +1 / -1.
        for i in 0..nf {
            fg[i] /= g_sum;
            fdg[i] /= if fdg[i] > 0.0 { dg_pos } else { dg_neg };
            fddg[i] /= if fddg[i] > 0.0 { ddg_pos } else { ddg_neg };
        }

        let cmax = max_color_distance();
        let rmax = rs.max(rf);
        let ryc = rs - negligible_taps(&sy).min(negligible_taps(&scx));
        let ws_ycx = (rs - ryc..=rs + ryc).map(|i| [sy[i], scx[i]]).collect();
        let ws_cz = (0..ns).map(|i| [scz1[i], scz2[i]]).collect();
        let wf = (0..nf).map(|i| [fg[i], fdg[i], fddg[i]]).collect();
        Ctx {
            w,
            h,
            ryc,
            ws_ycx,
            ws_cz,
            wf,
            rs,
            rf,
            rmax,
            ring: 2 * rmax + 2,
            sy,
            scx,
            scz1,
            scz2,
            fg,
            fdg,
            fddg,
            cmax,
            pccmax: GPC * cmax,
        }
    }
}

/// How many taps at each end of the symmetric filter `w` can be left out: those below 2⁻²⁴ of the centre tap. Summed
/// over a window they change a filtered value by less than its f32 rounding. The CSF's luminance and red-green
/// filters are about a pixel wide at 67 pixels per degree but span the blue-yellow filter's 21 taps: 8 of them are
/// dropped (the filters' multiply-adds per pixel 301 → 269). NVIDIA's code sums every tap.
fn negligible_taps(w: &[f32]) -> usize {
    let centre = w[w.len() / 2];
    w.iter().take(w.len() / 2).take_while(|&&v| v < centre * f32::EPSILON / 2.0).count()
}

/// `cmax`: HyAB distance (after Hunt adjustment, raised to gqc) between pure green and blue.
fn max_color_distance() -> f32 {
    let lab = |rgb: [f32; 3]| {
        let xyz = [0, 1, 2].map(|r| RGB2XYZ[r][0] * rgb[0] + RGB2XYZ[r][1] * rgb[1] + RGB2XYZ[r][2] * rgb[2]);
        let f = [0, 1, 2].map(|i| {
            let v = xyz[i] * INV_ILL[i];
            if v > LAB_DELTA_CUBE {
                v.powf(ONE_THIRD)
            } else {
                LAB_FACTOR * v + LAB_TERM
            }
        });
        let l = 116.0 * f[1] - 16.0;
        let a = 500.0 * (f[0] - f[1]);
        let b = 200.0 * (f[1] - f[2]);
        [l, 0.01 * l * a, 0.01 * l * b]
    };
    let g = lab([0.0, 1.0, 0.0]);
    let b = lab([0.0, 0.0, 1.0]);
    let hyab = (g[0] - b[0]).abs() + ((g[1] - b[1]) * (g[1] - b[1]) + (g[2] - b[2]) * (g[2] - b[2])).sqrt();
    hyab.powf(GQC)
}

/// HDR-FLIP's merge of one exposure's row `e` into the running maximum `out`, writing `tag` into the exposure map
/// `em` where the maximum grew.
#[inline(always)]
fn keep_max(out: &mut [f32], em: &mut [f32], e: &[f32], tag: f32) {
    for ((o, x), &v) in out.iter_mut().zip(em.iter_mut()).zip(e) {
        let grow = v > *o;
        *o = if grow { v } else { *o };
        *x = if grow { tag } else { *x };
    }
}

/// The instruction set the band kernels run on: the CPU's, capped by `GBUF_ISA` ([`Isa::detect`]); in tests, also
/// by the level a test forces.
#[inline]
fn band_isa() -> Isa {
    let isa = Isa::detect();
    #[cfg(test)]
    if let Some(cap) = tests::forced() {
        return isa.min(cap);
    }
    isa
}

// ---------------------------------------------------------------------------
// Several test images against one reference
// ---------------------------------------------------------------------------

/// Per-pixel values one image contributes to FLIP after filtering: Hunt-adjusted L, a, b, and the edge and point
/// feature magnitudes. Planes of a band, `FEATURES` floats per pixel, plane-major per tile row.
const FEATURES: usize = 5;

/// LDR-FLIP of several **sRGB-encoded** test images against one reference ([`ldr_flip`] for each, bit for bit),
/// filtering the reference once instead of once per test.
pub fn ldr_flip_many(
    reference_srgb: &[f32],
    tests: &[&[f32]],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> Vec<FlipMap> {
    for t in tests {
        check_sizes(reference_srgb, t, width, height);
    }
    let tests: Vec<Pixels<'_>> = tests.iter().map(|t| Pixels::F32(t)).collect();
    ldr_many(Pixels::F32(reference_srgb), &tests, width, height, opts)
}

/// [`ldr_flip_many`] on 8-bit sRGB images (interleaved RGB bytes, e.g. a tone-mapped display image): the numbers of
/// `ldr_flip_many` on the images as `f32(byte) / 255`, bit for bit, without those copies (4× the bytes).
pub fn ldr_flip_many_srgb8(
    reference: &[u8],
    tests: &[&[u8]],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> Vec<FlipMap> {
    let (reference, tests) = srgb8_pixels(reference, tests, width, height);
    ldr_many(reference, &tests, width, height, opts)
}

/// 8-bit sRGB images as FLIP reads them, their sizes checked (`width × height × 3` bytes each).
fn srgb8_pixels<'a>(
    reference: &'a [u8],
    tests: &[&'a [u8]],
    width: usize,
    height: usize,
) -> (Pixels<'a>, Vec<Pixels<'a>>) {
    let n = width.checked_mul(height).and_then(|n| n.checked_mul(3)).expect("FLIP: image size overflows usize");
    assert_eq!(reference.len(), n, "FLIP: reference image must have width * height * 3 values");
    for t in tests {
        assert_eq!(t.len(), n, "FLIP: test image must have width * height * 3 values");
    }
    (Pixels::Srgb8(reference), tests.iter().map(|t| Pixels::Srgb8(t)).collect())
}

/// The LDR-FLIP maps of `tests` against `reference` (sizes checked by the caller), the reference filtered once.
fn ldr_many(
    reference: Pixels<'_>,
    tests: &[Pixels<'_>],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> Vec<FlipMap> {
    let npix = width * height;
    let mut maps: Vec<Vec<f32>> = tests.iter().map(|_| vec![0.0f32; npix]).collect();
    let sums = run_flip(width, height, opts, reference, tests, &[Encoding::Srgb], Maps::Frame(&mut maps, None));
    maps.into_iter()
        .zip(sums)
        .map(|(values, sums)| FlipMap { width, height, values, mean: mean_of(&sums, npix) })
        .collect()
}

/// The mean LDR-FLIP of each 8-bit sRGB test against `reference` ([`ldr_flip_many_srgb8`]'s means, bit for bit)
/// without the maps: each band's errors are summed and dropped.
#[must_use]
pub fn ldr_flip_means_srgb8(
    reference: &[u8],
    tests: &[&[u8]],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> Vec<f64> {
    let (reference, tests) = srgb8_pixels(reference, tests, width, height);
    let sums = run_flip(width, height, opts, reference, &tests, &[Encoding::Srgb], Maps::SumsOnly);
    sums.iter().map(|s| mean_of(s, width * height)).collect()
}

/// An image's interleaved RGB values as FLIP reads them: floats, or sRGB bytes read as `byte / 255`.
#[derive(Clone, Copy)]
enum Pixels<'a> {
    F32(&'a [f32]),
    Srgb8(&'a [u8]),
}

impl Pixels<'_> {
    /// Whether pixels `from..to` are the same bits in both images (images of different kinds never are).
    fn row_eq(&self, other: &Pixels<'_>, from: usize, to: usize) -> bool {
        match (self, other) {
            (Pixels::F32(a), Pixels::F32(b)) => {
                bytemuck::cast_slice::<f32, u8>(&a[3 * from..3 * to])
                    == bytemuck::cast_slice::<f32, u8>(&b[3 * from..3 * to])
            }
            (Pixels::Srgb8(a), Pixels::Srgb8(b)) => a[3 * from..3 * to] == b[3 * from..3 * to],
            _ => false,
        }
    }
}

/// Whether band passes skip the windows a test shares with a donor ([`Same`]); off only in the test that checks
/// skipping changes no bit.
static SKIP_EQUAL: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

/// HDR-FLIP of several linear test images against one reference with the reference defaults ([`hdr_flip`] for
/// each, bit for bit): the exposures come from the reference, and at each exposure the reference is filtered once
/// instead of once per test.
pub fn hdr_flip_many(
    reference_linear: &[f32],
    tests: &[&[f32]],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> Vec<HdrFlip> {
    let (exposures, start, stop, tm) = hdr_range(reference_linear, tests, width, height);
    let npix = width * height;
    let mut maxes: Vec<Vec<f32>> = tests.iter().map(|_| vec![0.0f32; npix]).collect();
    let mut tags: Vec<Vec<f32>> = tests.iter().map(|_| vec![0.0f32; npix]).collect();
    let tests: Vec<Pixels<'_>> = tests.iter().map(|t| Pixels::F32(t)).collect();
    let encs = hdr_encodings(&exposures, tm);
    let r = Pixels::F32(reference_linear);
    let sums = run_flip(width, height, opts, r, &tests, &encs, Maps::Frame(&mut maxes, Some(&mut tags)));
    maxes
        .into_iter()
        .zip(tags)
        .zip(sums)
        .map(|((values, exposure_map), sums)| HdrFlip {
            map: FlipMap { width, height, values, mean: mean_of(&sums, npix) },
            exposures: exposures.clone(),
            start_exposure: start,
            stop_exposure: stop,
            tone_mapper: tm,
            exposure_map,
        })
        .collect()
}

/// The mean HDR-FLIP of each test ([`hdr_flip_many`]'s `map.mean`, bit for bit) without its maps: each band's
/// maxima over the exposures are summed and dropped, so nothing per test outlives its band.
#[must_use]
pub fn hdr_flip_means(
    reference_linear: &[f32],
    tests: &[&[f32]],
    width: usize,
    height: usize,
    opts: &FlipOptions,
) -> Vec<f64> {
    let (exposures, .., tm) = hdr_range(reference_linear, tests, width, height);
    let tests: Vec<Pixels<'_>> = tests.iter().map(|t| Pixels::F32(t)).collect();
    let encs = hdr_encodings(&exposures, tm);
    let sums = run_flip(width, height, opts, Pixels::F32(reference_linear), &tests, &encs, Maps::SumsOnly);
    sums.iter().map(|s| mean_of(s, width * height)).collect()
}

/// The exposures HDR-FLIP runs against `reference_linear` with the default tone mapper, their range and the tone
/// mapper (the tests' sizes checked).
fn hdr_range(
    reference_linear: &[f32],
    tests: &[&[f32]],
    width: usize,
    height: usize,
) -> (Vec<f32>, f32, f32, ToneMapper) {
    for t in tests {
        check_sizes(reference_linear, t, width, height);
    }
    let tm = ToneMapper::default();
    let (start, stop) = compute_exposures(reference_linear, tm);
    let exposures = exposure_list(start, stop, exposure_count(start, stop));
    (exposures, start, stop, tm)
}

/// One encoding per exposure: scaled by `2^e`, then tone mapped by `tm`.
fn hdr_encodings(exposures: &[f32], tm: ToneMapper) -> Vec<Encoding> {
    exposures.iter().map(|&e| Encoding::Hdr { scale: 2.0f32.powf(e), tm }).collect()
}

/// Where [`run_bands`] puts each test's errors besides its row sums: whole-frame maps (with several encodings, the
/// per-pixel maximum over them, and with the second vector the exposure map: the index of the encoding that gave
/// it, over their count less one), or nowhere.
enum Maps<'a> {
    Frame(&'a mut [Vec<f32>], Option<&'a mut [Vec<f32>]>),
    SumsOnly,
}

/// One test's rows of a band: its errors', and its exposure map's when kept.
type BandRows<'a> = (&'a mut [f32], Option<&'a mut [f32]>);

/// [`run_bands`] on a `w × h` frame, when there is anything to compare: each test's row sums (zeros otherwise).
fn run_flip(
    w: usize,
    h: usize,
    opts: &FlipOptions,
    r: Pixels<'_>,
    tests: &[Pixels<'_>],
    encs: &[Encoding],
    maps: Maps<'_>,
) -> Vec<Vec<f64>> {
    if w * h == 0 || tests.is_empty() {
        return tests.iter().map(|_| vec![0.0; h]).collect();
    }
    run_bands(&Ctx::new(w, h, opts.pixels_per_degree), r, tests, encs, maps)
}

/// Every FLIP evaluation, band-parallel and band-major: per band, each encoding (LDR-FLIP's one, HDR-FLIP's
/// exposures) in turn — the reference's features once, then each test against them, keeping the per-pixel maximum
/// over the encodings — and at the end each test's row sums, the band's errors then being dropped unless `maps`
/// keeps them. A test's pass skips the windows it shares with the reference or an earlier test ([`Same`], found
/// once per band for every encoding). A single pair is one test.
fn run_bands(ctx: &Ctx, r: Pixels<'_>, tests: &[Pixels<'_>], encs: &[Encoding], maps: Maps<'_>) -> Vec<Vec<f64>> {
    let (w, h) = (ctx.w, ctx.h);
    let threads = rayon::current_num_threads().max(1);
    let min_band = (4 * ctx.rmax).max(16);
    // Eight bands per thread: a band's cost varies with what it shares with the reference (a sky band skips most
    // of its work), and with three the last band of a batch ran alone (room 1080p × 4 report, FLIP stage 6.1–7.0 →
    // 5.6–6.4 s, two runs each, Zen 4 AVX-512, 2 threads); each band's halo of 2·rmax filtered rows is the price.
    let nbands = (threads * 8).min(h.div_ceil(min_band)).max(1);
    let band_h = h.div_ceil(nbands).next_multiple_of(2);
    let max = encs.len() > 1 || matches!(encs.first(), Some(Encoding::Hdr { .. }));
    let mut sums: Vec<Vec<f64>> = tests.iter().map(|_| vec![0.0; h]).collect();
    // Per band, per test: its row sums, and its rows of the kept maps.
    type TestBand<'a> = (&'a mut [f64], Option<BandRows<'a>>);
    let mut bands: Vec<Vec<TestBand<'_>>> = (0..h.div_ceil(band_h)).map(|_| Vec::new()).collect();
    let (mut values, mut tags) = match maps {
        Maps::Frame(v, t) => (Some(v.iter_mut()), t.map(|t| t.iter_mut())),
        Maps::SumsOnly => (None, None),
    };
    for s in &mut sums {
        let mut v = values.as_mut().map(|it| it.next().expect("a map per test").chunks_mut(band_h * w));
        let mut t = tags.as_mut().map(|it| it.next().expect("an exposure map per test").chunks_mut(band_h * w));
        for (b, rows) in s.chunks_mut(band_h).enumerate() {
            let map = v.as_mut().map(|c| (c.next().expect("a band"), t.as_mut().map(|c| c.next().expect("a band"))));
            bands[b].push((rows, map));
        }
    }
    bands.into_par_iter().enumerate().for_each(|(b, mut outs)| {
        let y0 = b * band_h;
        let rows = outs[0].0.len();
        // Taken, not borrowed: a nested call on this thread would find an empty buffer, never a held borrow.
        let mut buffer = BAND_FEATURES.take();
        // Every value is written by the reference's pass before the tests read it: no zeroing needed.
        buffer.resize(FEATURES * rows * w, 0.0);
        let feats = &mut buffer[..FEATURES * rows * w];
        // The errors of tests whose maps are not kept: band-sized, from 0 (the maxima start there).
        let mut local = BAND_ERRORS.take();
        local.clear();
        if outs[0].1.is_none() {
            local.resize(tests.len() * rows * w, 0.0);
        }
        let mut local_rows = local.chunks_mut(rows * w);
        let mut errs: Vec<BandRows<'_>> = outs
            .iter_mut()
            .map(|(_, m)| m.take().unwrap_or_else(|| (local_rows.next().expect("a band per test"), None)))
            .collect();
        let mut masks: Vec<Vec<u64>> = tests.iter().map(|_| Vec::new()).collect();
        let same: Vec<Same<'_>> =
            masks.iter_mut().enumerate().map(|(k, m)| Same::new(ctx, r, &tests[..=k], y0, rows, m)).collect();
        for (i, &enc) in encs.iter().enumerate() {
            band_features(ctx, r, enc, y0, rows, &mut Sink::Store(feats));
            let tag = if encs.len() > 1 { i as f32 / (encs.len() - 1) as f32 } else { 0.0 };
            for k in 0..tests.len() {
                let (done, rest) = errs.split_at_mut(k);
                let (out, em) = &mut rest[0];
                let keep = match em.as_deref_mut() {
                    Some(e) => Keep::Tagged(e, tag),
                    None if max => Keep::Max,
                    None => Keep::Store,
                };
                let mut sink = Sink::Compare { reference: feats, out, keep, same: same[k], donors: done };
                band_features(ctx, tests[k], enc, y0, rows, &mut sink);
            }
        }
        for ((row_sums, _), (errors, _)) in outs.iter_mut().zip(&errs) {
            for (s, row) in row_sums.iter_mut().zip(errors.chunks_exact(w)) {
                *s = row.iter().map(|&x| f64::from(x)).sum();
            }
        }
        drop(errs);
        BAND_ERRORS.set(local);
        BAND_FEATURES.set(buffer);
    });
    sums
}

thread_local! {
    /// A band's errors per test where the maps are not kept ([`Maps::SumsOnly`]), kept like [`BAND_FEATURES`].
    static BAND_ERRORS: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
    /// A band's reference features, kept by each thread from band to band and from call to call. A fresh buffer per
    /// band (about 7 MB at 1080p) was a fresh mapping every time (large blocks are mapped, `base::alloc`): the
    /// kernel zeroing its pages took 12% of an HDR-FLIP (a 1080p pair, 13 exposures, Zen 4).
    static BAND_FEATURES: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// What a test's band pass does with each error row: store it, keep the running per-pixel maximum, or keep the
/// maximum and tag where it grew (HDR-FLIP's exposure map).
enum Keep<'a> {
    Store,
    Max,
    Tagged(&'a mut [f32], f32),
}

/// What a one-image band pass does with each tile row's features: store them (the reference's), or compare them
/// with the stored reference features into an error map (a test's), optionally keeping the per-pixel maximum and
/// tagging where it grew (HDR-FLIP's exposures). Buffers are band-sized, `FEATURES` planes of `rows × w`.
enum Sink<'a> {
    Store(&'a mut [f32]),
    Compare { reference: &'a [f32], out: &'a mut [f32], keep: Keep<'a>, same: Same<'a>, donors: &'a [BandRows<'a>] },
}

impl Sink<'_> {
    /// Hands output rows `ry..ry + n` (band rows) of the tile at `x0` over without filtering, when their whole
    /// window is equal in the test and in a donor ([`Same`]); whether it did. Equal inputs give equal features, bit
    /// for bit (each output is the same sums of the same values), so a test equal to the reference there errs by
    /// exactly 0 (`lab_error` and `flip_error` of equal features are 0), and a test equal to an earlier test of the
    /// same call errs as that test did: its rows (the running maximum and exposure map too, as every exposure
    /// skips the same pixels) are copied.
    fn skip(&mut self, ctx: &Ctx, x0: usize, ry: usize, n: usize) -> bool {
        let Sink::Compare { out, keep, same, donors, .. } = self else { return false };
        let Some(donor) = same.donor(x0 / TW, ry, n) else { return false };
        #[cfg(test)]
        tests::SKIPPED.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        let w = ctx.w;
        let cols = (w - x0).min(TW);
        for r in ry..ry + n {
            let at = r * w + x0..r * w + x0 + cols;
            match (donor, &mut *keep) {
                // Equal to the reference: an error of 0, which no running maximum (≥ 0) keeps.
                (0, Keep::Store) => out[at].fill(0.0),
                (0, Keep::Max | Keep::Tagged(..)) => {}
                (j, keep) => {
                    let (rows, tags) = &donors[j - 1];
                    out[at.clone()].copy_from_slice(&rows[at.clone()]);
                    if let (Keep::Tagged(em, _), Some(tags)) = (keep, tags) {
                        em[at.clone()].copy_from_slice(&tags[at]);
                    }
                }
            }
        }
        true
    }
}

/// Where a test's band can skip filtering: per column tile and input row, a bit per donor whose pixels there equal
/// the test's, bit for bit (bit 0 the reference, bit `j + 1` the call's test `j`, the first 63). An output row's
/// window — the rows and columns its filters read — is equal where every row of it has the donor's bit. A sky, a
/// background, a region where two detectors shade alike: the report's tests share most of a frame with the
/// reference or with each other.
#[derive(Clone, Copy)]
struct Same<'a> {
    /// Bits per (tile, row of `rows_lo..=rows_hi`), tile-major.
    masks: &'a [u64],
    y0: usize,
    rows_lo: usize,
    rows_hi: usize,
    rmax: usize,
    h: usize,
}

impl<'a> Same<'a> {
    /// The masks of the last of `tests` (against the reference `r` and the tests before it) over the rows the band
    /// `y0..y0 + rows` reads, into `buffer`.
    fn new(ctx: &Ctx, r: Pixels<'_>, tests: &[Pixels<'_>], y0: usize, rows: usize, buffer: &'a mut Vec<u64>) -> Self {
        let (w, h, rmax) = (ctx.w, ctx.h, ctx.rmax);
        let rows_lo = y0.saturating_sub(rmax);
        let rows_hi = (y0 + rows + rmax).min(h - 1);
        let n = rows_hi + 1 - rows_lo;
        let tiles = w.div_ceil(TW);
        buffer.clear();
        buffer.resize(tiles * n, 0);
        let (test, earlier) = tests.split_last().expect("a test");
        if !SKIP_EQUAL.load(std::sync::atomic::Ordering::Relaxed) {
            return Same { masks: buffer, y0, rows_lo, rows_hi, rmax, h };
        }
        for t in 0..tiles {
            let x0 = t * TW;
            let lo = x0.saturating_sub(rmax);
            let hi = (x0 + TW + rmax).min(w);
            for y in rows_lo..=rows_hi {
                let mut bits = u64::from(test.row_eq(&r, y * w + lo, y * w + hi));
                for (j, e) in earlier.iter().take(63).enumerate() {
                    bits |= u64::from(test.row_eq(e, y * w + lo, y * w + hi)) << (j + 1);
                }
                buffer[t * n + y - rows_lo] = bits;
            }
        }
        Same { masks: buffer, y0, rows_lo, rows_hi, rmax, h }
    }

    /// The donor (0: the reference, `j + 1`: test `j`) whose pixels equal the test's over the whole window of output
    /// rows `ry..ry + n` of the band (from its first row) in column tile `tile`, if one does.
    fn donor(&self, tile: usize, ry: usize, n: usize) -> Option<usize> {
        let y = self.y0 + ry;
        let lo = y.saturating_sub(self.rmax);
        let hi = (y + n - 1 + self.rmax).min(self.h - 1);
        let rows = self.rows_hi + 1 - self.rows_lo;
        let masks = &self.masks[tile * rows..(tile + 1) * rows];
        let all = masks[lo - self.rows_lo..=hi - self.rows_lo].iter().fold(u64::MAX, |a, &m| a & m);
        (all != 0).then(|| all.trailing_zeros() as usize)
    }
}

/// Hands tile row `ry` (columns `x0..x0 + n`) of the features `f` to `sink`.
#[inline(always)]
fn sink_row(ctx: &Ctx, sink: &mut Sink<'_>, rows: usize, ry: usize, x0: usize, f: &[[f32; TW]; FEATURES]) {
    let w = ctx.w;
    let n = (w - x0).min(TW);
    let at = |p: usize| (p * rows + ry) * w + x0;
    match sink {
        Sink::Store(feats) => {
            for (p, plane) in f.iter().enumerate() {
                feats[at(p)..at(p) + n].copy_from_slice(&plane[..n]);
            }
        }
        Sink::Compare { reference, out, keep, .. } => {
            let (cmax, pccmax) = (ctx.cmax, ctx.pccmax);
            let r = |p: usize| &reference[at(p)..at(p) + n];
            let (lr, ar, br, er, pr) = (r(0), r(1), r(2), r(3), r(4));
            let mut e = [0.0f32; TW];
            for i in 0..n {
                let cd = lab_error(lr[i], ar[i], br[i], f[0][i], f[1][i], f[2][i], cmax, pccmax);
                e[i] = flip_error(cd, er[i], pr[i], f[3][i], f[4][i]);
            }
            let orow = &mut out[ry * w + x0..ry * w + x0 + n];
            match keep {
                Keep::Store => orow.copy_from_slice(&e[..n]),
                Keep::Max => orow.iter_mut().zip(&e[..n]).for_each(|(o, &v)| *o = if v > *o { v } else { *o }),
                Keep::Tagged(em, tag) => keep_max(orow, &mut em[ry * w + x0..ry * w + x0 + n], &e[..n], *tag),
            }
        }
    }
}

/// The features of rows `y0..y0 + rows` of one image, handed to `sink` tile row by tile row, compiled for
/// [`band_isa`]'s level as [`band`].
fn band_features(ctx: &Ctx, img: Pixels<'_>, enc: Encoding, y0: usize, rows: usize, sink: &mut Sink<'_>) {
    /// [`band_features_impl`] under [`crate::base::isa::run`].
    struct Features<'a, 'b, 'c> {
        ctx: &'a Ctx,
        img: Pixels<'a>,
        enc: Encoding,
        y0: usize,
        rows: usize,
        sink: &'b mut Sink<'c>,
    }
    impl crate::base::isa::Kernel for Features<'_, '_, '_> {
        type Output = ();
        #[inline(always)]
        fn run(self, _: Isa) {
            band_features_impl(self.ctx, self.img, self.enc, self.y0, self.rows, self.sink);
        }
    }
    crate::base::isa::run(band_isa(), Features { ctx, img, enc, y0, rows, sink });
}

/// One image's pass over a band: the ring of horizontally filtered rows (7 planes), the vertical sums, then per pixel
/// the Lab colour and feature magnitudes.
#[inline(always)]
fn band_features_impl(ctx: &Ctx, img: Pixels<'_>, enc: Encoding, y0: usize, rows: usize, sink: &mut Sink<'_>) {
    let (w, h) = (ctx.w, ctx.h);
    // A ring row is its NH planes and one cache line more: at NH·TW floats (7 KiB) apart, the rows a vertical sum
    // reads fell into 4 of the L1 cache's 64 sets (88 lines for 32 ways: each load missed to L2); a stride of an
    // odd number of lines spreads them over every set.
    let row_len = NH * TW + 16;
    let mut ring = vec![0.0f32; ctx.ring * row_len];
    let mut pad = vec![0.0f32; 4 * (TW + 2 * ctx.rmax)];
    let mut rgb = vec![0.0f32; 3 * (TW + 2 * ctx.rmax)];
    let mut offs_s = vec![0usize; 2 * ctx.rs + 2];
    let mut offs_f = vec![0usize; 2 * ctx.rf + 2];
    let mut acc = Box::new([[[0.0f32; TW]; 8]; 2]);
    let mut feats = Box::new([[0.0f32; TW]; FEATURES]);
    let mut x0 = 0;
    while x0 < w {
        let tw = TW.min(w - x0);
        let tws = tw.next_multiple_of(COLS);
        let mut next = y0.saturating_sub(ctx.rmax);
        let mut y = y0;
        while y < y0 + rows {
            if sink.skip(ctx, x0, y - y0, 2.min(y0 + rows - y)) {
                y += 2;
                continue;
            }
            // The rows this pair reads, from the first not yet in the ring (rows skipped above never entered it).
            next = next.max(y.saturating_sub(ctx.rmax));
            let hi = (y + 1 + ctx.rmax).min(h - 1);
            while next <= hi {
                let slot = next % ctx.ring;
                let dst = &mut ring[slot * row_len..(slot + 1) * row_len];
                hrow(ctx, &[img], enc, next, x0, tw, tws, &mut pad, &mut rgb, dst);
                next += 1;
            }
            for (i, o) in offs_s.iter_mut().enumerate() {
                *o = ((y + i).saturating_sub(ctx.rs).min(h - 1) % ctx.ring) * row_len;
            }
            for (i, o) in offs_f.iter_mut().enumerate() {
                *o = ((y + i).saturating_sub(ctx.rf).min(h - 1) % ctx.ring) * row_len;
            }
            assert!(offs_s.iter().chain(&offs_f).all(|&o| o + row_len <= ring.len()));
            let offs_ycx = &offs_s[ctx.rs - ctx.ryc..ctx.rs + ctx.ryc + 2];
            // acc[row][plane]: Y, Cx, Cz1, Cz2, dx, ddx, dy, ddy.
            let mut c = 0;
            while c < tws {
                // SAFETY: c < tws ≤ TW in steps of LANES (tws a multiple of COLS, itself of LANES); every offset
                // + row_len (≥ NH·TW, and every plane here is < NH) ≤ ring.len(), asserted above.
                let (ayc, byc) = unsafe { vsum2(&ring, offs_ycx, c, [HP_Y, HP_CX], &ctx.ws_ycx, [0, 1]) };
                // SAFETY: as above.
                let (az, bz) = unsafe { vsum2(&ring, &offs_s, c, [HP_CZ1, HP_CZ2], &ctx.ws_cz, [0, 1]) };
                let (a, b) = ([ayc[0], ayc[1], az[0], az[1]], [byc[0], byc[1], bz[0], bz[1]]);
                // SAFETY: as above.
                let (fa, fb) = unsafe { vsum2(&ring, &offs_f, c, [HP_DX, HP_DDX, HP_G, HP_G], &ctx.wf, [0, 0, 1, 2]) };
                for k in 0..4 {
                    acc[0][k][c..c + LANES].copy_from_slice(&a[k].0);
                    acc[1][k][c..c + LANES].copy_from_slice(&b[k].0);
                    acc[0][4 + k][c..c + LANES].copy_from_slice(&fa[k].0);
                    acc[1][4 + k][c..c + LANES].copy_from_slice(&fb[k].0);
                }
                c += LANES;
            }
            for dy in 0..2.min(y0 + rows - y) {
                let [sy, scx, sz1, sz2, dx, ddx, dyy, ddy] = &acc[dy];
                let [fl, fa, fb, fe, fp] = &mut *feats;
                // `tws <= TW` (a tile is at most TW columns), said so that the loop has no bounds checks and runs
                // in vector lanes: without it the Lab conversion ran one pixel at a time (scalar instructions were
                // 17% of this pass in `perf`, 6% after; 4 tests against one 1080p reference 216 → 199 ms, Xeon).
                for i in 0..tws.min(TW) {
                    let (l, a, b) = ycxcz_to_lab_hunt(sy[i], scx[i], sz1[i] + sz2[i]);
                    fl[i] = l;
                    fa[i] = a;
                    fb[i] = b;
                    fe[i] = (dx[i] * dx[i] + dyy[i] * dyy[i]).sqrt();
                    fp[i] = (ddx[i] * ddx[i] + ddy[i] * ddy[i]).sqrt();
                }
                sink_row(ctx, sink, rows, y + dy - y0, x0, &feats);
            }
            y += 2;
        }
        x0 += tw;
    }
}

/// Column tile width: a tile's ring of horizontally filtered rows
/// (`(2 rmax + 1) * NH * TW` floats, ~150 KB at 67 ppd) stays in L2.
const TW: usize = 256;
/// SIMD-friendly lane block of the inner loops.
const LANES: usize = 8;
/// Tile columns are computed in multiples of this (see `conv_rows`).
const COLS: usize = 4 * LANES;

/// Converts columns `[x0 - rmax, x0 + tws + rmax)` (clamped to the image) of row `y`
/// of the images to YCxCz and filters them horizontally into `out` (`NH` planes per image of stride `TW`, `tws`
/// columns each).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn hrow(
    ctx: &Ctx,
    imgs: &[Pixels<'_>],
    enc: Encoding,
    y: usize,
    x0: usize,
    tw: usize,
    tws: usize,
    pad: &mut [f32],
    rgb: &mut [f32],
    out: &mut [f32],
) {
    let w = ctx.w;
    let rp = ctx.rmax;
    let pw = tws + 2 * rp; // padded plane width
                           // Source columns actually present, and where they land in the padded planes.
    let lo = x0.saturating_sub(rp);
    let hi = (x0 + tw + rp).min(w);
    let n = hi - lo;
    let lpad = rp - (x0 - lo);
    for (img, src) in imgs.iter().enumerate() {
        let (rr, rest) = rgb[..3 * n].split_at_mut(n);
        let (gg, bb) = rest.split_at_mut(n);
        match src {
            Pixels::F32(src) => {
                let row = &src[(y * w + lo) * 3..(y * w + hi) * 3];
                // The row two below, which this band's next pass reads: a short stream the hardware prefetcher misses
                // (the deinterleave below waited on memory for 6% of an HDR-FLIP, Zen 4).
                crate::base::memory::prefetch(
                    src.as_ptr().cast(),
                    ((y + 2) * w + lo) * 12,
                    ((y + 2) * w + hi) * 12,
                    true,
                );
                for (((p, r0), g0), b0) in row.chunks_exact(3).zip(rr.iter_mut()).zip(gg.iter_mut()).zip(bb.iter_mut())
                {
                    *r0 = p[0];
                    *g0 = p[1];
                    *b0 = p[2];
                }
            }
            Pixels::Srgb8(src) => {
                let row = &src[(y * w + lo) * 3..(y * w + hi) * 3];
                crate::base::memory::prefetch(src.as_ptr(), ((y + 2) * w + lo) * 3, ((y + 2) * w + hi) * 3, true);
                for (((p, r0), g0), b0) in row.chunks_exact(3).zip(rr.iter_mut()).zip(gg.iter_mut()).zip(bb.iter_mut())
                {
                    *r0 = f32::from(p[0]) / 255.0;
                    *g0 = f32::from(p[1]) / 255.0;
                    *b0 = f32::from(p[2]) / 255.0;
                }
            }
        }
        match enc {
            Encoding::Srgb => {
                for ch in [&mut *rr, &mut *gg, &mut *bb] {
                    for v in ch.iter_mut() {
                        *v = clamp01(srgb_decode_fast(*v));
                    }
                }
            }
            Encoding::Linear => {
                for ch in [&mut *rr, &mut *gg, &mut *bb] {
                    for v in ch.iter_mut() {
                        *v = clamp01(*v);
                    }
                }
            }
            Encoding::Hdr { scale, tm: ToneMapper::Reinhard } => {
                for ((r0, g0), b0) in rr.iter_mut().zip(gg.iter_mut()).zip(bb.iter_mut()) {
                    let (r1, g1, b1) = (*r0 * scale, *g0 * scale, *b0 * scale);
                    let lum = 0.2126 * r1 + 0.7152 * g1 + 0.0722 * b1;
                    let f = 1.0 / (1.0 + lum);
                    *r0 = clamp01(r1 * f);
                    *g0 = clamp01(g1 * f);
                    *b0 = clamp01(b1 * f);
                }
            }
            Encoding::Hdr { scale, tm } => {
                let c = tm.coefficients();
                for ch in [&mut *rr, &mut *gg, &mut *bb] {
                    for v in ch.iter_mut() {
                        let x = *v * scale;
                        let x2 = x * x;
                        *v = clamp01((x2 * c[0] + x * c[1] + c[2]) / (x2 * c[3] + x * c[4] + c[5]));
                    }
                }
            }
        }
        // Linear RGB -> XYZ -> YCxCz (+ normalised Y for the feature filters), into padded planes.
        {
            let planes = &mut pad[img * 4 * pw..(img + 1) * 4 * pw];
            let (py, rest) = planes.split_at_mut(pw);
            let (pcx, rest) = rest.split_at_mut(pw);
            let (pcz, pyn) = rest.split_at_mut(pw);
            let it = py[lpad..lpad + n]
                .iter_mut()
                .zip(pcx[lpad..lpad + n].iter_mut())
                .zip(pcz[lpad..lpad + n].iter_mut())
                .zip(pyn[lpad..lpad + n].iter_mut())
                .zip(rr.iter().zip(gg.iter()).zip(bb.iter()));
            for ((((oy, ocx), ocz), oyn), ((&cr, &cg), &cb)) in it {
                let x = (RGB2XYZ[0][0] * cr + RGB2XYZ[0][1] * cg + RGB2XYZ[0][2] * cb) * INV_ILL[0];
                let yv = (RGB2XYZ[1][0] * cr + RGB2XYZ[1][1] * cg + RGB2XYZ[1][2] * cb) * INV_ILL[1];
                let z = (RGB2XYZ[2][0] * cr + RGB2XYZ[2][1] * cg + RGB2XYZ[2][2] * cb) * INV_ILL[2];
                let yy = 116.0 * yv - 16.0;
                *oy = yy;
                *ocx = 500.0 * (x - yv);
                *ocz = 200.0 * (yv - z);
                *oyn = yy * (1.0 / 116.0) + 16.0 / 116.0;
            }
        }
        // Clamp-to-edge padding (image borders), also fills the lane-rounding columns.
        for p in 0..4 {
            let plane = &mut pad[(img * 4 + p) * pw..(img * 4 + p + 1) * pw];
            let (first, last) = (plane[lpad], plane[lpad + n - 1]);
            plane[..lpad].fill(first);
            plane[lpad + n..].fill(last);
        }
    }
    let (rs, rf) = (ctx.rs, ctx.rf);
    for img in 0..imgs.len() {
        let plane = |p: usize| &pad[(img * 4 + p) * pw..(img * 4 + p + 1) * pw];
        let o = |q: usize| (img * 7 + q) * TW;
        let (kept, ryc) = (rs - ctx.ryc..=rs + ctx.ryc, ctx.ryc);
        conv_rows::<1, 4>(plane(0), [&ctx.sy[kept.clone()]], rp - ryc, tws, &mut out[o(HP_Y)..o(HP_Y) + tws]);
        conv_rows::<1, 4>(plane(1), [&ctx.scx[kept]], rp - ryc, tws, &mut out[o(HP_CX)..o(HP_CX) + tws]);
        conv_rows::<2, 2>(plane(2), [&ctx.scz1, &ctx.scz2], rp - rs, tws, &mut out[o(HP_CZ1)..o(HP_CZ2) + tws]);
        conv_rows::<3, 2>(plane(3), [&ctx.fdg, &ctx.fddg, &ctx.fg], rp - rf, tws, &mut out[o(HP_DX)..o(HP_G) + tws]);
    }
}

/// Eight f32 lanes; element-wise code on it compiles to one SIMD register op.
#[derive(Clone, Copy)]
struct F8([f32; LANES]);

impl F8 {
    #[inline(always)]
    fn zero() -> F8 {
        F8([0.0; LANES])
    }
    /// Loads `s[i..i + LANES]` without a bounds check, which would keep the filters' inner loops from
    /// vectorising (measured: the checked load made 4 LDR-FLIPs at 1080p ~8–10% slower).
    ///
    /// # Safety
    /// `i + LANES <= s.len()`. Every caller asserts the bounds of its loads once, up front (`conv_rows`, and the
    /// callers of the `unsafe fn vsum2`).
    #[inline(always)]
    unsafe fn load(s: &[f32], i: usize) -> F8 {
        debug_assert!(i + LANES <= s.len());
        // SAFETY: in bounds by this function's contract.
        F8(unsafe { (s.as_ptr().add(i) as *const [f32; LANES]).read_unaligned() })
    }
    /// `self += w * v`, lane-wise (no FMA, like the reference).
    #[inline(always)]
    fn mac(&mut self, w: f32, v: F8) {
        for l in 0..LANES {
            self.0[l] += w * v.0[l];
        }
    }
}

/// `out[j * TW + x] = sum_k wts[j][k] * src[off + x + k]` (x < n) for the N filters `wts`
/// (same length), accumulated in tap order; `n` must be a multiple of `4 * LANES`.
/// Columns are processed `C` lane blocks at a time so that `C * N` independent sums
/// hide the add latency.
#[inline(always)]
fn conv_rows<const N: usize, const C: usize>(src: &[f32], wts: [&[f32]; N], off: usize, n: usize, out: &mut [f32]) {
    let taps = wts[0].len();
    assert!(n.is_multiple_of(C * LANES) && n <= TW && src.len() >= off + n + taps - 1 && out.len() >= (N - 1) * TW + n);
    assert!(wts.iter().all(|w| w.len() == taps));
    let src = &src[off..];
    let mut c = 0;
    while c < n {
        let mut acc = [[F8::zero(); C]; N];
        for k in 0..taps {
            for b in 0..C {
                // SAFETY: c + b·LANES + k + LANES ≤ (n − C·LANES) + (C − 1)·LANES + (taps − 1) + LANES = n + taps − 1
                // ≤ src.len() (asserted above, `src` starting at `off`).
                let v = unsafe { F8::load(src, c + b * LANES + k) };
                for j in 0..N {
                    acc[j][b].mac(wts[j][k], v);
                }
            }
        }
        for j in 0..N {
            for b in 0..C {
                let o = j * TW + c + b * LANES;
                out[o..o + LANES].copy_from_slice(&acc[j][b].0);
            }
        }
        c += C * LANES;
    }
}

/// Vertical pass over `taps + 1` consecutive input rows (`offs[i]`) for two output
/// rows at once: input row i contributes `w[i]` to the first and `w[i - 1]` to the
/// second, so every ring load serves both (taps still accumulate in order).
/// Returns the two rows' sums for the ring planes `planes`, plane j weighted by
/// `wts[tap][wsel[j]]`.
///
/// # Safety
/// `c + LANES <= TW`, and for every offset `o` of `offs` and plane `q` of `planes`, `o + (q + 1) * TW <= ring.len()`.
#[inline(always)]
unsafe fn vsum2<const P: usize, const Q: usize>(
    ring: &[f32],
    offs: &[usize],
    c: usize,
    planes: [usize; P],
    wts: &[[f32; Q]],
    wsel: [usize; P],
) -> ([F8; P], [F8; P]) {
    let taps = wts.len();
    let mut a0 = [F8::zero(); P];
    let mut a1 = [F8::zero(); P];
    // SAFETY: base + q·TW + c + LANES ≤ base + (q + 1)·TW ≤ ring.len() by this function's contract.
    let load = |base: usize| planes.map(|q| unsafe { F8::load(ring, base + q * TW + c) });
    let v = load(offs[0]);
    for j in 0..P {
        a0[j].mac(wts[0][wsel[j]], v[j]);
    }
    for i in 1..taps {
        let v = load(offs[i]);
        let (w0, w1) = (&wts[i], &wts[i - 1]);
        for j in 0..P {
            a0[j].mac(w0[wsel[j]], v[j]);
            a1[j].mac(w1[wsel[j]], v[j]);
        }
    }
    let v = load(offs[taps]);
    for j in 0..P {
        a1[j].mac(wts[taps - 1][wsel[j]], v[j]);
    }
    (a0, a1)
}

/// The FLIP error of a pixel from its colour error `cd` and the edge / point feature magnitudes of the reference
/// (`er`, `pr`) and the test (`et`, `pt`).
#[inline(always)]
fn flip_error(cd: f32, er: f32, pr: f32, et: f32, pt: f32) -> f32 {
    let ed = (er - et).abs();
    let pd = (pr - pt).abs();
    let m = if ed > pd { ed } else { pd };
    let fd = (std::f32::consts::FRAC_1_SQRT_2 * m).sqrt(); // ^gqf, gqf = 0.5
    fast_pow(cd, 1.0 - fd)
}

/// Colour error in [0, 1] between two Hunt-adjusted Lab colours (HyAB, compressed).
#[inline(always)]
fn lab_error(lr: f32, ar: f32, br: f32, lt: f32, at: f32, bt: f32, cmax: f32, pccmax: f32) -> f32 {
    let hyab = (lr - lt).abs() + ((ar - at) * (ar - at) + (br - bt) * (br - bt)).sqrt();
    let c = fast_pow(hyab, GQC);
    if c < pccmax {
        c * (GPT / pccmax)
    } else {
        GPT + ((c - pccmax) / (cmax - pccmax)) * (1.0 - GPT)
    }
}

/// Filtered YCxCz -> XYZ -> linear RGB (clamped to the gamut [0,1]) -> XYZ -> CIELab,
/// with the Hunt adjustment applied to a and b.
#[inline(always)]
fn ycxcz_to_lab_hunt(yc: f32, cx: f32, cz: f32) -> (f32, f32, f32) {
    let yy = (yc + 16.0) / 116.0;
    let x = (yy + cx / 500.0) * ILL[0];
    let y = yy * ILL[1];
    let z = (yy - cz / 200.0) * ILL[2];
    let r = clamp01(XYZ2RGB[0][0] * x + XYZ2RGB[0][1] * y + XYZ2RGB[0][2] * z);
    let g = clamp01(XYZ2RGB[1][0] * x + XYZ2RGB[1][1] * y + XYZ2RGB[1][2] * z);
    let b = clamp01(XYZ2RGB[2][0] * x + XYZ2RGB[2][1] * y + XYZ2RGB[2][2] * z);
    let fx = lab_f((RGB2XYZ[0][0] * r + RGB2XYZ[0][1] * g + RGB2XYZ[0][2] * b) * INV_ILL[0]);
    let fy = lab_f((RGB2XYZ[1][0] * r + RGB2XYZ[1][1] * g + RGB2XYZ[1][2] * b) * INV_ILL[1]);
    let fz = lab_f((RGB2XYZ[2][0] * r + RGB2XYZ[2][1] * g + RGB2XYZ[2][2] * b) * INV_ILL[2]);
    let l = 116.0 * fy - 16.0;
    let a = 500.0 * (fx - fy);
    let bb = 200.0 * (fy - fz);
    (l, 0.01 * l * a, 0.01 * l * bb)
}

#[inline(always)]
fn lab_f(v: f32) -> f32 {
    let lin = LAB_FACTOR * v + LAB_TERM;
    let cbrt = fast_cbrt(v);
    if v > LAB_DELTA_CUBE {
        cbrt
    } else {
        lin
    }
}

#[inline(always)]
fn clamp01(v: f32) -> f32 {
    let v = if v > 0.0 { v } else { 0.0 };
    if v > 1.0 {
        1.0
    } else {
        v
    }
}

/// [`crate::base::picture::srgb_decode`] through the branch-free [`fast_pow`], so the band loops vectorise (the
/// reference's own sRGB; within 2e-6 of the exact one, tested).
#[inline(always)]
fn srgb_decode_fast(s: f32) -> f32 {
    let lin = s / 12.92;
    let p = fast_pow((s + 0.055) / 1.055, 2.4);
    if s <= 0.04045 {
        lin
    } else {
        p
    }
}

// ---------------------------------------------------------------------------
// Branch-free f32 pow (vectorisable): the crate's one log2 / exp2, `base::fastmath`
// ---------------------------------------------------------------------------

/// Cube root for x >= 0 (the reference uses powf(x, 1/3)): bit-level initial guess
/// (|rel. error| < 4%), one Halley step in f32 (~1e-4) and one in f64 (~1e-12), so the
/// result is the correctly rounded cube root in all but rare midpoint cases. Being
/// exact here matters: FLIP's HyAB^0.7 amplifies 1-ulp Lab differences between
/// nearly equal pixels.
#[inline(always)]
fn fast_cbrt(x: f32) -> f32 {
    let y = f32::from_bits(x.to_bits() / 3 + 709958130); // (127 - 127/3 - 0.033) * 2^23
    let y3 = y * y * y;
    let y = y * (y3 + 2.0 * x) / (2.0 * y3 + x);
    let (xd, yd) = (x as f64, y as f64);
    let y3 = yd * yd * yd;
    let y = (yd * (y3 + 2.0 * xd) / (2.0 * y3 + xd)) as f32;
    if x > 0.0 {
        y
    } else {
        0.0
    }
}

/// x^y for x >= 0 (x <= 0 gives 0, or 1 when y == 0, like powf(0, y)).
#[inline(always)]
fn fast_pow(x: f32, y: f32) -> f32 {
    let pos = x > 0.0;
    let xs = if pos { x } else { 1.0 };
    let r = fastmath::exp2_below(y * fastmath::log2_any(xs), 127.0);
    let zero_case = if y == 0.0 { 1.0 } else { 0.0 };
    if pos {
        r
    } else {
        zero_case
    }
}

// ---------------------------------------------------------------------------
// Magma colour map (matplotlib "magma", as tabulated in the reference; RGB8 = round(255 c))
// ---------------------------------------------------------------------------

#[rustfmt::skip]
static MAGMA_RGB8: [[u8; 3]; 256] = [
    [0, 0, 4], [1, 0, 5], [1, 1, 6], [1, 1, 8], [2, 1, 9], [2, 2, 11], [2, 2, 13], [3, 3, 15],
    [3, 3, 18], [4, 4, 20], [5, 4, 22], [6, 5, 24], [6, 5, 26], [7, 6, 28], [8, 7, 30], [9, 7, 32],
    [10, 8, 34], [11, 9, 36], [12, 9, 38], [13, 10, 41], [14, 11, 43], [16, 11, 45], [17, 12, 47], [18, 13, 49],
    [19, 13, 52], [20, 14, 54], [21, 14, 56], [22, 15, 59], [24, 15, 61], [25, 16, 63], [26, 16, 66], [28, 16, 68],
    [29, 17, 71], [30, 17, 73], [32, 17, 75], [33, 17, 78], [34, 17, 80], [36, 18, 83], [37, 18, 85], [39, 18, 88],
    [41, 17, 90], [42, 17, 92], [44, 17, 95], [45, 17, 97], [47, 17, 99], [49, 17, 101], [51, 16, 103], [52, 16, 105],
    [54, 16, 107], [56, 16, 108], [57, 15, 110], [59, 15, 112], [61, 15, 113], [63, 15, 114], [64, 15, 116], [66, 15, 117],
    [68, 15, 118], [69, 16, 119], [71, 16, 120], [73, 16, 120], [74, 16, 121], [76, 17, 122], [78, 17, 123], [79, 18, 123],
    [81, 18, 124], [82, 19, 124], [84, 19, 125], [86, 20, 125], [87, 21, 126], [89, 21, 126], [90, 22, 126], [92, 22, 127],
    [93, 23, 127], [95, 24, 127], [96, 24, 128], [98, 25, 128], [100, 26, 128], [101, 26, 128], [103, 27, 128], [104, 28, 129],
    [106, 28, 129], [107, 29, 129], [109, 29, 129], [110, 30, 129], [112, 31, 129], [114, 31, 129], [115, 32, 129], [117, 33, 129],
    [118, 33, 129], [120, 34, 129], [121, 34, 130], [123, 35, 130], [124, 35, 130], [126, 36, 130], [128, 37, 130], [129, 37, 129],
    [131, 38, 129], [132, 38, 129], [134, 39, 129], [136, 39, 129], [137, 40, 129], [139, 41, 129], [140, 41, 129], [142, 42, 129],
    [144, 42, 129], [145, 43, 129], [147, 43, 128], [148, 44, 128], [150, 44, 128], [152, 45, 128], [153, 45, 128], [155, 46, 127],
    [156, 46, 127], [158, 47, 127], [160, 47, 127], [161, 48, 126], [163, 48, 126], [165, 49, 126], [166, 49, 125], [168, 50, 125],
    [170, 51, 125], [171, 51, 124], [173, 52, 124], [174, 52, 123], [176, 53, 123], [178, 53, 123], [179, 54, 122], [181, 54, 122],
    [183, 55, 121], [184, 55, 121], [186, 56, 120], [188, 57, 120], [189, 57, 119], [191, 58, 119], [192, 58, 118], [194, 59, 117],
    [196, 60, 117], [197, 60, 116], [199, 61, 115], [200, 62, 115], [202, 62, 114], [204, 63, 113], [205, 64, 113], [207, 64, 112],
    [208, 65, 111], [210, 66, 111], [211, 67, 110], [213, 68, 109], [214, 69, 108], [216, 69, 108], [217, 70, 107], [219, 71, 106],
    [220, 72, 105], [222, 73, 104], [223, 74, 104], [224, 76, 103], [226, 77, 102], [227, 78, 101], [228, 79, 100], [229, 80, 100],
    [231, 82, 99], [232, 83, 98], [233, 84, 98], [234, 86, 97], [235, 87, 96], [236, 88, 96], [237, 90, 95], [238, 91, 94],
    [239, 93, 94], [240, 95, 94], [241, 96, 93], [242, 98, 93], [242, 100, 92], [243, 101, 92], [244, 103, 92], [244, 105, 92],
    [245, 107, 92], [246, 108, 92], [246, 110, 92], [247, 112, 92], [247, 114, 92], [248, 116, 92], [248, 118, 92], [249, 120, 93],
    [249, 121, 93], [249, 123, 93], [250, 125, 94], [250, 127, 94], [250, 129, 95], [251, 131, 95], [251, 133, 96], [251, 135, 97],
    [252, 137, 97], [252, 138, 98], [252, 140, 99], [252, 142, 100], [252, 144, 101], [253, 146, 102], [253, 148, 103], [253, 150, 104],
    [253, 152, 105], [253, 154, 106], [253, 155, 107], [254, 157, 108], [254, 159, 109], [254, 161, 110], [254, 163, 111], [254, 165, 113],
    [254, 167, 114], [254, 169, 115], [254, 170, 116], [254, 172, 118], [254, 174, 119], [254, 176, 120], [254, 178, 122], [254, 180, 123],
    [254, 182, 124], [254, 183, 126], [254, 185, 127], [254, 187, 129], [254, 189, 130], [254, 191, 132], [254, 193, 133], [254, 194, 135],
    [254, 196, 136], [254, 198, 138], [254, 200, 140], [254, 202, 141], [254, 204, 143], [254, 205, 144], [254, 207, 146], [254, 209, 148],
    [254, 211, 149], [254, 213, 151], [254, 215, 153], [254, 216, 154], [253, 218, 156], [253, 220, 158], [253, 222, 160], [253, 224, 161],
    [253, 226, 163], [253, 227, 165], [253, 229, 167], [253, 231, 169], [253, 233, 170], [253, 235, 172], [252, 236, 174], [252, 238, 176],
    [252, 240, 178], [252, 242, 180], [252, 244, 182], [252, 246, 184], [252, 247, 185], [252, 249, 187], [252, 251, 189], [252, 253, 191],
];

#[cfg(test)]
mod tests {
    use super::*;

    /// FLIP's vectorisable sRGB decode stays within 2e-6 (absolute) of the crate's exact one on every 8-bit code
    /// and a dense sweep of [0, 1].
    #[test]
    fn fast_srgb_decode_is_the_srgb_decode() {
        let worst = (0..=4096)
            .map(|i| i as f32 / 4096.0)
            .chain((0..=255).map(|c| c as f32 / 255.0))
            .map(|v| (srgb_decode_fast(v) - crate::base::picture::srgb_decode(v)).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 2e-6, "{worst}");
    }

    /// The level a test caps the band kernels at (0: none; else 1 + the `Isa` as listed).
    static FORCED: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(0);

    /// Held by every test that forces a level, so that each runs on the level it names (the cap is global: the
    /// bands run on rayon's threads).
    static FORCING: std::sync::Mutex<()> = std::sync::Mutex::new(());

    fn forcing() -> std::sync::MutexGuard<'static, ()> {
        FORCING.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Caps the band kernels at `isa` (`None`: the CPU's). Call with [`forcing`] held.
    pub(super) fn force(isa: Option<Isa>) {
        let v = isa.map_or(0, |i| 1 + Isa::ALL.iter().position(|&x| x == i).expect("a listed level") as u8);
        FORCED.store(v, std::sync::atomic::Ordering::Relaxed);
    }

    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) fn forced() -> Option<Isa> {
        match FORCED.load(std::sync::atomic::Ordering::Relaxed) {
            0 => None,
            v => Some(Isa::ALL[usize::from(v) - 1]),
        }
    }

    /// Every instruction set this CPU runs gives the portable build's bits, LDR and HDR (map and exposure map),
    /// one pair and several tests against one reference.
    #[test]
    fn every_instruction_set_gives_the_same_bits() {
        let _serial = forcing();
        let (w, h) = (300, 70);
        let a = lcg_image(w, h, 5);
        let b: Vec<f32> = a.iter().map(|v| (v * 0.9 + 0.03).min(1.0)).collect();
        let c = lcg_image(w, h, 11);
        let opts = FlipOptions::default();
        let hd = |x: &[f32]| -> Vec<f32> { x.iter().map(|v| v * v * 30.0).collect() };
        let (ha, hb, hc) = (hd(&a), hd(&b), hd(&c));
        let run = |isa: Isa| {
            force(Some(isa));
            let pair = (ldr_flip(&a, &b, w, h, &opts), hdr_flip(&ha, &b, w, h, &opts));
            let many = (ldr_flip_many(&a, &[&b, &c], w, h, &opts), hdr_flip_many(&ha, &[&hb, &hc], w, h, &opts));
            force(None);
            (pair, many)
        };
        let ((l0, h0), (lm0, hm0)) = run(Isa::Baseline);
        assert!(l0.mean > 0.0 && h0.mean() > 0.0);
        for isa in Isa::available() {
            let ((l, hh), (lm, hm)) = run(isa);
            assert_eq!(l.values, l0.values, "{}", isa.name());
            assert_eq!((&hh.map.values, &hh.exposure_map), (&h0.map.values, &h0.exposure_map), "{}", isa.name());
            for (x, y) in lm.iter().zip(&lm0) {
                assert_eq!(x.values, y.values, "{}: many, LDR", isa.name());
            }
            for (x, y) in hm.iter().zip(&hm0) {
                assert_eq!((&x.map.values, &x.exposure_map), (&y.map.values, &y.exposure_map), "{}", isa.name());
            }
        }
    }

    /// Several tests against one reference, the reference filtered once, give each test's maps alone bit for bit
    /// (one band driver serves both: the buffers reused from test to test must not leak between them): LDR and HDR
    /// (maps, exposure maps, means), two column tiles (the second partial), several bands, an identical test, both
    /// code paths.
    #[test]
    fn many_tests_against_one_reference_equal_each_pair() {
        let _serial = forcing();
        let (w, h) = (300, 70);
        let a = lcg_image(w, h, 5);
        let b: Vec<f32> = a.iter().map(|v| (v * 0.9 + 0.03).min(1.0)).collect();
        let c = lcg_image(w, h, 11);
        let opts = FlipOptions { pixels_per_degree: 40.0 };
        let hd = |x: &[f32]| -> Vec<f32> { x.iter().map(|v| v * v * 30.0).collect() };
        let (ha, hb, hc) = (hd(&a), hd(&b), hd(&c));
        for generic in [false, true] {
            force(generic.then_some(Isa::Baseline));
            let ldr = ldr_flip_many(&a, &[&b, &a, &c], w, h, &opts);
            for (m, t) in ldr.iter().zip([&b, &a, &c]) {
                let pair = ldr_flip(&a, t, w, h, &opts);
                assert_eq!((&m.values, m.mean), (&pair.values, pair.mean), "LDR, generic {generic}");
            }
            assert!(ldr[0].mean > 0.0 && ldr[1].mean == 0.0);
            let hdr = hdr_flip_many(&ha, &[&hb, &ha, &hc], w, h, &opts);
            for (m, t) in hdr.iter().zip([&hb, &ha, &hc]) {
                let pair = hdr_flip(&ha, t, w, h, &opts);
                assert_eq!(m.map.values, pair.map.values, "HDR, generic {generic}");
                assert_eq!(
                    (&m.exposure_map, &m.exposures, m.map.mean),
                    (&pair.exposure_map, &pair.exposures, pair.map.mean)
                );
            }
            assert!(hdr[0].exposures.len() >= 2 && hdr[2].mean() > hdr[0].mean());
            // The means alone, without exposure maps: the same bits.
            let means = hdr_flip_means(&ha, &[&hb, &ha, &hc], w, h, &opts);
            assert_eq!(means, hdr.iter().map(HdrFlip::mean).collect::<Vec<_>>(), "HDR means, generic {generic}");
            // And LDR's on 8-bit images, without maps.
            let bytes = |x: &[f32]| -> Vec<u8> { x.iter().map(|v| (v * 255.0 + 0.5) as u8).collect() };
            let (ba, bb, bc) = (bytes(&a), bytes(&b), bytes(&c));
            let maps = ldr_flip_many_srgb8(&ba, &[&bb, &ba, &bc], w, h, &opts);
            let means = ldr_flip_means_srgb8(&ba, &[&bb, &ba, &bc], w, h, &opts);
            assert_eq!(means, maps.iter().map(|m| m.mean).collect::<Vec<_>>(), "LDR means, generic {generic}");
            assert!(means[0] > 0.0 && means[1] == 0.0);
        }
        force(None);
        assert!(ldr_flip_many(&a, &[], w, h, &opts).is_empty());
    }

    /// Output rows handed over without filtering, in tile rows ([`Sink::skip`]).
    pub(super) static SKIPPED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

    /// Skipping the windows a test shares with the reference or an earlier test changes no bit of any map, exposure
    /// map or mean: LDR, HDR and HDR means; tests equal to the reference in a band of rows and a block of columns
    /// (a border tile among them), tests equal to an earlier test there, a test equal to an earlier one throughout,
    /// several bands and two column tiles, every level this CPU runs. And it skips.
    #[test]
    fn skipping_equal_windows_changes_no_bit() {
        let _serial = forcing();
        let (w, h) = (300, 130);
        let a = lcg_image(w, h, 5);
        // `b`: `a` but for rows 40..70; `c`: `b` but for a block of columns at the right border; `d`: `b`'s copy.
        let mut b = a.clone();
        let noise = lcg_image(w, h, 17);
        b[40 * w * 3..70 * w * 3].copy_from_slice(&noise[40 * w * 3..70 * w * 3]);
        let mut c = b.clone();
        for y in 0..h {
            c[(y * w + 270) * 3..(y * w + 300) * 3].copy_from_slice(&noise[(y * w + 270) * 3..(y * w + 300) * 3]);
        }
        let d = b.clone();
        let opts = FlipOptions { pixels_per_degree: 30.0 };
        let hd = |x: &[f32]| -> Vec<f32> { x.iter().map(|v| v * v * 30.0).collect() };
        let (ha, hb, hc, hdd) = (hd(&a), hd(&b), hd(&c), hd(&d));
        let run = |skip: bool| {
            SKIP_EQUAL.store(skip, std::sync::atomic::Ordering::Relaxed);
            let ldr = ldr_flip_many(&a, &[&b, &c, &d], w, h, &opts);
            let hdr = hdr_flip_many(&ha, &[&hb, &hc, &hdd], w, h, &opts);
            let means = hdr_flip_means(&ha, &[&hb, &hc, &hdd], w, h, &opts);
            SKIP_EQUAL.store(true, std::sync::atomic::Ordering::Relaxed);
            (ldr, hdr, means)
        };
        for isa in std::iter::once(Isa::Baseline).chain(Isa::available()) {
            force(Some(isa));
            let (l0, h0, m0) = run(false);
            let before = SKIPPED.load(std::sync::atomic::Ordering::Relaxed);
            let (l1, h1, m1) = run(true);
            let skipped = SKIPPED.load(std::sync::atomic::Ordering::Relaxed) - before;
            assert!(skipped > 3 * h, "{}: {skipped} rows skipped", isa.name());
            for (x, y) in l1.iter().zip(&l0) {
                assert_eq!((&x.values, x.mean), (&y.values, y.mean), "{}: LDR", isa.name());
            }
            for (x, y) in h1.iter().zip(&h0) {
                assert_eq!((&x.map.values, &x.exposure_map), (&y.map.values, &y.exposure_map), "{}: HDR", isa.name());
            }
            assert_eq!(m1, m0, "{}: HDR means", isa.name());
            assert!(l0[0].mean > 0.0 && l0[1].mean > l0[0].mean && l0[2].values == l0[0].values);
        }
        force(None);
    }

    #[test]
    fn linear_entry_point_matches_srgb_decoding() {
        let (w, h) = (40, 30);
        let a = lcg_image(w, h, 8);
        let b = lcg_image(w, h, 9);
        let dec = |v: &[f32]| -> Vec<f32> { v.iter().map(|&s| srgb_decode_fast(s)).collect() };
        let m1 = ldr_flip(&a, &b, w, h, &FlipOptions::default());
        let m2 = ldr_flip_linear(&dec(&a), &dec(&b), w, h, &FlipOptions::default());
        assert_eq!(m1.values, m2.values);
    }

    fn lcg_image(w: usize, h: usize, seed: u64) -> Vec<f32> {
        let mut s = seed;
        (0..w * h * 3)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 40) as f32 / (1u64 << 24) as f32
            })
            .collect()
    }

    #[test]
    fn default_ppd_matches_reference_formula() {
        let p = FlipOptions::default().pixels_per_degree;
        assert!((p - 67.0206).abs() < 1e-3, "{p}");
        assert_eq!(p, 0.7f32 * (3840.0f32 / 0.7f32) * (PI / 180.0));
    }

    #[test]
    fn filter_sizes_and_normalisation() {
        let c = Ctx::new(8, 8, default_ppd());
        assert_eq!((c.rs, c.rf), (10, 9));
        let s: f32 = c.sy.iter().sum();
        assert!((s - 1.0).abs() < 1e-5);
        let s: f32 = c.scx.iter().sum();
        assert!((s - 1.0).abs() < 1e-5);
        let s1: f32 = c.scz1.iter().sum();
        let s2: f32 = c.scz2.iter().sum();
        assert!((s1 * s1 + s2 * s2 - 1.0).abs() < 1e-5);
        let pos: f32 = c.fdg.iter().filter(|&&v| v > 0.0).sum();
        let neg: f32 = c.fddg.iter().filter(|&&v| v < 0.0).sum();
        assert!((pos - 1.0).abs() < 1e-5 && (neg + 1.0).abs() < 1e-5);
        assert!((c.cmax - 41.2).abs() < 0.5, "cmax {}", c.cmax);
    }

    /// The Y and Cx filters' dropped end taps weigh together less than 2⁻²⁴ of the filter (each filtered value moves
    /// by less than about one f32 rounding of itself), and no more could be dropped from both; at the default 67
    /// pixels per degree 6 taps either side are kept of 10. A filter with no negligible tap keeps all.
    #[test]
    fn the_luminance_and_red_green_filters_leave_out_only_negligible_taps() {
        for ppd in [default_ppd(), 20.0, 150.0] {
            let c = Ctx::new(8, 8, ppd);
            assert!(c.ryc <= c.rs && c.ws_ycx.len() == 2 * c.ryc + 1, "ppd {ppd}");
            for w in [&c.sy, &c.scx] {
                let dropped: f32 = w.iter().take(c.rs - c.ryc).chain(w.iter().skip(c.rs + c.ryc + 1)).sum();
                assert!(dropped < f32::EPSILON / 2.0, "ppd {ppd}: dropped weight {dropped}");
            }
            let needed = |w: &[f32]| w[c.rs - c.ryc] >= w[c.rs] * f32::EPSILON / 2.0;
            assert!(c.ryc == c.rs || needed(&c.sy) || needed(&c.scx), "ppd {ppd}: more taps could be left out");
        }
        assert_eq!(Ctx::new(8, 8, default_ppd()).ryc, 6);
        assert_eq!(negligible_taps(&[1.0, 2.0, 1.0]), 0);
    }

    #[test]
    fn fast_pow_accuracy() {
        // Worst relative error of fast_pow against f64 powf on [lo, hi).
        let worst = |lo: f32, hi: f32, y: f32| {
            let mut worst = 0.0f64;
            let mut x = lo;
            while x < hi {
                let a = fast_pow(x, y) as f64;
                let b = (x as f64).powf(y as f64);
                if (1e-36..1e36).contains(&b) {
                    worst = worst.max(((a - b) / b).abs());
                }
                x *= 1.000731;
            }
            worst
        };
        for &y in &[ONE_THIRD, GQC, 2.4, 0.05, 0.5, 1.0] {
            // The range FLIP uses (colours, distances, errors); the error is dominated by the
            // f32 rounding of y * log2(x) (a few ulp of a number up to ~20).
            let w = worst(1e-6, 300.0, y);
            assert!(w < 4e-6, "y = {y}: worst relative error {w}");
            let w = worst(1e-30, 1e6, y);
            assert!(w < 1e-5, "y = {y}: worst relative error {w}");
        }
        let mut worst = 0.0f64;
        let mut x = 1e-6f32;
        while x < 2.0 {
            let a = fast_cbrt(x) as f64;
            let b = (x as f64).cbrt();
            worst = worst.max(((a - b) / b).abs());
            x *= 1.000137;
        }
        assert!(worst < 6.5e-8, "cbrt worst relative error {worst}");
        assert_eq!(fast_cbrt(0.0), 0.0);
        assert_eq!(fast_pow(0.0, 0.7), 0.0);
        assert_eq!(fast_pow(0.0, 0.0), 1.0);
        assert!((fast_pow(1e-40, 0.5) as f64 - 1e-20).abs() < 1e-25);
    }

    #[test]
    fn identical_images_give_zero() {
        let (w, h) = (37, 23);
        let a = lcg_image(w, h, 1);
        let m = ldr_flip(&a, &a, w, h, &FlipOptions::default());
        assert!(m.values.iter().all(|&v| v == 0.0));
        assert_eq!(m.mean, 0.0);
        let hd: Vec<f32> = a.iter().map(|v| v * 20.0).collect();
        let r = hdr_flip(&hd, &hd, w, h, &FlipOptions::default());
        assert_eq!(r.map.mean, 0.0);
        assert!(r.exposures.len() >= 2);
    }

    #[test]
    fn errors_in_unit_range_and_tiny_images() {
        for &(w, h) in &[(1, 1), (1, 7), (5, 1), (3, 40), (130, 3)] {
            let a = lcg_image(w, h, 2);
            let b = lcg_image(w, h, 3);
            let m = ldr_flip(&a, &b, w, h, &FlipOptions::default());
            assert!(m.values.iter().all(|v| (0.0..=1.0).contains(v)), "{w}x{h}");
            assert!(m.mean > 0.0);
        }
        for &ppd in &[0.5f32, 5.0, 300.0] {
            let (w, h) = (45, 33);
            let a = lcg_image(w, h, 4);
            let b = lcg_image(w, h, 5);
            let m = ldr_flip(&a, &b, w, h, &FlipOptions { pixels_per_degree: ppd });
            assert!(m.values.iter().all(|v| (0.0..=1.0).contains(v)), "ppd {ppd}");
        }
        let e = ldr_flip(&[], &[], 0, 5, &FlipOptions::default());
        assert_eq!(e.mean, 0.0);
    }

    #[test]
    fn black_vs_white_is_max() {
        let (w, h) = (16, 16);
        let a = vec![0.0f32; w * h * 3];
        let b = vec![1.0f32; w * h * 3];
        let m = ldr_flip(&a, &b, w, h, &FlipOptions::default());
        assert!(m.mean > 0.9 && m.mean <= 1.0, "{}", m.mean);
    }

    #[test]
    fn magma_endpoints() {
        let rgb = magma_rgb8(&[0.0, 1.0, -1.0, f32::NAN, 2.0]);
        assert_eq!(&rgb[0..3], &[0, 0, 4]);
        assert_eq!(&rgb[3..6], &[252, 253, 191]);
        assert_eq!(&rgb[6..9], &[0, 0, 4]);
        assert_eq!(&rgb[9..12], &[0, 0, 4]);
        assert_eq!(&rgb[12..15], &[252, 253, 191]);
    }

    #[test]
    fn hdr_flip_of_a_mostly_black_reference_stays_finite() {
        // 3/4 of the pixels black: the reference code's median is 0 and its stop exposure infinite. 8 × 8: the test
        // runs under Miri too (CI's .ci/miri.sh), where 16 × 16 took four minutes.
        let (w, h) = (8, 8);
        let mut a = vec![0.0f32; w * h * 3];
        for (i, v) in a.iter_mut().enumerate().take(w * h * 3 / 4) {
            *v = if i % 3 == 0 { 4.0 } else { 0.5 };
        }
        let mut b = a.clone();
        b[0] = 8.0;
        let r = hdr_flip(&a, &b, w, h, &FlipOptions::default());
        assert!(
            r.start_exposure.is_finite() && r.stop_exposure.is_finite(),
            "{} {}",
            r.start_exposure,
            r.stop_exposure
        );
        assert!(r.exposures.len() <= MAX_EXPOSURE_RANGE as usize + 1 && r.mean() > 0.0);
        // An all-black reference: one exposure range [0, 0], still a number.
        let black = vec![0.0f32; w * h * 3];
        let r = hdr_flip(&black, &b, w, h, &FlipOptions::default());
        assert!((r.start_exposure, r.stop_exposure) == (0.0, 0.0) && r.mean().is_finite());
    }
}
