//! One [`Row`] per layout × detector (× culling) run of a sweep, with its measured [`Timing`]s and modelled
//! [`Bandwidth`]; the frames and the whole report that hold the rows are in [`crate::analysis::record`].

use crate::analysis::pareto;
use crate::measure::image::ErrorSet;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Instant;

/// A measured duration over several runs: median and spread.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Median over the runs, in milliseconds.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub median_ms: f64,
    /// Fastest run.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub min_ms: f64,
    /// Slowest run.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub max_ms: f64,
    /// Number of runs.
    pub runs: usize,
}

impl Timing {
    /// The timing of a set of run durations in milliseconds (`None` when empty).
    #[must_use]
    pub fn from_ms(mut ms: Vec<f64>) -> Option<Timing> {
        if ms.is_empty() {
            return None;
        }
        ms.sort_by(f64::total_cmp);
        let n = ms.len();
        let median = if n % 2 == 1 { ms[n / 2] } else { 0.5 * (ms[n / 2 - 1] + ms[n / 2]) };
        Some(Timing { median_ms: median, min_ms: ms[0], max_ms: ms[n - 1], runs: n })
    }
}

/// Runs `f` `runs` times (at least once), returning the last result and the timing of the runs. Stops at the
/// first error.
pub fn time_runs<T, E>(runs: usize, mut f: impl FnMut() -> Result<T, E>) -> Result<(T, Timing), E> {
    let mut ms = Vec::with_capacity(runs.max(1));
    let mut last = None;
    for _ in 0..runs.max(1) {
        // The previous run's result goes before the next run allocates its own: a whole-G-buffer pack or unpack
        // is hundreds of MB at 1080p × 4, and two of them alive at once set a report's peak memory.
        drop(last.take());
        let t = Instant::now();
        let v = f()?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        last = Some(v);
    }
    let timing = Timing::from_ms(ms).expect("at least one run");
    Ok((last.expect("at least one run"), timing))
}

/// Pareto membership of a row. Both fronts rank by the *layout error* (RMSE of the image lit from the unpacked
/// G-buffer against the exact G-buffer lit with the same detector and schedule), never by the error against the
/// every-sample reference, which also holds the detector's aliasing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ParetoFlags {
    /// On the front of layout error against bytes per sample.
    pub bytes: bool,
    /// On the front of layout error against the resolve pass time (decode + lighting).
    pub time: bool,
    /// On the front of layout error against the tiled traffic after the `dcc` compression model.
    #[serde(default)]
    pub compressed: bool,
}

/// A layout's G-buffer after framebuffer compression, per model (`dcc`, `ccs`, `afbc`; a target a model cannot hold
/// counts its nominal bytes, as hardware stores it uncompressed): bytes per sample, and the tiled resolve's traffic
/// with those bytes in place of the nominal ones.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Compressed {
    /// Bytes per sample under each model, in `layout::compression::SCHEMES` order.
    pub bytes_per_sample: [f64; 3],
    /// Tiled-deferred traffic (MB per frame, [`Bandwidth::tiled`]'s model) under each model.
    pub tiled_mb: [f64; 3],
}

/// Modelled G-buffer traffic of one frame, in MB (10⁶ bytes), per lighting schedule; docs/GUIDE.md gives the
/// formulas.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Bandwidth {
    /// Tiled deferred: the G-buffer written once per covered sample, read once per covered sample by the tiled
    /// resolve, and the RGBA16F output written once per pixel.
    #[serde(deserialize_with = "crate::base::json::f64_or_nan")]
    pub tiled: f64,
    /// Quad (light-volume) deferred: the G-buffer written once, then per light-fragment pair one G-buffer read and
    /// one RGBA16F accumulation read-modify-write; `None` when the pair count is unknown.
    pub quad: Option<f64>,
    /// The light-fragment pairs of the quad schedule (quad-culled resolve of the exact G-buffer with the row's
    /// detector).
    pub quad_light_fragments: Option<u64>,
}

