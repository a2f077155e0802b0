# Sourced by fuzz/seed.sh and fuzz/smoke.sh: toolchain, cargo-fuzz, build flags, per-target dictionaries.
# shellcheck shell=bash

FUZZ_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
export CARGO_TERM_COLOR=${CARGO_TERM_COLOR:-never}

# Nightly through rustup (installed when missing); if nightly cannot be had, the stable toolchain with
# RUSTC_BOOTSTRAP=1 (cargo-fuzz's flags are stable without a sanitizer; a sanitizer needs -Z flags).
# GBUF_FUZZ_TOOLCHAIN=stable forces the fallback.
pick_toolchain() {
  if [ "${GBUF_FUZZ_TOOLCHAIN:-}" != stable ] && ! rustup run nightly rustc -V >/dev/null 2>&1; then
    rustup toolchain install nightly --profile minimal >&2 || true
  fi
  if [ "${GBUF_FUZZ_TOOLCHAIN:-}" != stable ] && rustup run nightly rustc -V >/dev/null 2>&1; then
    CARGO=(cargo +nightly)
    FUZZ_RUSTC=$(rustup run nightly rustc -V)
  else
    echo "fuzz: no nightly toolchain; using stable with RUSTC_BOOTSTRAP=1" >&2
    export RUSTC_BOOTSTRAP=1
    CARGO=(cargo)
    FUZZ_RUSTC="$(rustc -V) with RUSTC_BOOTSTRAP=1"
  fi
  TRIPLE=$(rustc -vV | sed -n 's/^host: //p')
  BIN_DIR="${CARGO_TARGET_DIR:-$FUZZ_DIR/target}/$TRIPLE/release"
}

ensure_cargo_fuzz() {
  if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
  fi
}

# Release with debug assertions and overflow checks. No sanitizer by default: gbuf and the exr crate are safe Rust
# (bar the exr crate's AVX2 DCT), and without AddressSanitizer the build is faster, runs are about 3x faster and use
# a tenth of the memory. GBUF_FUZZ_SANITIZER=address for the cargo-fuzz default (docs/FUZZING.md).
BUILD_FLAGS=(--release --debug-assertions --sanitizer "${GBUF_FUZZ_SANITIZER:-none}")

# The dictionary of a target (empty for the structure-aware ones: their input is `arbitrary` data).
dict_for() {
  case "$1" in
    load | exr_raw) echo "$FUZZ_DIR/dict/exr.dict" ;;
    load_options) echo "$FUZZ_DIR/dict/load_options.dict" ;;
    sidecar) echo "$FUZZ_DIR/dict/sidecar.dict" ;;
    layout) echo "$FUZZ_DIR/dict/layout.dict" ;;
    *) echo "" ;;
  esac
}
