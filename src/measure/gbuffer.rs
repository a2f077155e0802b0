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
        return Err(Error::Mismatch(format!(
            "compare: reference is {}×{}×{}, test is {}×{}×{}",
            reference.width, reference.height, reference.samples, test.width, test.height, test.samples
        )));
    }
    let mut bands = CompareBands::new(reference)?;
    bands.add(0, test)?;
    Ok(bands.finish())
}

/// [`compare`] fed a band of rows at a time (a test G-buffer decoded band by band never exists whole): bands added
/// in row order and covering the frame give [`compare`]'s numbers bit for bit, because every statistic is one loop
/// in sample order carried from band to band (sums, first worst sample) or taken over the list of every angle
/// (the normals' 95th percentile: 8 bytes per covered sample, not the test's planes).
pub struct CompareBands<'a> {
    reference: &'a GBuffer,
    /// Per attribute of the reference, in canonical order: its running measure, `None` when the test lacks it
    /// (set by the first band).
    measures: Option<Vec<(Attribute, Option<Running>)>>,
    /// Samples added so far: the next band must start here.
    next: usize,
}

/// One attribute's statistics so far.
enum Running {
    Normal { angles: Vec<f64>, max: f64, worst: usize, skipped: u64 },
    Depth { n: u64, sum: f64, e: DepthErrors, nonfinite: u64 },
    Id(IdErrors),
    Values { n: u64, sum: f64, sum2: f64, e: ValueErrors, nonfinite: u64 },
}

impl<'a> CompareBands<'a> {
    /// Starts comparing against `reference`.
    pub fn new(reference: &'a GBuffer) -> Result<Self> {
        reference.validate()?;
        Ok(CompareBands { reference, measures: None, next: 0 })
    }

    /// Adds `test`, the reference's samples `start..start + test.len()` (whole rows, the band after the last one
    /// added). Errors when the band does not fit.
    pub fn add(&mut self, start: usize, test: &GBuffer) -> Result<()> {
        let r = self.reference;
        if (test.width, test.samples) != (r.width, r.samples) || start != self.next || start + test.len() > r.len() {
            return Err(Error::Mismatch(format!(
                "compare: a band of {}×{}×{} at sample {start} does not continue the {}×{}×{} reference at sample {}",
                test.width, test.height, test.samples, r.width, r.height, r.samples, self.next
            )));
        }
        test.validate()?;
        let measures = self.measures.get_or_insert_with(|| {
            r.attributes()
                .into_iter()
                .map(|a| {
                    let running = test.plane(a).map(|t| match (a, t) {
                        // Room for every covered sample's angle at once: grown band by band, the vector was copied
                        // at each doubling (twice its 44 MB at 1080p × 4 while it moved, and fresh pages each time).
                        (Attribute::Normal, PlaneRef::Vec3(_)) => Running::Normal {
                            angles: Vec::with_capacity(r.len() - r.background_samples()),
                            max: -1.0,
                            worst: 0,
                            skipped: 0,
                        },
                        (Attribute::Depth, PlaneRef::F32(_)) => {
                            Running::Depth { n: 0, sum: 0.0, e: DepthErrors::default(), nonfinite: 0 }
                        }
                        (_, PlaneRef::U32(_)) => {
                            Running::Id(IdErrors { attribute: a.name().into(), ..Default::default() })
                        }
                        _ => Running::Values {
                            n: 0,
                            sum: 0.0,
                            sum2: 0.0,
                            e: ValueErrors { attribute: a.name().into(), ..Default::default() },
                            nonfinite: 0,
                        },
                    });
                    (a, running)
                })
                .collect()
        });
        let range = start..start + test.len();
        let covered = Covered { flags: &r.coverage[range.clone()], base: start };
        // Attributes are measured in parallel, each by the same sequential loop as alone (the numbers do not
        // depend on the thread count).
        measures.par_iter_mut().try_for_each(|(attr, running)| {
            let Some(running) = running else { return Ok(()) };
            let (Some(rp), Some(tp)) = (r.plane(*attr), test.plane(*attr)) else {
                return Err(Error::Mismatch(format!("compare: a band lacks the {} plane", attr.name())));
            };
            match (running, rp, tp) {
                (Running::Normal { angles, max, worst, skipped }, PlaneRef::Vec3(rv), PlaneRef::Vec3(tv)) => {
                    normals(covered, &rv[range.clone()], tv, angles, (max, worst), skipped);
                }
                (Running::Depth { n, sum, e, nonfinite }, PlaneRef::F32(rv), PlaneRef::F32(tv)) => {
                    depth(r, covered, &rv[range.clone()], tv, (n, sum), e, nonfinite);
                }
                (Running::Id(e), PlaneRef::U32(rv), PlaneRef::U32(tv)) => {
                    let rv = &rv[range.clone()];
                    for i in covered.iter() {
                        if rv[i] != tv[i] {
                            e.mismatches += 1;
                            e.first.get_or_insert(at(r, start + i));
                        }
                    }
                }
                (Running::Values { n, sum, sum2, e, nonfinite }, rp, tp) => {
                    let comps = |p: PlaneRef<'_>, i: usize| -> [f32; 3] {
                        match p {
                            PlaneRef::F32(p) => [p[i], 0.0, 0.0],
                            PlaneRef::Vec2(p) => [p[i].x, p[i].y, 0.0],
                            PlaneRef::Vec3(p) => p[i].to_array(),
                            PlaneRef::U32(p) => [p[i] as f32, 0.0, 0.0],
                        }
                    };
                    let get = |i: usize| (comps(rp, start + i), comps(tp, i));
                    values(r, *attr, covered, get, (n, sum, sum2), e, nonfinite);
                }
                _ => return Err(Error::Mismatch(format!("compare: the {} planes differ in kind", attr.name()))),
            }
            Ok(())
        })?;
        self.next = range.end;
        Ok(())
    }

    /// The errors over every band added.
    #[must_use]
    pub fn finish(self) -> AttributeErrors {
        let r = self.reference;
        let mut out =
            AttributeErrors { covered_samples: r.coverage.iter().filter(|&&c| c).count() as u64, ..Default::default() };
        for (attr, running) in self.measures.unwrap_or_default() {
            let Some(running) = running else {
                out.missing.push(attr.name().to_string());
                continue;
            };
            match running {
                Running::Normal { mut angles, max, worst, skipped } => {
                    out.normal = Some(if angles.is_empty() {
                        NormalErrors { skipped_invalid: skipped, ..NormalErrors::default() }
                    } else {
                        let mean = angles.iter().sum::<f64>() / angles.len() as f64;
                        let k = ((angles.len() as f64 * 0.95).ceil() as usize).clamp(1, angles.len()) - 1;
                        let (_, p95, _) = angles.select_nth_unstable_by(k, f64::total_cmp);
                        NormalErrors {
                            mean_deg: mean,
                            p95_deg: *p95,
                            max_deg: max,
                            worst: at(r, worst),
                            skipped_invalid: skipped,
                        }
                    });
                }
                Running::Depth { n, sum, mut e, nonfinite } => {
                    e.rel_mean = if n > 0 { sum / n as f64 } else { 0.0 };
                    out.nonfinite += nonfinite;
                    out.depth = Some(e);
                }
                Running::Id(e) => out.ids.push(e),
                Running::Values { n, sum, sum2, mut e, nonfinite } => {
                    if n > 0 {
                        e.mean_abs = sum / n as f64;
                        e.rmse = (sum2 / n as f64).sqrt();
                    }
                    out.nonfinite += nonfinite;
                    match attr {
                        Attribute::Albedo => out.albedo = Some(e),
                        Attribute::Position => out.position = Some(e),
                        Attribute::Motion => out.motion = Some(e),
                        _ => out.scalars.push(e),
                    }
                }
            }
        }
        out
    }
}

