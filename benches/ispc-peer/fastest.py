#!/usr/bin/env python3
"""The fastest of N interleaved runs, C++ against gbuf per instruction set: on a busy shared host the minimum CPU
time of a CPU-bound process is the robust figure (a neighbour only ever adds time), where paired medians swing by
±20%. Run after run.sh has built the harness and made the inputs (WORK/build, WORK/data).

    benches/ispc-peer/fastest.py dense720 15                  gbuf = GBUF_BIN or <repo>/target/release/gbuf
    GBUF_BASE=/tmp/gbuf-old benches/ispc-peer/fastest.py …    also a second gbuf binary, interleaved (a same-run baseline)
"""
import os
import resource
import statistics
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
repo = os.path.dirname(os.path.dirname(here))
WORK = os.environ.get("PEER_WORK", os.path.join(repo, "target", "ispc-peer"))
SHM = os.environ.get("PEER_SHM", "/dev/shm/ispc-peer")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    stem, n = sys.argv[1], int(sys.argv[2])
    f = os.path.join(WORK, "data", stem + ".bin")
    os.makedirs(SHM, exist_ok=True)
    bins = [("gbuf", os.environ.get("GBUF_BIN", os.path.join(repo, "target", "release", "gbuf")))]
    if os.environ.get("GBUF_BASE"):
        bins.append(("base", os.environ["GBUF_BASE"]))
    cfgs = [("C++", [os.path.join(WORK, "build", "harness"), "frame", f, os.path.join(SHM, "fastest.ppm")], {})]
    for isa in ["avx512", "avx2", "baseline"]:
        for tag, b in bins:
            cmd = [b, "resolve", f, "--ldr", "gamma2.2", "--png", os.path.join(SHM, "fastest.png"), "--no-reference",
                   "--no-flip", "--json", "-q"]
            cfgs.append((f"{tag} {isa}", cmd, {"GBUF_ISA": isa}))
    times = {name: [] for name, _, _ in cfgs}
    for _ in range(n):
        for name, cmd, env in cfgs:
            e = dict(os.environ, RAYON_NUM_THREADS="1", **env)
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run(cmd, env=e, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            times[name].append(1000 * (r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime))
    c = times.pop("C++")
    print(f"{stem}: C++ fastest {min(c):.1f} ms, median {statistics.median(c):.1f} ms ({n} runs each, 1 thread)")
    for name, v in times.items():
        print(f"  {name:14s} fastest {min(v):6.1f} ms  median {statistics.median(v):6.1f} ms  "
              f"C++/gbuf {min(c) / min(v):.2f}x by the fastest, {statistics.median(c) / statistics.median(v):.2f}x by medians")


if __name__ == "__main__":
    main()
