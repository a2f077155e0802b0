//! Two images compared as a person and a script need it (`gbuf compare`): FLIP's pooled statistics as NVIDIA's
//! FLIP tool prints them, the numerical errors, and thresholds with `idiff`'s exit convention.
//!
//! **Pooled FLIP** (NVIDIA's `FLIPPooling::pooling`, `src/cpp/tool/pooling.h` of NVlabs/flip): the mean; the
//! *weighted* median and 1st/3rd quartiles, where each pixel weighs its own error (sort the errors; the percentile
//! p is the first error at which the running sum of errors exceeds p × their total); the min and max with the first
//! pixel (row-major) that has them; and the 100-bucket histogram over [0, 1] (bucket ⌊e / 0.01⌋, 1.0 in the last).
//! NVIDIA sums in `float`; we sum in f64, which moves the mean of a 1080p map by up to ~1e-4 from the tool's
//! printout (`FlipMap::mean_f32_sequential` reproduces the tool's float sum where that matters).
//!
//! **Numerical errors** on the values as the files hold them (linear radiance for EXR, display values for PNG):
//! RMSE, PSNR (peak: the reference's largest value), the largest absolute difference and where, tev's relative MSE
//! (the mean over channels of `(t − r)² / (r² + 0.01)`, tev's `RelativeSquaredError`) and the normalised MSE
//! `Σ(t − r)² / Σ r²` (what gbuf's reports call `rel_mse`).

use super::flip::{self, FlipMap};
use crate::image::file::{ImageFile, ImageKind};
use crate::image::HdrImage;
use serde::Serialize;

/// Buckets of the FLIP histogram (NVIDIA's tool: 100 over [0, 1]).
pub const HISTOGRAM_BUCKETS: usize = 100;

/// FLIP's pooled statistics of one error map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Pooled {
    /// Mean error (f64 sum).
    pub mean: f64,
    /// Weighted median (each pixel weighs its error).
    pub weighted_median: f64,
    /// 1st weighted quartile.
    pub weighted_q1: f64,
    /// 3rd weighted quartile.
    pub weighted_q3: f64,
    /// Smallest error.
    pub min: f64,
    /// Largest error.
    pub max: f64,
    /// First pixel (x, y) with the smallest error.
    pub min_at: [u32; 2],
    /// First pixel (x, y) with the largest error.
    pub max_at: [u32; 2],
    /// Pixels per bucket of width 0.01 over [0, 1].
    pub histogram: Vec<u64>,
}

/// The pooled statistics of `map` as NVIDIA's FLIP tool computes them (see the module doc). An empty map gives
/// zeros.
#[must_use]
pub fn pooled(map: &FlipMap) -> Pooled {
    let v = &map.values;
    let mut histogram = vec![0u64; HISTOGRAM_BUCKETS];
    let bucket = f64::from(1.0f32 / HISTOGRAM_BUCKETS as f32);
    let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
    let (mut min_i, mut max_i) = (0usize, 0usize);
    let mut sum = 0.0f64;
    for (i, &e) in v.iter().enumerate() {
        sum += f64::from(e);
        if e < min {
            min = e;
            min_i = i;
        }
        if e > max {
            max = e;
            max_i = i;
        }
        if (0.0..=1.0).contains(&e) {
            histogram[((f64::from(e) / bucket) as usize).min(HISTOGRAM_BUCKETS - 1)] += 1;
        }
    }
    if v.is_empty() {
        return Pooled {
            mean: 0.0,
            weighted_median: 0.0,
            weighted_q1: 0.0,
            weighted_q3: 0.0,
            min: 0.0,
            max: 0.0,
            min_at: [0, 0],
            max_at: [0, 0],
            histogram,
        };
    }
    let mut sorted = v.clone();
    sorted.sort_unstable_by(f32::total_cmp);
    let weighted = |p: f64| {
        let target = p * sum;
        let mut running = 0.0f64;
        for &e in &sorted {
            running += f64::from(e);
            if running > target {
                return f64::from(e);
            }
        }
        0.0
    };
    let at = |i: usize| [(i % map.width) as u32, (i / map.width) as u32];
    Pooled {
        mean: sum / v.len() as f64,
        weighted_median: weighted(0.5),
        weighted_q1: weighted(0.25),
        weighted_q3: weighted(0.75),
        min: f64::from(min),
        max: f64::from(max),
        min_at: at(min_i),
        max_at: at(max_i),
        histogram,
    }
}

