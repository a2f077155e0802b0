#!/usr/bin/env bash
# Source coverage of gbuf's readers reached by the corpora in fuzz/corpus/ (after fuzz/long.sh): builds the targets
# with -Cinstrument-coverage (`cargo fuzz coverage`), replays each corpus, and prints llvm-cov's region and line
# coverage of src/io/*.rs and src/layout/spec.rs per target and for all targets together. Needs the nightly
# toolchain's llvm-tools (installed here when missing). Usage: fuzz/coverage.sh [TARGET…]
set -euo pipefail
# shellcheck source=fuzz/common.sh
source "$(dirname "$0")/common.sh"

pick_toolchain
ensure_cargo_fuzz
cd "$FUZZ_DIR"
if [ "${CARGO[1]:-}" = +nightly ]; then toolchain=nightly; else toolchain=stable; fi
tools="$(rustup run "$toolchain" rustc --print sysroot)/lib/rustlib/$TRIPLE/bin"
if [ ! -x "$tools/llvm-cov" ]; then
  rustup component add llvm-tools --toolchain "$toolchain"
fi
if [ "$#" -gt 0 ]; then targets=("$@"); else mapfile -t targets < <("${CARGO[@]}" fuzz list); fi
bin="$FUZZ_DIR/target/$TRIPLE/coverage/$TRIPLE/release"
ignore='(\.cargo/|/rustc/|/fuzz/src/|/fuzz/fuzz_targets/)'
report() { # profdata, objects…
  local prof=$1
  shift
  local objs=("$1")
  shift
  for o in "$@"; do objs+=(-object "$o"); done
  "$tools/llvm-cov" report "${objs[@]}" -instr-profile="$prof" --ignore-filename-regex="$ignore" |
    awk '/^(io\/|layout\/spec)/ && $4 != "0.00%" { printf "  %-20s regions %7s  lines %7s\n", $1, $4, $10 }'
}
profs=()
objs=()
for t in "${targets[@]}"; do
  "${CARGO[@]}" fuzz coverage "${BUILD_FLAGS[@]}" "$t" "corpus/$t" >/dev/null 2>&1
  echo "$t:"
  report "coverage/$t/coverage.profdata" "$bin/$t"
  profs+=("coverage/$t/coverage.profdata")
  objs+=("$bin/$t")
done
if [ "${#targets[@]}" -gt 1 ]; then
  "$tools/llvm-profdata" merge -sparse "${profs[@]}" -o coverage/all.profdata
  echo "all targets:"
  report coverage/all.profdata "${objs[@]}"
fi
