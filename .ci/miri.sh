#!/usr/bin/env bash
# Miri over the unsafe code it can run (docs/DECISIONS.md, "Unsafe code and Miri"):
# A. the portable paths: the unchecked float→int roundings (codec::normal), the Vec3 re-typing (util), FLIP's
#    unchecked lane loads (measure::flip) and the ISA dispatch on the baseline ISA (GBUF_ISA=baseline caps
#    `Isa::detect`, so the portable lanes run);
# B. the AVX2 paths (`_mm256_*` intrinsics, the `#[target_feature]` wrappers), built with AVX2 and FMA enabled;
# C. the tiled resolve's schedule (tile prefetch, band dispatch) on a tiny frame, with AVX2.
# Not coverable: AVX-512 and NEON intrinsics (Miri implements neither); the bit-identity tests against the portable
# lanes cover them on real hardware (and NEON under qemu in .ci/aarch64.sh).
# Miri needs a nightly toolchain; installs it when missing and fails (does not skip) when it cannot.
set -euo pipefail
cd "$(dirname "$0")/.."
rustup toolchain install nightly --profile minimal --component miri,rust-src >/dev/null
cargo +nightly miri setup
# Tree Borrows: rayon's work-stealing deque (crossbeam-epoch) retags pointers in a way Stacked Borrows rejects
# (upstream's known report, not our code); Tree Borrows is the model that accepts it. Integer-to-pointer casts come
# from the same crate; rayon's pool threads outlive the test thread (-Zmiri-ignore-leaks lets them).
export MIRIFLAGS="${MIRIFLAGS:-} -Zmiri-tree-borrows -Zmiri-permissive-provenance -Zmiri-ignore-leaks"
# One build for both passes (a Miri build of the crate costs about 5 minutes on 2 cores): AVX2 and FMA enabled, and
# the portable pass caps the dispatch at the baseline lanes with GBUF_ISA, set inside the interpreter (Miri hides the
# host's environment).
export RUSTFLAGS="-C target-feature=+avx2,+fma"
MIRIFLAGS="$MIRIFLAGS -Zmiri-env-set=GBUF_ISA=baseline" cargo +nightly miri test --target-dir target/miri-avx2 --lib -- \
  codec::normal::tests::in_range_roundings_are_total \
  base::memory::tests::zeroed_vec3_is_zero_vectors_of_the_asked_length \
  measure::flip::tests::black_vs_white_is_max \
  measure::flip::tests::hdr_flip_of_a_mostly_black_reference_stays_finite \
  codec::simd::tests::detected_isa_is_available_and_run_clamps \
  base::isa::tests::the_environment_caps_the_detected_level
cargo +nightly miri test --target-dir target/miri-avx2 --lib -- \
  resolve::simd::tests::avx2_lanes_are_accurate_where_supported \
  codec::simd::tests::detected_isa_is_available_and_run_clamps \
  measure::flip::tests::black_vs_white_is_max
cargo +nightly miri test --target-dir target/miri-avx2 --test resolve_props -- \
  last_rows_and_columns_are_shaded_when_the_size_is_not_a_tile_multiple
