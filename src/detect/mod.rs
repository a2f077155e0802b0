//! Edge detectors for MSAA deferred shading: G-buffer → [`EdgeMask`] (which pixels need per-sample shading).
//!
//! A deferred renderer with MSAA shades most pixels once and only the pixels whose samples lie on different
//! surfaces once per sample (Lauritzen 2010, "Deferred Rendering for Current and Future Rendering Pipelines").
//! The detectors here decide which pixels those are, from what a G-buffer holds:
//!
//! | detector       | a pixel is per-sample when …                                                         |
//! |----------------|---------------------------------------------------------------------------------------|
//! | `lauritzen`    | some `|z_i − z_0| > |∂z/∂x| + |∂z/∂y|` or `n_i · n_0 < 0.99` ([`lauritzen`])          |
//! | `depth`        | some `|z_i − z_0| > absolute + relative · z_0` ([`geometric`])                        |
//! | `normal`       | some normal is more than the angle threshold away from `n_0` (`geometric`)          |
//! | `id`           | some material / object ID differs from sample 0's (`id`)                            |
//! | `combined`     | `lauritzen` or `id` (IDs when present)                                                |
//! | `forward-msaa` | baseline: shades once per distinct primitive covering the pixel ([`baselines`])       |
//! | `ssaa`         | baseline: every sample                                                               |
//! | `none`         | baseline: once per covered pixel                                                     |
//!
//! Conventions shared by every detector: a pixel with no covered sample has `shade_count` 0; a pixel mixing
//! background and surface samples is an edge for the geometric detectors (its background samples must not take
//! the surface's shading); any NaN or infinity among a covered pixel's samples makes it an edge (conservative).
//! Ground truth from IDs lives in [`truth`]; precision and recall in `measure::edges`.
//!
//! Work is parallel over rows with rayon.
//!
//! Measured on the built-in room (`gbuf scene room --width 960 --height 540 --msaa 4 -o room.exr && gbuf edges
//! room.exr --detector all`): against object IDs, `lauritzen` has precision 0.85 and recall 0.56 at a shading
//! fraction of 0.172 (`none` 0.165, `ssaa` 0.658 — a third of the frame is sky; these fractions were measured
//! before issue 16, when a per-sample pixel counted all its samples, background ones included: they now count covered
//! samples only, slightly less at silhouettes against the sky); `id` 1.00/1.00 at 0.176;
//! `forward-msaa` 0.32/0.81 at 0.175. Most of the geometric detectors' misses are the floor's checker tiles: separate,
//! coplanar objects that only a material or ID test can tell apart. Against the shading truth
//! (`measure::edges::shading_truth`, one display code step beyond the smooth gradient: 2.20% of the
//! pixels), precision / recall are `lauritzen` 0.98 / 0.45, `id` 1.00 / 0.69, `combined` 0.99 / 0.75,
//! `forward-msaa` 0.43 / 0.76; the rest of the shading truth is creases, specular highlights and sphere rims, shading
//! variation inside one surface that no G-buffer edge test sees.

pub mod baselines;
pub(crate) mod geometric;
pub(crate) mod id;
pub mod lauritzen;
pub mod picture;
pub mod rate;
pub(crate) mod thresholds;
pub mod truth;

pub use crate::base::mask::EdgeMask;
pub use thresholds::{DetectorConfig, IdSource};

use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use crate::layout::PackedFrame;
use rayon::prelude::*;
use std::borrow::Cow;

/// Every edge detector and baseline. `ALL` lists them in report order; `name` is the one CLI/JSON spelling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Detector {
    /// Lauritzen 2010: depth against the screen-space depth derivatives, normals against 0.99.
    Lauritzen,
    /// Relative (plus optional absolute) depth difference.
    Depth,
    /// Normal angle.
    Normal,
    /// Material / object ID differs.
    Id,
    /// `lauritzen` or `id`.
    Combined,
    /// Baseline: what hardware forward MSAA shades (one evaluation per distinct primitive in the pixel).
    ForwardMsaa,
    /// Baseline: every sample shaded.
    Ssaa,
    /// Baseline: every covered pixel shaded once.
    None,
}

crate::named!(Detector: "detector" {
    Lauritzen => "lauritzen",
    Depth => "depth",
    Normal => "normal",
    Id => "id",
    Combined => "combined",
    ForwardMsaa => "forward-msaa",
    Ssaa => "ssaa",
    None => "none",
});

