//! Reports: the folder a person reads (`report.md`, plots, heatmaps) or a script reads (`report.json`,
//! `report.csv`), written from the analysis' record ([`crate::analysis::record::Report`]): tables, CSV, JSON and
//! plot writers. Running the analysis that fills a report is the `study` module's.

pub(crate) mod csv;
pub mod figures;
pub mod format;
pub(crate) mod html;
pub(crate) mod markdown;
pub mod pipelines;
pub(crate) mod plot;
pub mod write;
