#!/usr/bin/env python3
"""Interleaved side-by-side runs: the ISPC `deferred` serial C++ (WORK/build/harness) against gbuf (GBUF_BIN) on the
same .bin files. Called by run.sh; writes WORK/results/raw.jsonl and summary.json (report.py makes the tables).

Paths: WORK = $PEER_WORK or <repo>/target/ispc-peer; GBUF_BIN defaults to <repo>/target/release/gbuf; output
images go to $PEER_SHM (default /dev/shm/ispc-peer), where compare.py reads them.

Every process is run under `/usr/bin/time -f "%e %U %S %M"` (its output kept in the raw records) and reaped with
os.wait4, whose rusage gives user+sys CPU to the microsecond (the `time` process and its child together; `time`
itself costs ~1 ms). Per-core comparisons use process CPU (user+sys) at one thread: robust to the other core's load,
unlike wall time. 2-thread runs are compared by wall time (what threads buy), so they carry the machine's noise.

usage: bench.py [--rounds N] [--files a.bin,b.bin] [--out DIR]   (relative paths are taken from WORK; the default
files are data/dense720.bin, dense1080.bin, blender720.bin and, when blender_native.sh has made it, blender720n.bin)
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
WORK = os.path.abspath(os.environ.get("PEER_WORK") or os.path.join(REPO, "target", "ispc-peer"))
SHM = os.environ.get("PEER_SHM") or "/dev/shm/ispc-peer"
GBUF = os.environ.get("GBUF_BIN") or os.path.join(REPO, "target", "release", "gbuf")
HARNESS = os.path.join(WORK, "build", "harness")
TIME_FMT = "%e %U %S %M"


def run(cmd, env_extra=None):
    """Runs cmd under /usr/bin/time; returns dict(wall, cpu, user, sys, maxrss_kb, time_line, stdout)."""
    env = dict(os.environ)
    env.pop("RAYON_NUM_THREADS", None)
    env.pop("GBUF_ISA", None)
    env.update(env_extra or {})
    tfile = os.path.join(SHM, "time.txt")
    full = ["/usr/bin/time", "-f", TIME_FMT, "-o", tfile] + cmd
    out = open(os.path.join(SHM, "stdout.txt"), "wb")
    t0 = time.perf_counter()
    p = subprocess.Popen(full, stdout=out, stderr=subprocess.PIPE, env=env)
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    out.close()
    stdout = open(os.path.join(SHM, "stdout.txt"), "rb").read().decode()
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{err.decode()}\n{stdout[:2000]}")
    tl = open(tfile).read().strip().splitlines()[-1]
    return {"wall_ms": 1e3 * wall, "cpu_ms": 1e3 * (ru.ru_utime + ru.ru_stime), "user_ms": 1e3 * ru.ru_utime,
            "sys_ms": 1e3 * ru.ru_stime, "maxrss_mb": ru.ru_maxrss / 1024, "time_line": tl, "stdout": stdout,
            "stderr": err.decode()[-500:]}


def gbuf_cmd(f, tag, png=True, detector=None):
    cmd = [GBUF, "resolve", f, "--ldr", "gamma2.2", "--png", os.path.join(SHM, f"{tag}.png")] if png else \
        [GBUF, "resolve", f]
    cmd += ["--brdf", "blinn-phong", "--falloff", "linear", "--culling", "tiled", "--no-reference", "--no-flip",
            "--json"]
    if detector:
        cmd += ["--detector", detector]
    return cmd


def configs(f, stem):
    """(name, kind, cmd, env) in the interleaved order of one round."""
    cpp = ("C++ frame", "cpp", [HARNESS, "frame", f, os.path.join(SHM, f"{stem}_cpp.ppm")], {})
    g = lambda isa, th, png=True, det=None, name=None: (
        name or f"gbuf {isa} {th}t", "gbuf", gbuf_cmd(f, f"{stem}_{isa}_{th}t", png, det),
        {"GBUF_ISA": isa, "RAYON_NUM_THREADS": str(th)})
    return [cpp, g("avx2", 1), cpp, g("avx512", 1), cpp, g("baseline", 1),
            g("avx2", 2), g("avx512", 2), g("baseline", 2),
            g("avx2", 1, png=False, name="gbuf avx2 1t no PNG"),
            g("avx2", 1, det="none", name="gbuf avx2 1t detector none"),
            g("avx512", 1, det="none", name="gbuf avx512 1t detector none"),
            g("avx2", 2, det="none", name="gbuf avx2 2t detector none")]


def med(xs):
    return statistics.median(xs) if xs else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=7)
    default = ["data/dense720.bin", "data/dense1080.bin", "data/blender720.bin"]
    if os.path.exists(os.path.join(WORK, "data", "blender720n.bin")):
        default.append("data/blender720n.bin")
    ap.add_argument("--files", default=",".join(default))
    ap.add_argument("--out", default="results")
    a = ap.parse_args()
    a.out = os.path.join(WORK, a.out)
    os.makedirs(SHM, exist_ok=True)
    os.makedirs(a.out, exist_ok=True)
    raw = open(os.path.join(a.out, "raw.jsonl"), "w")
    summary = {}
    for f in a.files.split(","):
        f = os.path.join(WORK, f)
        stem = os.path.splitext(os.path.basename(f))[0]
        # In-process C++ timings (thread CPU): DispatchDynamicC alone and the like-for-like frame, 7 runs each.
        ib = run([HARNESS, "bench", f, "7", os.path.join(SHM, f"{stem}_cppbench.ppm")])
        inproc = dict(l.split(" ", 1) for l in ib["stdout"].strip().splitlines())
        cnt = subprocess.run([HARNESS + "-count", "count", f], capture_output=True, text=True, check=True).stdout
        counts = dict(l.split(" ", 1) for l in cnt.strip().splitlines())
        recs = {}
        for r in range(a.rounds):
            for name, kind, cmd, env in configs(f, stem):
                res = run(cmd, env)
                rec = {"file": stem, "round": r, "config": name, "kind": kind, "env": env, "cmd": cmd, **res}
                if kind == "gbuf":
                    j = json.loads(res["stdout"])
                    rec["json_ms"] = j["ms"]
                    rec["isa"] = j["isa"]
                    rec["pairs_tested"] = j["light_pairs_tested"]
                    rec["evaluations"] = j["shading_evaluations"]
                    rec["lights_per_sample"] = j["lights_per_sample"]
                    rec["edge_fraction"] = j["edge_fraction"]
                else:
                    rec["harness"] = dict(l.split(" ", 1) for l in res["stdout"].strip().splitlines())
                del rec["stdout"]
                raw.write(json.dumps(rec) + "\n")
                raw.flush()
                recs.setdefault(name, []).append(rec)
            print(f"{stem}: round {r + 1}/{a.rounds} done", file=sys.stderr)
        summary[stem] = {"inproc": inproc, "counts": counts, "recs": recs}
    json.dump({k: {"inproc": v["inproc"], "counts": v["counts"],
                   "medians": {c: {"cpu_ms": med([x["cpu_ms"] for x in rs]),
                                   "cpu_min_ms": min(x["cpu_ms"] for x in rs),
                                   "cpu_max_ms": max(x["cpu_ms"] for x in rs),
                                   "wall_ms": med([x["wall_ms"] for x in rs]),
                                   "wall_min_ms": min(x["wall_ms"] for x in rs),
                                   "maxrss_mb": med([x["maxrss_mb"] for x in rs]),
                                   "n": len(rs),
                                   **({"json_ms": {s: med([x["json_ms"][s] for x in rs]) for s in rs[0]["json_ms"]},
                                       "pairs_tested": rs[0]["pairs_tested"],
                                       "lights_per_sample": rs[0]["lights_per_sample"],
                                       "evaluations": rs[0]["evaluations"]} if rs[0]["kind"] == "gbuf" else
                                      {"frame_cpu_ms": med([float(x["harness"]["frame_cpu_ms"]) for x in rs]),
                                       "dispatch_ms": med([float(x["harness"]["frame_dispatch_ms"]) for x in rs])})}
                              for c, rs in v["recs"].items()}}
               for k, v in summary.items()}, open(os.path.join(a.out, "summary.json"), "w"), indent=1)
    print(f"wrote {a.out}/raw.jsonl and summary.json", file=sys.stderr)


if __name__ == "__main__":
    main()
