//! Measuring normal codecs: angular error over a dense deterministic sphere sweep plus random vectors, an
//! exhaustive decode → re-encode check over every code where the code space is small, and encode/decode speed.
//!
//! The sweep is a Fibonacci (golden-angle) lattice — near-uniform, deterministic, with no clustering at the
//! poles — plus the stiff vectors (poles, axes, fold lines) and uniformly random vectors from a fixed seed.
//! Errors are angles computed in f64 ([`angle_deg`]).
//!
//! For the two-coordinate codecs ([`Planar`]) [`cell_sweep`] enumerates every code instead: each code owns a
//! rectangle of the plane, whose image on the sphere is every input that encodes to it; the sweep measures the
//! error at the rectangle's corners and edge midpoints (where the worst case of a Lipschitz map sits) and at
//! stratified random points weighted by the rectangle's solid angle, which gives the worst case to within the
//! sampling of the cell edges and the mean over uniformly distributed directions without sampling error beyond
//! a cell's.

use super::normal::{angle_deg, finish, sanitize, Planar, Projection, Quant};
use super::{Codec, NormalCodec};
use crate::base::isa::Isa;
use crate::base::rng::SplitMix64;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use std::hint::black_box;
use std::time::Instant;

/// Largest code space enumerated exhaustively (2^24 codes).
pub const MAX_EXHAUSTIVE_BITS: u32 = 24;

/// `count` points of the Fibonacci lattice on the unit sphere.
#[must_use]
pub fn fibonacci_sphere(count: usize) -> Vec<Vec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
        })
        .collect()
}

