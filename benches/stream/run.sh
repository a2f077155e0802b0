#!/usr/bin/env bash
# Checks `gbuf bench`'s copy-bandwidth probe against STREAM's Copy (John D. McCalpin's stream.c, built here from its
# public source, unmodified) on this machine: within ±TOL% (default 15) on 1 thread and on every thread, or a
# non-zero exit. gbuf's read probe and STREAM's other kernels are printed beside it, for information.
# See README.md beside this script. Cargo builds nothing here; the gbuf binary is measured as it is.
#
#   STREAM_GIT=/path/to/STREAM.git benches/stream/run.sh     a git snapshot of github.com/jeffhammond/STREAM
#                                                           (bare repository, or a directory holding it as repo/
#                                                           or .git/): git clone --bare
#                                                           https://github.com/jeffhammond/STREAM /tmp/STREAM.git
#   STREAM_SRC=/path/to/stream.c benches/stream/run.sh       or a stream.c file, or an http(s) URL of one
#                                                           (e.g. https://www.cs.virginia.edu/stream/FTP/Code/stream.c)
#   Neither is needed once WORK/src/stream.c exists (it is reused; giving one replaces it).
#
#   ROUNDS=5            interleaved rounds (default 5): each runs gbuf GBUF_RUNS times, then each STREAM build on 1
#                       thread and on THREADS (the order flips every other round)
#   GBUF_RUNS=3         gbuf runs per round (default 3; each probe is the best of 5 passes, STREAM's of 19)
#   THREADS=N           the "every thread" count (default: nproc)
#   TOL=15              tolerance, percent
#   MIB=512             MiB per gbuf buffer (`gbuf bench --mib`); STREAM's arrays are at least this big each
#   STREAM_N=N          elements per STREAM array (default: max(4 × the last-level caches, MIB MiB) / 8 B, rounded
#                       up to a million)
#   STREAM_REV=rev      commit of STREAM_GIT (default HEAD)
#   CC=gcc              compiler (flags: -O3 -march=STREAM_MARCH -fopenmp -fno-tree-loop-distribute-patterns
#                       -DSTREAM_ARRAY_SIZE=N -DNTIMES=20, plus -mcmodel=medium only when the arrays pass 2 GiB)
#   STREAM_MARCH=x86-64 STREAM's -march (default x86-64: 16-byte SSE2 loads and stores, as in the gbuf release
#                       binary Cargo builds by default; set native for a gbuf built with -C target-cpu=native)
#   WORK=/dir           work dir (default <repo>/target/stream, git-ignored): src/ (stream.c, SOURCE), build/,
#                       results/<date>/ (raw outputs, results.tsv, thp.tsv, table.md)
#   GBUF_BIN=/path      the gbuf measured (default <repo>/target/release/gbuf)
#
# Exit status: 0 when gbuf copy / STREAM Copy is within ±TOL% on every row, 1 when not, 2 when the check could not
# be run.
#
# What is compared (details in README.md). Both sides run the same loop: one 8-byte load and one ordinary 8-byte
# store per element (gbuf `dst[i] = src[i] ^ key`, STREAM `c[j] = a[j]`), both counted 16 B per element, both paying
# the same write-allocate read, so no factor. Three things are made equal, none by changing stream.c:
#  - STREAM is built with -fno-tree-loop-distribute-patterns. Without it gcc turns Copy's loop into a (tail) call
#    of memcpy, whose copies of this size use glibc's non-temporal-store path: not the loop gbuf runs. The script
#    disassembles both STREAM builds and stops (exit 2) if it finds a memcpy/memmove/memset call or jump, or a
#    non-temporal store.
#  - STREAM's arrays are advised to transparent huge pages by benches/stream/thp.c, linked beside the unmodified
#    stream.c, as gbuf's large buffers are (src/base/alloc.rs). STREAM's arrays are static; where
#    /sys/kernel/mm/transparent_hugepage/enabled is "madvise" they otherwise get 4 KiB pages. A second build, the
#    same with thp.c only reporting (-DTHP_ADVISE=0), runs too and is shown for information ("4 KiB").
#    thp.c reports at exit how much of the arrays huge pages backed; the header prints it.
#  - STREAM is built for -march=x86-64 (STREAM_MARCH), the target Cargo builds gbuf for: its Copy loop then moves
#    16-byte SSE2 vectors as gbuf's does. With -march=native gcc uses 64-byte AVX-512 stores, and on the Zen 4 VM of
#    the first measurement that Copy was some 10% slower than the same loop in SSE2.
# The read probe (loads only) is shown against STREAM's kernels with the write-allocate read added (bus traffic:
# 3/2 × the counted rate for Copy and Scale, 4/3 × for Add and Triad), for information only.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
WORK=${WORK:-$repo/target/stream}
GBUF_BIN=${GBUF_BIN:-$repo/target/release/gbuf}
ROUNDS=${ROUNDS:-5}
GBUF_RUNS=${GBUF_RUNS:-3}
THREADS=${THREADS:-$(nproc)}
TOL=${TOL:-15}
MIB=${MIB:-512}
CC=${CC:-gcc}
STREAM_MARCH=${STREAM_MARCH:-x86-64}
NTIMES=20
REF_COMMIT=6703f7504a38a8da96b353cadafa64d3c2d7a2d3 # jeffhammond/STREAM, the commit of the first measurement

