#!/usr/bin/env python3
"""AMD's FidelityFX Variable Shading shader, run on Mesa's lavapipe, against gbuf's `ffx_sri`, tile for tile.

For each frame, `gbuf vrs FRAME --ffx-wave W --out DIR` writes the image its FidelityFX model reads
(`full_rate.exr`) and the SRIs it derives (`sri_ffx_<tile>.dds`). The same image goes, as the colour input with
zero motion vectors, into AMD's own shading-rate-image pass (FidelityFX SDK 1.1.x: the Vulkan backend's
`ffx_vrs_imagegen_pass.glsl`, and with `--lang hlsl` also the DX12 backend's `.hlsl` through glslang's HLSL front
end), compiled from where the SDK lies and dispatched on lavapipe with subgroups of W lanes (vrs_dispatch.c). The
two SRIs are compared texel for texel. Not part of CI: see README.md beside this file.

    benches/ffx_lavapipe/run.py [--ffx-src DIR] [--waves 4,8,16] [--tiles 8,16,32] [--lang glsl,hlsl]

Exit status: 0 every tile identical, 1 some tile differs, 2 a prerequisite or an argument is missing, 3 a step
failed.
"""
import argparse
import glob
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SDK_URL = "https://github.com/GPUOpen-LibrariesAndSDKs/FidelityFX-SDK.git"
SDK_REF = "v1.1.4"  # the last SDK with VRS (2.0 dropped it); its VRS 1.2 files are those of v1.1.0 to v1.1.3
PASS = {
    "glsl": "sdk/src/backends/vk/shaders/vrs/ffx_vrs_imagegen_pass.glsl",
    "hlsl": "sdk/src/backends/dx12/shaders/vrs/ffx_vrs_imagegen_pass.hlsl",
}
GPU = "sdk/include/FidelityFX/gpu"
# Descriptor bindings (colour, motion vectors, SRI, constants) as each pass declares them (HLSL: t0, t1, u0, b0,
# shifted by glslang's --shift-image-binding 10 and --shift-cbuffer-binding 20).
BINDINGS = {"glsl": "0,1,2000,3000", "hlsl": "0,1,10,20"}
ENTRY = {"glsl": "main", "hlsl": "CS"}
SRI_FORMAT = {"glsl": "r8", "hlsl": "r32"}
CUTOFF = 0.015  # AMD's sample's VarianceCutoff; gbuf's FFX_VARIANCE_CUTOFF
MOTION_FACTOR = 0.01  # AMD's sample's default; it scales the motion vectors' length, zero here
RATES = {0: "1x1", 1: "1x2", 4: "2x1", 5: "2x2", 6: "2x4", 9: "4x2", 10: "4x4"}
FIX = ROOT / "fixtures"
FRAMES = [  # name, file, gbuf's extra arguments
    ("blender_1x", FIX / "blender_1x.exr", []),
    ("mitsuba_1x", FIX / "mitsuba_1x.exr", []),
    ("raster_4x", FIX / "raster_4x.exr", []),
    ("engine_4x", FIX / "engine_4x.rdc",
     ["--input-layout", str(FIX / "engine_4x/engine.toml"), "--scene", str(FIX / "engine_4x/scene.json")]),
]


def say(*a):
    print(*a, flush=True)


def run(cmd, env=None, what=""):
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if p.returncode != 0:
        say(f"FAILED {what or cmd[0]} (exit {p.returncode}): {' '.join(map(str, cmd))}")
        say((p.stdout + p.stderr).strip()[-3000:])
        sys.exit(3)
    return p


def prerequisites(args):
    missing = []
    for tool, pkg in [("glslangValidator", "apt-get install glslang-tools"), ("gcc", "apt-get install gcc"),
                      ("git", "apt-get install git")]:
        if not shutil.which(tool):
            missing.append(f"{tool} ({pkg})")
    if not Path("/usr/include/vulkan/vulkan.h").exists():
        missing.append("Vulkan headers and loader (apt-get install libvulkan-dev)")
    icds = sorted(glob.glob("/usr/share/vulkan/icd.d/lvp_icd*.json"))
    if not icds:
        missing.append("lavapipe (apt-get install mesa-vulkan-drivers)")
    for mod, pkg in [("numpy", "numpy"), ("OpenEXR", "openexr")]:
        try:
            __import__(mod)
        except ImportError:
            missing.append(f"Python module {mod} (python3 -m pip install {pkg})")
    if not Path(args.gbuf).is_file():
        missing.append(f"gbuf binary {args.gbuf} (cargo build --release)")
    if missing:
        say("missing prerequisites:\n  " + "\n  ".join(missing))
        sys.exit(2)
    return icds


