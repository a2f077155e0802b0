//! Many frames: a layout is chosen for a game, not a frame. The per-frame rows of a report (or of several
//! `report.json` files merged later) are aggregated per layout × detector (× culling) into the mean and the worst
//! frame of every measure, the worst frame named, and the fronts are marked on the aggregate by the mean or the
//! worst frame ([`Over`]).
//!
//! Aggregation depends only on the rows, so `gbuf report a b c` and `gbuf merge ra.json rb.json rc.json` give the
//! same tables and fronts.

use crate::analysis::pareto;
use crate::analysis::row::{ParetoFlags, Row};
use crate::analysis::sweep::DetectorResult;
use serde::{Deserialize, Serialize};

crate::named_enum! {
    /// Which frame of a capture decides: the mean over the frames or the worst one.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Over: "aggregate" {
        /// The mean over the frames.
        Mean => "mean",
        /// The worst frame (the default: a layout must hold on every frame of the game).
        #[default]
        Worst => "worst",
    }
}

/// A measure over frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stat {
    /// Mean over the frames that have the measure.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub mean: f64,
    /// Largest value (the worst frame: every aggregated measure is lower-is-better).
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub worst: f64,
    /// The frame with the largest value.
    pub worst_frame: String,
    /// Frames that have the measure.
    pub frames: usize,
}

impl Stat {
    /// The statistic of `(frame, value)` pairs; `None` when no value is finite.
    #[must_use]
    pub fn of<'a>(values: impl IntoIterator<Item = (&'a str, Option<f64>)>) -> Option<Stat> {
        let mut n = 0usize;
        let mut sum = 0.0;
        let mut worst: Option<(f64, &str)> = None;
        for (frame, v) in values {
            let Some(v) = v.filter(|v| v.is_finite()) else { continue };
            n += 1;
            sum += v;
            if worst.is_none_or(|(w, _)| v > w) {
                worst = Some((v, frame));
            }
        }
        let (w, f) = worst?;
        Some(Stat { mean: sum / n as f64, worst: w, worst_frame: f.to_string(), frames: n })
    }

    /// The mean or the worst value.
    #[must_use]
    pub fn over(&self, over: Over) -> f64 {
        match over {
            Over::Mean => self.mean,
            Over::Worst => self.worst,
        }
    }
}

/// One layout × detector (× culling) over every frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AggregateRow {
    /// Layout name.
    pub layout: String,
    /// Bytes per sample.
    pub bytes_per_sample: u32,
    /// Detector name.
    pub detector: String,
    /// Culling mode, when the sweep varied it.
    pub culling: Option<String>,
    /// Frames with a row for this combination.
    pub frames: usize,
    /// Frames of the report where this combination failed (its `error` is set) or has no row at all.
    pub failed_frames: usize,
    /// Layout error RMSE.
    pub layout_rmse: Option<Stat>,
    /// Layout error, mean LDR-FLIP (frames where it was computed).
    pub layout_flip_ldr: Option<Stat>,
    /// Layout error, mean HDR-FLIP.
    pub layout_flip_hdr: Option<Stat>,
    /// Anti-aliasing error RMSE.
    pub aa_rmse: Option<Stat>,
    /// Total error RMSE (against the every-sample reference).
    pub total_rmse: Option<Stat>,
    /// Largest normal error, degrees.
    pub normal_max_deg: Option<Stat>,
    /// Resolve pass time (decode + lighting), ms.
    pub resolve_pass_ms: Option<Stat>,
    /// Modelled traffic of the tiled schedule, MB per frame.
    pub bandwidth_tiled_mb: Option<Stat>,
    /// Modelled traffic of the quad schedule, MB per frame.
    pub bandwidth_quad_mb: Option<Stat>,
    /// Modelled traffic of the tiled schedule after the `dcc` compression model, MB per frame.
    #[serde(default)]
    pub bandwidth_tiled_dcc_mb: Option<Stat>,
    /// Decode operations per sample.
    pub decode_ops_per_sample: Option<u32>,
    /// On the aggregate fronts (layout error by [`Over`] against bytes, the mean resolve pass time and the mean
    /// traffic after compression).
    pub pareto: ParetoFlags,
}

impl AggregateRow {
    /// The layout error that ranks this row (`Over`), NaN when unknown or when a frame failed.
    #[must_use]
    fn ranked_error(&self, over: Over) -> f64 {
        if self.failed_frames > 0 {
            return f64::NAN;
        }
        self.layout_rmse.as_ref().map_or(f64::NAN, |s| s.over(over))
    }
}

/// A detector over every frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectorAggregate {
    /// Detector name.
    pub detector: String,
    /// Shading fraction on the exact G-buffer.
    pub shading_fraction: Option<Stat>,
    /// Anti-aliasing error RMSE.
    pub aa_rmse: Option<Stat>,
    /// Anti-aliasing error, mean LDR-FLIP.
    pub aa_flip_ldr: Option<Stat>,
    /// Anti-aliasing error, mean HDR-FLIP.
    pub aa_flip_hdr: Option<Stat>,
    /// On the front of anti-aliasing error (by [`Over`]) against the mean shading fraction.
    pub on_front: bool,
}

