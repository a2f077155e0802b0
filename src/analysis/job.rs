//! The resolve job: one frame lit as `gbuf resolve` lights it — through a layout or not, from the decoded frame or
//! from a reader's own arrays — with every number that command reports: the stage times, the error against the f64
//! reference, the layout's and the detector's errors apart, and the light pre-pass against full deferred shading.
//!
//! The command keeps its flags, progress, printing and files; a library user gets the same numbers from
//! [`resolve_frame`].

use crate::base::timing::{timed, StageMs};
use crate::detect::{self, Detector, DetectorConfig, EdgeMask};
use crate::error::{Error, Result};
use crate::gbuffer::{BandSource, GBuffer};
use crate::layout::{Layout, LitFrame, PackedFrame};
use crate::light::Light;
use crate::measure::image::{against_full_deferred, compare, error_triad, ErrorTriad, ImageError, Viewing};
use crate::resolve::{self, ResolveConfig, ResolveInput, Resolved, Schedule};

/// How to light the frame and what to measure.
#[derive(Clone, Debug)]
pub struct ResolveJob<'a> {
    /// Pack the frame into this layout's render targets and light what they hold (the reference still lights the
    /// frame as given).
    pub layout: Option<&'a Layout>,
    /// The edge detector choosing the pixels shaded per sample, and its thresholds.
    pub detector: Detector,
    /// The detector's thresholds.
    pub thresholds: DetectorConfig,
    /// The resolve, its lighting model already applied ([`crate::resolve::Lighting::apply`]).
    pub config: ResolveConfig,
    /// Light the f64 every-sample reference and measure against it.
    pub reference: bool,
    /// Add FLIP, as this viewer sees the images, to every error set.
    pub flip: Option<Viewing>,
}

/// Everything [`resolve_frame`] measured.
#[derive(Clone, Debug)]
pub struct ResolveOutcome {
    /// The lit image, its statistics and the light evaluations per pixel.
    pub resolved: Resolved,
    /// The pixels shaded per sample.
    pub mask: EdgeMask,
    /// Stage times (ms, wall): decode includes packing through the layout and the bands the resolve decoded;
    /// detect is the edge pass; total covers both and the resolve.
    pub stages: StageMs,
    /// The f64 reference's wall time (ms; 0 without it).
    pub reference_ms: f64,
    /// The full deferred resolve run for the pre-pass comparison (ms; 0 for the deferred schedule).
    pub deferred_for_prepass_ms: f64,
    /// The image against the reference (RMSE, PSNR, max, relative MSE), with the reference.
    pub error: Option<ImageError>,
    /// Total, layout and detector error sets (FLIP included when asked).
    pub triad: ErrorTriad,
    /// With the light pre-pass schedule: its image against full deferred shading of the same input.
    pub prepass_vs_deferred: Option<ImageError>,
}

