//! Per-attribute error between two G-buffers of the same geometry: what a layout's quantization did.
//!
//! Input: the reference (f32) G-buffer and a test one (typically [`crate::layout::Layout::roundtrip`] of it).
//! Output: [`AttributeErrors`], over covered samples of the reference only, each metric with the pixel of its
//! worst sample. Normals: angle in degrees (mean, 95th percentile, max) computed as `atan2(|a×b|, a·b)` in f64,
//! accurate for tiny angles where `acos` is not. Depth: relative error `|d′−d| / d`. Colours and scalars: absolute
//! error. IDs: mismatch counts. Non-finite test values count as the worst possible error (180° for normals,
//! otherwise they are tallied in `nonfinite` and skipped, so JSON stays finite).

use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer, PlaneRef};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Where a sample sits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SampleAt {
    /// Pixel column.
    pub x: u32,
    /// Pixel row (0 at the top).
    pub y: u32,
    /// Sample within the pixel.
    pub sample: u32,
}

/// Normal angular error.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NormalErrors {
    /// Mean angle, degrees.
    pub mean_deg: f64,
    /// 95th percentile, degrees.
    pub p95_deg: f64,
    /// Largest angle, degrees.
    pub max_deg: f64,
    /// The sample with the largest angle.
    pub worst: SampleAt,
    /// Covered samples left out because the reference normal itself is zero or not unit length (see
    /// [`crate::io::plausible::normal_is_valid`]): an angle to it means nothing.
    #[serde(default)]
    pub skipped_invalid: u64,
}

/// Depth error.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DepthErrors {
    /// Largest `|d′ − d| / d`.
    pub rel_max: f64,
    /// Mean `|d′ − d| / d`.
    pub rel_mean: f64,
    /// Largest `|d′ − d|` (view-space units).
    pub abs_max: f64,
    /// The sample with the largest relative error.
    pub worst: SampleAt,
}

/// Error of a 1-, 2- or 3-component float attribute (albedo, position, motion, specular, …).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ValueErrors {
    /// Attribute name.
    pub attribute: String,
    /// Largest absolute error of any component.
    pub max_abs: f64,
    /// Mean absolute error over components and samples.
    pub mean_abs: f64,
    /// Root mean square error over components and samples.
    pub rmse: f64,
    /// The sample with the largest error.
    pub worst: SampleAt,
}

/// ID mismatches.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IdErrors {
    /// Attribute name.
    pub attribute: String,
    /// Covered samples whose IDs differ.
    pub mismatches: u64,
    /// The first mismatching sample in scan order.
    pub first: Option<SampleAt>,
}

/// Everything [`compare`] measures.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AttributeErrors {
    /// Covered samples compared.
    pub covered_samples: u64,
    /// Normal error (both buffers have normals).
    pub normal: Option<NormalErrors>,
    /// Depth error.
    pub depth: Option<DepthErrors>,
    /// Albedo error.
    pub albedo: Option<ValueErrors>,
    /// Position error (absolute, view-space units).
    pub position: Option<ValueErrors>,
    /// Motion error (pixels).
    pub motion: Option<ValueErrors>,
    /// Scalar attributes (specular, specular power, roughness, metallic), in canonical order.
    pub scalars: Vec<ValueErrors>,
    /// ID attributes.
    pub ids: Vec<IdErrors>,
    /// Attributes the reference has and the test lacks.
    pub missing: Vec<String>,
    /// Non-finite test values skipped (per attribute sample component).
    pub nonfinite: u64,
}

impl AttributeErrors {
    /// The error of a scalar attribute, if measured.
    #[must_use]
    pub fn scalar(&self, attr: Attribute) -> Option<&ValueErrors> {
        self.scalars.iter().find(|s| s.attribute == attr.name())
    }

    /// The mismatches of an ID attribute, if measured.
    #[must_use]
    pub fn id(&self, attr: Attribute) -> Option<&IdErrors> {
        self.ids.iter().find(|s| s.attribute == attr.name())
    }
}

fn at(gb: &GBuffer, i: usize) -> SampleAt {
    let s = gb.samples as usize;
    let p = i / s;
    SampleAt { x: (p % gb.width as usize) as u32, y: (p / gb.width as usize) as u32, sample: (i % s) as u32 }
}