impl Detector {
    /// Is this one of the baselines (`forward-msaa`, `ssaa`, `none`) rather than a G-buffer edge detector?
    #[must_use]
    pub fn is_baseline(self) -> bool {
        matches!(self, Detector::ForwardMsaa | Detector::Ssaa | Detector::None)
    }
}

/// Runs `detector` on `gb` with thresholds `cfg`.
///
/// Errors when the thresholds are invalid, the G-buffer is inconsistent (plane lengths), or the detector needs an
/// attribute the G-buffer lacks (`lauritzen`/`combined`: depth or position, and normals; `depth`: depth or
/// position; `normal`: normals; `id`: material or object IDs as `cfg.ids` asks; `forward-msaa`: primitive IDs).
pub fn detect(gb: &GBuffer, detector: Detector, cfg: &DetectorConfig) -> Result<EdgeMask> {
    cfg.validate()?;
    gb.validate()?;
    // One sample per pixel: there is nothing to shade per sample, and every detector's mask is `none`'s (a
    // pass over the G-buffer saved on every 1-sample frame, e.g. every ISPC `.bin`).
    if gb.samples == 1 {
        return Ok(baselines::none(gb));
    }
    match detector {
        Detector::Lauritzen => lauritzen::detect(gb, cfg, false),
        Detector::Combined => lauritzen::detect(gb, cfg, true),
        Detector::Depth => geometric::detect_depth(gb, cfg),
        Detector::Normal => geometric::detect_normal(gb, cfg),
        Detector::Id => id::detect(gb, cfg),
        Detector::ForwardMsaa => baselines::forward_msaa(gb),
        Detector::Ssaa => Ok(baselines::ssaa(gb)),
        Detector::None => Ok(baselines::none(gb)),
    }
}

/// Rows above and below a pixel that a detector reads: `lauritzen`'s gradient estimate looks two pixels away.
pub const NEIGHBOUR_ROWS: u32 = 2;

/// Rows per band of [`detect_packed`]: a band of a 1080p × 4 frame with its neighbour rows decodes into about 2 MB
/// a plane.
const PACKED_BAND_ROWS: u32 = 32;

/// [`detect`] on packed render targets, decoded a band of rows at a time (with the [`NEIGHBOUR_ROWS`] around it),
/// as a GPU's edge pass reads its G-buffer: the mask is `detect`'s on the unpacked G-buffer pixel for pixel
/// (tested for every built-in layout and detector), and no decoded copy of the frame exists. Bands run in
/// parallel on rayon's current pool; errors are `detect`'s.
pub fn detect_packed(frame: &PackedFrame<'_>, detector: Detector, cfg: &DetectorConfig) -> Result<EdgeMask> {
    detect_packed_bands(frame, detector, cfg, 1)
}

/// An estimate of [`detect_packed`]'s wall time (ms) from every `stride`-th band (the others skipped), scaled by
/// the stride: the repeated timing runs of `gbuf report` (see `resolve::time_sampled`).
pub fn time_packed_sampled(
    frame: &PackedFrame<'_>,
    detector: Detector,
    cfg: &DetectorConfig,
    stride: u32,
) -> Result<f64> {
    let t = std::time::Instant::now();
    detect_packed_bands(frame, detector, cfg, stride.max(1))?;
    let bands = frame.like().height.div_ceil(PACKED_BAND_ROWS).max(1);
    let sampled = bands.div_ceil(stride.max(1));
    Ok(t.elapsed().as_secs_f64() * 1e3 * f64::from(bands) / f64::from(sampled))
}

/// The attributes `detector` reads (besides coverage): all a band decoded for it needs.
fn reads(detector: Detector) -> &'static [Attribute] {
    use Attribute as A;
    match detector {
        Detector::Lauritzen => &[A::Depth, A::Position, A::Normal],
        Detector::Combined => &[A::Depth, A::Position, A::Normal, A::MaterialId, A::ObjectId],
        Detector::Depth => &[A::Depth, A::Position],
        Detector::Normal => &[A::Normal],
        Detector::Id => &[A::MaterialId, A::ObjectId],
        Detector::ForwardMsaa => &[A::PrimitiveId, A::ObjectId],
        Detector::Ssaa | Detector::None => &[],
    }
}