/// The covered samples of a band, by index within the band, without a list of them (a 1080p × 4 dump has 8.3
/// million); `base` is the band's first sample in the frame.
#[derive(Clone, Copy)]
struct Covered<'a> {
    flags: &'a [bool],
    base: usize,
}

impl<'a> Covered<'a> {
    fn iter(self) -> impl Iterator<Item = usize> + 'a {
        self.flags.iter().enumerate().filter_map(|(i, &c)| c.then_some(i))
    }
}

/// Samples per chunk of [`normals`]' parallel passes.
const NORMAL_CHUNK: usize = 1 << 16;

/// Appends a band's normal angles to `angles` in two parallel passes over fixed chunks of samples: the valid
/// normals per chunk, then each chunk's angles into its own part of the list (the list's order, the first sample
/// of the largest angle and so every statistic are those of one loop in sample order, whatever the thread count).
/// `r` and `t` are the band's planes; `max` and `worst` (a frame sample index) carry the largest angle so far.
fn normals(
    covered: Covered<'_>,
    r: &[Vec3],
    t: &[Vec3],
    angles: &mut Vec<f64>,
    (max, worst): (&mut f64, &mut usize),
    skipped: &mut u64,
) {
    let len = covered.flags.len();
    let chunks = len.div_ceil(NORMAL_CHUNK);
    let span = |k: usize| k * NORMAL_CHUNK..((k + 1) * NORMAL_CHUNK).min(len);
    let valid = |i: usize| covered.flags[i] && crate::io::plausible::normal_is_valid(r[i]);
    let counts: Vec<usize> = (0..chunks).into_par_iter().map(|k| span(k).filter(|&i| valid(i)).count()).collect();
    let total: usize = counts.iter().sum();
    *skipped += (covered.iter().count() - total) as u64;
    let old = angles.len();
    angles.resize(old + total, 0.0);
    let mut parts = Vec::with_capacity(chunks);
    let mut rest = &mut angles[old..];
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
                    (worst, max) = (covered.base + i, a);
                }
                *slot = a;
            }
            (max, worst)
        })
        .collect();
    for (m, w) in maxima {
        if m > *max {
            (*max, *worst) = (m, w);
        }
    }
}

