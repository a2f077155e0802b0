#!/usr/bin/env bash
# Rebuilds and reruns the whole gbuf vs ISPC `deferred` (serial C++) comparison and prints markdown tables
# (also kept in WORK/results/tables.md). gbuf issue 14, target 2. See README.md beside this script.
#
#   cargo build --release && ISPC_GIT=/path/ispc.git benches/ispc-peer/run.sh
#   ROUNDS=9 …/run.sh             more interleaved rounds (default 7)
#   PERF_RUNS=0 …/run.sh          skip the perf profiles (default 2 per cell)
#   GBUF_BIN=/path/to/gbuf …      another gbuf binary (default: <repo>/target/release/gbuf)
#   PEER_WORK=/dir …              work dir (default: <repo>/target/ispc-peer, git-ignored)
#   PEER_SHM=/dir …               scratch dir for output images and perf data (default: /dev/shm/ispc-peer)
#   BLENDER_NATIVE=0|1 …          the natively rendered blender720n input (blender_native.sh): default on when
#                                 `blender` (or $BLENDER) is found, skipped with a message otherwise; 1 = required
#
# Needs: g++, python3 with numpy, pillow, openexr (pip install numpy pillow openexr), /usr/bin/time, and for the
# stage profiles `perf` (Debian: linux-perf). ISPC_GIT is needed only while WORK/ispc-deferred is missing (build.sh
# extracts the example from it). Inputs are made once into WORK/data (see below) and reused: delete that directory
# after a change to `gbuf scene` or make_bin.py.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
WORK=${PEER_WORK:-$repo/target/ispc-peer}
mkdir -p "$WORK"
WORK="$(cd "$WORK" && pwd)"
export PEER_WORK="$WORK"
export PEER_SHM=${PEER_SHM:-/dev/shm/ispc-peer}
ROUNDS=${ROUNDS:-7}
PERF_RUNS=${PERF_RUNS:-2}
export GBUF_BIN=${GBUF_BIN:-$repo/target/release/gbuf}
G=$GBUF_BIN
[ -x "$G" ] || { echo "run.sh: no gbuf binary at $G: run \`cargo build --release\` in $repo or set GBUF_BIN" >&2; exit 1; }
FIXTURE=$repo/fixtures/blender_gbuffer.exr
cd "$WORK"
mkdir -p data results out "$PEER_SHM"

"$here/build.sh"

# Inputs (deterministic): gbuf's own .bin writer for the synthetic room (1024 scattered lights, seed 1), light ranges
# scaled so that the C++ culling leaves ~27 lights per pixel; the Blender Cycles fixture converted by make_bin.py
# (1024 lights, ~4.5 per pixel); and, with Blender, the same scene rendered natively at 1280x720 (blender_native.sh,
# ~4.5 lights per pixel; Blender's normals may differ in the last bits between renders, see fixtures/README.md).
if [ ! -f data/dense720.bin ]; then
  "$G" scene room --msaa 1 --width 1280 --height 720 --lights 1024 -o data/room720.bin >&2
  "$here/make_bin.py" rescale data/room720.bin data/dense720.bin --range 1.78 --color 0.3
fi
if [ ! -f data/dense1080.bin ]; then
  "$G" scene room --msaa 1 --width 1920 --height 1080 --lights 1024 -o data/room1080.bin >&2
  "$here/make_bin.py" rescale data/room1080.bin data/dense1080.bin --range 1.83 --color 0.3
fi
if [ ! -f data/blender720.bin ]; then
  "$here/make_bin.py" from-exr "$FIXTURE" data/blender720.bin \
    --width 1280 --height 720 --lights 1024 --range 0.148 --color 0.8 --seed 1 >&2
fi
stems=(dense720 dense1080 blender720)
BLENDER_NATIVE=${BLENDER_NATIVE:-auto}
if [ "$BLENDER_NATIVE" != 0 ]; then
  if [ -f data/blender720n.bin ]; then
    stems+=(blender720n)
  elif command -v "${BLENDER:-blender}" >/dev/null; then
    "$here/blender_native.sh"
    stems+=(blender720n)
  elif [ "$BLENDER_NATIVE" = 1 ]; then
    echo "run.sh: BLENDER_NATIVE=1 but no Blender (${BLENDER:-blender}): apt-get install blender or set BLENDER" >&2
    exit 1
  else
    echo "run.sh: no Blender (${BLENDER:-blender}): skipping the native blender720n input (apt-get install blender," \
      "or BLENDER=/path/to/blender; BLENDER_NATIVE=0 skips it without this message)" >&2
  fi