/// Which FLIP to compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlipMode {
    /// LDR-FLIP for PNG pairs, HDR-FLIP for EXR pairs (NVIDIA's tool's choice).
    #[default]
    Auto,
    /// LDR-FLIP: a PNG's sRGB values as they are; an EXR's values tone-mapped and exposed as `gbuf resolve --png`.
    Ldr,
    /// HDR-FLIP of linear values (EXR; a PNG is sRGB-decoded first), exposures from the reference.
    Hdr,
    /// Both.
    Both,
    /// No FLIP (numerical errors only).
    None,
}

crate::named!(FlipMode: "FLIP mode" {
    Auto => "auto",
    Ldr => "ldr",
    Hdr => "hdr",
    Both => "both",
    None => "none",
});

/// The numerical errors of a pair (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Numeric {
    /// Root mean square error over every channel value.
    pub rmse: f64,
    /// PSNR in dB with the peak below ([`super::image::PSNR_CAP_DB`] for identical images).
    pub psnr_db: f64,
    /// The PSNR peak: the reference's largest channel value (1 when it is black).
    pub psnr_peak: f64,
    /// Largest absolute channel difference.
    pub max_abs: f64,
    /// First pixel (x, y) with it.
    pub max_abs_at: [u32; 2],
    /// tev's relative MSE: mean over channels of `(t − r)² / (r² + 0.01)`.
    pub rel_mse: f64,
    /// `Σ(t − r)² / Σ r²` (gbuf's reports call it `rel_mse`).
    pub nmse: f64,
}

/// The numerical errors of `test` against `reference` (same size).
#[must_use]
pub fn numeric(reference: &HdrImage, test: &HdrImage) -> Numeric {
    let base = super::image::compare(reference, test);
    let (mut tev, mut max, mut max_i) = (0.0f64, -1.0f64, 0usize);
    for (i, (r, t)) in reference.rgb.iter().zip(&test.rgb).enumerate() {
        for k in 0..3 {
            let (a, b) = (f64::from(r[k]), f64::from(t[k]));
            let d = b - a;
            // tev computes in float: (t − r)² / (r² + 0.01f).
            tev += f64::from((t[k] - r[k]) * (t[k] - r[k]) / (r[k] * r[k] + 0.01));
            if d.abs() > max {
                max = d.abs();
                max_i = i;
            }
        }
    }
    let n = (reference.rgb.len() * 3).max(1) as f64;
    let w = reference.width.max(1) as usize;
    Numeric {
        rmse: base.rmse,
        psnr_db: base.psnr_db,
        psnr_peak: base.peak,
        max_abs: base.max_abs,
        max_abs_at: [(max_i % w) as u32, (max_i / w) as u32],
        rel_mse: tev / n,
        nmse: base.rel_mse,
    }
}

/// How to compare.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareOptions {
    /// Which FLIP.
    pub flip: FlipMode,
    /// How an EXR is shown for LDR-FLIP, and the viewer's pixels per degree for both.
    pub viewing: super::image::Viewing,
}

/// The comparison of two images.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Width and height.
    pub size: [u32; 2],
    /// What the values are (both files are of this kind).
    pub kind: ImageKind,
    /// The numerical errors.
    pub numeric: Numeric,
    /// LDR-FLIP's pooled statistics, when computed.
    pub flip_ldr: Option<Pooled>,
    /// HDR-FLIP's pooled statistics, when computed.
    pub flip_hdr: Option<Pooled>,
    /// The pixels per degree FLIP used.
    pub pixels_per_degree: f32,
    /// The FLIP maps (LDR, HDR), for writing; not serialised.
    #[serde(skip)]
    pub maps: (Option<FlipMap>, Option<FlipMap>),
}

/// Why two images cannot be compared.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Incomparable {
    /// Different widths or heights.
    Size([u32; 2], [u32; 2]),
    /// One is HDR, the other LDR.
    Kind(ImageKind, ImageKind),
}

