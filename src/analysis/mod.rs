//! Analysis: the measured answers a report is made of — sweeps of layouts × detectors ([`sweep`]), the Pareto
//! fronts ([`pareto`]), the byte-budget search ([`budget`]), what a scene does not need ([`needs`]) and the layouts
//! pruned to it (`prune`), and the rows they produce ([`row`]).
//!
//! Input: a G-buffer (loaded or rendered) with its lights. Output: rows of measured numbers (errors against the
//! unquantized reference, measured times) and the Pareto front; `report` writes them for a person or a script.

pub mod aggregate;
pub mod budget;
pub mod compress;
pub mod errors;
pub mod forward;
pub mod job;
pub mod needs;
pub mod normal_targets;
pub mod pareto;
pub mod pipelines;
pub(crate) mod prune;
pub mod record;
pub mod row;
pub mod surfaces;
pub mod sweep;
pub mod traffic;
pub mod vrs;

use crate::analysis::needs::{Needs, PrunedLayout};
use crate::analysis::sweep::{SweepConfig, SweepOutput};
use crate::gbuffer::GBuffer;
use crate::layout::Layout;
use crate::light::Light;

/// What a report is about.
#[derive(Clone, Debug)]
pub struct ReportInput<'a> {
    /// A name for the input (file path or scene name).
    pub name: String,
    /// The reference G-buffer.
    pub gbuffer: &'a GBuffer,
    /// View-space lights.
    pub lights: &'a [Light],
    /// Where the lights came from.
    pub lights_source: String,
    /// The same frame rendered with 1 sample at pixel centres, when there is one: the pipelines' no-AA image and
    /// MLAA's input (else sample 0 stands in).
    pub single: Option<&'a GBuffer>,
    /// The analytic scene the frame was rendered from, when it is one of gbuf's (the demo): the visibility buffer
    /// is then re-materialised from its triangles.
    pub geometry: Option<crate::scene::SceneName>,
    /// What the reader said about the frame that every output must repeat (e.g. a packed input has no float
    /// truth: its errors are against the engine's decoded frame).
    pub notes: Vec<String>,
    /// The frame's position plane was left out of `gbuffer` because depth and the camera give it bit for bit
    /// ([`GBuffer::position_is_derived`]; every reader then derives the same bits): the needs analysis counts position
    /// as derivable, not absent.
    pub position_derived: bool,
}

/// The lossless measuring baseline among the built-ins: never picked as the layout to prune when another one can
/// be pruned, since nobody ships it.
pub const LOSSLESS_BASELINE: &str = "reference-f32";

/// Picks the layout to prune — among the swept layouts whose pruning saves bytes, the one with the least layout
/// error in the sweep (ties → the larger saving; the lossless baseline only when nothing else can be pruned) —
/// prunes it and measures the pruned layout's error.
pub fn pruned_layout(
    input: &ReportInput<'_>,
    needs: &Needs,
    cfg: &SweepConfig,
    out: &SweepOutput,
) -> Option<(PrunedLayout, Layout)> {
    let first_det = cfg.detectors.first()?.name();
    let base_rmse = |name: &str| {
        out.rows
            .iter()
            .find(|r| r.layout == name && r.detector == first_det && r.error.is_none())
            .and_then(|r| r.layout_rmse())
    };
    let mut best: Option<(u32, f64, &Layout, crate::layout::LayoutSpec, Vec<String>)> = None;
    for l in &cfg.layouts {
        let (spec, changes) = prune::prune_spec(l.spec(), needs);
        let Ok(p) = Layout::from_spec(spec.clone()) else { continue };
        let saved = (l.bytes_per_sample() - p.bytes_per_sample().min(l.bytes_per_sample())) as u32;
        let err = base_rmse(l.name()).unwrap_or(f64::INFINITY);
        // Rank: saves something, is not the lossless baseline, least error, largest saving.
        let rank =
            |saved: u32, err: f64, name: &str| (saved == 0, name == LOSSLESS_BASELINE, err, std::cmp::Reverse(saved));
        let better = match &best {
            None => true,
            Some((s, e, bl, ..)) => {
                rank(saved, err, l.name()).partial_cmp(&rank(*s, *e, bl.name())).is_some_and(|o| o.is_lt())
            }
        };
        if better {
            best = Some((saved, err, l, spec, changes));
        }
    }
    let (saved, _, base, spec, changes) = best?;
    let layout = Layout::from_spec(spec).ok()?;
    let mut p = PrunedLayout {
        name: layout.name().to_string(),
        base: base.name().to_string(),
        bytes_per_sample: layout.bytes_per_sample() as u32,
        base_bytes_per_sample: base.bytes_per_sample() as u32,
        bytes_saved: saved,
        changes,
        base_rmse: base_rmse(base.name()),
        rmse: None,
        psnr_db: None,
        note: None,
    };
    match out.exact.first().and_then(Option::as_ref) {
        Some(exact) => match errors::layout_image_error(
            input.gbuffer,
            input.lights,
            &layout,
            exact,
            cfg.detectors.first().copied().unwrap_or(crate::detect::Detector::Lauritzen),
            &cfg.detector_config,
            &cfg.resolve,
        ) {
            Ok(e) => {
                p.rmse = Some(e.rmse);
                p.psnr_db = Some(e.psnr_db);
            }
            Err(e) => p.note = Some(format!("could not measure the pruned layout: {e}")),
        },
        None => p.note = Some("the exact G-buffer could not be lit: the pruned layout's error is unknown".into()),
    }
    if p.changes.is_empty() {
        p.note = Some("the scene uses everything every layout stores: nothing to leave out".into());
    }
    Some((p, layout))
}

/// The needs analysis with a pruned layout chosen without lighting (for `gbuf info`): among the built-ins, the one
/// whose pruning saves the most bytes (the lossless baseline only when nothing else can be pruned). Its error is
/// left unmeasured (`gbuf report` measures it).
#[must_use]
pub fn needs_with_pruned_layout(gb: &GBuffer) -> Needs {
    let mut needs = needs::analyze(gb);
    let mut best: Option<(Layout, Layout, Vec<String>)> = None;
    for l in Layout::builtins() {
        let (spec, changes) = prune::prune_spec(l.spec(), &needs);
        let Ok(p) = Layout::from_spec(spec) else { continue };
        let saved = l.bytes_per_sample().saturating_sub(p.bytes_per_sample());
        let rank = |saved: usize, name: &str| (saved == 0, name == LOSSLESS_BASELINE, std::cmp::Reverse(saved));
        let better = match &best {
            None => true,
            Some((b, bp, _)) => {
                rank(saved, l.name()) < rank(b.bytes_per_sample().saturating_sub(bp.bytes_per_sample()), b.name())
            }
        };
        if better {
            best = Some((l, p, changes));
        }
    }
    if let Some((base, p, changes)) = best {
        let saved = base.bytes_per_sample().saturating_sub(p.bytes_per_sample()) as u32;
        needs.pruned_layout = Some(PrunedLayout {
            name: p.name().to_string(),
            base: base.name().to_string(),
            bytes_per_sample: p.bytes_per_sample() as u32,
            base_bytes_per_sample: base.bytes_per_sample() as u32,
            bytes_saved: saved,
            note: Some(if changes.is_empty() {
                "the scene uses everything every layout stores: nothing to leave out".into()
            } else {
                "error not measured here: `gbuf report` lights the scene and measures it".into()
            }),
            changes,
            base_rmse: None,
            rmse: None,
            psnr_db: None,
        });
    }
    needs
}