fi

out=results/tables.md
{
  echo "## Machine and inputs ($(date -u '+%Y-%m-%d %H:%M UTC'))"
  echo
  echo "- CPU: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores; flags: $(grep -o -w -E 'avx512f|avx512vl|avx512bw|avx512dq|avx2|fma' /proc/cpuinfo | sort -u | tr '\n' ' ')"
  echo "- load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "- C++: $(${CXX:-g++} --version | head -1), -O3 -march=native -DNDEBUG; ISPC sources: $(cat ispc-deferred/SOURCE)"
  echo "- gbuf: $G ($("$G" --version), sha256 $(sha256sum "$G" | cut -c1-12), modified $(date -u -r "$G" '+%Y-%m-%d %H:%M UTC')); repo $repo at $(git --no-optional-locks -C "$repo" describe --always --dirty 2>/dev/null || echo '?')"
  for s in "${stems[@]}"; do
    f=data/$s.bin
    echo "- $f (sha256 $(sha256sum $f | cut -c1-12)): $("$here/make_bin.py" info $f | sed -n '1s/^[^:]*://p'); C++ $(./build/harness-count count $f | grep lights_per_pixel)"
  done
  echo
} > "$out"

"$here/bench.py" --rounds "$ROUNDS" --files "$(printf 'data/%s.bin,' "${stems[@]}" | sed 's/,$//')"
"$here/report.py" results/summary.json >> "$out"
{
  echo
  echo "### Image agreement: C++ PPM vs gbuf PNG (--ldr gamma2.2), 8-bit codes"
  echo
  "$here/compare.py" --keep out "${stems[@]}"
} >> "$out"

if [ "$PERF_RUNS" -gt 0 ] && command -v perf >/dev/null && perf record -q -e cpu-clock -o /dev/null true 2>/dev/null; then
  mkdir -p results/perf
  {
    echo
    echo "### Where gbuf's frame goes: perf profile, 1 thread (cpu-clock at 2 kHz, dwarf call graphs, mean of $PERF_RUNS runs)"
    echo
    echo "Each sample is filed by the gbuf functions on its stack (profile.py). 'on main thread' = share of the"
    echo "stage's CPU on the main thread: rayon's parallel loops run on its worker thread(s), so 100% = serial code."
  } >> "$out"
  for f in "${stems[@]}"; do
    for isa in avx512 avx2 baseline; do
      files=()
      for k in $(seq 1 "$PERF_RUNS"); do
        rm -f "$PEER_SHM/perf.data"  # (perf record would keep the previous one as perf.data.old)
        RAYON_NUM_THREADS=1 GBUF_ISA=$isa perf record -q -F 2000 -e cpu-clock --call-graph dwarf,16384 \
          -o "$PEER_SHM/perf.data" "$G" resolve data/$f.bin --ldr gamma2.2 --png "$PEER_SHM/perf.png" \
          --brdf blinn-phong --falloff linear --culling tiled --no-reference --no-flip --json > /dev/null 2>/dev/null
        perf script -i "$PEER_SHM/perf.data" -F pid,tid,period,ip,sym 2>/dev/null > results/perf/${f}_${isa}_$k.txt
        files+=(results/perf/${f}_${isa}_$k.txt)
      done
      { echo; echo "#### $f, GBUF_ISA=$isa, RAYON_NUM_THREADS=1"; echo; "$here/profile.py" "${files[@]}"; } >> "$out"
    done
  done
elif [ "$PERF_RUNS" -gt 0 ]; then
  echo "run.sh: perf is missing or not allowed (kernel.perf_event_paranoid?): no stage profiles" >&2
fi
rm -f "$PEER_SHM"/*.png "$PEER_SHM"/*.ppm "$PEER_SHM"/perf.data "$PEER_SHM"/perf.data.old "$PEER_SHM"/time.txt "$PEER_SHM"/stdout.txt
rmdir "$PEER_SHM" 2>/dev/null || true
echo "results in $WORK/results (tables.md, raw.jsonl, summary.json, perf/), images in $WORK/out" >&2
cat "$out"
