//! The running machine's own limits, measured: how fast one thread and every thread read memory, and the FMA peak
//! of each instruction-set path ([`crate::resolve::peak`]). `gbuf bench` sets a frame's stages against them, so
//! that a reader on another CPU knows what "fast" means there.

use crate::base::isa::Isa;
use rayon::prelude::*;
use serde::Serialize;

/// Read bandwidth, bytes per second.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Bandwidth {
    /// The buffer read, bytes (far beyond the caches at the default size).
    pub bytes: usize,
    /// One thread summing the buffer (best of three passes).
    pub one_thread: f64,
    /// Every thread of the pool summing its part (best of three passes).
    pub all_threads: f64,
    /// The pool's threads.
    pub threads: usize,
}

/// The multiply-add peak of one instruction-set path, one thread.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Peak {
    /// The path (`avx512`, `avx2`, `baseline`).
    pub isa: &'static str,
    /// FLOP/s (a multiply-add counts two).
    pub flops: f64,
    /// f32 lanes per operation.
    pub lanes: usize,
}

/// Sums a slice with eight independent accumulators (so the loads, not the adds, bound the loop).
fn sum(d: &[u64]) -> u64 {
    let mut acc = [0u64; 8];
    let mut chunks = d.chunks_exact(8);
    for c in &mut chunks {
        for (a, x) in acc.iter_mut().zip(c) {
            *a = a.wrapping_add(*x);
        }
    }
    chunks.remainder().iter().chain(&acc).fold(0u64, |s, x| s.wrapping_add(*x))
}

/// Read bandwidth over a buffer of `mib` MiB (at least 1), written first so that its pages exist.
#[must_use]
pub fn read_bandwidth(mib: usize) -> Bandwidth {
    let n = mib.max(1) * (1 << 20) / 8;
    let data: Vec<u64> = (0..n as u64).into_par_iter().collect();
    let best = |f: &dyn Fn() -> u64| {
        (0..3)
            .map(|_| {
                let t = std::time::Instant::now();
                std::hint::black_box(f());
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
            .max(1e-9)
    };
    let bytes = n * 8;
    let one = best(&|| sum(&data));
    let all = best(&|| data.par_chunks(1 << 16).map(sum).reduce(|| 0, u64::wrapping_add));
    Bandwidth {
        bytes,
        one_thread: bytes as f64 / one,
        all_threads: bytes as f64 / all,
        threads: rayon::current_num_threads(),
    }
}

/// The multiply-add peak of every instruction-set path this CPU has.
#[must_use]
pub fn fma_peaks() -> Vec<Peak> {
    Isa::available()
        .into_iter()
        .map(|isa| {
            let (flops, lanes) = crate::resolve::peak::fma_flops(isa);
            Peak { isa: isa.name(), flops, lanes }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sum_reads_every_element() {
        let d: Vec<u64> = (1..=1001).collect();
        assert_eq!(sum(&d), 1001 * 1002 / 2);
    }

    #[test]
    fn probes_measure_positive_finite_rates() {
        let b = read_bandwidth(8);
        assert_eq!(b.bytes, 8 << 20);
        assert!(b.one_thread.is_finite() && b.one_thread > 1e8, "{b:?}");
        assert!(b.all_threads.is_finite() && b.all_threads > 1e8, "{b:?}");
        let peaks = fma_peaks();
        assert_eq!(peaks.len(), Isa::available().len());
        assert!(peaks.iter().all(|p| p.flops.is_finite() && p.flops > 1e8 && p.lanes >= 4), "{peaks:?}");
    }
}
