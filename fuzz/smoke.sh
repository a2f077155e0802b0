#!/usr/bin/env bash
# CI smoke run of every fuzz target: installs cargo-fuzz and a nightly toolchain if needed, builds every target,
# writes the seeds, and runs each target for GBUF_FUZZ_SMOKE_SECONDS (default 15) from its seeds, its
# regressions (fuzz/regressions/<target>/) and its dictionary.
# Fails if a target does not build or run, or finds a crash, panic, timeout or out-of-memory; what it found is
# kept in fuzz/artifacts/<target>/. About 7 minutes on 2 idle cores from a clean checkout (docs/FUZZING.md).
set -euo pipefail
# shellcheck source=fuzz/common.sh
source "$(dirname "$0")/common.sh"
seconds=${GBUF_FUZZ_SMOKE_SECONDS:-15}
# No DWA decoding here (the targets refuse it as without --allow-dwa): a DWAB chunk can make the exr crate allocate
# gigabytes for a 504-byte file (fuzz/regressions/exr_raw/), which would fail this run at random. The long run
# decodes DWA. Drop this once gbuf checks chunk sizes against the file (issue 16 part 2).
export GBUF_FUZZ_DWA=${GBUF_FUZZ_DWA:-0}

start=$(date +%s)
pick_toolchain
ensure_cargo_fuzz
cd "$FUZZ_DIR"
echo "fuzz: $FUZZ_RUSTC, $(cargo fuzz --version), flags ${BUILD_FLAGS[*]}"
"${CARGO[@]}" fuzz build "${BUILD_FLAGS[@]}"
./seed.sh >/dev/null
built=$(date +%s)

mapfile -t targets < <("${CARGO[@]}" fuzz list)
if [ "${#targets[@]}" -eq 0 ]; then
  echo "fuzz: no targets" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failed=()
for t in "${targets[@]}"; do
  mkdir -p "$work/$t/corpus" "$work/$t/artifacts"
  args=("$work/$t/corpus")
  [ -d "seeds/$t" ] && args+=("seeds/$t")
  [ -d "regressions/$t" ] && args+=("regressions/$t")
  dict=$(dict_for "$t")
  [ -n "$dict" ] && args+=("-dict=$dict")
  args+=(-max_total_time="$seconds" -rss_limit_mb=2048 -timeout=25 -print_final_stats=1
    -artifact_prefix="$work/$t/artifacts/")
  status=0
  RUST_BACKTRACE=1 "$BIN_DIR/$t" "${args[@]}" >"$work/$t/log" 2>&1 || status=$?
  found=$(find "$work/$t/artifacts" -type f | wc -l)
  done_line=$(grep -E '^#[0-9]+\s+DONE' "$work/$t/log" | tail -1 || true)
  if [ "$status" -ne 0 ] || [ "$found" -ne 0 ] || [ -z "$done_line" ]; then
    echo "fuzz: $t FAILED (exit $status, $found artifact(s)); end of its log:"
    tail -n 60 "$work/$t/log"
    mkdir -p "artifacts/$t"
    cp -r "$work/$t/artifacts/." "artifacts/$t/" 2>/dev/null || true
    cp "$work/$t/log" "artifacts/$t/smoke.log"
    failed+=("$t")
  else
    note=""
    contained=$(grep -c 'gbuf-fuzz: contained panic' "$work/$t/log" || true)
    [ "${contained:-0}" -gt 0 ] && note=" ($contained distinct panics contained by gbuf, see the log)"
    echo "fuzz: $t ok: ${done_line#*DONE }$note"
  fi
done
end=$(date +%s)
echo "fuzz: build + seeds $((built - start)) s, runs $((end - built)) s, total $((end - start)) s"
if [ "${#failed[@]}" -ne 0 ]; then
  echo "fuzz: failed: ${failed[*]} (inputs and logs in fuzz/artifacts/)" >&2
  exit 1
fi
