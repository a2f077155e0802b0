//! `report.csv`: one line per row, every numeric metric in its own column, empty cells where a metric could not
//! be computed (the `note`/`error` columns say why).

use crate::analysis::row::Row;
use std::fmt::Write as _;

/// The header columns, in order.
pub const COLUMNS: [&str; 34] = [
    "layout",
    "bytes_per_sample",
    "footprint_bytes",
    "detector",
    "culling",
    "normal_mean_deg",
    "normal_p95_deg",
    "normal_max_deg",
    "depth_rel_mean",
    "depth_rel_max",
    "albedo_max_abs",
    "scalar_max_abs",
    "rmse",
    "psnr_db",
    "layout_rmse",
    "max_abs",
    "rel_mse",
    "shading_fraction",
    "edge_fraction",
    "precision",
    "recall",
    "encode_ms",
    "encode_ms_min",
    "encode_ms_max",
    "decode_ms",
    "decode_ms_min",
    "decode_ms_max",
    "detect_ms",
    "resolve_ms",
    "resolve_ms_min",
    "resolve_ms_max",
    "pareto_bytes",
    "pareto_time",
    "note",
];

/// Quotes a field when it holds a comma, quote or newline (RFC 4180).
#[must_use]
pub fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn num(v: Option<f64>) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x}"),
        Some(x) if x.is_nan() => String::new(),
        Some(x) if x > 0.0 => "inf".into(),
        Some(_) => "-inf".into(),
        None => String::new(),
    }
}

/// The CSV text for `rows`.
#[must_use]
pub fn to_csv(rows: &[Row]) -> String {
    let mut s = COLUMNS.join(",");
    s.push('\n');
    for r in rows {
        let t = |stage: &str, which: fn(&crate::analysis::row::Timing) -> f64| num(r.timings.get(stage).map(which));
        let note = match (&r.note, &r.error) {
            (Some(n), Some(e)) => format!("error: {e}; {n}"),
            (None, Some(e)) => format!("error: {e}"),
            (Some(n), None) => n.clone(),
            (None, None) => String::new(),
        };
        let cells = [
            field(&r.layout),
            r.bytes_per_sample.to_string(),
            r.footprint_bytes.to_string(),
            field(&r.detector),
            field(r.culling.as_deref().unwrap_or("")),
            num(r.normal_mean_deg),
            num(r.normal_p95_deg),
            num(r.normal_max_deg),
            num(r.depth_rel_mean),
            num(r.depth_rel_max),
            num(r.albedo_max_abs),
            num(r.scalar_max_abs),
            num(r.rmse),
            num(r.psnr_db),
            num(r.layout_rmse),
            num(r.max_abs),
            num(r.rel_mse),
            num(r.shading_fraction),
            num(r.edge_fraction),
            num(r.precision),
            num(r.recall),
            num(r.encode_ms),
            t("encode", |t| t.min_ms),
            t("encode", |t| t.max_ms),
            num(r.decode_ms),
            t("decode", |t| t.min_ms),
            t("decode", |t| t.max_ms),
            num(r.detect_ms),
            num(r.resolve_ms),
            t("resolve", |t| t.min_ms),
            t("resolve", |t| t.max_ms),
            r.pareto.bytes.to_string(),
            r.pareto.time.to_string(),
            field(&note),
        ];
        debug_assert_eq!(cells.len(), COLUMNS.len());
        let _ = writeln!(s, "{}", cells.join(","));
    }
    s
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
            rmse: Some(0.25),
            psnr_db: Some(f64::INFINITY),
            ..Default::default()
        };
        r.set_timing("encode", Timing::from_ms(vec![1.0, 2.0, 3.0]).unwrap());
        r.add_note("say \"why\"");
        let csv = to_csv(&[r.clone(), Row { error: Some("failed".into()), ..r }]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[1].starts_with("\"a,b\",12,0,depth-normal,,"));
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
            assert_eq!(n, COLUMNS.len(), "{l}");
        }
    }
}