type Key = (String, String, Option<String>);

/// Aggregates per-frame rows per layout × detector × culling (in first-seen order) and marks the fronts.
#[must_use]
pub fn aggregate(rows: &[Row], over: Over) -> Vec<AggregateRow> {
    let mut frames: Vec<&str> = Vec::new();
    for r in rows {
        if !frames.contains(&r.frame.as_str()) {
            frames.push(&r.frame);
        }
    }
    let mut keys: Vec<Key> = Vec::new();
    for r in rows {
        let k = (r.layout.clone(), r.detector.clone(), r.culling.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let mut out: Vec<AggregateRow> = keys
        .into_iter()
        .map(|(layout, detector, culling)| {
            let group: Vec<&Row> =
                rows.iter().filter(|r| r.layout == layout && r.detector == detector && r.culling == culling).collect();
            let ok: Vec<&Row> = group.iter().copied().filter(|r| r.error.is_none()).collect();
            let stat = |f: &dyn Fn(&Row) -> Option<f64>| Stat::of(ok.iter().map(|r| (r.frame.as_str(), f(r))));
            AggregateRow {
                bytes_per_sample: group[0].bytes_per_sample,
                frames: group.len(),
                failed_frames: frames.len() - ok.len(),
                layout_rmse: stat(&|r| r.layout_error.map(|e| e.rmse)),
                layout_flip_ldr: stat(&|r| r.layout_error.and_then(|e| e.flip_ldr)),
                layout_flip_hdr: stat(&|r| r.layout_error.and_then(|e| e.flip_hdr)),
                aa_rmse: stat(&|r| r.aa_error.map(|e| e.rmse)),
                total_rmse: stat(&|r| r.total_error.map(|e| e.rmse)),
                normal_max_deg: stat(&|r| r.normal_max_deg),
                resolve_pass_ms: stat(&|r| r.resolve_pass_ms),
                bandwidth_tiled_mb: stat(&|r| Some(r.bandwidth_mb.tiled)),
                bandwidth_quad_mb: stat(&|r| r.bandwidth_mb.quad),
                bandwidth_tiled_dcc_mb: stat(&|r| r.compressed.map(|c| c.tiled_mb[0])),
                decode_ops_per_sample: group[0].decode_ops_per_sample,
                pareto: ParetoFlags::default(),
                layout,
                detector,
                culling,
            }
        })
        .collect();
    mark_aggregate_pareto(&mut out, over);
    out
}

/// Marks the aggregate fronts: layout error (by `over`) against bytes per sample, against the mean resolve pass
/// time, and against the mean tiled traffic after the `dcc` compression model.
fn mark_aggregate_pareto(rows: &mut [AggregateRow], over: Over) {
    let by_bytes: Vec<(f64, f64)> =
        rows.iter().map(|r| (f64::from(r.bytes_per_sample), r.ranked_error(over))).collect();
    let by_time: Vec<(f64, f64)> =
        rows.iter().map(|r| (r.resolve_pass_ms.as_ref().map_or(f64::NAN, |s| s.mean), r.ranked_error(over))).collect();
    let by_traffic: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.bandwidth_tiled_dcc_mb.as_ref().map_or(f64::NAN, |s| s.mean), r.ranked_error(over)))
        .collect();
    let (fb, ft, fc) = (pareto::front(&by_bytes), pareto::front(&by_time), pareto::front(&by_traffic));
    for (i, r) in rows.iter_mut().enumerate() {
        r.pareto = ParetoFlags { bytes: fb[i], time: ft[i], compressed: fc[i] };
    }
}

/// Aggregates the detectors of every frame (in first-seen order) and marks their front.
#[must_use]
pub fn aggregate_detectors(per_frame: &[DetectorResult], over: Over) -> Vec<DetectorAggregate> {
    let mut names: Vec<&str> = Vec::new();
    for d in per_frame {
        if !names.contains(&d.detector.as_str()) {
            names.push(&d.detector);
        }
    }
    let mut out: Vec<DetectorAggregate> = names
        .into_iter()
        .map(|name| {
            let g: Vec<&DetectorResult> = per_frame.iter().filter(|d| d.detector == name).collect();
            let stat =
                |f: &dyn Fn(&DetectorResult) -> Option<f64>| Stat::of(g.iter().map(|d| (d.frame.as_str(), f(d))));
            DetectorAggregate {
                detector: name.to_string(),
                shading_fraction: stat(&|d| d.shading_fraction),
                aa_rmse: stat(&|d| d.aa_error.map(|e| e.rmse)),
                aa_flip_ldr: stat(&|d| d.aa_error.and_then(|e| e.flip_ldr)),
                aa_flip_hdr: stat(&|d| d.aa_error.and_then(|e| e.flip_hdr)),
                on_front: false,
            }
        })
        .collect();
    let pts: Vec<(f64, f64)> = out
        .iter()
        .map(|d| {
            (
                d.shading_fraction.as_ref().map_or(f64::NAN, |s| s.mean),
                d.aa_rmse.as_ref().map_or(f64::NAN, |s| s.over(over)),
            )
        })
        .collect();
    for (d, on) in out.iter_mut().zip(pareto::front(&pts)) {
        d.on_front = on;
    }
    out
}

