#!/usr/bin/env bash
# Checks `gbuf bench`'s read-bandwidth probe against STREAM (John D. McCalpin's stream.c), built here from its public
# source, on this machine: within ±TOL% (default 15) on 1 thread and on every thread, or a non-zero exit.
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
#   ROUNDS=5            interleaved rounds (default 5): each runs gbuf once, STREAM on 1 thread, STREAM on THREADS
#   THREADS=N           the "every thread" count (default: nproc)
#   TOL=15              tolerance, percent
#   MIB=512             MiB gbuf's probe reads (`gbuf bench --mib`); STREAM's arrays are at least this big each
#   STREAM_N=N          elements per STREAM array (default: max(4 × the last-level caches, MIB MiB) / 8 B, rounded
#                       up to a million)
#   STREAM_REV=rev      commit of STREAM_GIT (default HEAD)
#   CC=gcc              compiler (flags: -O3 -march=native -fopenmp -DSTREAM_ARRAY_SIZE=N -DNTIMES=20, plus
#                       -mcmodel=medium only when the three arrays pass 2 GiB)
#   WORK=/dir           work dir (default <repo>/target/stream, git-ignored): src/ (stream.c, SOURCE), build/,
#                       results/<date>/ (raw outputs, results.tsv, table.md)
#   GBUF_BIN=/path      the gbuf measured (default <repo>/target/release/gbuf)
#
# Exit status: 0 when every row is within ±TOL%, 1 when one is not, 2 when the check could not be run.
#
# What is compared (details in README.md). gbuf's probe only reads: one 8-byte load per element of a MIB MiB buffer,
# bytes = MIB·2^20, no writes. STREAM has no read-only kernel. It counts 2 × 8 B per element for Copy and Scale
# (read one array, write one) and 3 × 8 B for Add and Triad (read two, write one); it does not count the
# write-allocate read that a regular store makes the cache do (the line is read before it is written). The bytes
# actually moved across the memory bus are therefore 3/2 × the reported rate for Copy and Scale and 4/3 × for Add
# and Triad. The check sets gbuf's read rate against the best STREAM kernel's bus traffic, both the best across
# rounds (each program reports a best-of-passes rate); STREAM's own (counted) rates are printed beside it.
# The write-allocate factors hold only when the STREAM build uses regular stores: the script looks for
# non-temporal stores and memcpy calls in the binary and, if it finds any (or cannot look), uses factor 1 and says so.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
WORK=${WORK:-$repo/target/stream}
GBUF_BIN=${GBUF_BIN:-$repo/target/release/gbuf}
ROUNDS=${ROUNDS:-5}
THREADS=${THREADS:-$(nproc)}
TOL=${TOL:-15}
MIB=${MIB:-512}
CC=${CC:-gcc}
NTIMES=20
REF_COMMIT=6703f7504a38a8da96b353cadafa64d3c2d7a2d3 # jeffhammond/STREAM, the commit of the first measurement

die() { echo "stream/run.sh: $*" >&2; exit 2; }
is_uint() { [[ $1 =~ ^[0-9]+$ ]]; }
is_uint "$ROUNDS" && [ "$ROUNDS" -ge 1 ] || die "ROUNDS=$ROUNDS: a whole number ≥ 1"
is_uint "$THREADS" && [ "$THREADS" -ge 1 ] || die "THREADS=$THREADS: a whole number ≥ 1"
is_uint "$MIB" && [ "$MIB" -ge 1 ] || die "MIB=$MIB: a whole number ≥ 1"
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