def ffx_source(args, work):
    """AMD's files: a checkout (or extracted copy) of the SDK, or a git directory read at --ffx-ref; returns the
    directory holding them and a description (commit) of what was compiled."""
    src = args.ffx_src
    if src is None:
        src = work / "FidelityFX-SDK"
        if not (src / PASS["glsl"]).exists():
            say(f"cloning {SDK_URL} at {args.ffx_ref} into {src}")
            run(["git", "clone", "-q", "--depth", "1", "--branch", args.ffx_ref, SDK_URL, str(src)], what="git clone")
    src = Path(src).resolve()
    if (src / PASS["glsl"]).exists():
        rev = subprocess.run(["git", "-C", str(src), "rev-parse", "HEAD"], capture_output=True, text=True)
        return src, f"{src} (" + (f"commit {rev.stdout.strip()})" if rev.returncode == 0 else "not a git checkout)")
    # A git directory (a bare mirror or a checkout of another revision): extract the files at --ffx-ref.
    gd = ["git", "--git-dir", str(src if (src / "HEAD").exists() else src / ".git")]
    p = subprocess.run(gd + ["rev-parse", "--verify", f"{args.ffx_ref}^{{commit}}"], capture_output=True, text=True)
    if p.returncode != 0:
        say(f"--ffx-src {src}: neither an SDK checkout ({PASS['glsl']} missing) nor a git directory with "
            f"{args.ffx_ref}")
        sys.exit(2)
    commit = p.stdout.strip()
    out = work / f"ffx-src-{commit[:12]}"
    paths = run(gd + ["ls-tree", "-r", "--name-only", commit, "--", f"{GPU}/vrs", f"{GPU}/ffx_core.h",
                      f"{GPU}/ffx_common_types.h", f"{GPU}/ffx_core_glsl.h", f"{GPU}/ffx_core_hlsl.h",
                      f"{GPU}/ffx_core_gpu_common.h", f"{GPU}/ffx_core_gpu_common_half.h",
                      f"{GPU}/ffx_core_portability.h", PASS["glsl"], PASS["hlsl"]], what="git ls-tree").stdout.split()
    for path in paths:
        dest = out / path
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(subprocess.run(gd + ["show", f"{commit}:{path}"], capture_output=True, check=True).stdout)
    return out, f"{src} at {args.ffx_ref} (commit {commit}), extracted to {out}"


def compile_shaders(src, work, langs, tiles, extras):
    spv = {}
    inc = [f"-I{src / GPU}", f"-I{src / GPU / 'vrs'}"]
    for lang in langs:
        if not (src / PASS[lang]).exists():
            say(f"--ffx-src: {src / PASS[lang]} missing")
            sys.exit(2)
        for tile, extra in ((t, e) for t in tiles for e in extras):
            out = work / f"ffx_vrs_{lang}_{tile}{'_extra' if extra else ''}.spv"
            # As AMD's build compiles the pass (sdk/src/backends/vk/CMakeShadersVRS.txt, CMakeCompileVRSShaders.txt):
            # glslang, Vulkan 1.2, FFX_GPU, the base-rates or the additional-rates permutation at this tile size.
            cmd = ["glslangValidator", "-V", "--target-env", "vulkan1.2", "-S", "comp", "-Os", "-DFFX_GPU=1",
                   f"-DFFX_VRS_OPTION_ADDITIONALSHADINGRATES={int(extra)}", f"-DFFX_VARIABLESHADING_TILESIZE={tile}",
                   *inc, "-o", str(out)]
            if lang == "glsl":
                cmd += ["-DFFX_GLSL=1"]
            else:
                cmd += ["-D", "-e", "CS", "-DFFX_HLSL=1", "--shift-image-binding", "10", "--shift-cbuffer-binding", "20"]
            run(cmd + [str(src / PASS[lang])], what=f"glslangValidator ({lang}, tile {tile}, extra {int(extra)})")
            spv[lang, tile, extra] = out
    return spv


def device_info(harness, env):
    p = run([str(harness), "--info"], env=env, what="vrs_dispatch --info")
    return dict(line.split(" ", 1) for line in p.stdout.strip().splitlines())


