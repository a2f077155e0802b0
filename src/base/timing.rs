//! Wall-clock timing of one run of a pipeline stage, in milliseconds (what `--json` reports under `ms`): [`ms`],
//! [`timed`]. Repeated runs with their median and spread are the analysis' `time_runs` (the report's timings).

use serde::Serialize;
use std::time::{Duration, Instant};

/// A duration in milliseconds (f64).
#[must_use]
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Runs `f` and returns its result with the elapsed milliseconds.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let v = f();
    (v, ms(t.elapsed()))
}

/// Milliseconds spent in each stage of a resolve run (the CLI fills `decode` and `detect`; the resolve fills
/// the rest). Summable: [`StageMs::add`]. Wall-clock times; `decode`, `detect` and `total` are measured, while
/// `gather`, `cull` and `shade` are estimates: the parallel part's wall time split by the shares the stages took on
/// the tiles whose stages were timed (1 in 8), plus the serial light preparation in `cull`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageMs {
    /// Loading and unpacking the G-buffer.
    pub decode: f64,
    /// Edge detection.
    pub detect: f64,
    /// Building the per-tile work lists (reading and sanitising samples).
    pub gather: f64,
    /// Light culling (light preparation, bounds, light lists).
    pub cull: f64,
    /// Shading and the box filter.
    pub shade: f64,
    /// The whole resolve (gather + cull + shade + assembling the image), plus decode and detect when filled.
    pub total: f64,
}

impl StageMs {
    /// Adds `o` into `self`, stage by stage.
    pub fn add(&mut self, o: &StageMs) {
        self.decode += o.decode;
        self.detect += o.detect;
        self.gather += o.gather;
        self.cull += o.cull;
        self.shade += o.shade;
        self.total += o.total;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ms_converts_and_add_sums() {
        assert_eq!(ms(Duration::from_micros(1500)), 1.5);
        let mut a = StageMs { shade: 1.0, total: 2.0, ..Default::default() };
        a.add(&StageMs { shade: 0.5, decode: 3.0, ..Default::default() });
        assert_eq!((a.shade, a.decode, a.total), (1.5, 3.0, 2.0));
        let (v, t) = timed(|| 7);
        assert!(v == 7 && t >= 0.0);
    }
}
