#!/usr/bin/env bash
# Builds the peer harness for the serial C++ path of ISPC's examples/cpu/deferred (gbuf issue 14, target 2).
# Not built by Cargo. Everything it makes goes to the work dir WORK=${PEER_WORK:-<repo>/target/ispc-peer}:
#   WORK/ispc-deferred/   the example's sources (third-party, BSD-3, never in gbuf's git), with SOURCE = the commit
#   WORK/build/           harness (timed) and harness-count (counting build, never timed)
#
# ISPC sources: when WORK/ispc-deferred is missing they are extracted from a bare git snapshot of
# github.com/ispc/ispc named by ISPC_GIT (the repository, or a directory holding it as repo/ or .git/):
#   git clone --bare https://github.com/ispc/ispc /path/ispc.git   then   ISPC_GIT=/path/ispc.git
# ISPC_REV picks the commit (default: the snapshot's HEAD). The commit used is resolved once, every file is taken from
# it, and it is printed and written to WORK/ispc-deferred/SOURCE. The first measurement used 13713a66c43f.
# (The example's data/*.bin are not in git: run.sh makes the inputs with gbuf and make_bin.py.)
#
# gen/kernels_ispc.h stands in for the header `ispc kernels.ispc -h kernels_ispc.h` would generate: the two structs
# InputHeader and InputDataArrays, field for field from kernels.ispc. main.cpp (which calls the ISPC kernels) is not
# built; harness.cpp replaces it.
#
# Flags: g++ -O3 -march=native, plus -DNDEBUG as the example's CMake Release build (its default) has. The only
# asserts are in MinMaxZTree's constructor; they fire for heights that are not a multiple of 16 (1080), where the
# example still runs: its last 8 rows fall in a tile the tree does not cover, which it culls to 0 lights (black).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
WORK=${PEER_WORK:-$repo/target/ispc-peer}
mkdir -p "$WORK"
WORK="$(cd "$WORK" && pwd)"
cd "$WORK"

REF_COMMIT=13713a66c43fdfde160980412ad880287dd90c0f   # the commit of the first measurement (for the notice below)
FILES=(examples/cpu/deferred/deferred.h examples/cpu/deferred/common.cpp examples/cpu/deferred/dynamic_c.cpp
       examples/cpu/deferred/main.cpp examples/cpu/deferred/kernels.ispc examples/cpu/deferred/CMakeLists.txt
       examples/common/timing.h LICENSE.txt)

die() { echo "build.sh: $*" >&2; exit 1; }

if [ ! -d ispc-deferred ]; then
  if [ -z "${ISPC_GIT:-}" ]; then
    die "no ISPC sources in $WORK/ispc-deferred and ISPC_GIT is not set.
  Get a snapshot of github.com/ispc/ispc and point ISPC_GIT at it, e.g.
    git clone --bare https://github.com/ispc/ispc /tmp/ispc.git
    ISPC_GIT=/tmp/ispc.git $here/run.sh"
  fi
  rev=${ISPC_REV:-HEAD}
  G=
  for c in "$ISPC_GIT" "$ISPC_GIT/repo" "$ISPC_GIT/.git" "$ISPC_GIT"/*/; do
    c=${c%/}
    if [ -d "$c" ] && git --git-dir="$c" rev-parse --verify -q "$rev^{commit}" >/dev/null 2>&1; then
      G="$c"
      break
    fi
  done
  [ -n "$G" ] || die "ISPC_GIT=$ISPC_GIT: no git repository with commit '$rev' there (nor in repo/ or .git/ below it).
  Make one with: git clone --bare https://github.com/ispc/ispc /tmp/ispc.git"
  commit=$(git --git-dir="$G" rev-parse --verify "$rev^{commit}")
  tmp=$(mktemp -d "$WORK/ispc-deferred.tmp.XXXXXX")
  for f in "${FILES[@]}"; do
    mkdir -p "$tmp/$(dirname "$f")"
    git --git-dir="$G" show "$commit:$f" > "$tmp/$f" || { rm -rf "$tmp"; die "$f is not in ispc/ispc $commit"; }
  done
  echo "ispc/ispc $commit ($(git --git-dir="$G" log -1 --format=%cd "$commit"))" > "$tmp/SOURCE"
  mv "$tmp" ispc-deferred
  echo "extracted the ISPC example from $G into $WORK/ispc-deferred" >&2
fi
for f in "${FILES[@]}" SOURCE; do
  [ -f "ispc-deferred/$f" ] || die "$WORK/ispc-deferred/$f is missing: delete $WORK/ispc-deferred and rerun with ISPC_GIT set"
done
src=$(cat ispc-deferred/SOURCE)
echo "ISPC sources: $src" >&2
case "$src" in
  *"$REF_COMMIT"*) ;;
  *) echo "note: not ispc/ispc ${REF_COMMIT:0:12}, the commit of the first measurement" >&2 ;;
esac

D=ispc-deferred/examples/cpu/deferred
mkdir -p build
CXX=${CXX:-g++}
FLAGS=(-O3 -march=native -DNDEBUG -std=c++17 -I"$here/gen" -I"$D")

# Timed build: the example's files unchanged.
$CXX "${FLAGS[@]}" -o build/harness "$here/harness.cpp" $D/common.cpp $D/dynamic_c.cpp

# Counting build (never timed): a copy of dynamic_c.cpp with one counter line at the top of ShadeTileC, to report
# how many light-pixel pairs the C++ culling leaves (its "lights per pixel").
awk '{print} /uint8_t framebuffer_r\[\], uint8_t framebuffer_g\[\], uint8_t framebuffer_b\[\]\) \{/ && !done {
  print "    { extern long long g_peer_pairs, g_peer_pixels; long long px = (long long)(tileEndX - tileStartX) * (tileEndY - tileStartY);";
  print "      g_peer_pairs += px * tileNumLights; g_peer_pixels += px; }"; done=1 }
  END { print "long long g_peer_pairs = 0, g_peer_pixels = 0;" }' $D/dynamic_c.cpp > build/dynamic_c_count.cpp
grep -q g_peer_pairs build/dynamic_c_count.cpp
# (-I$D finds deferred.h for the copy in build/.)
$CXX "${FLAGS[@]}" -DPEER_COUNT -o build/harness-count "$here/harness.cpp" $D/common.cpp build/dynamic_c_count.cpp
echo "built $WORK/build/harness and harness-count with $($CXX --version | head -1)" >&2
