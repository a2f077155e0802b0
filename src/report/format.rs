//! The pieces every report writer shares: number formatting, stage-time summaries and the files written beside
//! the reports.

use crate::analysis::sweep::add_stage_time;

/// A file to put in the report folder besides the three reports (a figure, a layout file).
#[derive(Clone, Debug)]
pub struct Attachment {
    /// File name inside the folder (no directories).
    pub name: String,
    /// Contents.
    pub bytes: Vec<u8>,
}

/// Formats an optional number with `prec` decimals; `—` when missing, `∞` when infinite.
#[must_use]
pub fn fmt_opt(v: Option<f64>, prec: usize) -> String {
    match v {
        None => "—".into(),
        Some(x) if x.is_nan() => "—".into(),
        Some(x) if x == f64::INFINITY => "∞".into(),
        Some(x) if x == f64::NEG_INFINITY => "−∞".into(),
        Some(x) if x != 0.0 && x.abs() < 10f64.powi(-(prec as i32)) => format!("{x:.1e}"),
        Some(x) => format!("{x:.prec$}"),
    }
}

/// `kind 1.2 s, kind 0.3 s, …` of sweeps' [`Frame::stage_seconds`](crate::analysis::record::Frame) (one frame's, or
/// several frames' summed by kind), largest first; empty when there are none.
#[must_use]
pub fn stage_summary<'a>(stages: impl IntoIterator<Item = &'a (String, f64)>) -> String {
    let mut sums = Vec::new();
    for (kind, s) in stages {
        add_stage_time(&mut sums, kind, *s);
    }
    sums.sort_by(|a, b| b.1.total_cmp(&a.1));
    sums.iter().map(|(k, t)| format!("{k} {t:.1} s")).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    /// Several frames' stages sum by kind and list largest first; none gives an empty summary.
    #[test]
    fn stage_summary_sums_frames_by_kind() {
        let a = [("FLIP".to_string(), 1.0), ("resolve".to_string(), 0.5)];
        let b = [("resolve".to_string(), 2.0), ("reference".to_string(), 0.25)];
        assert_eq!(super::stage_summary(a.iter().chain(&b)), "resolve 2.5 s, FLIP 1.0 s, reference 0.2 s");
        assert_eq!(super::stage_summary(&[]), "");
    }
}