/// [`detect_packed`] on every `stride`-th band only (the others' rows stay 0).
fn detect_packed_bands(
    frame: &PackedFrame<'_>,
    detector: Detector,
    cfg: &DetectorConfig,
    stride: u32,
) -> Result<EdgeMask> {
    cfg.validate()?;
    let like = frame.like();
    like.validate()?;
    let (w, h) = (like.width, like.height);
    if like.samples == 1 || w == 0 || h == 0 {
        return Ok(baselines::none(like));
    }
    let mut mask = EdgeMask::filled(w, h, like.samples, 0);
    let band_px = (PACKED_BAND_ROWS * w) as usize;
    let stride = stride as usize;
    mask.shade_count.par_chunks_mut(band_px).enumerate().filter(|(b, _)| b % stride == 0).try_for_each_init(
        GBuffer::default,
        |band, (b, out)| {
            let y0 = b as u32 * PACKED_BAND_ROWS;
            let y1 = (y0 + PACKED_BAND_ROWS).min(h);
            let (top, bottom) = (y0.saturating_sub(NEIGHBOUR_ROWS), (y1 + NEIGHBOUR_ROWS).min(h));
            frame.decode_rows_only(top..bottom, band, reads(detector))?;
            let m = detect(band, detector, cfg)?;
            let skip = ((y0 - top) * w) as usize;
            out.copy_from_slice(&m.shade_count[skip..skip + out.len()]);
            Ok(())
        },
    )?;
    Ok(mask)
}

/// The error for a detector that needs an attribute the G-buffer lacks; lists what the G-buffer has.
pub(crate) fn missing(gb: &GBuffer, detector: Detector, needs: &str) -> Error {
    let have: Vec<&str> = gb.attributes().iter().map(|a| a.name()).collect();
    let have = if have.is_empty() { "none".to_string() } else { have.join(", ") };
    Error::Mismatch(format!("detector {detector} needs {needs}; the G-buffer has: {have}"))
}

/// The view-depth plane: `depth`, else `−position.z` (0 at background samples).
pub(crate) fn depth_plane<'a>(gb: &'a GBuffer, detector: Detector) -> Result<Cow<'a, [f32]>> {
    if let Some(d) = gb.depth.as_deref() {
        return Ok(Cow::Borrowed(d));
    }
    if let Some(p) = gb.position.as_deref() {
        return Ok(Cow::Owned(p.iter().zip(&gb.coverage).map(|(p, &c)| if c { -p.z } else { 0.0 }).collect()));
    }
    Err(missing(gb, detector, Attribute::Depth.name()))
}

/// How many of a pixel's samples are covered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PixelCoverage {
    /// No surface at all.
    Empty,
    /// Some background, some surface.
    Mixed,
    /// Every sample on a surface.
    Full,
}

/// Coverage of the pixel whose samples start at plane index `base`.
#[inline]
pub(crate) fn pixel_coverage(coverage: &[bool], base: usize, samples: usize) -> PixelCoverage {
    let n = coverage[base..base + samples].iter().filter(|&&c| c).count();
    match n {
        0 => PixelCoverage::Empty,
        n if n == samples => PixelCoverage::Full,
        _ => PixelCoverage::Mixed,
    }
}

/// Covered samples of every pixel, row-major (what [`EdgeMask::evaluations`] takes).
#[must_use]
pub fn covered_per_pixel(gb: &GBuffer) -> Vec<u8> {
    let s = gb.samples as usize;
    if s == 0 {
        return vec![0; gb.pixel_count()];
    }
    gb.coverage.chunks(s).map(|px| px.iter().filter(|&&c| c).count().min(usize::from(u8::MAX)) as u8).collect()
}

/// Runs `count(x, y, base)` for every pixel, parallel over rows, and collects an [`EdgeMask`].
pub(crate) fn per_pixel(gb: &GBuffer, count: impl Fn(u32, u32, usize) -> u8 + Sync) -> EdgeMask {
    let mut mask = EdgeMask::filled(gb.width, gb.height, gb.samples, 0);
    let (w, s) = (gb.width as usize, gb.samples as usize);
    if w == 0 {
        return mask;
    }
    mask.shade_count.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, c) in row.iter_mut().enumerate() {
            *c = count(x as u32, y as u32, (y * w + x) * s);
        }
    });
    mask
}

