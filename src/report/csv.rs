//! `report.csv`: one line per row, every numeric metric in its own column, empty cells where a metric could not
//! be computed (the `note`/`error` columns say why). Written by the `csv` crate from [`CsvRow`], whose field names
//! are the header: the columns are listed once.

use crate::analysis::aggregate::{AggregateRow, Stat};
use crate::analysis::row::Row;
use serde::{Serialize, Serializer};

/// A metric cell: the shortest decimal that reads back to the value, `inf`/`-inf`, or empty (absent or NaN).
#[derive(Clone, Copy, Debug, Default)]
pub struct Num(pub Option<f64>);

impl Serialize for Num {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.0 {
            Some(x) if x.is_finite() => s.collect_str(&x),
            Some(x) if x.is_nan() => s.serialize_str(""),
            Some(x) if x > 0.0 => s.serialize_str("inf"),
            Some(_) => s.serialize_str("-inf"),
            None => s.serialize_str(""),
        }
    }
}

/// One line of `report.csv`.
#[derive(Debug, Serialize)]
#[allow(missing_docs)] // the field names are the CSV header, documented in docs/GUIDE.md
pub struct CsvRow<'a> {
    pub frame: &'a str,
    pub layout: &'a str,
    pub bytes_per_sample: u32,
    pub footprint_bytes: u64,
    pub detector: &'a str,
    pub culling: &'a str,
    pub normal_mean_deg: Num,
    pub normal_p95_deg: Num,
    pub normal_max_deg: Num,
    pub depth_rel_mean: Num,
    pub depth_rel_max: Num,
    pub albedo_max_abs: Num,
    pub scalar_max_abs: Num,
    pub layout_rmse: Num,
    pub layout_psnr_db: Num,
    pub layout_flip_ldr: Num,
    pub layout_flip_hdr: Num,
    pub aa_rmse: Num,
    pub aa_psnr_db: Num,
    pub aa_flip_ldr: Num,
    pub aa_flip_hdr: Num,
    pub total_rmse: Num,
    pub total_psnr_db: Num,
    pub total_flip_ldr: Num,
    pub total_flip_hdr: Num,
    pub total_psnr_peak: Num,
    pub shading_fraction: Num,
    pub edge_fraction: Num,
    pub precision: Num,
    pub recall: Num,
    pub decode_ops_per_sample: Num,
    pub bandwidth_tiled_mb: Num,
    pub bandwidth_quad_mb: Num,
    pub dcc_bytes_per_sample: Num,
    pub ccs_bytes_per_sample: Num,
    pub afbc_bytes_per_sample: Num,
    pub bandwidth_tiled_dcc_mb: Num,
    pub encode_ms: Num,
    pub encode_ms_min: Num,
    pub encode_ms_max: Num,
    pub decode_ms: Num,
    pub decode_ms_min: Num,
    pub decode_ms_max: Num,
    pub detect_ms: Num,
    pub resolve_ms: Num,
    pub resolve_ms_min: Num,
    pub resolve_ms_max: Num,
    pub resolve_pass_ms: Num,
    pub pareto_bytes: bool,
    pub pareto_time: bool,
    pub pareto_compressed: bool,
    pub note: String,
}

