//! The light loop's arithmetic ceiling on this CPU: how many floating-point operations one thread's fused
//! multiply-adds reach per second on each instruction set's lanes (what `gbuf bench` compares the shading with).

use super::simd::{lanes_for, BaselineLanes, Lanes};
use crate::base::isa::{self, Isa, Kernel};

/// Independent multiply-adds in flight: enough to cover two FMA pipes' latency (4 cycles × 2 ≤ 12), spread over
/// accumulators that stay in registers where they can — 12 AVX-512 vectors (of 32 registers), 6 AVX2 pairs (12 of
/// 16). The portable lanes (arrays the compiler vectorises) measured fastest with 12 (39 against 9 GFLOP/s with 3,
/// Zen 4).
fn chains_for(isa: Isa) -> usize {
    match isa {
        Isa::Avx2 => 6,
        Isa::Avx512 | Isa::Baseline => 12,
    }
}

/// `iterations` rounds of [`CHAINS`] independent multiply-adds on the lanes of the level it is compiled for.
struct Chains {
    iterations: u64,
}

impl Kernel for Chains {
    type Output = f32;
    #[inline(always)]
    fn run(self, isa: Isa) -> f32 {
        match chains_for(isa) {
            6 => lanes_for!(isa, BaselineLanes, |V| chains::<V, 6>(self.iterations)),
            _ => lanes_for!(isa, BaselineLanes, |V| chains::<V, 12>(self.iterations)),
        }
    }
}

#[inline(always)]
fn chains<V: Lanes, const C: usize>(iterations: u64) -> f32 {
    let a = V::splat(std::hint::black_box(0.999_999));
    let b = V::splat(std::hint::black_box(1e-7));
    let mut acc = [V::splat(1.0); C];
    for _ in 0..iterations {
        for x in &mut acc {
            *x = x.mul_add(a, b);
        }
    }
    acc.into_iter().fold(V::splat(0.0), |s, x| s + x).hmax()
}

/// One thread's multiply-add throughput on `isa`'s lanes (capped at this CPU's level): FLOP/s, counting a
/// multiply-add as two operations (as FMA peaks are quoted; the portable lanes issue them as a multiply and an
/// add), and the lanes' width. The best of five runs of about 20 ms.
#[must_use]
pub fn fma_flops(isa: Isa) -> (f64, usize) {
    let isa = isa.min(Isa::detect());
    let lanes = lanes_for!(isa, BaselineLanes, |V| V::N);
    let run = |iterations: u64| {
        let t = std::time::Instant::now();
        std::hint::black_box(isa::run(isa, Chains { iterations }));
        t.elapsed().as_secs_f64()
    };
    // Size the run to about 20 ms from a short one.
    let probe = 20_000;
    let per = run(probe).max(1e-6) / probe as f64;
    let iterations = ((0.02 / per) as u64).clamp(probe, 1 << 32);
    let best = (0..5).map(|_| run(iterations)).fold(f64::INFINITY, f64::min).max(1e-9);
    (2.0 * (lanes * chains_for(isa)) as f64 * iterations as f64 / best, lanes)
}
