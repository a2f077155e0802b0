//! Reports: the folder a person reads (`report.md`, plots, heatmaps) or a script reads (`report.json`,
//! `report.csv`), written from the analysis ([`crate::analysis`]): tables, CSV, JSON and plot writers.

pub mod csv;
pub mod figures;
pub mod markdown;
pub mod plot;
pub mod write;

use crate::analysis::needs;
use crate::analysis::row::Report;
use crate::analysis::sweep::{self, SweepConfig};
use crate::analysis::{pruned_layout, ReportInput};
use crate::error::Result;
use crate::report::write::Attachment;

/// Runs the needs analysis and the sweep, prunes, and builds the figures: everything a report folder holds.
pub fn run(
    input: &ReportInput<'_>,
    cfg: &SweepConfig,
    progress: sweep::Progress<'_>,
) -> Result<(Report, Vec<Attachment>)> {
    let gb = input.gbuffer;
    let mut needs = needs::analyze(gb);
    let out = sweep::sweep(gb, input.lights, cfg, progress)?;
    let (mut files, figures) = figures::figures(gb, &out)?;
    if let Some((p, layout)) = pruned_layout(input, &needs, cfg, &out) {
        if !p.changes.is_empty() {
            if let Ok(text) = layout.spec().to_text(crate::layout::SpecSyntax::Toml) {
                files.push(Attachment { name: "pruned_layout.toml".into(), bytes: text.into_bytes() });
            }
        }
        needs.pruned_layout = Some(p);
    }
    let covered = gb.len() - gb.background_samples();
    let rep = Report {
        input: input.name.clone(),
        width: gb.width,
        height: gb.height,
        samples: gb.samples,
        coverage: if gb.is_empty() { 0.0 } else { covered as f64 / gb.len() as f64 },
        lights: input.lights.len(),
        lights_source: input.lights_source.clone(),
        runs: cfg.runs.max(1),
        reference: Some(out.reference_timing),
        sweep_seconds: out.seconds,
        needs,
        rows: out.rows,
        figures,
    };
    Ok((rep, files))
}