impl<'a> CsvRow<'a> {
    /// The CSV line of `r`.
    #[must_use]
    pub fn of(r: &'a Row) -> Self {
        let note = match (&r.note, &r.error) {
            (Some(n), Some(e)) => format!("error: {e}; {n}"),
            (None, Some(e)) => format!("error: {e}"),
            (Some(n), None) => n.clone(),
            (None, None) => String::new(),
        };
        let (l, a, t) = (r.layout_error.as_ref(), r.aa_error.as_ref(), r.total_error.as_ref());
        CsvRow {
            frame: &r.frame,
            layout: &r.layout,
            bytes_per_sample: r.bytes_per_sample,
            footprint_bytes: r.footprint_bytes,
            detector: &r.detector,
            culling: r.culling.as_deref().unwrap_or(""),
            normal_mean_deg: Num(r.normal_mean_deg),
            normal_p95_deg: Num(r.normal_p95_deg),
            normal_max_deg: Num(r.normal_max_deg),
            depth_rel_mean: Num(r.depth_rel_mean),
            depth_rel_max: Num(r.depth_rel_max),
            albedo_max_abs: Num(r.albedo_max_abs),
            scalar_max_abs: Num(r.scalar_max_abs),
            layout_rmse: Num(l.map(|e| e.rmse)),
            layout_psnr_db: Num(l.map(|e| e.psnr_db)),
            layout_flip_ldr: Num(l.and_then(|e| e.flip_ldr)),
            layout_flip_hdr: Num(l.and_then(|e| e.flip_hdr)),
            aa_rmse: Num(a.map(|e| e.rmse)),
            aa_psnr_db: Num(a.map(|e| e.psnr_db)),
            aa_flip_ldr: Num(a.and_then(|e| e.flip_ldr)),
            aa_flip_hdr: Num(a.and_then(|e| e.flip_hdr)),
            total_rmse: Num(t.map(|e| e.rmse)),
            total_psnr_db: Num(t.map(|e| e.psnr_db)),
            total_flip_ldr: Num(t.and_then(|e| e.flip_ldr)),
            total_flip_hdr: Num(t.and_then(|e| e.flip_hdr)),
            total_psnr_peak: Num(t.map(|e| e.psnr_peak)),
            shading_fraction: Num(r.shading_fraction),
            edge_fraction: Num(r.edge_fraction),
            precision: Num(r.precision),
            recall: Num(r.recall),
            decode_ops_per_sample: Num(r.decode_ops_per_sample.map(f64::from)),
            bandwidth_tiled_mb: Num(r.error.is_none().then_some(r.bandwidth_mb.tiled)),
            bandwidth_quad_mb: Num(r.bandwidth_mb.quad),
            dcc_bytes_per_sample: Num(r.compressed.map(|c| c.bytes_per_sample[0])),
            ccs_bytes_per_sample: Num(r.compressed.map(|c| c.bytes_per_sample[1])),
            afbc_bytes_per_sample: Num(r.compressed.map(|c| c.bytes_per_sample[2])),
            bandwidth_tiled_dcc_mb: Num(r.compressed.map(|c| c.tiled_mb[0])),
            encode_ms: Num(r.encode_ms),
            encode_ms_min: Num(r.timings.get("encode").map(|t| t.min_ms)),
            encode_ms_max: Num(r.timings.get("encode").map(|t| t.max_ms)),
            decode_ms: Num(r.decode_ms),
            decode_ms_min: Num(r.timings.get("decode").map(|t| t.min_ms)),
            decode_ms_max: Num(r.timings.get("decode").map(|t| t.max_ms)),
            detect_ms: Num(r.detect_ms),
            resolve_ms: Num(r.resolve_ms),
            resolve_ms_min: Num(r.timings.get("resolve").map(|t| t.min_ms)),
            resolve_ms_max: Num(r.timings.get("resolve").map(|t| t.max_ms)),
            resolve_pass_ms: Num(r.resolve_pass_ms),
            pareto_bytes: r.pareto.bytes,
            pareto_time: r.pareto.time,
            pareto_compressed: r.pareto.compressed,
            note,
        }
    }
}

/// One line of `aggregate.csv`: a layout × detector over every frame.
#[derive(Debug, Serialize)]
#[allow(missing_docs)] // the field names are the CSV header, documented in docs/GUIDE.md
pub struct AggregateCsvRow<'a> {
    pub layout: &'a str,
    pub bytes_per_sample: u32,
    pub detector: &'a str,
    pub culling: &'a str,
    pub frames: usize,
    pub failed_frames: usize,
    pub layout_rmse_mean: Num,
    pub layout_rmse_worst: Num,
    pub layout_rmse_worst_frame: &'a str,
    pub layout_flip_ldr_mean: Num,
    pub layout_flip_ldr_worst: Num,
    pub layout_flip_hdr_mean: Num,
    pub aa_rmse_mean: Num,
    pub total_rmse_mean: Num,
    pub total_rmse_worst: Num,
    pub normal_max_deg_worst: Num,
    pub resolve_pass_ms_mean: Num,
    pub bandwidth_tiled_mb_mean: Num,
    pub bandwidth_quad_mb_mean: Num,
    pub decode_ops_per_sample: Num,
    pub pareto_bytes: bool,
    pub pareto_time: bool,
}

