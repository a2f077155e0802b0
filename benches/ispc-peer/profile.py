#!/usr/bin/env python3
"""Splits a `perf record -e cpu-clock --call-graph dwarf` profile of one `gbuf resolve FILE.bin --png …` process
into the frame's stages, by the gbuf functions on each sample's stack (MARKERS, in priority order).

usage: profile.py PERF.TXT [PERF.TXT …]   (each the output of `perf script -F pid,tid,period,ip,sym`, as run.sh
makes them). PROFILE_VERBOSE=1 lists the commonest unattributed stacks on stderr.
Prints CPU ms per stage (sum of sample periods, averaged over the files) as a markdown table, with the share of each
stage that ran on the main thread: rayon's parallel loops run on its worker threads (the main thread only waits),
so a stage at 100% main thread is serial code, one at 0% ran inside a parallel loop. A rayon worker's sample whose
stack holds only rayon's generic frames (the gbuf closure inlined away) is filed under the stage of the same thread's
next attributed sample (else the previous one); the table's footnote gives how much was filed that way.
"""
import os
import re
import sys
from collections import Counter, defaultdict

# (regex on a frame's symbol, stage) in priority order: the first marker found anywhere on a sample's stack decides.
MARKERS = [
    (r"gbuf::resolve::kernel::", "shade: light loop (kernel)"),
    (r"schedule::touching_", "shade: per-vector light lists"),
    (r"gbuf::resolve::culling::|schedule::cull_into|gbuf::resolve::lights::", "cull: tile bounds + light list"),
    (r"gbuf::resolve::schedule::|gbuf::resolve::worklist|gbuf::resolve::surface", "gather/work list/box filter (run_band)"),
    (r"gbuf::resolve::", "resolve: other (setup, image alloc)"),
    ((r"gbuf::io::ispc::decode", r"from_elem|extend_with|GBuffer::new"), "load: allocate + zero G-buffer planes"),
    (r"gbuf::io::ispc::Band::convert|gbuf::io::ispc::decode", "load: convert .bin arrays -> G-buffer"),
    (r"gbuf::io::ispc::read", "load: file read"),
    (r"gbuf::io::plausible::", "load: plausibility check (io::finish)"),
    (r"gbuf::io::sanitize::", "load: sanitize (io::finish)"),
    (r"gbuf::io::", "load: other (io::finish, stats)"),
    (r"gbuf::detect::", "detect (edge mask)"),
    (r"to_ldr_gamma22|Gamma22Lut", "LDR gamma-2.2 encode"),
    (r"png::|fdeflate|write_rgb8_png|picture::write_png|crc32|adler", "PNG encode + write"),
    (r"gbuf::cli::resolve::pick_lights|gbuf::light::", "lights"),
    (r"serde|print_json", "JSON report"),
    (r"^_dl_start|^_dl_init|^dl_main|^_dl_relocate|^_dl_map|init_cpu_features", "process start (loader)"),
    (r"gbuf::main|clap|std::rt::", "main: other (args, drops, exit)"),
]
# A marker with several patterns needs each of them somewhere on the stack.
COMPILED = [([re.compile(x) for x in (p if isinstance(p, tuple) else (p,))], s) for p, s in MARKERS]


# A sample's header line: "PID/TID PERIOD". perf right-aligns the pid, so shorter pids come with leading spaces
# ("  9553/9553      500000"); the stack frames below it are indented ("\t    55d0c3a1b2c4 symbol").
HEADER = re.compile(r"^\s*(\d+)/(\d+)\s+(\d+)\s*$")


def samples(path):
    cur = None
    skipped = 0
    for line in open(path, errors="replace"):
        if not line.strip():
            if cur is not None:
                yield cur
            cur = None
            continue
        m = HEADER.match(line)
        if m:
            if cur is not None:
                yield cur
            cur = (int(m.group(3)), [], m.group(1) == m.group(2), m.group(2))
            continue
        if cur is None:
            skipped += 1  # not a header and no sample open: not a line of `perf script -F pid,tid,period,ip,sym`
            continue
        parts = line.strip().split(None, 1)
        cur[1].append(parts[1] if len(parts) > 1 else "?")
    if cur is not None:
        yield cur
    if skipped:
        print(f"profile.py: {path}: {skipped} lines outside any sample skipped (expected pid/tid period headers)",
              file=sys.stderr)