def read_exr_rgba(path):
    import numpy as np
    import OpenEXR
    if hasattr(OpenEXR, "File"):
        ch = OpenEXR.File(str(path)).channels()
        rgb = ch["RGB"].pixels if "RGB" in ch else np.stack([ch[c].pixels for c in "RGB"], -1)
    else:  # the OpenEXR module before 3.3
        f = OpenEXR.InputFile(str(path))
        dw = f.header()["dataWindow"]
        w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
        rgb = np.stack([np.frombuffer(f.channel(c), np.float32).reshape(h, w) for c in "RGB"], -1)
    rgba = np.ones(rgb.shape[:2] + (4,), np.float32)
    rgba[..., :3] = rgb
    return rgba


def read_dds_r8(path):
    import numpy as np
    d = Path(path).read_bytes()
    if d[:4] != b"DDS ":
        raise ValueError(f"{path}: not a DDS")
    height, width = int.from_bytes(d[12:16], "little"), int.from_bytes(d[16:20], "little")
    off = 4 + 124 + (20 if d[84:88] == b"DX10" else 0)
    if d[84:88] == b"DX10" and int.from_bytes(d[128:132], "little") != 62:
        raise ValueError(f"{path}: not R8_UINT")
    return np.frombuffer(d[off:off + width * height], np.uint8).reshape(height, width)


def clamp_to_samples(sri, samples, extra):
    """D3D12's clamp of a tile's rate at `samples` samples (a coarse pixel spans at most 16 samples; the rates beyond
    2x2 only with `extra`), as gbuf applies it to its ffx SRI (`Sri::clamped`, `Rate::fit`): the longer side halved
    until the rate is allowed (2x2 becomes 1x2 at 8x, everything 1x1 at 16x)."""
    def fit(code):
        w, h = 1 << (code >> 2), 1 << (code & 3)
        while True:
            if (w, h) == (4, 1):
                w = 2
            if (w, h) == (1, 4):
                h = 2
            if ((w * h <= 4 or extra) and w * h * max(samples, 1) <= 16) or (w, h) == (1, 1):
                return (w.bit_length() - 1) << 2 | (h.bit_length() - 1)
            if w >= h:
                w //= 2
            else:
                h //= 2
    out = sri.copy()
    for code in RATES:
        out[sri == code] = fit(code)
    return out