die() { echo "stream/run.sh: $*" >&2; exit 2; }
is_uint() { [[ $1 =~ ^[0-9]+$ ]]; }
is_uint "$ROUNDS" && [ "$ROUNDS" -ge 1 ] || die "ROUNDS=$ROUNDS: a whole number ≥ 1"
is_uint "$GBUF_RUNS" && [ "$GBUF_RUNS" -ge 1 ] || die "GBUF_RUNS=$GBUF_RUNS: a whole number ≥ 1"
is_uint "$THREADS" && [ "$THREADS" -ge 1 ] || die "THREADS=$THREADS: a whole number ≥ 1"
is_uint "$MIB" && [ "$MIB" -ge 1 ] || die "MIB=$MIB: a whole number ≥ 1"
[[ $STREAM_MARCH =~ ^[A-Za-z0-9._-]+$ ]] || die "STREAM_MARCH=$STREAM_MARCH: a -march value (x86-64, native, …)"
[[ $TOL =~ ^[0-9]+([.][0-9]+)?$ ]] || die "TOL=$TOL: a number (percent)"
[ -x "$GBUF_BIN" ] || die "no gbuf binary at $GBUF_BIN: run \`cargo build --release\` in $repo or set GBUF_BIN"
command -v "$CC" >/dev/null || die "no C compiler '$CC' (set CC)"
mkdir -p "$WORK/src" "$WORK/build" "$WORK/results"
WORK="$(cd "$WORK" && pwd)"

