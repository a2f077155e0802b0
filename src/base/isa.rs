//! CPU instruction-set levels: the one list every SIMD path (codec slices, the resolve's gather, culling and
//! light loop) dispatches on at run time.
//!
//! Each level has one feature list, and every `#[target_feature(enable = …)]` in the crate names exactly one of
//! them (a test in `tests/architecture.rs` checks it):
//!
//! | level      | features                                         |
//! |------------|--------------------------------------------------|
//! | `baseline` | none beyond the target's default (SSE2 on x86-64; any other architecture) |
//! | `avx2`     | [`AVX2_FEATURES`]                                  |
//! | `avx512`   | [`AVX512_FEATURES`]                                |
//!
//! [`Isa::detect`] checks every feature of a level before choosing it, so a function compiled for a level's list
//! is safe to call once `Isa::detect() >= level`.

use std::sync::OnceLock;

/// The features of [`Isa::Avx2`], as written in `#[target_feature(enable = …)]`.
pub const AVX2_FEATURES: &str = "avx2,fma";
/// The features of [`Isa::Avx512`], as written in `#[target_feature(enable = …)]`.
pub const AVX512_FEATURES: &str = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma";

/// The environment variable that caps [`Isa::detect`] (see there).
pub const ISA_ENV: &str = "GBUF_ISA";

/// An instruction-set level the SIMD paths are compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// The x86-64 baseline (SSE2), or any other architecture.
    Baseline,
    /// AVX2 + FMA.
    Avx2,
    /// AVX-512 F/VL/BW/DQ (with AVX2 + FMA).
    Avx512,
}

crate::named!(Isa: "instruction set" { Baseline => "baseline", Avx2 => "avx2", Avx512 => "avx512" });

impl Isa {
    /// The widest level this CPU supports (detected once), capped by the environment variable [`ISA_ENV`] when it
    /// names a level (`baseline`, `avx2`, `avx512`): that is how an AVX-512 machine measures the AVX2 or portable
    /// paths end to end (`GBUF_ISA=avx2 gbuf resolve …`). A cap above the CPU's level changes nothing; an unknown
    /// name is reported on stderr once and ignored.
    #[must_use]
    pub fn detect() -> Isa {
        static DETECTED: OnceLock<Isa> = OnceLock::new();
        *DETECTED.get_or_init(|| {
            let hw = detect_uncached();
            match std::env::var(ISA_ENV) {
                Ok(v) if !v.is_empty() => match v.parse::<Isa>() {
                    Ok(cap) => hw.min(cap),
                    Err(_) => {
                        eprintln!(
                            "warning: {ISA_ENV}={v:?} is not an instruction set (baseline, avx2, avx512); using {}",
                            hw.name()
                        );
                        hw
                    }
                },
                _ => hw,
            }
        })
    }

    /// Every level this CPU can run, narrowest first (what the bit-identity tests iterate over).
    #[must_use]
    pub fn available() -> Vec<Isa> {
        let top = Isa::detect();
        Isa::ALL.iter().copied().filter(|i| *i <= top).collect()
    }
}

#[cfg(target_arch = "x86_64")]
fn detect_uncached() -> Isa {
    let has = |list: &str| list.split(',').all(x86_feature);
    if has(AVX512_FEATURES) {
        Isa::Avx512
    } else if has(AVX2_FEATURES) {
        Isa::Avx2
    } else {
        Isa::Baseline
    }
}

/// `is_x86_feature_detected!` takes a literal, so the names of the feature lists are matched here.
#[cfg(target_arch = "x86_64")]
fn x86_feature(name: &str) -> bool {
    match name {
        "avx2" => is_x86_feature_detected!("avx2"),
        "fma" => is_x86_feature_detected!("fma"),
        "avx512f" => is_x86_feature_detected!("avx512f"),
        "avx512vl" => is_x86_feature_detected!("avx512vl"),
        "avx512bw" => is_x86_feature_detected!("avx512bw"),
        "avx512dq" => is_x86_feature_detected!("avx512dq"),
        _ => false,
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn detect_uncached() -> Isa {
    Isa::Baseline
}

/// Work to run under [`run`], compiled for the instruction set it picks: the one way gbuf runs code for the CPU's
/// instruction set (the codecs' slice loops, the `.bin` conversion, the resolve's bands, culling and shading
/// kernel, FLIP's bands). `run` receives the level its wrapper was compiled for, a constant once inlined: work
/// generic over a lane type picks it there (`resolve::simd::lanes_for!`). Implementations mark `run`
/// `#[inline(always)]` so that its body is compiled inside each `#[target_feature]` wrapper.
pub trait Kernel {
    /// What the work returns.
    type Output;
    /// Does the work, compiled for `isa`.
    fn run(self, isa: Isa) -> Self::Output;
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<K: Kernel>(k: K) -> K::Output {
    k.run(Isa::Avx2)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")]
unsafe fn run_avx512<K: Kernel>(k: K) -> K::Output {
    k.run(Isa::Avx512)
}

/// Runs `k` compiled for `isa`, or for the widest level below it that this CPU has.
#[inline]
pub fn run<K: Kernel>(isa: Isa, k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        match isa.min(Isa::detect()) {
            // SAFETY: the CPU supports the features each wrapper enables (checked by `Isa::detect`).
            Isa::Avx512 => unsafe { run_avx512(k) },
            // SAFETY: as above.
            Isa::Avx2 => unsafe { run_avx2(k) },
            Isa::Baseline => k.run(Isa::Baseline),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = isa;
        k.run(Isa::Baseline)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `GBUF_ISA` cap holds: the dispatch runs no level above it, and every level up to it that the CPU has stays
    /// available (CI's Miri pass over the portable paths sets `baseline` on an AVX2 build and relies on this).
    #[test]
    fn the_environment_caps_the_detected_level() {
        let Some(cap) = std::env::var(ISA_ENV).ok().and_then(|v| v.parse::<Isa>().ok()) else { return };
        assert!(Isa::detect() <= cap, "{} above the cap {}", Isa::detect().name(), cap.name());
        assert_eq!(Isa::detect(), detect_uncached().min(cap));
    }

    #[test]
    fn every_listed_feature_is_known_and_levels_are_ordered() {
        #[cfg(target_arch = "x86_64")]
        for f in AVX2_FEATURES.split(',').chain(AVX512_FEATURES.split(',')) {
            // An unknown name would make `x86_feature` say false: the level could never be chosen.
            assert!(
                matches!(f, "avx2" | "fma" | "avx512f" | "avx512vl" | "avx512bw" | "avx512dq"),
                "feature {f} is not matched by x86_feature"
            );
        }
        assert!(AVX2_FEATURES.split(',').all(|f| AVX512_FEATURES.split(',').any(|g| g == f)));
        let avail = Isa::available();
        assert_eq!(avail[0], Isa::Baseline);
        assert_eq!(*avail.last().unwrap(), Isa::detect());
    }
}