/// Angle between two vectors in degrees (0 when both are zero, 180 when one is zero or non-finite).
#[must_use]
pub fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    if !a.is_finite() || !b.is_finite() {
        return 180.0;
    }
    match (a == DVec3::ZERO, b == DVec3::ZERO) {
        (true, true) => 0.0,
        (true, false) | (false, true) => 180.0,
        _ => a.cross(b).length().atan2(a.dot(b)).to_degrees(),
    }
}

/// Compares `test` against `reference` over the reference's covered samples. Errors when the geometry differs.
pub fn compare(reference: &GBuffer, test: &GBuffer) -> Result<AttributeErrors> {
    if (reference.width, reference.height, reference.samples) != (test.width, test.height, test.samples)
        || reference.coverage.len() != reference.len()
    {
        return Err(Error::Argument(format!(
            "compare: reference is {}×{}×{}, test is {}×{}×{}",
            reference.width, reference.height, reference.samples, test.width, test.height, test.samples
        )));
    }
    reference.validate()?;
    test.validate()?;
    let covered = Covered(&reference.coverage);
    let mut out = AttributeErrors { covered_samples: covered.iter().count() as u64, ..Default::default() };
    // Attributes are measured in parallel, each by the same sequential loop as alone (the numbers do not depend on
    // the thread count), and assembled in canonical order.
    let measured: Vec<(Attribute, Option<(Measured, u64)>)> = reference
        .attributes()
        .into_par_iter()
        .map(|attr| {
            let (Some(r), Some(t)) = (reference.plane(attr), test.plane(attr)) else {
                return (attr, None);
            };
            let mut nonfinite = 0;
            let m = match (attr, r, t) {
                (Attribute::Normal, PlaneRef::Vec3(r), PlaneRef::Vec3(t)) => {
                    Measured::Normal(normals(reference, covered, r, t))
                }
                (Attribute::Depth, PlaneRef::F32(r), PlaneRef::F32(t)) => {
                    Measured::Depth(depth(reference, covered, r, t, &mut nonfinite))
                }
                (_, PlaneRef::U32(r), PlaneRef::U32(t)) => {
                    let mut e = IdErrors { attribute: attr.name().into(), ..Default::default() };
                    for i in covered.iter() {
                        if r[i] != t[i] {
                            e.mismatches += 1;
                            e.first.get_or_insert(at(reference, i));
                        }
                    }
                    Measured::Id(e)
                }
                (_, r, t) => {
                    let comps = |p: PlaneRef<'_>, i: usize| -> [f32; 3] {
                        match p {
                            PlaneRef::F32(p) => [p[i], 0.0, 0.0],
                            PlaneRef::Vec2(p) => [p[i].x, p[i].y, 0.0],
                            PlaneRef::Vec3(p) => p[i].to_array(),
                            PlaneRef::U32(p) => [p[i] as f32, 0.0, 0.0],
                        }
                    };
                    Measured::Values(values(reference, attr, covered, |i| (comps(r, i), comps(t, i)), &mut nonfinite))
                }
            };
            (attr, Some((m, nonfinite)))
        })
        .collect();
    for (attr, m) in measured {
        let Some((m, nonfinite)) = m else {
            out.missing.push(attr.name().to_string());
            continue;
        };
        out.nonfinite += nonfinite;
        match m {
            Measured::Normal(e) => out.normal = Some(e),
            Measured::Depth(e) => out.depth = Some(e),
            Measured::Id(e) => out.ids.push(e),
            Measured::Values(e) => match attr {
                Attribute::Albedo => out.albedo = Some(e),
                Attribute::Position => out.position = Some(e),
                Attribute::Motion => out.motion = Some(e),
                _ => out.scalars.push(e),
            },
        }
    }
    Ok(out)
}

/// One attribute's errors, of the kind its plane has.
enum Measured {
    Normal(NormalErrors),
    Depth(DepthErrors),
    Id(IdErrors),
    Values(ValueErrors),
}