impl std::fmt::Display for Incomparable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Incomparable::Size(a, b) => write!(f, "the images differ in size: {}×{} and {}×{}", a[0], a[1], b[0], b[1]),
            Incomparable::Kind(a, b) => {
                let name = |k: &ImageKind| match k {
                    ImageKind::Hdr => "HDR (linear, EXR)",
                    ImageKind::Ldr => "LDR (sRGB display values, PNG)",
                };
                write!(
                    f,
                    "the reference is {} and the test {}: compare an EXR with an EXR and a PNG with a PNG \
                     (`gbuf resolve` writes both, `-o OUT.exr --png OUT.png`)",
                    name(a),
                    name(b)
                )
            }
        }
    }
}

/// Compares `test` against `reference`.
///
/// # Errors
/// [`Incomparable`] when their sizes or kinds differ.
pub fn compare(reference: &ImageFile, test: &ImageFile, opts: &CompareOptions) -> Result<Comparison, Incomparable> {
    let (r, t) = (&reference.image, &test.image);
    if (r.width, r.height) != (t.width, t.height) {
        return Err(Incomparable::Size([r.width, r.height], [t.width, t.height]));
    }
    if reference.kind != test.kind {
        return Err(Incomparable::Kind(reference.kind, test.kind));
    }
    let kind = reference.kind;
    let (ldr, hdr) = match opts.flip {
        FlipMode::None => (false, false),
        FlipMode::Ldr => (true, false),
        FlipMode::Hdr => (false, true),
        FlipMode::Both => (true, true),
        FlipMode::Auto => (kind == ImageKind::Ldr, kind == ImageKind::Hdr),
    };
    let (w, h) = (r.width as usize, r.height as usize);
    let fo = flip::FlipOptions { pixels_per_degree: opts.viewing.pixels_per_degree };
    let floats = |img: &HdrImage| -> Vec<f32> { bytemuck::cast_slice(&img.rgb).to_vec() };
    let ldr_map = ldr.then(|| match kind {
        ImageKind::Ldr => flip::ldr_flip(&floats(r), &floats(t), w, h, &fo),
        ImageKind::Hdr => {
            let shown = |img: &HdrImage| -> Vec<f32> {
                img.to_srgb8(opts.viewing.tone()).iter().map(|&b| f32::from(b) / 255.0).collect()
            };
            flip::ldr_flip(&shown(r), &shown(t), w, h, &fo)
        }
    });
    let hdr_map = hdr.then(|| {
        let linear = |img: &HdrImage| -> Vec<f32> {
            let v = floats(img);
            match kind {
                ImageKind::Hdr => v.into_iter().map(|x| x.max(0.0)).collect(),
                ImageKind::Ldr => v.into_iter().map(crate::base::picture::srgb_decode).collect(),
            }
        };
        flip::hdr_flip(&linear(r), &linear(t), w, h, &fo).map
    });
    Ok(Comparison {
        size: [r.width, r.height],
        kind,
        numeric: numeric(r, t),
        flip_ldr: ldr_map.as_ref().map(pooled),
        flip_hdr: hdr_map.as_ref().map(pooled),
        pixels_per_degree: opts.viewing.pixels_per_degree,
        maps: (ldr_map, hdr_map),
    })
}

/// A measure a threshold can gate on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gate {
    /// Mean FLIP (HDR when computed, else LDR).
    Flip,
    /// Mean LDR-FLIP.
    FlipLdr,
    /// Mean HDR-FLIP.
    FlipHdr,
    /// Weighted median FLIP (HDR when computed, else LDR).
    FlipMedian,
    /// Largest FLIP error.
    FlipMax,
    /// RMSE.
    Rmse,
    /// tev's relative MSE.
    RelMse,
    /// Normalised MSE.
    Nmse,
    /// Largest absolute difference.
    MaxAbs,
}

crate::named!(Gate: "measure" {
    Flip => "flip",
    FlipLdr => "flip-ldr",
    FlipHdr => "flip-hdr",
    FlipMedian => "flip-median",
    FlipMax => "flip-max",
    Rmse => "rmse",
    RelMse => "rel-mse",
    Nmse => "nmse",
    MaxAbs => "max-abs",
});