# --- stream.c: extracted from STREAM_GIT or copied from STREAM_SRC into WORK/src, never into the repository -------
if [ -n "${STREAM_GIT:-}" ] || [ -n "${STREAM_SRC:-}" ]; then
  tmp=$(mktemp -d "$WORK/src.tmp.XXXXXX")
  trap 'rm -rf "$tmp"' EXIT
  if [ -n "${STREAM_GIT:-}" ]; then
    rev=${STREAM_REV:-HEAD}
    G=
    for c in "$STREAM_GIT" "$STREAM_GIT/repo" "$STREAM_GIT/.git" "$STREAM_GIT"/*/; do
      c=${c%/}
      if [ -d "$c" ] && git --git-dir="$c" rev-parse --verify -q "$rev^{commit}" >/dev/null 2>&1; then G="$c"; break; fi
    done
    [ -n "$G" ] || die "STREAM_GIT=$STREAM_GIT: no git repository with commit '$rev' there (nor in repo/ or .git/ below it).
  Make one with: git clone --bare https://github.com/jeffhammond/STREAM /tmp/STREAM.git"
    commit=$(git --git-dir="$G" rev-parse --verify "$rev^{commit}")
    git --git-dir="$G" show "$commit:stream.c" >"$tmp/stream.c" || die "stream.c is not in $G at $commit"
    git --git-dir="$G" show "$commit:LICENSE.txt" >"$tmp/LICENSE.txt" 2>/dev/null || true
    echo "jeffhammond/STREAM $commit ($(git --git-dir="$G" log -1 --format=%cd "$commit")) from $G" >"$tmp/SOURCE"
  else
    case "$STREAM_SRC" in
      http://* | https://*)
        command -v curl >/dev/null || die "STREAM_SRC is a URL but curl is missing"
        curl -fsSL "$STREAM_SRC" -o "$tmp/stream.c" || die "could not download $STREAM_SRC" ;;
      *) [ -f "$STREAM_SRC" ] || die "STREAM_SRC=$STREAM_SRC: no such file"
         cp "$STREAM_SRC" "$tmp/stream.c" ;;
    esac
    echo "stream.c from $STREAM_SRC" >"$tmp/SOURCE"
  fi
  grep -q 'STREAM_ARRAY_SIZE' "$tmp/stream.c" && grep -q 'Triad' "$tmp/stream.c" ||
    die "the file given does not look like STREAM's stream.c"
  rm -rf "$WORK/src"
  mv "$tmp" "$WORK/src"
  trap - EXIT
fi
[ -f "$WORK/src/stream.c" ] || die "no $WORK/src/stream.c and neither STREAM_GIT nor STREAM_SRC is set.
  Get STREAM's public source, e.g.
    git clone --bare https://github.com/jeffhammond/STREAM /tmp/STREAM.git
    STREAM_GIT=/tmp/STREAM.git $0"
src_sha=$(sha256sum "$WORK/src/stream.c" | cut -c1-16)
src_desc="$(cat "$WORK/src/SOURCE" 2>/dev/null || echo "stream.c (origin unrecorded)"), sha256 $src_sha…"
case "$src_desc" in *"$REF_COMMIT"*) ;; *) echo "note: not jeffhammond/STREAM ${REF_COMMIT:0:12}, the commit of the first measurement" >&2 ;; esac

# --- array size: each array ≥ 4 × the sum of the last-level caches (STREAM's rule) and ≥ gbuf's buffer --------------
llc_bytes=0 llc_desc="unknown"
maxlvl=0
for d in /sys/devices/system/cpu/cpu[0-9]*/cache/index[0-9]*; do
  [ -r "$d/level" ] && [ "$(cat "$d/type" 2>/dev/null)" != Instruction ] || continue
  l=$(cat "$d/level"); [ "$l" -gt "$maxlvl" ] && maxlvl=$l
