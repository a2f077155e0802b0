#!/usr/bin/env bash
# The `blender720n` input of the peer benchmark: the Blender Cycles scene of fixtures/blender_gbuffer.exr rendered
# natively at 1280x720 (one ray per pixel centre, the fixture's vertical field of view, a 24 m floor so that the 16:9
# frame has no sky beside the floor), converted by `make_bin.py from-exr --native` (no resampling) with 1024 lights.
# run.sh calls it when `blender` is found; it can also be run alone (a few seconds of Blender).
#
#   benches/ispc-peer/blender_native.sh            writes WORK/data/blender720n.bin (and blender720n_cycles.exr,
#                                                  .json, .log: the render, its sidecar and Blender's log)
#   BLENDER=/path/to/blender …                     another Blender (default: `blender` on PATH; tested with 3.4.1)
#   PEER_WORK=/dir …                               work dir (default: <repo>/target/ispc-peer)
#
# The light range (0.19, against 0.148 for blender720) gives about the same C++ lights per pixel as blender720
# (~4.5): the native frame keeps the fixture's vertical field of view, so at 16:9 it sees more of the scene and each
# object and light covers fewer pixels than in the upsampled crop.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
WORK=${PEER_WORK:-$repo/target/ispc-peer}
BLENDER=${BLENDER:-blender}
command -v "$BLENDER" >/dev/null || {
  echo "blender_native.sh: no Blender ($BLENDER): apt-get install blender, or set BLENDER=/path/to/blender" >&2
  exit 1
}
mkdir -p "$WORK/data"
data="$(cd "$WORK/data" && pwd)"
# The render is named blender720n_cycles, not blender720n: gbuf reads X.json beside X.bin as the frame's sidecar,
# and the Blender sidecar's 2 lights would replace the .bin's 1024.
rm -f "$data/blender720n.json"
start=$(date +%s%N)
log=$data/blender720n_cycles.log
"$BLENDER" -b --factory-startup --python-exit-code 1 --python "$repo/fixtures/scripts/blender_gbuffer.py" -- \
  "$data" --width 1280 --height 720 --supersample 1 --name blender720n_cycles --floor 24 > "$log" 2>&1 || {
  tail -20 "$log" >&2
  echo "blender_native.sh: Blender failed (log: $log)" >&2
  exit 1
}
end=$(date +%s%N)
echo "blender_native.sh: rendered $data/blender720n_cycles.exr in $(( (end - start) / 1000000 )) ms" >&2
"$here/make_bin.py" from-exr "$data/blender720n_cycles.exr" "$data/blender720n.bin" --native \
  --lights 1024 --range 0.19 --color 0.8 --seed 1 >&2