/// One measured combination. Every metric is `None` when it could not be computed; `note` or `error` says why.
///
/// Three image errors are kept apart: [`Row::layout_error`] (what the layout's packing costs),
/// [`Row::aa_error`] (what the detector's anti-aliasing costs, the same for every layout) and
/// [`Row::total_error`] (both, against the every-sample reference).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The frame (dump) this row was measured on.
    #[serde(default)]
    pub frame: String,
    /// Layout name.
    pub layout: String,
    /// Bytes per sample of the layout.
    pub bytes_per_sample: u32,
    /// Bytes the layout's render targets take at this resolution and sample count.
    pub footprint_bytes: u64,
    /// Edge detector name.
    pub detector: String,
    /// Light culling mode, when the sweep varies it.
    pub culling: Option<String>,
    /// Mean angular normal error (degrees) after the roundtrip.
    pub normal_mean_deg: Option<f64>,
    /// 95th percentile angular normal error (degrees).
    pub normal_p95_deg: Option<f64>,
    /// Maximum angular normal error (degrees).
    pub normal_max_deg: Option<f64>,
    /// Mean relative depth error.
    pub depth_rel_mean: Option<f64>,
    /// Maximum relative depth error.
    pub depth_rel_max: Option<f64>,
    /// Maximum absolute albedo error (any channel).
    pub albedo_max_abs: Option<f64>,
    /// Maximum absolute error over the scalar attributes (relative for specular power).
    pub scalar_max_abs: Option<f64>,
    /// The image lit from the unpacked G-buffer against the exact G-buffer lit with the same detector and
    /// schedule: the error the layout alone causes (0 for a lossless layout).
    pub layout_error: Option<ErrorSet>,
    /// The exact G-buffer lit with the detector against the every-sample reference: the detector's aliasing,
    /// whatever the layout.
    pub aa_error: Option<ErrorSet>,
    /// The image lit from the unpacked G-buffer against the every-sample reference: both errors together.
    pub total_error: Option<ErrorSet>,
    /// Shaded samples / all samples.
    pub shading_fraction: Option<f64>,
    /// Fraction of pixels flagged as edges.
    pub edge_fraction: Option<f64>,
    /// Detector precision against ground truth.
    pub precision: Option<f64>,
    /// Detector recall against ground truth.
    pub recall: Option<f64>,
    /// Arithmetic operations the lighting pass spends decoding one sample (summed over the layout's fields, as the
    /// codecs count them).
    pub decode_ops_per_sample: Option<u32>,
    /// Modelled G-buffer traffic per frame.
    pub bandwidth_mb: Bandwidth,
    /// Median encode (pack) time in ms: a tool cost (a renderer writes its G-buffer while rasterising).
    pub encode_ms: Option<f64>,
    /// Median decode (unpack) time in ms.
    pub decode_ms: Option<f64>,
    /// Median edge-detection time in ms.
    pub detect_ms: Option<f64>,
    /// Median resolve (lighting) time in ms.
    pub resolve_ms: Option<f64>,
    /// The resolve pass, the time axis of the fronts: the resolve's median when it read the packed targets (it
    /// decodes what it lights: `packed_resolve`), else decode + resolve medians.
    pub resolve_pass_ms: Option<f64>,
    /// The resolve (and the detector) read the layout's packed targets, decoding a band at a time: `resolve_ms`
    /// holds the decode, and `decode_ms` is what decoding the whole frame once costs.
    #[serde(default)]
    pub packed_resolve: bool,
    /// Sum of the four medians (the tool's own time for the row).
    pub total_ms: Option<f64>,
    /// The full timings (median and spread) per stage.
    pub timings: BTreeMap<String, Timing>,
    /// Bytes after framebuffer compression (`layout::compression`'s models of published constraints) and the
    /// tiled resolve's traffic recomputed with them; `None` when the layout could not be packed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compressed: Option<Compressed>,
    /// Pareto membership.
    pub pareto: ParetoFlags,
    /// Remarks (e.g. why a metric is missing).
    pub note: Option<String>,
    /// The error that stopped this row, if any.
    pub error: Option<String>,
}

impl Row {
    /// Adds a stage timing, keeping the flat median fields in step.
    pub fn set_timing(&mut self, stage: &str, t: Timing) {
        match stage {
            "encode" => self.encode_ms = Some(t.median_ms),
            "decode" => self.decode_ms = Some(t.median_ms),
            "detect" => self.detect_ms = Some(t.median_ms),
            "resolve" => self.resolve_ms = Some(t.median_ms),
            _ => {}
        }
        self.timings.insert(stage.to_string(), t);
        self.resolve_pass_ms = match (self.decode_ms, self.resolve_ms) {
            (_, Some(d)) if self.packed_resolve => Some(d),
            (Some(b), Some(d)) => Some(b + d),
            _ => None,
        };
        self.total_ms = match (self.encode_ms, self.decode_ms, self.detect_ms, self.resolve_ms) {
            (Some(a), Some(b), Some(c), Some(d)) => Some(a + b + c + d),
            _ => None,
        };
    }

    /// Appends a remark to `note`.
    pub fn add_note(&mut self, s: impl AsRef<str>) {
        self.note = Some(match self.note.take() {
            Some(n) => format!("{n}; {}", s.as_ref()),
            None => s.as_ref().to_string(),
        });
    }

