#!/usr/bin/env python3
"""Markdown tables from bench.py's summary.json (and the raw.jsonl beside it, for the paired ratios).

usage: report.py [WORK/results/summary.json]   (default: results/summary.json in the current directory; run.sh runs
it from WORK)
"""
import json
import sys

d = json.load(open(sys.argv[1] if len(sys.argv) > 1 else "results/summary.json"))
ISAS = ("avx512", "avx2", "baseline")


def f1(x):
    return f"{x:.1f}"


print("### Per core: one frame, CPU time (median; 1 thread for gbuf)\n")
print("C++ columns: `harness` (ISPC example's DispatchDynamicC, g++ -O3 -march=native). *dispatch* = DispatchDynamicC "
      "alone on input already in memory; *frame in-proc* = file read + InitDynamicC + DispatchDynamicC + WriteFrame "
      "(RGB8 interleave + PPM write), thread CPU; *frame process* = user+sys of a `harness frame` process. "
      "gbuf: user+sys of one `gbuf resolve F.bin --ldr gamma2.2 --png OUT.png --no-reference --no-flip --json` "
      "process at RAYON_NUM_THREADS=1 (file read, convert, checks, detect, resolve, LDR, PNG). Ratio = C++ frame "
      "process / gbuf process.\n")
print("| frame | C++ lights/px | gbuf lights/sample (pairs) | C++ dispatch | C++ frame in-proc | C++ frame process | "
      + " | ".join(f"gbuf {i}" for i in ISAS) + " | " + " | ".join(f"C++/gbuf {i}" for i in ISAS) + " |")
print("|---|--:|--:|--:|--:|--:|" + "--:|" * (2 * len(ISAS)))
for stem, v in d.items():
    m = v["medians"]
    cpp = m["C++ frame"]["cpu_ms"]
    g = {i: m[f"gbuf {i} 1t"]["cpu_ms"] for i in ISAS}
    ga = m["gbuf avx2 1t"]
    print(f"| {stem} | {float(v['counts']['lights_per_pixel']):.1f} | {ga['lights_per_sample']:.1f} "
          f"({ga['pairs_tested'] / 1e6:.1f} M; C++ {int(v['counts']['pairs']) / 1e6:.1f} M) | "
          f"{float(v['inproc']['dispatch_cpu_median_ms']):.1f} | {float(v['inproc']['frame_cpu_median_ms']):.1f} | "
          f"{f1(cpp)} | " + " | ".join(f1(g[i]) for i in ISAS) + " | "
          + " | ".join(f"{cpp / g[i]:.2f}×" for i in ISAS) + " |")

# Paired ratios: each gbuf 1-thread run against the C++ run just before it in the same round (the load of the other
# core changes slowly, so adjacent runs see about the same machine).
import os
import statistics
rawp = os.path.join(os.path.dirname(sys.argv[1] if len(sys.argv) > 1 else "results/summary.json"), "raw.jsonl")
if os.path.exists(rawp):
    recs = [json.loads(l) for l in open(rawp)]
    print("\n### Paired per-core ratios (C++ frame process CPU / the next gbuf 1-thread process CPU, same round)\n")
    print("| frame | " + " | ".join(f"C++/gbuf {i}: median (min–max)" for i in ISAS) + " |")
    print("|---|" + "--:|" * len(ISAS))
    for stem in d:
        rs = [r for r in recs if r["file"] == stem]
        ratios = {i: [] for i in ISAS}
        for k, r in enumerate(rs):
            for i in ISAS:
                if r["config"] == f"gbuf {i} 1t" and k > 0 and rs[k - 1]["kind"] == "cpp":
                    ratios[i].append(rs[k - 1]["cpu_ms"] / r["cpu_ms"])
        print(f"| {stem} | " + " | ".join(
            f"{statistics.median(ratios[i]):.2f}× ({min(ratios[i]):.2f}–{max(ratios[i]):.2f})" if ratios[i] else "—"
            for i in ISAS) + " |")

