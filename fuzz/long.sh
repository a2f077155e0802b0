#!/usr/bin/env bash
# The documented long run (docs/FUZZING.md): every target in sequence, one process on one core (-jobs=1, rayon
# limited to one thread), for SECONDS each (default 240), from fuzz/corpus/<target>/ (kept between runs) plus the
# seeds and regressions, with its dictionary. Prints libFuzzer's last status line per target and keeps the logs in
# fuzz/logs/. Findings go to fuzz/artifacts/<target>/. Usage: fuzz/long.sh [SECONDS] [TARGET…]
set -euo pipefail
# shellcheck source=fuzz/common.sh
source "$(dirname "$0")/common.sh"
seconds=${1:-240}
shift || true

pick_toolchain
ensure_cargo_fuzz
cd "$FUZZ_DIR"
"${CARGO[@]}" fuzz build "${BUILD_FLAGS[@]}"
./seed.sh >/dev/null
if [ "$#" -gt 0 ]; then targets=("$@"); else mapfile -t targets < <("${CARGO[@]}" fuzz list); fi
mkdir -p logs
status=0
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t" "logs/$t"
  args=("$FUZZ_DIR/corpus/$t")
  [ -d "seeds/$t" ] && args+=("$FUZZ_DIR/seeds/$t")
  [ -d "regressions/$t" ] && args+=("$FUZZ_DIR/regressions/$t")
  dict=$(dict_for "$t")
  [ -n "$dict" ] && args+=("-dict=$dict")
  rm -f "logs/$t"/fuzz-*.log
  (cd "logs/$t" && RAYON_NUM_THREADS=1 RUST_BACKTRACE=1 "$BIN_DIR/$t" "${args[@]}" \
    -jobs=1 -workers=1 -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=25 -print_final_stats=1 \
    -artifact_prefix="$FUZZ_DIR/artifacts/$t/") >/dev/null 2>&1 || status=1
  log="logs/$t/fuzz-0.log"
  last=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  echo "$t: ${execs:-?} execs; last: ${last:-none}"
done
found=$(find artifacts -type f | wc -l)
echo "fuzz: $found finding(s) under fuzz/artifacts/"
[ "$status" -eq 0 ] && [ "$found" -eq 0 ]