def classify(frames):
    # Markers in priority order, each against the whole stack (inlined helpers such as gbuf::resolve::simd::* sit
    # between the leaf and the kernel function, so "innermost frame wins" would misfile them).
    for rxs, stage in COMPILED:
        if all(any(rx.search(f) for f in frames) for rx in rxs):
            return stage
    kernelish = all(re.match(r"^[a-z_0-9.]+$", f) or "kallsyms" in f or f == "?" for f in frames)
    if any("exit" in f or "munmap" in f or "free" in f for f in frames):
        return "exit / free"
    return "other (kernel/libc, unattributed)" if kernelish else "other"


STAGES = {s for _, s in MARKERS}
# A rayon worker running a job has only rayon's generic frames on its stack (bridge_producer_consumer, folders, …):
# the gbuf closures are inlined into them and show up only when the sample lands inside one.
RAYON_JOB = re.compile(r"^rayon(_core)?::|^<rayon(_core)?::")


def classified(path):
    """(period, stage, on_main, by_neighbour) per sample. A sample with no gbuf frame on a rayon job's stack is filed
    under the stage of the next sample of the same thread that has one (perf script prints samples in time order;
    the loop it belongs to is the one that goes on), else the previous one."""
    recs = [(period, classify(frames), on_main, tid, frames) for period, frames, on_main, tid in samples(path)]
    out = [None] * len(recs)
    nxt, prev = {}, {}
    for k in range(len(recs) - 1, -1, -1):
        period, st, on_main, tid, frames = recs[k]
        if st in STAGES:
            nxt[tid] = st
        elif st == "other" and tid in nxt and any(RAYON_JOB.search(f) for f in frames):
            out[k] = (period, nxt[tid], on_main, True)
    for k, (period, st, on_main, tid, frames) in enumerate(recs):
        if st in STAGES:
            prev[tid] = st
        if out[k] is None:
            if st == "other" and tid in prev and any(RAYON_JOB.search(f) for f in frames):
                out[k] = (period, prev[tid], on_main, True)
            else:
                out[k] = (period, st, on_main, False)
        yield out[k] + (frames,)


def main():
    totals = defaultdict(float)
    main_ms = defaultdict(float)
    unknown = Counter()
    neighbour_ms = 0.0
    files = sys.argv[1:]
    for p in files:
        for period, st, on_main, by_neighbour, frames in classified(p):
            ms = period / 1e6 / len(files)  # ns -> ms, averaged over files
            totals[st] += ms
            if on_main:
                main_ms[st] += ms
            if by_neighbour:
                neighbour_ms += ms
            if st.startswith("other"):
                unknown[" <- ".join(frames[:6])] += 1
    order = [s for _, s in MARKERS] + ["exit / free", "other (kernel/libc, unattributed)", "other"]
    all_ms = sum(totals.values())
    print("| stage | CPU ms | share | on main thread |\n|---|--:|--:|--:|")
    for s in dict.fromkeys(order):
        if totals.get(s):
            print(f"| {s} | {totals[s]:.1f} | {100 * totals[s] / all_ms:.1f}% | {100 * main_ms[s] / totals[s]:.0f}% |")
    am = sum(main_ms.values())
    print(f"| **all samples** | **{all_ms:.1f}** | 100% | {100 * am / all_ms:.0f}% |")
    groups = {"resolve (shade + cull + gather + setup)": ("shade", "cull", "gather", "resolve"),
              "load (file -> checked G-buffer)": ("load",), "output (LDR + PNG)": ("LDR", "PNG")}
    for g, prefixes in groups.items():
        t = sum(v for k, v in totals.items() if k.startswith(prefixes))
        m = sum(v for k, v in main_ms.items() if k.startswith(prefixes))
        print(f"| *subtotal: {g}* | *{t:.1f}* | *{100 * t / all_ms:.1f}%* | *{100 * m / max(t, 1e-9):.0f}%* |")
    print(f"\n{neighbour_ms:.1f} ms ({100 * neighbour_ms / all_ms:.1f}%) of rayon job samples without a gbuf frame were "
          "filed under the stage of their thread's next (else previous) attributed sample.")
    serial = am / all_ms
    print(f"\nSerial share {100 * serial:.0f}% → Amdahl bound for 2 threads: {1 / (serial + (1 - serial) / 2):.2f}×")
    if os.environ.get("PROFILE_VERBOSE"):
        for k, v in unknown.most_common(15):
            print(v, k, file=sys.stderr)


if __name__ == "__main__":
    main()
