//! What a report holds, as `report.json` stores it: the analysed [`Frame`]s, their [`Row`]s, the rows aggregated
//! over the frames, and the [`Figure`]s. Filled by the sweep and the aggregation (the report writers write it out;
//! `gbuf merge` reads it back).

use crate::analysis::aggregate::{AggregateRow, BudgetChoice, DetectorAggregate, Over};
use crate::analysis::needs::Needs;
use crate::analysis::row::{Row, Timing};
use crate::analysis::sweep::{DetectorResult, FlipRows};
use crate::measure::image::Viewing;
use serde::{Deserialize, Serialize};

/// A figure written next to the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// File name inside the report folder.
    pub file: String,
    /// One-line caption.
    pub caption: String,
    /// The image this one is shown against (an A/B pair: the report page flickers or wipes between them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against: Option<String>,
}

/// Where one layout's targets bind as one pass ([`crate::layout::limits`]), at a frame's sample count.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LayoutFit {
    /// The layout.
    pub layout: String,
    /// Platforms it binds on as every conforming device guarantees.
    pub fits: Vec<String>,
    /// Platforms it binds on with an optional feature.
    pub with_feature: Vec<String>,
}

impl LayoutFit {
    /// `layout`'s fit on every platform at `samples` per pixel.
    #[must_use]
    pub fn of(layout: &crate::layout::Layout, samples: u32) -> LayoutFit {
        let (mut fits, mut with_feature) = (Vec::new(), Vec::new());
        for p in crate::layout::limits::PLATFORMS {
            let c = crate::layout::limits::check(p, layout.formats(), samples);
            if c.fits() {
                fits.push(p.name.to_string());
            } else if c.problems.is_empty() {
                with_feature.push(p.name.to_string());
            }
        }
        LayoutFit { layout: layout.name().to_string(), fits, with_feature }
    }
}

/// One analysed frame (dump) of a report: what it is and what was measured on it apart from the rows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// What was analysed (file path or scene name).
    pub input: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// Fraction of samples covered by a surface.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub coverage: f64,
    /// Number of lights.
    pub lights: usize,
    /// Where the lights came from.
    pub lights_source: String,
    /// What the reader said about the frame that every output repeats (e.g. no float truth for packed targets).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Time of the reference resolve (every sample shaded, f64 accumulation).
    pub reference: Option<Timing>,
    /// Wall time of this frame's sweep in seconds.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub sweep_seconds: f64,
    /// Where the sweep's wall time went, by kind of stage (seconds, in the order first met).
    #[serde(default)]
    pub stage_seconds: Vec<(String, f64)>,
    /// Where the frame's wall time outside the sweep went (seconds, in the order met): reading the dump, the needs
    /// analysis, the figures, the pruned layout's check, the pipelines comparison.
    #[serde(default)]
    pub other_seconds: Vec<(String, f64)>,
    /// The scene-needs analysis.
    pub needs: Needs,
    /// Each detector on the exact G-buffer: its anti-aliasing error and the shading it costs.
    pub detectors: Vec<DetectorResult>,
    /// Forward, deferred and visibility-buffer pipelines measured on this frame.
    #[serde(default)]
    pub pipelines: Option<crate::analysis::pipelines::Pipelines>,
    /// Why the pipelines could not be measured on this frame.
    #[serde(default)]
    pub pipelines_error: Option<String>,
    /// How many surfaces each pixel holds (by IDs and by geometry): what MSAA G-buffer compression could keep.
    #[serde(default)]
    pub surfaces_per_pixel: Option<crate::analysis::surfaces::SurfacesPerPixel>,
    /// Per layout swept, the platforms whose guarantees its targets bind within as one pass at this frame's
    /// sample count ([`crate::layout::limits::check`]), and those they need a feature on.
    #[serde(default)]
    pub fits: Vec<LayoutFit>,
}

/// Everything a report folder holds: the frames, one row per frame × layout × detector (× culling), and the rows
/// aggregated over the frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The frames, in the order given.
    pub frames: Vec<Frame>,
    /// Timing runs per stage.
    pub runs: usize,
    /// How the images were shown for FLIP.
    pub viewing: Viewing,
    /// Which rows got FLIP.
    pub flip: FlipRows,
    /// What the aggregate fronts rank by: each layout's mean or worst frame.
    pub over: Over,
    /// The lighting model every row was lit with, and why (absent in reports written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting: Option<crate::resolve::Lighting>,
    /// One row per frame × combination; the fronts are marked within each frame.
    pub rows: Vec<Row>,
    /// One row per combination over every frame (mean and worst frame); the fronts rank by [`Report::over`].
    pub aggregate: Vec<AggregateRow>,
    /// Each detector over every frame.
    pub detectors: Vec<DetectorAggregate>,
    /// With a byte budget (`--max-bytes`): the layout of the report that wins over every frame.
    #[serde(default)]
    pub budget: Option<BudgetChoice>,
    /// Plots and pictures.
    pub figures: Vec<Figure>,
}

/// A one-frame report of `rows` on an empty `width` × `height` G-buffer, for the writers' tests.
#[cfg(test)]
pub(crate) fn test_report(input: &str, width: u32, height: u32, rows: Vec<Row>, figures: Vec<Figure>) -> Report {
    let gb = crate::GBuffer::new(width, height, 1).expect("a small G-buffer");
    Report {
        frames: vec![Frame {
            input: input.into(),
            width,
            height,
            samples: 1,
            coverage: 0.0,
            lights: 0,
            lights_source: "none".into(),
            notes: vec![],
            reference: None,
            sweep_seconds: 0.5,
            stage_seconds: vec![],
            other_seconds: vec![],
            needs: crate::analysis::needs::analyze(&gb),
            detectors: vec![],
            pipelines: None,
            pipelines_error: None,
            surfaces_per_pixel: None,
            fits: vec![],
        }],
        runs: 3,
        viewing: Viewing::default(),
        flip: FlipRows::default(),
        over: Over::default(),
        lighting: None,
        aggregate: crate::analysis::aggregate::aggregate(&rows, Over::default()),
        detectors: vec![],
        budget: None,
        rows,
        figures,
    }
}
