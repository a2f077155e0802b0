#!/usr/bin/env python3
"""8-bit image agreement: the C++ example's PPM against gbuf's --ldr gamma2.2 PNGs (from bench.py's last runs).

usage: compare.py [--keep DIR] STEM [STEM …]
Images are read from $PEER_SHM (default /dev/shm/ispc-peer), where bench.py wrote them: STEM_cpp.ppm and
STEM_{isa}_{t}t.png. --keep DIR saves STEM_cpp.png (the C++ frame) and STEM_gbuf_avx2.png there for a look by eye.
Prints a markdown table: max and mean |Δ| over all channels, share of channels that differ, share differing by > 1
code. For heights that are not a multiple of 16 the C++ leaves the last rows black (its min/max-Z tree does not
cover them; see build.sh), so those rows are also reported apart.
"""
import argparse
import os
import shutil

import numpy as np
from PIL import Image

SHM = os.environ.get("PEER_SHM") or "/dev/shm/ispc-peer"


def load(p):
    return np.asarray(Image.open(p).convert("RGB"), dtype=np.int16)


def stats(a, b):
    d = np.abs(a - b)
    return d.max(), d.mean(), 100 * (d > 0).mean(), 100 * (d > 1).mean()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--keep", metavar="DIR", help="save the C++ and gbuf avx2 1t images there as PNG")
    ap.add_argument("stems", nargs="+")
    a = ap.parse_args()
    print("| frame | gbuf run | max abs Δ | mean abs Δ | channels ≠ | channels Δ > 1 | note |")
    print("|---|---|--:|--:|--:|--:|---|")
    for stem in a.stems:
        ref = load(os.path.join(SHM, f"{stem}_cpp.ppm"))
        if a.keep:
            os.makedirs(a.keep, exist_ok=True)
            Image.fromarray(ref.astype(np.uint8)).save(os.path.join(a.keep, f"{stem}_cpp.png"))
            g = os.path.join(SHM, f"{stem}_avx2_1t.png")
            if os.path.exists(g):
                shutil.copyfile(g, os.path.join(a.keep, f"{stem}_gbuf_avx2.png"))
        h = ref.shape[0]
        full = h - h % 16
        imgs = {}
        for isa in ("avx512", "avx2", "baseline"):
            for t in (1, 2):
                p = os.path.join(SHM, f"{stem}_{isa}_{t}t.png")
                if os.path.exists(p):
                    imgs[f"{isa} {t}t"] = load(p)
        for name, g in imgs.items():
            m, mean, ne, ne1 = stats(ref, g)
            note = ""
            if full != h:
                m2, mean2, ne2, ne12 = stats(ref[:full], g[:full])
                note = (f"rows 0–{full - 1} only: max {m2}, mean {mean2:.4f}, ≠ {ne2:.3f}%, Δ>1 {ne12:.4f}%; "
                        f"last {h - full} rows: C++ black")
            print(f"| {stem} | {name} | {m} | {mean:.4f} | {ne:.3f}% | {ne1:.4f}% | {note} |")
        # gbuf against itself across ISAs and threads
        names = list(imgs)
        same_threads = all(np.array_equal(imgs[f"{i} 1t"], imgs[f"{i} 2t"]) for i in ("avx512", "avx2", "baseline")
                           if f"{i} 1t" in imgs and f"{i} 2t" in imgs)
        if "avx512 1t" in imgs:
            cross = {n: stats(imgs["avx512 1t"], imgs[n])[0] for n in names}
            print(f"| {stem} | gbuf 1t vs 2t identical: {same_threads}; max Δ vs avx512 1t: "
                  + ", ".join(f"{n} {v}" for n, v in cross.items() if n != "avx512 1t") + " | | | | | |")


if __name__ == "__main__":
    main()