/// The covered samples of a G-buffer, by index, without a list of them (a 1080p × 4 dump has 8.3 million).
#[derive(Clone, Copy)]
struct Covered<'a>(&'a [bool]);

impl<'a> Covered<'a> {
    fn iter(self) -> impl Iterator<Item = usize> + 'a {
        self.0.iter().enumerate().filter_map(|(i, &c)| c.then_some(i))
    }
}

/// Samples per chunk of [`normals`]' parallel passes.
const NORMAL_CHUNK: usize = 1 << 16;

/// Normal errors in two parallel passes over fixed chunks of samples: the valid normals per chunk, then each
/// chunk's angles into its own part of one list (the list's order, its sum and so the mean, the first sample of
/// the largest angle and the 95th percentile are those of one loop in sample order, whatever the thread count).
fn normals(gb: &GBuffer, covered: Covered<'_>, r: &[Vec3], t: &[Vec3]) -> NormalErrors {
    let chunks = covered.0.len().div_ceil(NORMAL_CHUNK);
    let span = |k: usize| k * NORMAL_CHUNK..((k + 1) * NORMAL_CHUNK).min(covered.0.len());
    let valid = |i: usize| covered.0[i] && crate::io::plausible::normal_is_valid(r[i]);
    let counts: Vec<usize> = (0..chunks).into_par_iter().map(|k| span(k).filter(|&i| valid(i)).count()).collect();
    let total: usize = counts.iter().sum();
    let skipped_invalid = (covered.iter().count() - total) as u64;
    if total == 0 {
        return NormalErrors { skipped_invalid, ..NormalErrors::default() };
    }
    let mut angles = vec![0.0f64; total];
    let mut parts = Vec::with_capacity(chunks);
    let mut rest = angles.as_mut_slice();
    for &n in &counts {
        let (part, tail) = rest.split_at_mut(n);
        parts.push(part);
        rest = tail;
    }
    // Per chunk: its largest angle and the first sample with it.
    let maxima: Vec<(f64, usize)> = parts
        .into_par_iter()
        .enumerate()
        .map(|(k, part)| {
            let (mut max, mut worst) = (-1.0f64, 0usize);
            for (slot, i) in part.iter_mut().zip(span(k).filter(|&i| valid(i))) {
                let a = angle_deg(r[i], t[i]);
                if a > max {
                    (worst, max) = (i, a);
                }
                *slot = a;
            }
            (max, worst)
        })
        .collect();
    let (max, worst) = maxima.into_iter().fold((-1.0f64, 0usize), |m, c| if c.0 > m.0 { c } else { m });
    let mean = angles.iter().sum::<f64>() / angles.len() as f64;
    let k = ((angles.len() as f64 * 0.95).ceil() as usize).clamp(1, angles.len()) - 1;
    let (_, p95, _) = angles.select_nth_unstable_by(k, f64::total_cmp);
    NormalErrors { mean_deg: mean, p95_deg: *p95, max_deg: max, worst: at(gb, worst), skipped_invalid }
}

fn depth(gb: &GBuffer, covered: Covered<'_>, r: &[f32], t: &[f32], nonfinite: &mut u64) -> DepthErrors {
    let mut e = DepthErrors::default();
    let mut n = 0u64;
    let mut sum = 0.0;
    for i in covered.iter() {
        let (a, b) = (f64::from(r[i]), f64::from(t[i]));
        if !b.is_finite() || !a.is_finite() {
            *nonfinite += 1;
            continue;
        }
        let abs = (b - a).abs();
        let rel = abs / a.abs().max(f64::from(f32::MIN_POSITIVE));
        n += 1;
        sum += rel;
        e.abs_max = e.abs_max.max(abs);
        if rel > e.rel_max {
            e.rel_max = rel;
            e.worst = at(gb, i);
        }
    }
    e.rel_mean = if n > 0 { sum / n as f64 } else { 0.0 };
    e
}