# --- build ----------------------------------------------------------------------------------------------------------
FLAGS=(-O3 -march=native -fopenmp "-DSTREAM_ARRAY_SIZE=$N" "-DNTIMES=$NTIMES")
[ $((3 * N * 8)) -lt $(((1 << 31) - (64 << 20))) ] || FLAGS+=(-mcmodel=medium) # static arrays past 2 GiB
S="$WORK/build/stream.$N"
"$CC" "${FLAGS[@]}" "$WORK/src/stream.c" -o "$S" || die "could not build STREAM: $CC ${FLAGS[*]}"
cc_desc="$("$CC" --version | head -1); ${FLAGS[*]}"
# Regular stores (write-allocate applies) or not: non-temporal stores or library copies change the bus traffic.
stores="unknown (no objdump)"
wa_copy=1 wa_add=1
if command -v objdump >/dev/null; then
  dis=$(objdump -d --no-show-raw-insn "$S")
  nt=$(grep -cE '\bmovnt|\bvmovnt' <<<"$dis" || true)
  lib=$(grep -cE 'call.*<(memcpy|memmove|memset)' <<<"$dis" || true)
  if [ "$nt" -eq 0 ] && [ "$lib" -eq 0 ]; then
    stores="regular (no non-temporal stores, no memcpy): write-allocate applies"
    wa_copy=1.5 wa_add=$(awk 'BEGIN { printf "%.10f", 4/3 }')
  else
    stores="$nt non-temporal store(s), $lib memcpy/memmove/memset call(s): write-allocate factor NOT applied (1)"
  fi
fi
[ "$wa_copy" = 1 ] && echo "warning: STREAM's bus traffic is taken as its counted bytes ($stores)" >&2

