#!/usr/bin/env bash
# Builds the seed corpora from fixtures/ (EXRs subsampled and re-encoded, the ISPC .bin, sidecars, layouts,
# load_options combinations) into fuzz/seeds/<target>/ (or the directory given), replacing what was there.
# The seeds are written by a fuzz target binary (GBUF_FUZZ_MAKE_SEEDS, fuzz/src/seeds.rs), built here if needed.
set -euo pipefail
# shellcheck source=fuzz/common.sh
source "$(dirname "$0")/common.sh"
out=${1:-$FUZZ_DIR/seeds}

pick_toolchain
ensure_cargo_fuzz
(cd "$FUZZ_DIR" && "${CARGO[@]}" fuzz build "${BUILD_FLAGS[@]}" load)
rm -rf "$out"
GBUF_FUZZ_MAKE_SEEDS="$out" "$BIN_DIR/load"