fn values(
    gb: &GBuffer,
    attr: Attribute,
    covered: Covered<'_>,
    get: impl Fn(usize) -> ([f32; 3], [f32; 3]),
    nonfinite: &mut u64,
) -> ValueErrors {
    let nc = attr.components();
    let mut e = ValueErrors { attribute: attr.name().into(), ..Default::default() };
    let (mut n, mut sum, mut sum2) = (0u64, 0.0, 0.0);
    for i in covered.iter() {
        let (a, b) = get(i);
        for c in 0..nc {
            let d = (f64::from(b[c]) - f64::from(a[c])).abs();
            if !d.is_finite() {
                *nonfinite += 1;
                continue;
            }
            n += 1;
            sum += d;
            sum2 += d * d;
            if d > e.max_abs {
                e.max_abs = d;
                e.worst = at(gb, i);
            }
        }
    }
    if n > 0 {
        e.mean_abs = sum / n as f64;
        e.rmse = (sum2 / n as f64).sqrt();
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair() -> (GBuffer, GBuffer) {
        let mut a = GBuffer::new(4, 3, 2).unwrap();
        a.coverage = vec![true; a.len()];
        a.coverage[0] = false;
        a.normal = Some(vec![Vec3::Z; a.len()]);
        a.depth = Some(vec![10.0; a.len()]);
        a.albedo = Some(vec![Vec3::splat(0.5); a.len()]);
        a.roughness = Some(vec![0.25; a.len()]);
        a.object_id = Some((0..a.len() as u32).collect());
        (a.clone(), a)
    }

    /// Over several chunks, with uncovered samples, invalid reference normals and the largest angle reached twice
    /// in different chunks: the numbers of one loop in sample order, bit for bit, on 1 and 2 threads.
    #[test]
    fn normal_errors_over_chunks_equal_one_loop_in_sample_order() {
        let mut a = GBuffer::new(300, 120, 4).unwrap();
        assert!(a.len() > 2 * NORMAL_CHUNK);
        let mut rng = crate::util::SplitMix64::new(11);
        a.coverage = (0..a.len()).map(|i| i % 7 != 3).collect();
        a.normal = Some((0..a.len()).map(|_| Vec3::new(rng.range_f32(-0.2, 0.2), 0.1, 1.0).normalize()).collect());
        let mut b = a.clone();
        for n in b.normal.as_mut().unwrap() {
            *n = (*n + Vec3::new(rng.range_f32(-0.01, 0.01), 0.0, 0.0)).normalize();
        }
        let (first, second) = (NORMAL_CHUNK + 5, 2 * NORMAL_CHUNK + 9);
        {
            let (rn, tn) = (a.normal.as_mut().unwrap(), b.normal.as_mut().unwrap());
            rn[11] = Vec3::ZERO; // invalid: skipped
            rn[NORMAL_CHUNK + 2] = Vec3::new(0.0, 0.0, 3.0); // invalid: skipped
            for i in [first, second] {
                (rn[i], tn[i]) = (Vec3::Z, Vec3::X); // 90°, the largest, twice
            }
        }
        let (rn, tn) = (a.normal.as_deref().unwrap(), b.normal.as_deref().unwrap());
        let (mut angles, mut skipped, mut max, mut worst) = (Vec::new(), 0u64, -1.0f64, 0usize);
        for i in (0..a.len()).filter(|&i| a.coverage[i]) {
            if !crate::io::plausible::normal_is_valid(rn[i]) {
                skipped += 1;
                continue;
            }
            let x = angle_deg(rn[i], tn[i]);
            if x > max {
                (worst, max) = (i, x);
            }
            angles.push(x);
        }
        let mean = angles.iter().sum::<f64>() / angles.len() as f64;
        let k = ((angles.len() as f64 * 0.95).ceil() as usize).clamp(1, angles.len()) - 1;
        let p95 = *angles.select_nth_unstable_by(k, f64::total_cmp).1;
        assert_eq!((worst, skipped), (first, 2));
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let e = pool.install(|| normals(&a, Covered(&a.coverage), rn, tn));
            assert_eq!(e.mean_deg.to_bits(), mean.to_bits(), "{threads} threads");
            assert_eq!((e.p95_deg, e.max_deg, e.skipped_invalid), (p95, max, skipped));
            assert_eq!(e.worst, at(&a, worst));
        }
    }

    #[test]
    fn identical_buffers_have_zero_error() {
        let (a, b) = pair();
        let e = compare(&a, &b).unwrap();
        assert_eq!(e.covered_samples, 23);
        assert_eq!(e.normal.as_ref().unwrap().max_deg, 0.0);
        assert_eq!(e.depth.as_ref().unwrap().rel_max, 0.0);
        assert_eq!(e.albedo.as_ref().unwrap().max_abs, 0.0);
        assert_eq!(e.id(Attribute::ObjectId).unwrap().mismatches, 0);
        assert!(e.missing.is_empty());
    }

    #[test]
    fn worst_samples_are_located() {
        let (a, mut b) = pair();
        let i = a.index(3, 2, 1);
        b.normal.as_mut().unwrap()[i] = Vec3::X;
        b.depth.as_mut().unwrap()[a.index(1, 1, 0)] = 11.0;
        b.roughness.as_mut().unwrap()[a.index(2, 0, 1)] = 0.5;
        b.object_id.as_mut().unwrap()[a.index(1, 0, 0)] = 999;
        b.object_id.as_mut().unwrap()[0] = 999; // background: ignored
        let e = compare(&a, &b).unwrap();
        let n = e.normal.unwrap();
        assert!((n.max_deg - 90.0).abs() < 1e-9);
        assert_eq!(n.worst, SampleAt { x: 3, y: 2, sample: 1 });
        assert!((n.mean_deg - 90.0 / 23.0).abs() < 1e-9);
        assert_eq!(n.p95_deg, 0.0); // one outlier in 23 is above the 95th percentile
        let d = e.depth.unwrap();
        assert!((d.rel_max - 0.1).abs() < 1e-9);
        assert_eq!(d.worst, SampleAt { x: 1, y: 1, sample: 0 });
        assert_eq!(e.scalars[0].attribute, "roughness");
        assert_eq!(e.scalars[0].max_abs, 0.25);
        assert_eq!(e.scalars[0].worst, SampleAt { x: 2, y: 0, sample: 1 });
        let ids = e.ids[0].clone();
        assert_eq!((ids.mismatches, ids.first), (1, Some(SampleAt { x: 1, y: 0, sample: 0 })));
    }

    /// The attributes are measured in parallel: the same numbers, bit for bit, on 1 thread and on 3.
    #[test]
    fn numbers_do_not_depend_on_the_thread_count() {
        let (a, mut b) = pair();
        let mut rng = crate::util::SplitMix64::new(5);
        for n in b.normal.as_mut().unwrap() {
            *n = Vec3::new(rng.range_f32(-0.3, 0.3), rng.range_f32(-0.3, 0.3), 1.0).normalize();
        }
        for d in b.depth.as_mut().unwrap() {
            *d = rng.range_f32(9.0, 11.0);
        }
        b.roughness.as_mut().unwrap()[5] = f32::NAN;
        b.object_id.as_mut().unwrap()[7] = 1234;
        let on = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| compare(&a, &b).unwrap())
        };
        let one = on(1);
        assert_eq!(one, on(3));
        assert!(one.normal.as_ref().unwrap().mean_deg > 0.0 && one.nonfinite == 1 && one.ids[0].mismatches == 1);
    }

    #[test]
    fn tiny_angles_are_accurate_and_nan_is_worst() {
        let a = Vec3::Z;
        let b = Vec3::new(1e-4, 0.0, 1.0).normalize();
        assert!((angle_deg(a, b) - 1e-4f64.atan().to_degrees()).abs() < 1e-9);
        assert_eq!(angle_deg(a, Vec3::NAN), 180.0);
        assert_eq!(angle_deg(Vec3::ZERO, Vec3::ZERO), 0.0);
        let (r, mut t) = pair();
        t.albedo.as_mut().unwrap()[5] = Vec3::NAN;
        t.remove(Attribute::Roughness);
        let e = compare(&r, &t).unwrap();
        assert_eq!(e.nonfinite, 3);
        assert_eq!(e.missing, ["roughness"]);
        assert!(serde_json::to_string(&e).is_ok());
    }

    #[test]
    fn mismatched_geometry_is_an_error() {
        let (a, _) = pair();
        let b = GBuffer::new(3, 3, 2).unwrap();
        assert!(compare(&a, &b).is_err());
    }
}