/// What a byte budget picks over the frames of a report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BudgetChoice {
    /// The budget, bytes per sample.
    pub max_bytes: u32,
    /// Mean or worst frame.
    pub over: Over,
    /// The chosen layout, `None` when no layout of the report fits and was measured on every frame.
    pub layout: Option<String>,
    /// The detector of its row.
    pub detector: Option<String>,
    /// Its bytes per sample.
    pub bytes_per_sample: Option<u32>,
    /// Its layout error over the frames.
    pub layout_rmse: Option<Stat>,
}

impl BudgetChoice {
    /// The choice among `rows` (see `budget_choice`).
    #[must_use]
    pub fn of(rows: &[AggregateRow], max_bytes: u32, over: Over) -> Self {
        let c = budget_choice(rows, max_bytes, over);
        BudgetChoice {
            max_bytes,
            over,
            layout: c.map(|r| r.layout.clone()),
            detector: c.map(|r| r.detector.clone()),
            bytes_per_sample: c.map(|r| r.bytes_per_sample),
            layout_rmse: c.and_then(|r| r.layout_rmse.clone()),
        }
    }
}

/// The layout a byte budget picks over the aggregate: the least layout error (by `over`) among the rows of at
/// most `max_bytes` per sample that were measured on every frame (ties → fewer bytes).
#[must_use]
fn budget_choice(rows: &[AggregateRow], max_bytes: u32, over: Over) -> Option<&AggregateRow> {
    rows.iter().filter(|r| r.bytes_per_sample <= max_bytes && r.ranked_error(over).is_finite()).min_by(|a, b| {
        a.ranked_error(over).total_cmp(&b.ranked_error(over)).then(a.bytes_per_sample.cmp(&b.bytes_per_sample))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::image::ErrorSet;

    fn row(frame: &str, layout: &str, bytes: u32, rmse: f64) -> Row {
        Row {
            frame: frame.into(),
            layout: layout.into(),
            detector: "lauritzen".into(),
            bytes_per_sample: bytes,
            layout_error: Some(ErrorSet { rmse, ..Default::default() }),
            ..Default::default()
        }
    }

    #[test]
    fn mean_worst_and_the_worst_frame_named() {
        let rows = vec![row("a", "x", 8, 0.1), row("b", "x", 8, 0.3), row("a", "y", 12, 0.2), row("b", "y", 12, 0.2)];
        let agg = aggregate(&rows, Over::Worst);
        assert_eq!(agg.len(), 2);
        let x = agg[0].layout_rmse.as_ref().unwrap();
        assert!((x.mean - 0.2).abs() < 1e-12 && x.worst == 0.3 && x.worst_frame == "b" && x.frames == 2);
        // Worst: x (0.3 at 8 B) and y (0.2 at 12 B) are both on the bytes front; by the mean, y (0.2) ties x's
        // mean (0.2) with more bytes, so it falls off.
        assert_eq!((agg[0].pareto.bytes, agg[1].pareto.bytes), (true, true));
        let mean = aggregate(&rows, Over::Mean);
        assert_eq!((mean[0].pareto.bytes, mean[1].pareto.bytes), (true, false));
        assert_eq!(budget_choice(&agg, 12, Over::Worst).unwrap().layout, "y");
        assert_eq!(budget_choice(&agg, 12, Over::Mean).unwrap().layout, "x", "tie on the mean → fewer bytes");
        assert_eq!(budget_choice(&agg, 8, Over::Worst).unwrap().layout, "x");
        assert!(budget_choice(&agg, 4, Over::Worst).is_none());
    }

    #[test]
    fn a_failed_frame_keeps_a_layout_off_the_fronts_and_out_of_the_budget() {
        let mut bad = row("b", "x", 4, 0.0);
        bad.error = Some("roundtrip failed".into());
        let rows = vec![row("a", "x", 4, 0.0), bad, row("a", "y", 12, 0.5), row("b", "y", 12, 0.5)];
        let agg = aggregate(&rows, Over::Worst);
        assert_eq!(agg[0].failed_frames, 1);
        // A layout with no row at all on a frame counts as failed there too.
        let rows = vec![row("a", "x", 4, 0.0), row("a", "y", 12, 0.5), row("b", "y", 12, 0.5)];
        let agg = aggregate(&rows, Over::Worst);
        assert_eq!((agg[0].frames, agg[0].failed_frames), (1, 1));
        assert_eq!(BudgetChoice::of(&agg, 100, Over::Worst).layout.as_deref(), Some("y"));
        assert!(!agg[0].pareto.bytes && agg[1].pareto.bytes);
        assert_eq!(budget_choice(&agg, 100, Over::Worst).unwrap().layout, "y");
    }
}
