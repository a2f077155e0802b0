//! The running machine's own limits, measured: how fast one thread and every thread read memory and copy it (as
//! STREAM's Copy counts it, for a like-for-like check against STREAM: `benches/stream/`), and the FMA peak of each
//! instruction-set path ([`crate::resolve::peak`]). `gbuf bench` sets a frame's stages against them, so
//! that a reader on another CPU knows what "fast" means there.

use crate::base::isa::Isa;
use rayon::prelude::*;
use serde::Serialize;

/// Memory bandwidth, bytes per second.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Bandwidth {
    /// The buffer read, bytes (far beyond the caches at the default size).
    pub bytes: usize,
    /// One thread summing the buffer (best of [`PASSES`] passes).
    pub one_thread: f64,
    /// Every thread of the pool summing its part (best of [`PASSES`] passes).
    pub all_threads: f64,
    /// One thread copying the buffer into a second one as large, counted as STREAM's Copy counts it: 16 bytes per
    /// 8-byte element (one read, one write; the read-for-ownership of each written line is not counted).
    pub copy_one_thread: f64,
    /// Every thread copying its part, counted the same way.
    pub copy_all_threads: f64,
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

/// Passes of each probe; the fastest counts (a shared or virtual machine's slow passes are other work's).
pub const PASSES: usize = 5;

/// `dst[i] = src[i] ^ key`: a copy with ordinary stores. A plain `dst[i] = src[i]` loop becomes `memcpy`, which
/// switches to non-temporal stores on large blocks and would skip the write-allocate traffic STREAM's Copy pays.
fn copy(dst: &mut [u64], src: &[u64], key: u64) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = s ^ key;
    }
}

/// Read and copy bandwidth over a buffer of `mib` MiB (at least 1) and a second one as large, both written first so
/// that their pages exist.
#[must_use]
pub fn memory_bandwidth(mib: usize) -> Bandwidth {
    let n = mib.max(1) * (1 << 20) / 8;
    let data: Vec<u64> = (0..n as u64).into_par_iter().collect();
    let best = |f: &mut dyn FnMut() -> u64| {
        (0..PASSES)
            .map(|_| {
                let t = std::time::Instant::now();
                std::hint::black_box(f());
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
            .max(1e-9)
    };
    let bytes = n * 8;
    let one = best(&mut || sum(&data));
    let all = best(&mut || data.par_chunks(1 << 16).map(sum).reduce(|| 0, u64::wrapping_add));
    let mut dst: Vec<u64> = (0..n as u64).into_par_iter().collect();
    // The key is unknown to the compiler: the loop stays a loop of loads and stores.
    let key = std::hint::black_box(0);
    let copy_one = best(&mut || {
        copy(&mut dst, &data, key);
        dst[n - 1]
    });
    let copy_all = best(&mut || {
        dst.par_chunks_mut(1 << 16).zip(data.par_chunks(1 << 16)).for_each(|(d, s)| copy(d, s, key));
        dst[n - 1]
    });
    Bandwidth {
        bytes,
        one_thread: bytes as f64 / one,
        all_threads: bytes as f64 / all,
        copy_one_thread: 2.0 * bytes as f64 / copy_one,
        copy_all_threads: 2.0 * bytes as f64 / copy_all,
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
    fn the_copy_writes_every_element() {
        let src: Vec<u64> = (1..=1001).collect();
        let mut dst = vec![0; 1001];
        copy(&mut dst, &src, 0);
        assert_eq!(dst, src);
        copy(&mut dst, &src, 1);
        assert!(dst.iter().zip(&src).all(|(d, s)| *d == s ^ 1));
    }

    #[test]
    fn the_sum_reads_every_element() {
        let d: Vec<u64> = (1..=1001).collect();
        assert_eq!(sum(&d), 1001 * 1002 / 2);
    }

    #[test]
    fn probes_measure_positive_finite_rates() {
        let b = memory_bandwidth(8);
        assert_eq!(b.bytes, 8 << 20);
        assert!(b.one_thread.is_finite() && b.one_thread > 1e8, "{b:?}");
        assert!(b.all_threads.is_finite() && b.all_threads > 1e8, "{b:?}");
        assert!(b.copy_one_thread.is_finite() && b.copy_one_thread > 1e8, "{b:?}");
        assert!(b.copy_all_threads.is_finite() && b.copy_all_threads > 1e8, "{b:?}");
        let peaks = fma_peaks();
        assert_eq!(peaks.len(), Isa::available().len());
        assert!(peaks.iter().all(|p| p.flops.is_finite() && p.flops > 1e8 && p.lanes >= 4), "{peaks:?}");
    }
}