/// `count` uniformly random unit vectors from `seed` (z uniform in [−1, 1], azimuth uniform: Archimedes).
#[must_use]
pub fn random_unit_vectors(count: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|_| {
            let z = rng.range_f32(-1.0, 1.0);
            let phi = rng.range_f32(0.0, std::f32::consts::TAU);
            let r = (1.0 - z * z).max(0.0).sqrt();
            sanitize(Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// Poles, axes, diagonals and octahedron fold lines (x = 0 or y = 0 with z < 0).
#[must_use]
pub fn stiff_vectors() -> Vec<Vec3> {
    let mut v = vec![Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
    for i in 1..64 {
        let z = -(i as f32) / 64.0;
        let r = (1.0 - z * z).sqrt();
        v.extend([Vec3::new(0.0, r, z), Vec3::new(r, 0.0, z), Vec3::new(0.0, -r, z), Vec3::new(-r, 0.0, z)]);
        let z = -z;
        let d = r * std::f32::consts::FRAC_1_SQRT_2;
        v.extend([Vec3::new(d, d, z), Vec3::new(-d, d, -z)]);
    }
    v.into_iter().map(sanitize).collect()
}

/// The standard evaluation set: `sweep` lattice points, `random` seeded random vectors and the stiff vectors.
#[must_use]
pub fn evaluation_set(sweep: usize, random: usize) -> Vec<Vec3> {
    let mut v = fibonacci_sphere(sweep);
    v.extend(random_unit_vectors(random, 0x6b75_6675_6e63));
    v.extend(stiff_vectors());
    v
}

/// Angular error statistics of one codec.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ErrorStats {
    /// Vectors measured.
    pub samples: usize,
    /// Mean angular error, degrees.
    pub mean_deg: f64,
    /// Largest angular error, degrees.
    pub max_deg: f64,
    /// Largest error over the front hemisphere z ≥ 0 (what a view-space G-buffer mostly sees), degrees.
    pub max_hemi_deg: f64,
    /// Largest error among vectors inside the codec's domain, degrees (compare with the bound).
    pub max_domain_deg: f64,
    /// Mean error among vectors inside the codec's domain, degrees (for hemisphere codecs the useful mean).
    pub mean_domain_deg: f64,
    /// The input with the largest error.
    pub worst_input: [f32; 3],
}

/// Error of `codec` over `inputs` (unit vectors), in parallel.
#[must_use]
pub fn measure_error(codec: &dyn NormalCodec, inputs: &[Vec3]) -> ErrorStats {
    let per: Vec<(f64, bool, bool)> = inputs
        .par_iter()
        .map(|&n| (f64::from(angle_deg(n, codec.decode(codec.encode(n)))), n.z >= 0.0, codec.in_domain(n)))
        .collect();
    let mut s = ErrorStats { samples: inputs.len(), ..ErrorStats::default() };
    let (mut sum, mut sum_dom, mut n_dom) = (0.0, 0.0, 0usize);
    for (i, &(e, hemi, dom)) in per.iter().enumerate() {
        sum += e;
        if e > s.max_deg {
            s.max_deg = e;
            s.worst_input = inputs[i].to_array();
        }
        if hemi {
            s.max_hemi_deg = s.max_hemi_deg.max(e);
        }
        if dom {
            s.max_domain_deg = s.max_domain_deg.max(e);
            sum_dom += e;
            n_dom += 1;
        }
    }
    s.mean_deg = if per.is_empty() { 0.0 } else { sum / per.len() as f64 };
    s.mean_domain_deg = if n_dom == 0 { 0.0 } else { sum_dom / n_dom as f64 };
    s
}

/// Result of decoding every code, re-encoding the decoded normal and decoding again.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Exhaustive {
    /// Codes enumerated (2^bits).
    pub codes: u64,
    /// Codes whose decode was not a finite unit vector (must be 0).
    pub bad_decodes: u64,
    /// Codes with decode(encode(decode(c))) ≠ decode(c) bit for bit.
    pub reencode_mismatches: u64,
    /// Largest angle between decode(c) and decode(encode(decode(c))), degrees.
    pub reencode_max_deg: f64,
}

/// Tolerance on |decoded| − 1 for a "unit" output: f32 normalisation leaves a few ulp.
pub const UNIT_LENGTH_TOL: f32 = 1e-6;

/// Enumerates every code of `codec` (only when `bits() ≤` [`MAX_EXHAUSTIVE_BITS`]; `None` otherwise).
#[must_use]
pub fn exhaustive(codec: &dyn NormalCodec) -> Option<Exhaustive> {
    let bits = codec.bits();
    if bits > MAX_EXHAUSTIVE_BITS {
        return None;
    }
    let codes = 1u64 << bits;
    let chunk = 1u64 << 14;
    let parts: Vec<Exhaustive> = (0..codes.div_ceil(chunk))
        .into_par_iter()
        .map(|ci| {
            let mut e = Exhaustive::default();
            for c in ci * chunk..((ci + 1) * chunk).min(codes) {
                let d = codec.decode(c);
                if !d.is_finite() || (d.length() - 1.0).abs() > UNIT_LENGTH_TOL {
                    e.bad_decodes += 1;
                    continue;
                }
                let d2 = codec.decode(codec.encode(d));
                if d2 != d {
                    e.reencode_mismatches += 1;
                    e.reencode_max_deg = e.reencode_max_deg.max(f64::from(angle_deg(d, d2)));
                }
            }
            e
        })
        .collect();
    let mut total = Exhaustive { codes, ..Exhaustive::default() };
    for p in parts {
        total.bad_decodes += p.bad_decodes;
        total.reencode_mismatches += p.reencode_mismatches;
        total.reencode_max_deg = total.reencode_max_deg.max(p.reencode_max_deg);
    }
    Some(total)
}

/// Result of [`cell_sweep`]: the error of a planar codec over every one of its code cells.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CellSweep {
    /// Code cells enumerated: every distinct stored value (snorm's second code for −1 is skipped).
    pub cells: u64,
    /// Sum of the cells' solid angles in steradians: 4π when the cells tile the sphere once (checks the weights).
    pub area_sr: f64,
    /// Mean angular error over uniformly distributed directions, degrees.
    pub mean_deg: f64,
    /// Largest angular error found, degrees (a lower bound on the supremum, within the edge sampling).
    pub max_deg: f64,
    /// The input with the largest error.
    pub worst_input: [f32; 3],
    /// Sampled inputs that encoded to a neighbouring code (ties and f32 rounding at a cell's edge); their error
    /// counts against the code the encoder chose.
    pub other_code: u64,
}

/// How far inside its cell a corner or edge sample sits, as a fraction of the half step: far enough that f32
/// rounding of the projection round trip (≈ 1e-7 of plane distance) keeps it in the cell at 12 bits per
/// coordinate (half step 2.4e-4), near enough that the measured worst case is within 0.1% of the corner's.
pub const CELL_EDGE_INSET: f32 = 1e-3;

/// Enumerates every code cell of a two-coordinate codec with snorm or unorm storage of at most
/// [`MAX_EXHAUSTIVE_BITS`] bits (`None` otherwise, and for f16 storage, whose cells are not a grid).
///
/// For each code c, with plane rectangle R (the plane points that round to c, clipped to the square): the
/// inputs are the projection's images of R's four corners and four edge midpoints, each moved
/// [`CELL_EDGE_INSET`] of a half step towards the centre, and of one uniformly random point in each of the
/// s × s equal parts of R (jittered stratification, seeded by `seed`; s = 4 up to 16 bits, 2 above, which keeps
/// the mean's sampling error near 0.02% at every size). Each input is encoded and decoded by the codec itself.
/// The mean weights each cell's stratified errors by the solid angle of the image of R (two spherical
/// triangles through its corners).
#[must_use]
pub fn cell_sweep<P: Projection + std::fmt::Debug>(codec: &Planar<P>, seed: u64) -> Option<CellSweep> {
    let q = codec.quant();
    let k = q.bits();
    let (lo, hi) = match q {
        Quant::Snorm(_) | Quant::UnormSigned(_) => (-1.0f32, 1.0f32),
        Quant::Unorm(_) => (0.0, 1.0),
        Quant::F16 => return None,
    };
    if 2 * k > MAX_EXHAUSTIVE_BITS {
        return None;
    }
    let h = q.half_step(1.0);
    let strata: u32 = if 2 * k <= 16 { 4 } else { 2 };
    let proj = codec.projection();
    let comps: Vec<u64> = (0..1u64 << k).filter(|&c| !(matches!(q, Quant::Snorm(_)) && c == 1 << (k - 1))).collect();
    let rows: Vec<(CellSweep, f64)> = comps
        .par_iter()
        .map(|&i| {
            let mut rng = SplitMix64::new(seed ^ i.wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut s = CellSweep::default();
            let mut weighted = 0.0f64;
            let cx = q.decode(i);
            let (x0, x1) = ((cx - h).max(lo), (cx + h).min(hi));
            for &j in &comps {
                let code = i | (j << k);
                let cy = q.decode(j);
                let (y0, y1) = ((cy - h).max(lo), (cy + h).min(hi));
                let image = |x: f32, y: f32| finish(proj.decode_plane(glam::Vec2::new(x, y)));
                let error = |x: f32, y: f32, s: &mut CellSweep| {
                    let n = image(x, y);
                    let c = codec.encode(n);
                    s.other_code += u64::from(c != code);
                    let e = f64::from(angle_deg(n, codec.decode(c)));
                    if e > s.max_deg {
                        s.max_deg = e;
                        s.worst_input = n.to_array();
                    }
                    e
                };
                let inset = |a: f32, b: f32| (a + (b - a) * CELL_EDGE_INSET, b + (a - b) * CELL_EDGE_INSET);
                let ((ex0, ex1), (ey0, ey1)) = (inset(x0, x1), inset(y0, y1));
                let (mx, my) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
                for (x, y) in
                    [(ex0, ey0), (ex1, ey0), (ex0, ey1), (ex1, ey1), (mx, ey0), (mx, ey1), (ex0, my), (ex1, my)]
                {
                    error(x, y, &mut s);
                }
                let mut sum = 0.0;
                let part = 1.0 / strata as f32;
                for sx in 0..strata {
                    for sy in 0..strata {
                        let x = x0 + (sx as f32 + rng.next_f32()) * part * (x1 - x0);
                        let y = y0 + (sy as f32 + rng.next_f32()) * part * (y1 - y0);
                        sum += error(x, y, &mut s);
                    }
                }
                let corners = [image(x0, y0), image(x1, y0), image(x1, y1), image(x0, y1)].map(|v| v.as_dvec3());
                let area =
                    solid_angle(corners[0], corners[1], corners[2]) + solid_angle(corners[0], corners[2], corners[3]);
                s.area_sr += area;
                weighted += area * sum / f64::from(strata * strata);
                s.cells += 1;
            }
            (s, weighted)
        })
        .collect();
    let mut total = CellSweep::default();
    let mut weighted = 0.0;
    for (s, w) in rows {
        total.cells += s.cells;
        total.area_sr += s.area_sr;
        total.other_code += s.other_code;
        weighted += w;
        if s.max_deg > total.max_deg {
            total.max_deg = s.max_deg;
            total.worst_input = s.worst_input;
        }
    }
    total.mean_deg = if total.area_sr > 0.0 { weighted / total.area_sr } else { 0.0 };
    Some(total)
}

/// Solid angle of the spherical triangle through three unit vectors (Van Oosterom and Strackee 1983).
fn solid_angle(a: glam::DVec3, b: glam::DVec3, c: glam::DVec3) -> f64 {
    2.0 * a.dot(b.cross(c)).abs().atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
}

/// Nanoseconds per normal for encode and for decode over `inputs`, through the slice path
/// ([`Codec::encode_slice`] / [`Codec::decode_slice`]: one thread, vectorised with the widest instruction set the
/// CPU has), best of `reps` passes.
#[must_use]
pub fn time_codec(codec: &dyn NormalCodec, inputs: &[Vec3], reps: usize) -> (f64, f64) {
    let mut codes = vec![0u64; inputs.len()];
    let mut out = vec![Vec3::ZERO; inputs.len()];
    let (mut enc, mut dec) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        codec.encode_slice(black_box(inputs), &mut codes);
        black_box(&codes);
        enc = enc.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        codec.decode_slice(black_box(&codes), &mut out);
        black_box(&out);
        dec = dec.min(t.elapsed().as_secs_f64());
    }
    let n = inputs.len().max(1) as f64;
    (enc * 1e9 / n, dec * 1e9 / n)
}

/// Seconds of the fastest of `reps` runs of `f` (at least one): the timer the benches use for their ratio
/// tables, where the minimum is the least disturbed by other processes.
pub fn best_time(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

/// One row of the `gbuf codecs` table.
#[derive(Clone, Debug, Serialize)]
pub struct CodecRow {
    /// Registry name, e.g. `oct-16`.
    pub codec: String,
    /// Scheme without bit count, e.g. `oct`.
    pub scheme: String,
    /// Total bits per normal.
    pub bits: u32,
    /// Mean angular error over the evaluation set, degrees.
    pub mean_deg: f64,
    /// Largest angular error over the evaluation set, degrees.
    pub max_deg: f64,
    /// Largest error over z ≥ 0, degrees.
    pub max_hemi_deg: f64,
    /// Largest error inside the codec's domain, degrees.
    pub max_domain_deg: f64,
    /// Mean error inside the codec's domain, degrees.
    pub mean_domain_deg: f64,
    /// The documented bound (inside the domain), degrees.
    pub bound_deg: f64,
    /// Vectors in the evaluation set.
    pub samples: usize,
    /// The exhaustive check, where the code space is ≤ 2^24 and it was requested.
    pub exhaustive: Option<Exhaustive>,
    /// Nanoseconds per normal to encode through the slice path, one thread (see [`time_codec`]).
    pub encode_ns: f64,
    /// Nanoseconds per normal to decode through the slice path, one thread (see [`time_codec`]).
    pub decode_ns: f64,
    /// How `encode_ns`/`decode_ns` were measured, e.g. `slice, 1 thread, avx512` (empty when timing was off).
    pub timing: String,
}

/// What to run for each codec.
#[derive(Clone, Copy, Debug)]
pub struct EvalOptions {
    /// Fibonacci lattice points.
    pub sweep: usize,
    /// Random vectors.
    pub random: usize,
    /// Enumerate small code spaces.
    pub exhaustive: bool,
    /// Vectors timed per pass (0: no timing).
    pub timing_samples: usize,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions { sweep: 1 << 20, random: 1 << 20, exhaustive: true, timing_samples: 1 << 20 }
    }
}

/// Measures one codec on a prepared evaluation set.
#[must_use]
pub fn evaluate(codec: &dyn NormalCodec, scheme: &str, inputs: &[Vec3], opts: &EvalOptions) -> CodecRow {
    let err = measure_error(codec, inputs);
    let ex = if opts.exhaustive { exhaustive(codec) } else { None };
    let (encode_ns, decode_ns) = if opts.timing_samples > 0 {
        time_codec(codec, &inputs[..opts.timing_samples.min(inputs.len())], 3)
    } else {
        (0.0, 0.0)
    };
    CodecRow {
        codec: codec.name(),
        scheme: scheme.to_string(),
        bits: codec.bits(),
        mean_deg: err.mean_deg,
        max_deg: err.max_deg,
        max_hemi_deg: err.max_hemi_deg,
        max_domain_deg: err.max_domain_deg,
        mean_domain_deg: err.mean_domain_deg,
        bound_deg: f64::from(codec.max_error_deg()),
        samples: err.samples,
        exhaustive: ex,
        encode_ns,
        decode_ns,
        timing: if opts.timing_samples > 0 {
            format!("slice, 1 thread, {}", Isa::detect().name())
        } else {
            String::new()
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibonacci_points_are_unit_and_cover_both_hemispheres_evenly() {
        let p = fibonacci_sphere(10_000);
        assert!(p.iter().all(|v| (v.length() - 1.0).abs() < 1e-6));
        let up = p.iter().filter(|v| v.z > 0.0).count();
        assert_eq!(up, 5_000);
        // Near-uniform: every random direction has a lattice point within ~2.5× the mean spacing.
        let spacing = (4.0 * std::f32::consts::PI / 10_000.0).sqrt().to_degrees();
        for q in random_unit_vectors(200, 1) {
            let nearest = p.iter().map(|&v| angle_deg(v, q)).fold(f32::INFINITY, f32::min);
            assert!(nearest < 2.5 * spacing, "{q}: nearest lattice point {nearest}° away");
        }
    }

    #[test]
    fn measure_error_reports_the_worst_input() {
        let codec = super::super::normal_codec("xy-hemi-16").unwrap();
        let s = measure_error(codec.as_ref(), &[Vec3::Z, Vec3::NEG_Z]);
        assert!((s.max_deg - 180.0).abs() < 1e-3, "{s:?}");
        assert_eq!(s.worst_input, [0.0, 0.0, -1.0]);
        assert!(s.max_hemi_deg < 1e-3 && s.max_domain_deg < 1e-3, "{s:?}");
        assert!((s.mean_deg - 90.0).abs() < 1e-3);
    }
}