/// Lights `gb` with `lights` as `job` says and measures it.
///
/// `source`, when given, holds the frame's planes in a reader's own form (the ISPC `.bin`'s arrays): the edge pass
/// and the resolve decode it band by band instead of reading `gb`'s planes, which then only give the frame's size
/// and camera. Not with a layout (it packs `gb`).
///
/// `beside` runs on the lit frame while the measurements run (the CLI encodes its pictures there); its result is
/// returned with the outcome. `progress` names each long step as it starts. Errors name `name`.
pub fn resolve_frame<R: Send>(
    name: &str,
    gb: &GBuffer,
    source: Option<&dyn BandSource>,
    lights: &[Light],
    job: &ResolveJob<'_>,
    progress: &(dyn Fn(&str) + Sync),
    beside: impl FnOnce(&Resolved) -> R + Send,
) -> Result<(ResolveOutcome, R)> {
    let in_frame = |step: &'static str| move |e: Error| Error::InFrame { frame: name.into(), step, source: e.into() };
    if source.is_some() && job.layout.is_some() {
        return Err(Error::Argument(format!(
            "{name}: a reader's own arrays and a layout cannot both be lit: the layout packs the decoded frame"
        )));
    }
    let cfg = &job.config;
    // The frame made ready for lighting by the library's one policy (packed targets read band by band, the input
    // itself, or a decoded copy: `Layout::prepare_lighting`), or the reader's arrays.
    let (prepared, t_pack) =
        timed(|| job.layout.map(|l| l.prepare_lighting(gb, 1, resolve::TIMING_STRIDE)).transpose());
    let prepared = prepared.map_err(in_frame("packing with the layout"))?;
    let (frame, planes) = match (job.layout, &prepared) {
        (Some(l), Some(p)) => match p.frame(l, gb).map_err(in_frame("the layout's frame"))? {
            LitFrame::Packed(f) => (Some(f), None),
            LitFrame::Planes(d) => (None, Some(d)),
        },
        _ => match source {
            Some(s) => (Some(PackedFrame::of_source(gb, s).map_err(in_frame("its arrays"))?), None),
            None => (None, None),
        },
    };
    let lit: ResolveInput<'_> = match (&frame, planes) {
        (Some(f), _) => f.into(),
        (None, Some(d)) => d.into(),
        (None, None) => gb.into(),
    };

    progress("edges");
    let (mask, t_detect) = timed(|| match (&frame, planes) {
        (Some(f), _) => detect::detect_packed(f, job.detector, &job.thresholds),
        (None, Some(d)) => detect::detect(d, job.detector, &job.thresholds),
        (None, None) => detect::detect(gb, job.detector, &job.thresholds),
    });
    let mask = mask.map_err(in_frame("edge detector"))?;

    progress("lighting");
    let resolved = resolve::resolve(lit, lights, &mask, cfg).map_err(in_frame("resolve"))?;
    if resolved.stats.shading_evaluations == 0 {
        return Err(Error::Implausible(format!(
            "{name}: the resolve shaded no sample ({} covered of {}): nothing was lit",
            gb.coverage.iter().filter(|c| **c).count(),
            gb.len()
        )));
    }
    // The resolve's own decode (the packed bands it read) is part of the pass.
    let mut stages = StageMs { decode: t_pack + resolved.stats.ms.decode, detect: t_detect, ..resolved.stats.ms };
    stages.total += t_pack + t_detect;

    // The measurements run beside `beside` (the CLI's encoding).
    let measure = || -> Result<Measured> {
        // The light pre-pass approximates full deferred shading; its own error is measured against that, on the
        // same input, apart from the error against the reference (which also holds the detector's and the
        // layout's).
        let (prepass_vs_deferred, t_deferred) = if cfg.schedule == Schedule::LightPrepass {
            let (e, t) = against_full_deferred(lit, lights, &mask, cfg, &resolved.image)
                .map_err(in_frame("full deferred resolve for the pre-pass comparison"))?;
            (Some(e), t)
        } else {
            (None, 0.0)
        };
        // With a layout, the exact G-buffer lit the same way separates the layout's loss from the detector's.
        let exact = match job.layout {
            Some(_) => Some(
                crate::analysis::errors::lit(gb, lights, job.detector, &job.thresholds, cfg)
                    .map_err(in_frame("exact resolve"))?
                    .image,
            ),
            None => None,
        };
        let (reference, t_ref) = if job.reference {
            progress("the every-sample reference");
            let (reference, t) = timed(|| resolve::reference(gb, lights, cfg));
            let reference = reference.map_err(in_frame("reference"))?;
            resolve::check_meaningful(gb, lights, &reference).map_err(in_frame("nothing to compare"))?;
            (Some(reference), t)
        } else {
            (None, 0.0)
        };
        let triad = error_triad(&resolved.image, exact.as_ref(), reference.as_ref(), job.flip.as_ref());
        let error = reference.as_ref().map(|r| compare(r, &resolved.image));
        Ok(Measured { prepass_vs_deferred, t_deferred, t_ref, triad, error })
    };
    let (aside, measured) = rayon::join(|| beside(&resolved), measure);
    let Measured { prepass_vs_deferred, t_deferred, t_ref, triad, error } = measured?;
    let outcome = ResolveOutcome {
        resolved,
        mask,
        stages,
        reference_ms: t_ref,
        deferred_for_prepass_ms: t_deferred,
        error,
        triad,
        prepass_vs_deferred,
    };
    Ok((outcome, aside))
}

/// What the measurements beside the encoding give.
struct Measured {
    prepass_vs_deferred: Option<ImageError>,
    t_deferred: f64,
    t_ref: f64,
    triad: ErrorTriad,
    error: Option<ImageError>,
}