done
if [ "$maxlvl" -gt 0 ]; then
  # one entry per distinct cache (level, shared_cpu_list); sizes like 32768K
  llc_bytes=$(for d in /sys/devices/system/cpu/cpu[0-9]*/cache/index[0-9]*; do
      [ "$(cat "$d/level" 2>/dev/null)" = "$maxlvl" ] && [ "$(cat "$d/type")" != Instruction ] || continue
      echo "$(cat "$d/shared_cpu_list") $(cat "$d/size")"
    done | sort -u | awk '{ s=$2; m=1; if (s ~ /K$/) m=1024; else if (s ~ /M$/) m=1048576; else if (s ~ /G$/) m=1073741824;
                          sub(/[KMG]$/, "", s); t += s*m; n++ } END { printf "%d %d\n", t, n }')
  llc_n=${llc_bytes#* }; llc_bytes=${llc_bytes% *}
  llc_desc="L$maxlvl $((llc_bytes >> 20)) MiB ($llc_n instance(s))"
fi
if [ -n "${STREAM_N:-}" ]; then
  is_uint "$STREAM_N" && [ "$STREAM_N" -ge 1000000 ] || die "STREAM_N=$STREAM_N: a whole number ≥ 1000000"
  N=$STREAM_N
else
  need=$((4 * llc_bytes)); [ $((MIB << 20)) -gt "$need" ] && need=$((MIB << 20))
  N=$(((need / 8 + 999999) / 1000000 * 1000000))
fi
[ "$llc_bytes" -gt 0 ] && [ $((N * 8)) -lt $((4 * llc_bytes)) ] &&
  echo "warning: STREAM_N=$N: each array ($((N * 8 >> 20)) MiB) is under 4 × the last-level caches" >&2
avail_kb=$(awk '/^MemAvailable:/ {print $2}' /proc/meminfo)
[ $((3 * N * 8 / 1024)) -lt $((avail_kb * 3 / 4)) ] ||
  die "STREAM's three arrays ($((3 * N * 8 >> 20)) MiB) do not fit in 3/4 of the available memory ($((avail_kb >> 10)) MiB)"


# --- build: two STREAM binaries, the unmodified stream.c beside thp.c (advising huge pages, or only reporting) ------
FLAGS=(-O3 "-march=$STREAM_MARCH" -fopenmp -fno-tree-loop-distribute-patterns "-DSTREAM_ARRAY_SIZE=$N" "-DNTIMES=$NTIMES")
[ $((3 * N * 8)) -lt $(((1 << 31) - (64 << 20))) ] || FLAGS+=(-mcmodel=medium) # static arrays past 2 GiB
[ -f "$here/thp.c" ] || die "no $here/thp.c"
S="$WORK/build/stream.thp.$N"  # arrays advised to transparent huge pages: the check
S4="$WORK/build/stream.4k.$N"  # arrays not advised (4 KiB pages where THP is "madvise"): information
"$CC" "${FLAGS[@]}" "$WORK/src/stream.c" "$here/thp.c" -o "$S" || die "could not build STREAM: $CC ${FLAGS[*]}"
"$CC" "${FLAGS[@]}" -DTHP_ADVISE=0 "$WORK/src/stream.c" "$here/thp.c" -o "$S4" ||
  die "could not build STREAM: $CC ${FLAGS[*]} -DTHP_ADVISE=0"
cc_desc="$("$CC" --version | head -1); ${FLAGS[*]}; stream.c + benches/stream/thp.c"
# Regular stores only: a library copy (memcpy of a large block takes glibc's non-temporal path) or a non-temporal
# store would skip the write-allocate read gbuf's loop pays, and the comparison would not be like for like.
command -v objdump >/dev/null || die "no objdump (binutils): it is needed to check that STREAM's kernels use regular stores"
for b in "$S" "$S4"; do
  dis=$(objdump -d --no-show-raw-insn "$b")
  nt=$(grep -cE '\bv?movnt' <<<"$dis" || true)
  lib=$(grep -cE '\b(call|jmp)[a-z]*[[:space:]].*<(memcpy|memmove|memset)(@plt)?>' <<<"$dis" || true)
  [ "$nt" -eq 0 ] && [ "$lib" -eq 0 ] ||
    die "$b has $nt non-temporal store(s) and $lib memcpy/memmove/memset call(s) or jump(s): its Copy is not a loop of
  regular stores like gbuf's (did $CC ignore -fno-tree-loop-distribute-patterns? clang needs other flags)"
done
stores="regular (no non-temporal stores, no memcpy/memmove/memset call or jump in either binary): write-allocate applies on both sides"
wa_copy=1.5 wa_add=$(awk 'BEGIN { printf "%.10f", 4/3 }')
thp_sys="enabled: $(cat /sys/kernel/mm/transparent_hugepage/enabled 2>/dev/null || echo '?'), defrag: $(cat /sys/kernel/mm/transparent_hugepage/defrag 2>/dev/null || echo '?')"

# --- interleaved rounds ---------------------------------------------------------------------------------------------
stamp=$(date +%Y%m%d-%H%M%S)
R="$WORK/results/$stamp"
mkdir -p "$R"
T="$R/results.tsv" # round  program  threads  kernel  GB/s (counted)  load1
printf 'round\tprogram\tthreads\tkernel\tgbps\tload1\n' >"$T"
H="$R/thp.tsv" # round  program  threads  KiB of the arrays' range  KiB of it in huge pages (thp.c's report)
printf 'round\tprogram\tthreads\tbss_kib\tanon_huge_kib\n' >"$H"
thread_counts=(1); [ "$THREADS" -gt 1 ] && thread_counts+=("$THREADS")
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
busy_cores() { # CPUs kept busy by other processes over a 1 s pause of ours (from /proc/stat)
  local a b; a=$(head -1 /proc/stat); sleep 1; b=$(head -1 /proc/stat)
  awk -v a="$a" -v b="$b" -v n="$(nproc)" 'BEGIN { split(a, x, " "); split(b, y, " "); t = 0; i = 0
    for (k = 2; k <= 9; k++) t += y[k] - x[k]; i = (y[5] - x[5]) + (y[6] - x[6]); printf "%.2f", (t > 0 ? n * (t - i) / t : 0) }'
}
B="$R/busy.tsv"; printf 'round\tbusy_cpus\n' >"$B"
gbuf_run() { # round
  local k; for ((k = 1; k <= GBUF_RUNS; k++)); do gbuf_once "$1" "$k"; done
}
gbuf_once() { # round run
  local out="$R/gbuf.r$1.$2.json" l; l=$(cut -d' ' -f1 /proc/loadavg)
  "$GBUF_BIN" bench --json -q --mib "$MIB" --threads "$THREADS" --width 64 --height 64 --lights 16 >"$out" ||
    die "gbuf bench failed (see $out)"
  awk -v r="$1" -v n="$THREADS" -v l="$l" '
    function val() { v = $2; sub(/,$/, "", v); return v / 1e9 }
    $1 == "\"one_thread\":"       { printf "%s\tgbuf\t1\tread\t%.4f\t%s\n", r, val(), l; a++ }
    $1 == "\"all_threads\":"      { if (n > 1) printf "%s\tgbuf\t%s\tread\t%.4f\t%s\n", r, n, val(), l; b++ }
    $1 == "\"copy_one_thread\":"  { printf "%s\tgbuf\t1\tcopy\t%.4f\t%s\n", r, val(), l; c++ }
    $1 == "\"copy_all_threads\":" { if (n > 1) printf "%s\tgbuf\t%s\tcopy\t%.4f\t%s\n", r, n, val(), l; d++ }
    $1 == "\"threads\":"          { t = $2; sub(/,$/, "", t) }
    END { if (a != 1 || b != 1 || c != 1 || d != 1 || t != n) exit 1 }' "$out" >>"$T" ||
    die "unexpected gbuf bench --json output (bandwidth fields incl. copy_*, threads = $THREADS): $out"
}
stream_run() { # round program (stream | stream4k) threads
  local bin out="$R/$2.r$1.t$3.txt" l; l=$(cut -d' ' -f1 /proc/loadavg)
  [ "$2" = stream ] && bin=$S || bin=$S4
  OMP_NUM_THREADS=$3 "$bin" >"$out" 2>"$out.stderr" || die "STREAM failed (see $out, $out.stderr)"
  grep -q '^Solution Validates' "$out" || die "STREAM's results did not validate (see $out)"
  grep -q "^Number of Threads counted = $3\$" "$out" || die "STREAM did not run on $3 thread(s) (see $out)"
  awk -v r="$1" -v p="$2" -v t="$3" -v l="$l" '$1 ~ /^(Copy|Scale|Add|Triad):$/ { k=$1; sub(/:$/, "", k);
      printf "%s\t%s\t%s\t%s\t%.4f\t%s\n", r, p, t, k, $2/1000, l; n++ } END { if (n != 4) exit 1 }' "$out" >>"$T" ||
    die "unexpected STREAM output: $out"
  awk -v r="$1" -v p="$2" -v t="$3" '/^thp\.c:/ { for (i = 2; i <= NF; i++) { split($i, kv, "="); f[kv[1]] = kv[2] }
      printf "%s\t%s\t%s\t%s\t%s\n", r, p, t, f["bss_kib"], f["anon_huge_kib"]; n++ } END { if (n != 1) exit 1 }' \
    "$out.stderr" >>"$H" || die "no report from thp.c in $out.stderr"
}
echo "gbuf $GBUF_BIN vs STREAM ($N elements × 3 arrays × 8 B = $((3 * N * 8 >> 20)) MiB), $ROUNDS round(s)" >&2
for ((r = 1; r <= ROUNDS; r++)); do
  busy=$(busy_cores); printf '%s\t%s\n' "$r" "$busy" >>"$B"
  echo "  round $r/$ROUNDS (load $(cut -d' ' -f1 /proc/loadavg), $busy CPU(s) busy with other work)" >&2
  if ((r % 2)); then
    gbuf_run "$r"; for t in "${thread_counts[@]}"; do stream_run "$r" stream "$t"; stream_run "$r" stream4k "$t"; done
  else
    for ((i = ${#thread_counts[@]} - 1; i >= 0; i--)); do
      stream_run "$r" stream4k "${thread_counts[i]}"; stream_run "$r" stream "${thread_counts[i]}"
    done
    gbuf_run "$r"
  fi
done
load_end=$(cut -d' ' -f1-3 /proc/loadavg)
busy_range=$(awk 'NR > 1 { if (n == 0 || $2 < lo) lo = $2; if ($2 > hi) hi = $2; n++ } END { printf "%.2f to %.2f", lo, hi }' "$B")
busy_max=${busy_range##* }
busy_warn=$(awk -v m="$busy_max" 'BEGIN { print ((m >= 0.25) ? 1 : 0) }')
huge_pct() { # program: "min to max %" of the arrays' range backed by huge pages over the runs
  awk -F'\t' -v p="$1" 'NR > 1 && $2 == p && $4 > 0 { q = 100 * $5 / $4; if (n == 0 || q < lo) lo = q; if (q > hi) hi = q; n++ }
    END { if (n) printf "%.1f%% to %.1f%%", lo, hi; else printf "unknown" }' "$H"
}
huge_thp=$(huge_pct stream) huge_4k=$(huge_pct stream4k)
huge_low=$(awk -F'\t' 'NR > 1 && $2 == "stream" && $4 > 0 && $5 < 0.9 * $4 { n++ } END { print n + 0 }' "$H")

# --- table ----------------------------------------------------------------------------------------------------------
cpu_model=$(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
cpu_flags=$(grep -m1 '^flags' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
simd=$(tr ' ' '\n' <<<"$cpu_flags" | grep -E '^(avx2|avx512f|avx512bw|avx512vl|fma)$' | paste -sd' ' -)
[[ " $cpu_flags " == *" avx512f "* ]] && avx512=yes || avx512=no
hyp=$(grep -qw hypervisor <<<"$cpu_flags" && echo ", virtual machine (hypervisor flag)" || true)
gbuf_ver=$("$GBUF_BIN" --version 2>/dev/null || echo gbuf)
gbuf_when=$(date -r "$GBUF_BIN" '+%Y-%m-%d %H:%M')
set +e
awk -F'\t' -v gr="$GBUF_RUNS" -v nt="$((NTIMES - 1))" -v tol="$TOL" -v wc="$wa_copy" -v wa="$wa_add" -v rounds="$ROUNDS" -v tc="${thread_counts[*]}" '
  function med(arr, n,   i, j, x, s) { for (i = 1; i <= n; i++) s[i] = arr[i]
      for (i = 2; i <= n; i++) { x = s[i]; for (j = i - 1; j >= 1 && s[j] > x; j--) s[j+1] = s[j]; s[j+1] = x }
      return n % 2 ? s[(n+1)/2] : (s[n/2] + s[n/2+1]) / 2 }
  function spread(p, t, k,   r, a, lo, hi) { lo = 1e30; hi = 0
      for (r = 1; r <= rounds; r++) { a[r] = v[p, t, k, r]; if (a[r] < lo) lo = a[r]; if (a[r] > hi) hi = a[r] }
      return sprintf("%.1f / %.1f / %.1f", lo, med(a, rounds), hi) }
  function ratios(p, t, k, q, tq, kq,   r, a, lo, hi) { lo = 1e30; hi = 0
      for (r = 1; r <= rounds; r++) { a[r] = v[p, t, k, r] / v[q, tq, kq, r]; if (a[r] < lo) lo = a[r]; if (a[r] > hi) hi = a[r] }
      return sprintf("%.2f / %.2f / %.2f", lo, med(a, rounds), hi) }
  NR == 1 { next }
  { r=$1; p=$2; t=$3; k=$4; x=$5+0; if (NR == 2 || $6+0 < lmin) lmin=$6+0; if ($6+0 > lmax) lmax=$6+0
    if (x > v[p, t, k, r]) v[p, t, k, r] = x
    if (x > best[p, t, k]) best[p, t, k] = x
    if (p == "stream") { f = (k == "Copy" || k == "Scale") ? wc : wa
      if (x * f > bus[t, r]) bus[t, r] = x * f
      if (x * f > busbest[t]) { busbest[t] = x * f; busk[t] = k }
      if (x > cntbest[t]) cntbest[t] = x } }
  END {
    n = split(tc, T, " "); fail = 0
    print "**The check** (GB/s counted as STREAM counts Copy, 16 B per element; best across rounds):"
    print ""
    print "| threads | STREAM Copy, huge pages | gbuf copy | gbuf copy / STREAM Copy | within ±" tol "% | STREAM Copy, 4 KiB pages (information) | gbuf copy / it |"
    print "|---:|---:|---:|---:|:---:|---:|---:|"
    for (i = 1; i <= n; i++) { t = T[i]
      ratio = best["gbuf", t, "copy"] / best["stream", t, "Copy"]; ok = (ratio >= 1 - tol/100 && ratio <= 1 + tol/100)
      if (!ok) fail = 1
      printf "| %s | %.1f | %.1f | %.2f | %s | %.1f | %.2f |\n", t, best["stream", t, "Copy"], best["gbuf", t, "copy"],
        ratio, ok ? "yes" : "**no**", best["stream4k", t, "Copy"], best["gbuf", t, "copy"] / best["stream4k", t, "Copy"] }
    print ""
    print "Spread over the " rounds " interleaved round(s) (each round: gbuf best of " gr " run(s) × 5 passes, STREAM best of " nt " per kernel), min / median / max:"
    print ""
    print "| threads | gbuf copy | STREAM Copy, huge pages | per-round gbuf copy / STREAM Copy | STREAM Copy, 4 KiB pages |"
    print "|---:|---:|---:|---:|---:|"
    for (i = 1; i <= n; i++) { t = T[i]
      printf "| %s | %s | %s | %s | %s |\n", t, spread("gbuf", t, "copy"), spread("stream", t, "Copy"),
        ratios("gbuf", t, "copy", "stream", t, "Copy"), spread("stream4k", t, "Copy") }
    print ""
    print "**For information**: STREAM (huge pages) kernels as counted (bus traffic, with the write-allocate read: × 1.5 Copy and Scale, × 1.33 Add and Triad), against the gbuf read probe (loads only, one buffer of `--mib` MiB):"
    print ""
    print "| threads | Copy | Scale | Add | Triad | STREAM best, bus traffic | gbuf read | gbuf read / STREAM bus | gbuf read / STREAM counted | 4 KiB pages: Copy | Scale | Add | Triad |"
    print "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    for (i = 1; i <= n; i++) { t = T[i]
      printf "| %s | %.1f (%.1f) | %.1f (%.1f) | %.1f (%.1f) | %.1f (%.1f) | %.1f (%s) | %.1f | %.2f | %.2f | %.1f | %.1f | %.1f | %.1f |\n", t,
        best["stream", t, "Copy"], best["stream", t, "Copy"] * wc, best["stream", t, "Scale"], best["stream", t, "Scale"] * wc,
        best["stream", t, "Add"], best["stream", t, "Add"] * wa, best["stream", t, "Triad"], best["stream", t, "Triad"] * wa,
        busbest[t], busk[t], best["gbuf", t, "read"], best["gbuf", t, "read"] / busbest[t], best["gbuf", t, "read"] / cntbest[t],
        best["stream4k", t, "Copy"], best["stream4k", t, "Scale"], best["stream4k", t, "Add"], best["stream4k", t, "Triad"] }
    printf "\nload average (1 min) during the rounds: %.2f to %.2f (our own runs count in it)\n", lmin, lmax
    exit fail }' "$T" >"$R/table.body.md"
verdict=$?
set -e
[ "$verdict" -le 1 ] || die "could not summarise $T"
{
  echo "## gbuf bench copy probe vs STREAM Copy ($(date '+%Y-%m-%d %H:%M'))"
  echo
  echo "STREAM's arrays advised to transparent huge pages by benches/stream/thp.c, linked beside the unmodified stream.c, as gbuf's large buffers are."
  echo
  echo "- machine: $cpu_model, $(nproc) CPU(s), $llc_desc, avx512: $avx512 ($simd)$hyp"
  echo "- flags: $cpu_flags"
  echo "- transparent huge pages ($thp_sys); huge pages backed $huge_thp of STREAM's arrays (advised), $huge_4k (4 KiB build)"
  [ "$huge_low" -eq 0 ] || echo "- **warning**: in $huge_low run(s) huge pages backed under 90% of the advised STREAM arrays (thp.tsv): the \"huge pages\" column is not all huge pages"
  echo "- load average at start: $load_start; at end: $load_end (our own runs count in it)"
  echo "- CPUs busy with other processes, over a 1 s pause before each round: $busy_range"
  [ "$busy_warn" = 0 ] || echo "- **warning**: other processes used up to $busy_max of the $(nproc) CPUs between rounds: the rates (above all the $THREADS-thread row, where a thread shares its CPU) are not this machine's best; rerun on an idle machine"
  echo "- STREAM: $src_desc"
  echo "- built: $cc_desc; stores: $stores"
  echo "- STREAM arrays: $N elements × 8 B = $((N * 8 >> 20)) MiB each; gbuf: $gbuf_ver ($GBUF_BIN, built $gbuf_when), \`bench --mib $MIB --threads $THREADS\` (two buffers of $MIB MiB for copy), $GBUF_RUNS run(s) per round"
  echo "- GB/s = 10^9 B/s. gbuf copy is \`bandwidth.copy_*\` (\`dst[i] = src[i] ^ key\`, 16 B per element), STREAM Copy is \`c[j] = a[j]\` (16 B per element): no write-allocate factor, both pay it."
  echo
  cat "$R/table.body.md"
  echo
  if [ "$verdict" -eq 0 ]; then
    echo "**check passed**: gbuf's copy probe is within ±$TOL% of STREAM's Copy (huge pages) on every row."
  else
    echo "**check FAILED**: gbuf's copy probe is not within ±$TOL% of STREAM's Copy (huge pages) on every row (see README.md, \"When it fails\")."
  fi
} >"$R/table.md"
rm -f "$R/table.body.md"
cat "$R/table.md"
echo "(raw outputs, results.tsv and thp.tsv in $R)" >&2
exit "$verdict"
