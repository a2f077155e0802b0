//! Reports: sweeps of layouts × detectors, the byte-budget search, the scene-needs analysis, and the
//! table/CSV/JSON/plot writers.
//!
//! Input: a G-buffer (loaded or rendered) with its lights. Output: rows of measured numbers (errors against the
//! unquantized reference, measured times), the Pareto front, and a folder a person reads (`report.md`) or a
//! script reads (`report.json`, `report.csv`).

pub mod csv;
pub mod font;
pub mod markdown;
pub mod needs;
pub mod pareto;
pub mod plot;
pub mod row;
pub mod write;