impl<'a> AggregateCsvRow<'a> {
    /// The CSV line of `r`.
    #[must_use]
    pub fn of(r: &'a AggregateRow) -> Self {
        let mean = |s: &Option<Stat>| Num(s.as_ref().map(|s| s.mean));
        let worst = |s: &Option<Stat>| Num(s.as_ref().map(|s| s.worst));
        AggregateCsvRow {
            layout: &r.layout,
            bytes_per_sample: r.bytes_per_sample,
            detector: &r.detector,
            culling: r.culling.as_deref().unwrap_or(""),
            frames: r.frames,
            failed_frames: r.failed_frames,
            layout_rmse_mean: mean(&r.layout_rmse),
            layout_rmse_worst: worst(&r.layout_rmse),
            layout_rmse_worst_frame: r.layout_rmse.as_ref().map_or("", |s| s.worst_frame.as_str()),
            layout_flip_ldr_mean: mean(&r.layout_flip_ldr),
            layout_flip_ldr_worst: worst(&r.layout_flip_ldr),
            layout_flip_hdr_mean: mean(&r.layout_flip_hdr),
            aa_rmse_mean: mean(&r.aa_rmse),
            total_rmse_mean: mean(&r.total_rmse),
            total_rmse_worst: worst(&r.total_rmse),
            normal_max_deg_worst: worst(&r.normal_max_deg),
            resolve_pass_ms_mean: mean(&r.resolve_pass_ms),
            bandwidth_tiled_mb_mean: mean(&r.bandwidth_tiled_mb),
            bandwidth_quad_mb_mean: mean(&r.bandwidth_quad_mb),
            decode_ops_per_sample: Num(r.decode_ops_per_sample.map(f64::from)),
            pareto_bytes: r.pareto.bytes,
            pareto_time: r.pareto.time,
        }
    }
}

fn write_csv<T: Serialize>(lines: &[T]) -> String {
    let mut w = csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_writer(Vec::new());
    for l in lines {
        // Writing into a Vec cannot fail, and every field serializes to a string, number or bool.
        let _ = w.serialize(l);
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// The CSV text of `rows`, one line each by `line` (header first); with no rows, the header alone (of `blank`).
fn table<'a, R, L: Serialize>(rows: &'a [R], blank: &'a R, line: impl Fn(&'a R) -> L) -> String {
    if rows.is_empty() {
        let text = write_csv(&[line(blank)]);
        return text.lines().next().map(|h| format!("{h}\n")).unwrap_or_default();
    }
    write_csv(&rows.iter().map(line).collect::<Vec<_>>())
}

/// The text of `aggregate.csv` (header line first).
#[must_use]
pub fn aggregate_csv(rows: &[AggregateRow]) -> String {
    table(rows, &AggregateRow::default(), AggregateCsvRow::of)
}

/// The CSV text for `rows` (header line first, RFC 4180 quoting). An empty report still has its header.
#[must_use]
pub fn to_csv(rows: &[Row]) -> String {
    table(rows, &Row::default(), CsvRow::of)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::row::Timing;

    #[test]
    fn header_and_rows_have_the_same_width_and_quote_commas() {
        let mut r = Row {
            layout: "a,b".into(),
            bytes_per_sample: 12,
            detector: "depth-normal".into(),
            layout_error: Some(crate::measure::image::ErrorSet {
                rmse: 0.25,
                psnr_db: f64::INFINITY,
                ..Default::default()
            }),
            ..Default::default()
        };
        r.set_timing("encode", Timing::from_ms(vec![1.0, 2.0, 3.0]).unwrap());
        r.add_note("say \"why\"");
        let csv = to_csv(&[r.clone(), Row { error: Some("failed".into()), ..r }]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0].split(',').count(), 52);
        assert!(lines[0].starts_with("frame,layout,bytes_per_sample,footprint_bytes,detector,culling,"));
        assert_eq!(to_csv(&[]), format!("{}\n", lines[0]), "an empty report keeps its header");
        assert!(lines[1].starts_with(",\"a,b\",12,0,depth-normal,,"));
        assert!(lines[1].contains(",0.25,inf,"));
        assert!(lines[1].contains(",2,1,3,"), "encode median, min, max: {}", lines[1]);
        assert!(lines[1].ends_with(",\"say \"\"why\"\"\""));
        assert!(lines[2].contains("error: failed"));
        // Every line splits into the same number of fields once quoted commas are accounted for.
        for l in &lines[1..] {
            let mut n = 1;
            let mut q = false;
            for c in l.chars() {
                match c {
                    '"' => q = !q,
                    ',' if !q => n += 1,
                    _ => {}
                }
            }
            assert_eq!(n, lines[0].split(',').count(), "{l}");
        }
    }
}