def explain(rgba, tile, wave, tx, ty):
    """AMD's per-coarse-pixel deltas (horizontal, vertical, range, raised by the neighbours' min and max), maxed
    over each wave of the thread group holding tile (tx, ty): what the classification compares with the cutoff."""
    import numpy as np
    lum = rgba[..., 0] * np.float32(0.30) + rgba[..., 1] * np.float32(0.59) + rgba[..., 2] * np.float32(0.11)
    t = 16 if tile == 32 else 8
    g = (tx // 2, ty // 2) if tile == 8 else (tx, ty)
    ox, oy = g[0] * 2 * t, g[1] * 2 * t
    pad = np.pad(lum, 4, mode="edge")  # coordinates clamped to the image
    h, w = lum.shape

    def stats(x, y):
        px = lambda a, b: pad[min(max(b, -4), h + 3) + 4, min(max(a, -4), w + 3) + 4]
        a, b, c, d = px(x, y), px(x + 1, y), px(x, y + 1), px(x + 1, y + 1)
        mn, mx = min(a, b, c, d), max(a, b, c, d)
        return np.array([max(abs(a - b), abs(c - d)), max(abs(a - c), abs(b - d)), mx - mn], np.float32), mn, mx

    rows = []
    for i in range(t * t):
        x, y = ox + 2 * (i % t), oy + 2 * (i // t)
        v, mn, mx = stats(x, y)
        n = [stats(x, y - 2), stats(x - 2, y), stats(x, y + 2), stats(x + 2, y)]
        dmin = max(np.float32(0), mn - min(s[1] for s in n))
        dmax = max(np.float32(0), max(s[2] for s in n) - mx)
        rows.append(np.maximum(v + dmin + dmax, 0))
    rows = np.array(rows)
    return [rows[k:k + wave].max(0) for k in range(0, t * t, wave)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ffx-src", type=Path, help="FidelityFX SDK 1.1.x: a checkout, or a git directory read at "
                    f"--ffx-ref (default: git clone {SDK_URL} --branch {SDK_REF} into the work folder)")
    ap.add_argument("--ffx-ref", default=SDK_REF, help=f"the SDK revision to read from a git directory ({SDK_REF})")
    ap.add_argument("--gbuf", default=str(ROOT / "target/release/gbuf"), help="gbuf's binary (target/release/gbuf)")
    ap.add_argument("--work", type=Path, default=Path("/tmp/ffx"), help="outputs and scratch (/tmp/ffx)")
    ap.add_argument("--tiles", default="8,16,32", help="tile sizes (8,16,32)")
    ap.add_argument("--waves", default="", help="subgroup sizes to run, as lavapipe's vector width 32·W bits "
                    "(LP_NATIVE_VECTOR_WIDTH): 4, 8, 16 on a CPU with AVX-512; default: lavapipe's own")
    ap.add_argument("--gbuf-wave", type=int, help="a different --ffx-wave for gbuf (a control: tiles then differ)")
    ap.add_argument("--lang", default="glsl", help="AMD's passes: glsl (Vulkan backend), hlsl (DX12 backend)")
    ap.add_argument("--frame", action="append", default=[], type=Path, help="another dump (any gbuf reads)")
    ap.add_argument("--room", metavar="WxH", help="also a `gbuf scene room` frame of this size (e.g. 1280x720)")
    ap.add_argument("--rates", default="base", help="AMD's builds of the pass: base (1x1 to 2x2), extra (the "
                    "additional rates to 4x4, against `gbuf vrs --extra-rates`), or base,extra")
    ap.add_argument("--show", type=int, default=5, help="differing tiles to explain per frame and tile size")
    args = ap.parse_args()
    t0 = time.time()
    icds = prerequisites(args)
    tiles = [int(t) for t in args.tiles.split(",")]
    langs = args.lang.split(",")
    extras = [{"base": False, "extra": True}.get(r) for r in args.rates.split(",")]
    if any(t not in (8, 16, 32) for t in tiles) or any(lang not in PASS for lang in langs) or None in extras:
        say("--tiles: 8, 16, 32; --lang: glsl, hlsl; --rates: base, extra")
        sys.exit(2)
    work = args.work.resolve()
    work.mkdir(parents=True, exist_ok=True)
    import numpy as np

    src, described = ffx_source(args, work)
    say(f"AMD's source: {described}")
    spv = compile_shaders(src, work, langs, tiles, extras)
    harness = work / "vrs_dispatch"
    run(["gcc", "-O1", "-Wall", "-o", str(harness), str(HERE / "vrs_dispatch.c"), "-lvulkan"], what="gcc")
    env = dict(os.environ, VK_ICD_FILENAMES=":".join(icds), VK_DRIVER_FILES=":".join(icds))
    waves = [int(w) for w in args.waves.split(",")] if args.waves else [None]

    frames = [(n, f, a) for n, f, a in FRAMES]
    frames += [(f.stem, f, []) for f in args.frame]
    if args.room:
        w, h = args.room.lower().split("x")
        room = work / f"room_{w}x{h}.exr"
        if not room.exists():
            run([args.gbuf, "scene", "room", "-o", str(room), "--width", w, "--height", h, "--msaa", "1"],
                what="gbuf scene")
        frames.append((f"room_{w}x{h}", room, []))
    if subprocess.run(["/usr/bin/python3", "-c", "import renderdoc"], capture_output=True).returncode != 0:
        say("engine_4x.rdc: skipped (gbuf replays it with RenderDoc: apt-get install renderdoccmd python3-renderdoc)")
        frames = [f for f in frames if f[0] != "engine_4x"]

    table, differs = [], False
    for wave in waves:
        wenv = dict(env, LP_NATIVE_VECTOR_WIDTH=str(32 * wave)) if wave else env
        dev = device_info(harness, wenv)
        if wave and not int(dev["minSubgroupSize"]) <= wave <= int(dev["maxSubgroupSize"]):
            say(f"wave {wave}: {dev['device']} offers subgroups of {dev['minSubgroupSize']} to "
                f"{dev['maxSubgroupSize']} lanes: skipped")
            continue
        # Always required explicitly: lavapipe left to itself reduces over 4 lanes while reporting 8.
        wave = wave or int(dev["subgroupSize"])
        say(f"device: {dev['device']}, subgroups of {wave} lanes required")
        # Lavapipe fills a subgroup along x only: a group 8 threads wide (tiles 8 and 16; every tile of the build
        # with the additional rates) reduces over min(W, 8).
        for ext in extras:
            lanes = {tile: min(wave, 16 if tile == 32 and not ext else 8) for tile in tiles}
            rates = "extra" if ext else "base"
            for name, path, extra in frames:
                for used in sorted(set(lanes.values())):
                    sub = [t for t in tiles if lanes[t] == used]
                    gwave = args.gbuf_wave or used
                    out = work / name / f"lanes{wave}_{used}_gbuf{gwave}{'_extra' if ext else ''}"
                    p = run([args.gbuf, "vrs", str(path), "--tile", ",".join(map(str, sub)), "--no-flip",
                             "--ffx-wave", str(gwave), "--out", str(out), *(["--extra-rates"] if ext else []), *extra],
                            what=f"gbuf vrs {name}")
                    samples = int(re.search(r"(\d+)×(\d+)×(\d+)", p.stdout).group(3))
                    rgba = read_exr_rgba(out / "full_rate.exr")
                    h, w = rgba.shape[:2]
                    colour = out / "full_rate.rgba32f"
                    rgba.tofile(colour)
                    for tile, lang in ((t, la) for t in sub for la in langs):
                        ours = read_dds_r8(out / f"sri_ffx_{tile}.dds")
                        amd_path = out / f"sri_amd_{lang}_{tile}.u8"
                        run([str(harness), str(spv[lang, tile, ext]), ENTRY[lang], str(colour), str(w), str(h),
                             str(tile), str(CUTOFF), str(MOTION_FACTOR), str(amd_path), BINDINGS[lang], str(wave),
                             SRI_FORMAT[lang], str(int(ext))],
                            env=wenv, what=f"vrs_dispatch {name} tile {tile} {lang} {rates}")
                        amd = np.fromfile(amd_path, np.uint8).reshape(ours.shape)
                        if (amd == 255).any():
                            say(f"{name} tile {tile}: AMD's pass left {(amd == 255).sum()} texels unwritten")
                            sys.exit(3)
                        amd = clamp_to_samples(amd, samples, ext)
                        same = int((amd == ours).sum())
                        hist = " ".join(f"{RATES[v]} {int((amd == v).sum())}" for v in sorted(RATES)
                                        if (amd == v).any())
                        table.append((name, f"{w}x{h}x{samples}", f"{wave}/{used}/{gwave}", tile, lang, rates,
                                      ours.size, same, hist))
                        if same == ours.size:
                            continue
                        differs = True
                        bad = np.argwhere(amd != ours)
                        say(f"{name} tile {tile} ({lang}, {rates} rates, {used} lanes, gbuf --ffx-wave {gwave}): "
                            f"{len(bad)} tiles differ; the first {min(args.show, len(bad))}:")
                        for ty, tx in bad[:args.show]:
                            why = ""
                            if not ext:
                                per_wave = explain(rgba, tile, used, int(tx), int(ty))
                                why = (f"; per-wave max (dx, dy, range) of its group, cutoff {CUTOFF}: "
                                       + "; ".join(f"({d[0]:.6g}, {d[1]:.6g}, {d[2]:.6g})" for d in per_wave))
                            say(f"  tile ({tx},{ty}): gbuf {RATES.get(ours[ty, tx], ours[ty, tx])}, AMD "
                                f"{RATES.get(amd[ty, tx], amd[ty, tx])}{why}")
    say("")
    say("lanes: the subgroup size required / the lanes each reduction spans / gbuf's --ffx-wave")
    say(f"{'frame':<14} {'size':<12} {'lanes':>8} {'tile':>4} {'pass':<5} {'rates':<5} {'tiles':>6} "
        f"{'identical':>9} {'%':>7}  AMD's rates")
    for name, size, wave, tile, lang, rates, n, same, hist in table:
        say(f"{name:<14} {size:<12} {wave:>8} {tile:>4} {lang:<5} {rates:<5} {n:>6} {same:>9} "
            f"{100.0 * same / n:>6.2f}%  {hist}")
    total, same = sum(r[6] for r in table), sum(r[7] for r in table)
    say(f"total: {same} of {total} tiles identical; {time.time() - t0:.1f} s")
    sys.exit(1 if differs else 0)


if __name__ == "__main__":
    main()