# --- interleaved rounds ---------------------------------------------------------------------------------------------
stamp=$(date +%Y%m%d-%H%M%S)
R="$WORK/results/$stamp"
mkdir -p "$R"
T="$R/results.tsv" # round  program  threads  kernel  GB/s (counted)  load1
printf 'round\tprogram\tthreads\tkernel\tgbps\tload1\n' >"$T"
thread_counts=(1); [ "$THREADS" -gt 1 ] && thread_counts+=("$THREADS")
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
busy_cores() { # CPUs kept busy by other processes over a 1 s pause of ours (from /proc/stat)
  local a b; a=$(head -1 /proc/stat); sleep 1; b=$(head -1 /proc/stat)
  awk -v a="$a" -v b="$b" -v n="$(nproc)" 'BEGIN { split(a, x, " "); split(b, y, " "); t = 0; i = 0
    for (k = 2; k <= 9; k++) t += y[k] - x[k]; i = (y[5] - x[5]) + (y[6] - x[6]); printf "%.2f", t > 0 ? n * (t - i) / t : 0 }'
}
B="$R/busy.tsv"; printf 'round\tbusy_cpus\n' >"$B"
gbuf_run() { # round
  local out="$R/gbuf.r$1.json" l; l=$(cut -d' ' -f1 /proc/loadavg)
  "$GBUF_BIN" bench --json -q --mib "$MIB" --threads "$THREADS" --width 64 --height 64 --lights 16 >"$out" ||
    die "gbuf bench failed (see $out)"
  awk -v r="$1" -v n="$THREADS" -v l="$l" '
    /"one_thread":/  { v=$2; sub(/,$/, "", v); printf "%s\tgbuf\t1\tread\t%.4f\t%s\n", r, v/1e9, l; a++ }
    /"all_threads":/ { v=$2; sub(/,$/, "", v); if (n > 1) printf "%s\tgbuf\t%s\tread\t%.4f\t%s\n", r, n, v/1e9, l; b++ }
    /"threads":/     { t=$2; sub(/,$/, "", t) }
    END { if (a != 1 || b != 1 || t != n) exit 1 }' "$out" >>"$T" ||
    die "unexpected gbuf bench --json output (bandwidth fields, threads = $THREADS): $out"
}
stream_run() { # round threads
  local out="$R/stream.r$1.t$2.txt" l; l=$(cut -d' ' -f1 /proc/loadavg)
  OMP_NUM_THREADS=$2 "$S" >"$out" || die "STREAM failed (see $out)"
  grep -q '^Solution Validates' "$out" || die "STREAM's results did not validate (see $out)"
  grep -q "^Number of Threads counted = $2\$" "$out" || die "STREAM did not run on $2 thread(s) (see $out)"
  awk -v r="$1" -v t="$2" -v l="$l" '$1 ~ /^(Copy|Scale|Add|Triad):$/ { k=$1; sub(/:$/, "", k);
      printf "%s\tstream\t%s\t%s\t%.4f\t%s\n", r, t, k, $2/1000, l; n++ } END { if (n != 4) exit 1 }' "$out" >>"$T" ||
    die "unexpected STREAM output: $out"
}
echo "gbuf $GBUF_BIN vs STREAM ($N elements × 3 arrays × 8 B = $((3 * N * 8 >> 20)) MiB), $ROUNDS round(s)" >&2
for ((r = 1; r <= ROUNDS; r++)); do
  busy=$(busy_cores); printf '%s\t%s\n' "$r" "$busy" >>"$B"
  echo "  round $r/$ROUNDS (load $(cut -d' ' -f1 /proc/loadavg), $busy CPU(s) busy with other work)" >&2
  if ((r % 2)); then
    gbuf_run "$r"; for t in "${thread_counts[@]}"; do stream_run "$r" "$t"; done
  else
    for ((i = ${#thread_counts[@]} - 1; i >= 0; i--)); do stream_run "$r" "${thread_counts[i]}"; done; gbuf_run "$r"
  fi
done
load_end=$(cut -d' ' -f1-3 /proc/loadavg)
busy_range=$(awk 'NR > 1 { if (n == 0 || $2 < lo) lo = $2; if ($2 > hi) hi = $2; n++ } END { printf "%.2f to %.2f", lo, hi }' "$B")
busy_max=${busy_range##* }
busy_warn=$(awk -v m="$busy_max" 'BEGIN { print (m >= 0.25) ? 1 : 0 }')

# --- table ----------------------------------------------------------------------------------------------------------
cpu_model=$(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
cpu_flags=$(grep -m1 '^flags' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
simd=$(tr ' ' '\n' <<<"$cpu_flags" | grep -E '^(avx2|avx512f|avx512bw|avx512vl|fma)$' | paste -sd' ' -)
[[ " $cpu_flags " == *" avx512f "* ]] && avx512=yes || avx512=no
hyp=$(grep -qw hypervisor <<<"$cpu_flags" && echo ", virtual machine (hypervisor flag)" || true)
gbuf_ver=$("$GBUF_BIN" --version 2>/dev/null || echo gbuf)
gbuf_when=$(date -r "$GBUF_BIN" '+%Y-%m-%d %H:%M')
set +e
awk -F'\t' -v nt="$((NTIMES - 1))" -v tol="$TOL" -v wc="$wa_copy" -v wa="$wa_add" -v rounds="$ROUNDS" -v tc="${thread_counts[*]}" '
  function med(arr, n,   i, j, x, s) { for (i = 1; i <= n; i++) s[i] = arr[i]
      for (i = 2; i <= n; i++) { x = s[i]; for (j = i - 1; j >= 1 && s[j] > x; j--) s[j+1] = s[j]; s[j+1] = x }
      return n % 2 ? s[(n+1)/2] : (s[n/2] + s[n/2+1]) / 2 }
  NR == 1 { next }
  { r=$1; p=$2; t=$3; k=$4; v=$5+0; if (NR == 2 || $6+0 < lmin) lmin=$6+0; if ($6+0 > lmax) lmax=$6+0
    if (p == "gbuf") { g[t, r] = v; if (v > gbest[t]) gbest[t] = v; next }
    f = (k == "Copy" || k == "Scale") ? wc : wa
    if (v > best[t, k]) best[t, k] = v
    if (v * f > bus[t, r]) bus[t, r] = v * f
    if (v * f > busbest[t]) { busbest[t] = v * f; busk[t] = k }
    if (v > cntbest[t]) cntbest[t] = v }
  END {
    print "| threads | STREAM Copy | Scale | Add | Triad | STREAM best, bus traffic | gbuf read | gbuf / STREAM bus | within ±" tol "% | gbuf / STREAM counted |"
    print "|---:|---:|---:|---:|---:|---:|---:|---:|:---:|---:|"
    n = split(tc, T, " "); fail = 0
    for (i = 1; i <= n; i++) { t = T[i]
      ratio = gbest[t] / busbest[t]; ok = (ratio >= 1 - tol/100 && ratio <= 1 + tol/100); if (!ok) fail = 1
      printf "| %s | %.1f (%.1f) | %.1f (%.1f) | %.1f (%.1f) | %.1f (%.1f) | %.1f (%s) | %.1f | %.2f | %s | %.2f |\n", t,
        best[t,"Copy"], best[t,"Copy"]*wc, best[t,"Scale"], best[t,"Scale"]*wc, best[t,"Add"], best[t,"Add"]*wa,
        best[t,"Triad"], best[t,"Triad"]*wa, busbest[t], busk[t], gbest[t], ratio, ok ? "yes" : "**no**", gbest[t] / cntbest[t] }
    print ""
    print "Spread over the " rounds " interleaved round(s) (each round: gbuf best of 3 passes, STREAM best of " nt " per kernel):"
    print ""
    print "| threads | gbuf read min / median / max | STREAM bus (best kernel) min / median / max | per-round gbuf / STREAM bus min / median / max |"
    print "|---:|---:|---:|---:|"
    for (i = 1; i <= n; i++) { t = T[i]; gm = 1e30; gx = 0; sm = 1e30; sx = 0; qm = 1e30; qx = 0
      for (r = 1; r <= rounds; r++) { a[r] = g[t, r]; b[r] = bus[t, r]; q[r] = g[t, r] / bus[t, r]
        if (a[r] < gm) gm = a[r]; if (a[r] > gx) gx = a[r]; if (b[r] < sm) sm = b[r]; if (b[r] > sx) sx = b[r]
        if (q[r] < qm) qm = q[r]; if (q[r] > qx) qx = q[r] }
      printf "| %s | %.1f / %.1f / %.1f | %.1f / %.1f / %.1f | %.2f / %.2f / %.2f |\n", t, gm, med(a, rounds), gx,
        sm, med(b, rounds), sx, qm, med(q, rounds), qx }
    printf "\nload average (1 min) during the rounds: %.2f to %.2f\n", lmin, lmax
    exit fail }' "$T" >"$R/table.body.md"
verdict=$?
set -e
[ "$verdict" -le 1 ] || die "could not summarise $T"
{
  echo "## gbuf bench read probe vs STREAM ($(date '+%Y-%m-%d %H:%M'))"
  echo
  echo "- machine: $cpu_model, $(nproc) CPU(s), $llc_desc, avx512: $avx512 ($simd)$hyp"
  echo "- flags: $cpu_flags"
  echo "- load average at start: $load_start; at end: $load_end (our own runs count in it)"
  echo "- CPUs busy with other processes, over a 1 s pause before each round: $busy_range"
  [ "$busy_warn" = 0 ] || echo "- **warning**: other processes used up to $busy_max of the $(nproc) CPUs between rounds: the rates (above all the $THREADS-thread row, where a thread shares its CPU) are not this machine's best; rerun on an idle machine"
  echo "- STREAM: $src_desc"
  echo "- built: $cc_desc; stores: $stores"
  echo "- STREAM arrays: $N elements × 8 B = $((N * 8 >> 20)) MiB each; gbuf: $gbuf_ver ($GBUF_BIN, built $gbuf_when), \`bench --mib $MIB --threads $THREADS\`"
  echo "- GB/s = 10^9 B/s, best across rounds. STREAM cells: its counted rate (bus traffic = × $(awk -v w="$wa_copy" 'BEGIN{printf "%.3g", w}') Copy/Scale, × $(awk -v w="$wa_add" 'BEGIN{printf "%.3g", w}') Add/Triad, for the write-allocate reads). gbuf read counts MIB·2^20 bytes loaded, nothing written."
  echo
  cat "$R/table.body.md"
  echo
  if [ "$verdict" -eq 0 ]; then
    echo "**check passed**: gbuf's read probe is within ±$TOL% of STREAM's best bus traffic on every row."
  else
    echo "**check FAILED**: gbuf's read probe is not within ±$TOL% of STREAM's best bus traffic on every row (see README.md, \"When it fails\")."
  fi
} >"$R/table.md"
rm -f "$R/table.body.md"
cat "$R/table.md"
echo "(raw outputs and results.tsv in $R)" >&2
exit "$verdict"