/// The driver of the geometric detectors: empty pixels get 0, mixed pixels `samples`, fully covered pixels 1 when
/// `same_surface(x, y, base)` holds and `samples` otherwise.
pub(crate) fn geometric_mask(gb: &GBuffer, same_surface: impl Fn(u32, u32, usize) -> bool + Sync) -> EdgeMask {
    let s = gb.samples as usize;
    let per_sample = gb.samples.min(u32::from(u8::MAX)) as u8;
    per_pixel(gb, |x, y, base| match pixel_coverage(&gb.coverage, base, s) {
        PixelCoverage::Empty => 0,
        PixelCoverage::Mixed => per_sample,
        PixelCoverage::Full if s == 1 || same_surface(x, y, base) => 1,
        PixelCoverage::Full => per_sample,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detector_names_round_trip() {
        for d in Detector::ALL {
            assert_eq!(Detector::from_name(d.name()), Some(d));
            assert_eq!(serde_json::to_string(&d).unwrap(), format!("\"{}\"", d.name()));
        }
        // One spelling rule for every name (`base::names`): case, `-` and `_` do not matter.
        assert_eq!(Detector::from_name("Forward_MSAA"), Some(Detector::ForwardMsaa));
        assert_eq!(Detector::from_name("forward-msaa2"), None);
        assert!(Detector::ForwardMsaa.is_baseline() && !Detector::Lauritzen.is_baseline());
    }

    #[test]
    fn mask_fractions() {
        let m = EdgeMask { width: 2, height: 2, samples: 4, shade_count: vec![0, 1, 4, 2] };
        assert_eq!(m.edge_pixels(), 2);
        assert_eq!(m.shaded_samples(), 7);
        assert!((m.edge_fraction() - 0.5).abs() < 1e-12);
        assert!((m.shading_fraction() - 7.0 / 16.0).abs() < 1e-12);
        assert_eq!(m.edges(), vec![false, false, true, true]);
        let empty = EdgeMask::filled(0, 0, 4, 0);
        assert_eq!((empty.edge_fraction(), empty.shading_fraction()), (0.0, 0.0));
        // What the mask costs: per-sample pixels pay only for their covered samples (the last pixel's count 2 is
        // forward-msaa-like, below its 3 covered samples).
        assert_eq!(m.evaluations(&[0, 4, 3, 3]), 1 + 3 + 2);
        assert!((m.evaluated_fraction(&[0, 4, 3, 3]) - 6.0 / 16.0).abs() < 1e-12);
    }

    #[test]
    fn ssaa_costs_the_covered_samples() {
        // Issue 16: `ssaa` asked for 4 × pixels with any coverage; it costs the covered samples. Its mask keeps
        // `samples` for a pixel with one covered sample: a count of 1 would mean "sample 0 stands for the pixel",
        // shading it at full weight (and at sample 0 even when sample 0 is background).
        let mut gb = GBuffer::new(3, 1, 4).unwrap();
        gb.coverage = vec![true, true, true, true, false, true, false, false, false, false, false, false];
        let m = baselines::ssaa(&gb);
        assert_eq!(m.shade_count, vec![4, 4, 0]);
        assert_eq!(m.shaded_samples(), 8);
        assert_eq!(covered_per_pixel(&gb), vec![4, 1, 0]);
        assert_eq!(m.evaluations(&covered_per_pixel(&gb)), 5);
    }

    #[test]
    fn missing_attribute_error_names_detector_and_contents() {
        let gb = GBuffer::new(2, 2, 4).unwrap();
        for d in [Detector::Lauritzen, Detector::Depth, Detector::Normal, Detector::Id, Detector::ForwardMsaa] {
            let e = detect(&gb, d, &DetectorConfig::default()).unwrap_err().to_string();
            assert!(e.contains(d.name()) && e.contains("has: none"), "{e}");
        }
        for d in [Detector::Ssaa, Detector::None] {
            assert!(detect(&gb, d, &DetectorConfig::default()).is_ok());
        }
    }

    #[test]
    fn inconsistent_gbuffer_is_an_error_not_a_panic() {
        let mut gb = GBuffer::new(2, 2, 4).unwrap();
        gb.depth = Some(vec![1.0; 3]);
        assert!(detect(&gb, Detector::Depth, &DetectorConfig::default()).is_err());
    }
}