print("\n### Spread of the per-core numbers (process CPU ms: min / median / max over the runs)\n")
print("| frame | run | n | min | median | max |\n|---|---|--:|--:|--:|--:|")
for stem, v in d.items():
    for c in ["C++ frame"] + [f"gbuf {i} 1t" for i in ISAS]:
        x = v["medians"][c]
        print(f"| {stem} | {c} | {x['n']} | {f1(x['cpu_min_ms'])} | {f1(x['cpu_ms'])} | {f1(x['cpu_max_ms'])} |")

print("\n### Threads: wall time of one process (median, min in brackets), ms\n")
print("| frame | C++ frame (1 thread) | " + " | ".join(f"gbuf {i} 1t | 2t | 1→2t" for i in ISAS)
      + " | gbuf avx2 2t, detector none |")
print("|---|--:|" + "--:|--:|--:|" * len(ISAS) + "--:|")
for stem, v in d.items():
    m = v["medians"]
    row = [f"{f1(m['C++ frame']['wall_ms'])} ({f1(m['C++ frame']['wall_min_ms'])})"]
    for i in ISAS:
        a, b = m[f"gbuf {i} 1t"], m[f"gbuf {i} 2t"]
        row += [f"{f1(a['wall_ms'])} ({f1(a['wall_min_ms'])})", f"{f1(b['wall_ms'])} ({f1(b['wall_min_ms'])})",
                f"{a['wall_ms'] / b['wall_ms']:.2f}× ({a['wall_min_ms'] / b['wall_min_ms']:.2f}×)"]
    n = m["gbuf avx2 2t detector none"]
    row.append(f"{f1(n['wall_ms'])} ({f1(n['wall_min_ms'])})")
    print(f"| {stem} | " + " | ".join(row) + " |")

print("\n### gbuf's own stage timers (`--json` ms, wall clock inside the process; medians)\n")
print("gather/cull/shade are gbuf's estimates from timing 1 tile in 8; decode = file read + convert + load checks. "
      "'process − total' = everything outside gbuf's timers (start, lights, LDR, PNG, JSON, exit), wall. "
      "PNG+LDR = CPU of the avx2 1t run with `--png` minus the same without.\n")
print("| frame | run | decode | detect | gather | cull | shade | total | process wall | process − total |")
print("|---|---|--:|--:|--:|--:|--:|--:|--:|--:|")
for stem, v in d.items():
    m = v["medians"]
    for c in [f"gbuf {i} {t}t" for t in (1, 2) for i in ISAS]:
        j = m[c]["json_ms"]
        print(f"| {stem} | {c} | {f1(j['decode'])} | {f1(j['detect'])} | {f1(j['gather'])} | {f1(j['cull'])} | "
              f"{f1(j['shade'])} | {f1(j['total'])} | {f1(m[c]['wall_ms'])} | {f1(m[c]['wall_ms'] - j['total'])} |")

print("\n### Fixed costs and options (avx2, 1 thread, process CPU ms, medians)\n")
print("| frame | default (lauritzen, PNG) | no PNG (→ PNG+LDR cost) | detector none | avx512 detector none | "
      "peak RSS gbuf / C++ (MB) |")
print("|---|--:|--:|--:|--:|--:|")
for stem, v in d.items():
    m = v["medians"]
    a, n, dn, dn5 = (m[k]["cpu_ms"] for k in ("gbuf avx2 1t", "gbuf avx2 1t no PNG", "gbuf avx2 1t detector none",
                                              "gbuf avx512 1t detector none"))
    print(f"| {stem} | {f1(a)} | {f1(n)} ({f1(a - n)}) | {f1(dn)} | {f1(dn5)} | "
          f"{m['gbuf avx2 1t']['maxrss_mb']:.0f} / {m['C++ frame']['maxrss_mb']:.0f} |")