impl Comparison {
    /// The value of `g`, `None` when it was not computed (a FLIP that was not asked for).
    #[must_use]
    pub fn value(&self, g: Gate) -> Option<f64> {
        let main = self.flip_hdr.as_ref().or(self.flip_ldr.as_ref());
        match g {
            Gate::Flip => main.map(|p| p.mean),
            Gate::FlipLdr => self.flip_ldr.as_ref().map(|p| p.mean),
            Gate::FlipHdr => self.flip_hdr.as_ref().map(|p| p.mean),
            Gate::FlipMedian => main.map(|p| p.weighted_median),
            Gate::FlipMax => main.map(|p| p.max),
            Gate::Rmse => Some(self.numeric.rmse),
            Gate::RelMse => Some(self.numeric.rel_mse),
            Gate::Nmse => Some(self.numeric.nmse),
            Gate::MaxAbs => Some(self.numeric.max_abs),
        }
    }
}

/// Parses `flip=0.05,rmse=0.01`: measures and the value each may not exceed.
///
/// # Errors
/// A message naming the bad entry.
pub fn parse_gates(s: &str) -> Result<Vec<(Gate, f64)>, String> {
    s.split(',')
        .filter(|e| !e.trim().is_empty())
        .map(|e| {
            let (k, v) = e.split_once('=').ok_or_else(|| format!("{e:?}: expected MEASURE=VALUE, e.g. flip=0.05"))?;
            let g: Gate = k.trim().parse()?;
            let v: f64 = v.trim().parse().map_err(|_| format!("{e:?}: {v:?} is not a number"))?;
            if !v.is_finite() {
                return Err(format!("{e:?}: the threshold must be finite"));
            }
            Ok((g, v))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(values: Vec<f32>, width: usize) -> FlipMap {
        let height = values.len() / width;
        let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64;
        FlipMap { width, height, values, mean }
    }

    #[test]
    fn weighted_percentiles_weigh_each_pixel_by_its_error() {
        // Errors 0.1, 0.2, 0.3, 0.4: total 1.0; the running sums 0.1, 0.3, 0.6, 1.0 first exceed 0.5 at 0.3,
        // 0.25 at 0.2, 0.75 at 0.4 (the unweighted median would be 0.2 or 0.3).
        let p = pooled(&map(vec![0.4, 0.1, 0.3, 0.2], 2));
        assert_eq!((p.weighted_q1, p.weighted_median, p.weighted_q3), (0.2f32.into(), 0.3f32.into(), 0.4f32.into()));
        assert_eq!((p.min_at, p.max_at), ([1, 0], [0, 0]));
        assert!((p.mean - 0.25).abs() < 1e-7, "{}", p.mean);
        assert_eq!(p.histogram.iter().sum::<u64>(), 4);
        assert_eq!(p.histogram[10] + p.histogram[9], 1, "0.1f32 lands in bucket 9 or 10 by its f32 rounding");
    }

    #[test]
    fn the_largest_error_goes_in_the_last_bucket() {
        let p = pooled(&map(vec![1.0, 0.0, 0.999, 0.5], 4));
        assert_eq!(p.histogram[99], 2);
        assert_eq!(p.histogram[0], 1);
        assert_eq!(p.histogram[50], 1);
    }

    #[test]
    fn gates_parse_and_refuse() {
        assert_eq!(parse_gates("flip=0.05, rmse=1e-3").unwrap(), vec![(Gate::Flip, 0.05), (Gate::Rmse, 1e-3)]);
        assert!(parse_gates("flip").is_err());
        assert!(parse_gates("flop=1").is_err());
        assert!(parse_gates("rmse=x").is_err());
        assert!(parse_gates("rmse=inf").is_err());
    }

    #[test]
    fn tev_relative_mse_and_the_normalised_mse_differ() {
        let r = HdrImage { width: 1, height: 1, rgb: vec![glam::Vec3::splat(1.0)] };
        let t = HdrImage { width: 1, height: 1, rgb: vec![glam::Vec3::splat(2.0)] };
        let n = numeric(&r, &t);
        assert!((n.rel_mse - 1.0 / 1.01).abs() < 1e-6, "{}", n.rel_mse);
        assert!((n.nmse - 1.0).abs() < 1e-12);
        assert_eq!(n.max_abs_at, [0, 0]);
    }
}