fn depth(
    gb: &GBuffer,
    covered: Covered<'_>,
    r: &[f32],
    t: &[f32],
    (n, sum): (&mut u64, &mut f64),
    e: &mut DepthErrors,
    nonfinite: &mut u64,
) {
    for i in covered.iter() {
        let (a, b) = (f64::from(r[i]), f64::from(t[i]));
        if !b.is_finite() || !a.is_finite() {
            *nonfinite += 1;
            continue;
        }
        let abs = (b - a).abs();
        let rel = abs / a.abs().max(f64::from(f32::MIN_POSITIVE));
        *n += 1;
        *sum += rel;
        e.abs_max = e.abs_max.max(abs);
        if rel > e.rel_max {
            e.rel_max = rel;
            e.worst = at(gb, covered.base + i);
        }
    }
}

fn values(
    gb: &GBuffer,
    attr: Attribute,
    covered: Covered<'_>,
    get: impl Fn(usize) -> ([f32; 3], [f32; 3]),
    (n, sum, sum2): (&mut u64, &mut f64, &mut f64),
    e: &mut ValueErrors,
    nonfinite: &mut u64,
) {
    let nc = attr.components();
    for i in covered.iter() {
        let (a, b) = get(i);
        for c in 0..nc {
            let d = (f64::from(b[c]) - f64::from(a[c])).abs();
            if !d.is_finite() {
                *nonfinite += 1;
                continue;
            }
            *n += 1;
            *sum += d;
            *sum2 += d * d;
            if d > e.max_abs {
                e.max_abs = d;
                e.worst = at(gb, covered.base + i);
            }
        }
    }
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
        let mut rng = crate::base::rng::SplitMix64::new(11);
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
            let e = pool.install(|| compare(&a, &b).unwrap().normal.unwrap());
            assert_eq!(e.mean_deg.to_bits(), mean.to_bits(), "{threads} threads");
            assert_eq!((e.p95_deg, e.max_deg, e.skipped_invalid), (p95, max, skipped));
            assert_eq!(e.worst, at(&a, worst));
        }
    }

    /// Bands of any height, added in order, give the whole comparison's numbers bit for bit; a band out of order or
    /// of another width is refused.
    #[test]
    fn bands_in_order_equal_the_whole_comparison() {
        let mut a = GBuffer::new(61, 23, 4).unwrap();
        let mut rng = crate::base::rng::SplitMix64::new(3);
        let n = a.len();
        a.coverage = (0..n).map(|i| i % 9 != 2).collect();
        a.normal = Some((0..n).map(|_| Vec3::new(rng.range_f32(-0.5, 0.5), 0.2, 1.0).normalize()).collect());
        a.depth = Some((0..n).map(|_| rng.range_f32(1.0, 50.0)).collect());
        a.albedo = Some((0..n).map(|_| Vec3::splat(rng.next_f32())).collect());
        a.object_id = Some((0..n as u32).collect());
        let mut b = a.clone();
        for (i, v) in b.normal.as_mut().unwrap().iter_mut().enumerate() {
            *v = (*v + Vec3::new(rng.range_f32(-0.05, 0.05), 0.0, 0.0)).normalize();
            if i == 777 {
                *v = Vec3::NAN;
            }
        }
        for d in b.depth.as_mut().unwrap() {
            *d *= 1.0 + rng.range_f32(-1e-3, 1e-3);
        }
        b.albedo.as_mut().unwrap()[1000] = Vec3::new(f32::INFINITY, 0.0, 0.0);
        b.object_id.as_mut().unwrap()[500] = 7;
        let whole = compare(&a, &b).unwrap();
        let row = (a.width * a.samples) as usize;
        for rows in [1, 5, 8, 23] {
            let mut bands = CompareBands::new(&a).unwrap();
            let mut y = 0;
            while y < a.height {
                let h = rows.min(a.height - y);
                let range = y as usize * row..(y + h) as usize * row;
                let band = b.map_planes(
                    (b.width, h, b.samples),
                    b.sample_positions.clone(),
                    b.coverage[range.clone()].to_vec(),
                    &mut Crop(range.clone()),
                );
                bands.add(range.start, &band).unwrap();
                y += h;
            }
            let banded = bands.finish();
            assert_eq!(banded, whole, "bands of {rows} rows");
            assert_eq!(
                banded.normal.as_ref().unwrap().mean_deg.to_bits(),
                whole.normal.as_ref().unwrap().mean_deg.to_bits()
            );
        }
        let mut bands = CompareBands::new(&a).unwrap();
        let band = b.map_planes(
            (b.width, 1, b.samples),
            b.sample_positions.clone(),
            b.coverage[row..2 * row].to_vec(),
            &mut Crop(row..2 * row),
        );
        assert!(bands.add(row, &band).is_err(), "a band that does not start where the last one ended");
    }

    /// Crops every plane to a range of samples.
    struct Crop(std::ops::Range<usize>);

    impl crate::gbuffer::PlaneMapper for Crop {
        fn map<T: Copy + Default + Send + Sync>(&mut self, _: Attribute, plane: &[T]) -> Option<Vec<T>> {
            Some(plane[self.0.clone()].to_vec())
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
        let mut rng = crate::base::rng::SplitMix64::new(5);
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
