//! Sweeps, the byte-budget search, the scene-needs analysis and the table/CSV/JSON/plot writers.