    /// The layout error's RMSE, what the fronts rank by.
    #[must_use]
    pub fn layout_rmse(&self) -> Option<f64> {
        self.layout_error.map(|e| e.rmse)
    }
}

/// Marks the Pareto fronts (layout error against bytes, against the resolve pass time, and against the traffic after
/// the `dcc` compression model) on `rows`.
pub fn mark_pareto(rows: &mut [Row]) {
    let err = |r: &Row| if r.error.is_some() { f64::NAN } else { r.layout_rmse().unwrap_or(f64::NAN) };
    // Bytes in memory: the footprint (AFRC targets at their fixed rate), whose order within a frame is bytes per
    // sample's.
    let by_bytes: Vec<(f64, f64)> = rows.iter().map(|r| (r.footprint_bytes as f64, err(r))).collect();
    let by_time: Vec<(f64, f64)> = rows.iter().map(|r| (r.resolve_pass_ms.unwrap_or(f64::NAN), err(r))).collect();
    let by_traffic: Vec<(f64, f64)> =
        rows.iter().map(|r| (r.compressed.map_or(f64::NAN, |c| c.tiled_mb[0]), err(r))).collect();
    let (fb, ft, fc) = (pareto::front(&by_bytes), pareto::front(&by_time), pareto::front(&by_traffic));
    for (i, r) in rows.iter_mut().enumerate() {
        r.pareto = ParetoFlags { bytes: fb[i], time: ft[i], compressed: fc[i] };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_median_and_spread() {
        let t = Timing::from_ms(vec![5.0, 1.0, 3.0]).unwrap();
        assert_eq!((t.median_ms, t.min_ms, t.max_ms, t.runs), (3.0, 1.0, 5.0, 3));
        let t = Timing::from_ms(vec![4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!(t.median_ms, 2.5);
        assert!(Timing::from_ms(vec![]).is_none());
    }

    #[test]
    fn time_runs_counts_and_propagates_errors() {
        let mut n = 0;
        let (v, t) = time_runs(3, || -> Result<i32, ()> {
            n += 1;
            Ok(n)
        })
        .unwrap();
        assert_eq!((v, t.runs), (3, 3));
        assert!(t.min_ms <= t.median_ms && t.median_ms <= t.max_ms);
        assert!(time_runs(3, || -> Result<(), &str> { Err("boom") }).is_err());
        // One result alive at a time: the previous run's is dropped before the next run starts.
        struct Live<'a>(&'a std::cell::Cell<i32>);
        impl Drop for Live<'_> {
            fn drop(&mut self) {
                self.0.set(self.0.get() - 1);
            }
        }
        let (live, peak) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
        let (v, _) = time_runs(4, || -> Result<Live<'_>, ()> {
            live.set(live.get() + 1);
            peak.set(peak.get().max(live.get()));
            Ok(Live(&live))
        })
        .unwrap();
        assert_eq!((live.get(), peak.get()), (1, 1));
        drop(v);
        assert_eq!(live.get(), 0);
    }

    #[test]
    fn pareto_marks_rows_without_numbers_as_off_the_front() {
        let mk = |b, e: Option<f64>, t| {
            let mut r = Row {
                bytes_per_sample: b,
                footprint_bytes: u64::from(b) * 100,
                layout_error: e.map(|rmse| ErrorSet { rmse, ..Default::default() }),
                // Traffic after compression: 8, 12, 1 and 4 MB.
                compressed: Some(Compressed { tiled_mb: [f64::from(b % 16 + b / 16); 3], ..Default::default() }),
                ..Default::default()
            };
            for s in ["encode", "decode", "detect", "resolve"] {
                r.set_timing(s, Timing::from_ms(vec![t / 4.0]).unwrap());
            }
            r
        };
        let mut rows = vec![mk(8, Some(0.5), 10.0), mk(12, Some(0.1), 40.0), mk(16, Some(0.2), 5.0), mk(4, None, 1.0)];
        mark_pareto(&mut rows);
        let flags: Vec<(bool, bool)> = rows.iter().map(|r| (r.pareto.bytes, r.pareto.time)).collect();
        assert_eq!(flags, vec![(true, false), (true, true), (false, true), (false, false)]);
        // Traffic after compression 8, 12 and 1 MB: the 16 B row compresses best and dominates the 8 B one.
        let compressed: Vec<bool> = rows.iter().map(|r| r.pareto.compressed).collect();
        assert_eq!(compressed, vec![false, true, true, false]);
        assert_eq!(rows[0].total_ms, Some(10.0));
        assert_eq!(rows[0].resolve_pass_ms, Some(5.0), "decode + resolve");
    }
}
