#!/usr/bin/env python3
"""Inputs for the gbuf vs ISPC `deferred` peer measurement, in the example's .bin format.

The format, as examples/cpu/deferred/common.cpp (CreateInputDataFromFile) reads it, little-endian:
  header (152 bytes, the struct InputHeader of kernels.ispc, read with one fread):
    float cameraProj[4][4]      D3D row-vector form: [0][0] x scale, [1][1] y scale, [2][2] = f/(f-n), [2][3] = 1,
                                [3][2] = -n*f/(f-n)
    float cameraNear, cameraFar
    int32 framebufferWidth, framebufferHeight, numLights, inputDataChunkSize
    int32 inputDataArrayOffsets[16]   byte offsets into the chunk, in deferred.h's enum order:
       zBuffer (f32, post-projection z, 1 = sky), normalEncoded_x, normalEncoded_y (f16 spheremap),
       specularAmount, specularPower (f16), albedo_x, _y, _z (u8), then per light (f32):
       lightPositionView_x, _y, _z (left-handed view space, +z forward), lightAttenuationBegin,
       lightColor_x, _y, _z, lightAttenuationEnd
  chunk (inputDataChunkSize bytes, read with one fread into 64-byte aligned memory).
The serial C++ culls MAX_LIGHTS = 1024 light slots whatever numLights says, so every file here holds 1024 slots
(unused ones zero: attenuation end 0 culls them). The shading decodes normals as
  f = (x - x^2) + (y - y^2), m = sqrt(4f - 1), n = (m(4x - 2), m(4y - 2), 3 - 8f).

Subcommands:
  info FILE.bin                         print the header and light statistics
  rescale IN.bin OUT.bin --range S [--color C]
                                        multiply every light's attenuation begin/end by S (and colour by C): how the
                                        dense frames are made from `gbuf scene room --msaa 1 --lights 1024 -o X.bin`
  from-exr EXR OUT.bin [--width W --height H | --native] [--lights N --range R --seed S]
                                        a real renderer's G-buffer (the Blender Cycles fixture of gbuf,
                                        fixtures/blender_gbuffer.exr + .json, 128x96, 1 ray per pixel centre) cropped
                                        to W:H and upsampled (1/z and normals bilinear inside one object, nearest at
                                        object edges; default 1280x720), with N point lights scattered over the
                                        visible surfaces. --native (or W x H equal to the EXR's size) takes every
                                        pixel as it is, no crop or resampling: for an EXR rendered at the target size
                                        (fixtures/scripts/blender_gbuffer.py --width 1280 --height 720, as
                                        blender_native.sh does). The lights follow the same rule either way.
Needs numpy; from-exr also the `OpenEXR` module (pip install numpy openexr).
"""
import argparse
import json
import math
import struct
import sys

import numpy as np

HEADER = struct.Struct("<16f2f4i16i")
assert HEADER.size == 152
SLOTS = 1024
PIXEL_ARRAYS = [("zBuffer", "<f4"), ("normalEncoded_x", "<f2"), ("normalEncoded_y", "<f2"),
                ("specularAmount", "<f2"), ("specularPower", "<f2"), ("albedo_x", "u1"), ("albedo_y", "u1"),
                ("albedo_z", "u1")]
LIGHT_ARRAYS = ["lightPositionView_x", "lightPositionView_y", "lightPositionView_z", "lightAttenuationBegin",
                "lightColor_x", "lightColor_y", "lightColor_z", "lightAttenuationEnd"]


def read_bin(path):
    b = open(path, "rb").read()
    v = HEADER.unpack_from(b, 0)
    h = {"proj": np.array(v[0:16], np.float32).reshape(4, 4), "near": v[16], "far": v[17], "width": v[18],
         "height": v[19], "num_lights": v[20], "chunk": v[21], "offsets": list(v[22:38])}
    chunk = b[152:152 + h["chunk"]]
    assert len(chunk) == h["chunk"], "truncated"
    n = h["width"] * h["height"]
    arrays = {}
    for k, (name, dt) in enumerate(PIXEL_ARRAYS):
        arrays[name] = np.frombuffer(chunk, dt, n, h["offsets"][k]).copy()
    for k, name in enumerate(LIGHT_ARRAYS):
        # The C++ reads all 1024 slots; a file with fewer must still hold them inside the chunk to be safe.
        avail = min(SLOTS, (h["chunk"] - h["offsets"][8 + k]) // 4)
        arrays[name] = np.frombuffer(chunk, "<f4", avail, h["offsets"][8 + k]).copy()
    return h, arrays


def write_bin(path, proj, near, far, width, height, arrays, num_lights):
    n = width * height
    offsets, parts, size = [], [], 0
    align = lambda x: (x + 63) // 64 * 64
    for name, dt in PIXEL_ARRAYS:
        a = np.ascontiguousarray(arrays[name], dtype=dt)
        assert a.size == n, name
        offsets.append(size)
        parts.append((size, a.tobytes()))
        size = align(size + a.nbytes)
    for name in LIGHT_ARRAYS:
        a = np.zeros(SLOTS, "<f4")
        src = np.asarray(arrays[name], np.float32)[:SLOTS]
        a[:src.size] = src
        offsets.append(size)
        parts.append((size, a.tobytes()))
        size = align(size + a.nbytes)
    chunk = bytearray(size)
    for at, data in parts:
        chunk[at:at + len(data)] = data
    head = HEADER.pack(*[float(x) for x in np.asarray(proj, np.float32).reshape(16)], float(near), float(far),
                       width, height, num_lights, size, *offsets)
    with open(path, "wb") as f:
        f.write(head)
        f.write(chunk)


def cmd_info(a):
    h, arr = read_bin(a.file)
    z = arr["zBuffer"]
    sky = np.mean(z >= 1.0)
    nl = h["num_lights"]
    end = arr["lightAttenuationEnd"][:nl]
    print(f"{a.file}: {h['width']}x{h['height']}, {nl} lights, chunk {h['chunk']} B, sky {100 * sky:.1f}%")
    print(f"  proj diag {np.diag(h['proj'])}, [3][2] {h['proj'][3][2]:.5g}, near {h['near']:.4g}, far {h['far']:.4g}")
    if nl:
        print(f"  attenuation end min/median/max {end.min():.4g}/{np.median(end):.4g}/{end.max():.4g}; "
              f"colour max {max(arr['lightColor_' + c][:nl].max() for c in 'xyz'):.4g}")


def cmd_rescale(a):
    h, arr = read_bin(a.inp)
    for name in ("lightAttenuationBegin", "lightAttenuationEnd"):
        arr[name] = arr[name] * np.float32(a.range)
    for c in "xyz":
        arr["lightColor_" + c] = arr["lightColor_" + c] * np.float32(a.color)
    write_bin(a.out, h["proj"], h["near"], h["far"], h["width"], h["height"], arr, h["num_lights"])


def encode_spheremap(n):
    """n in the file's left-handed view space (+z away from the eye; visible surfaces have n.z < 0)."""
    d = np.sqrt(np.maximum(8.0 - 8.0 * n[..., 2], 1e-12))  # the example's decode gives z = 3 - 8f = ... (see below)
    return n[..., 0] / d + 0.5, n[..., 1] / d + 0.5


def decode_spheremap(x, y):
    f = (x - x * x) + (y - y * y)
    m = np.sqrt(np.maximum(4 * f - 1, 0))
    return np.stack([m * (4 * x - 2), m * (4 * y - 2), 3 - 8 * f], -1)


def cmd_from_exr(a):
    import OpenEXR
    side = json.load(open(a.exr.rsplit(".", 1)[0] + ".json"))
    cam = side["camera"]
    part = OpenEXR.File(a.exr).parts[0]
    ch = {k.split(".", 1)[1]: v.pixels for k, v in part.channels.items()}
    H0, W0 = ch["Depth.Z"].shape
    depth = ch["Depth.Z"].astype(np.float64)            # planar view depth (Cycles 3.4), 1e10 on the sky
    wv = np.array(cam["world_to_view"], np.float64)
    nw = np.stack([ch["Normal.X"], ch["Normal.Y"], ch["Normal.Z"]], -1).astype(np.float64)
    nv = nw @ wv[:3, :3].T                               # world -> our right-handed view space (-z forward)
    metal = ch["Metallic.X"].astype(np.float64)[..., None]
    # Cycles' DiffCol is 0 on metals (the gold cube): take their GlossCol as the demo's single albedo instead.
    alb = np.clip(ch["DiffCol"].astype(np.float64) + metal * ch["GlossCol"].astype(np.float64), 0, 1)
    gloss = np.clip(ch["GlossCol"].astype(np.float64).mean(-1), 0, 1)
    rough = ch["Roughness.X"].astype(np.float64)
    obj = ch["IndexOB.X"].astype(np.int64)
    covered = (depth > 0) & (depth < 1e9) & np.isfinite(depth)

    tan_y0 = math.tan(cam["yfov"] / 2)
    tan_x0 = tan_y0 * cam["aspect"]
    native = a.native or (a.width, a.height) == (W0, H0)
    if native:
        if (a.width or W0, a.height or H0) != (W0, H0):
            sys.exit(f"from-exr --native: the EXR is {W0}x{H0}, not {a.width or W0}x{a.height or H0}")
        if abs(cam["aspect"] - W0 / H0) > 1e-6:
            sys.exit(f"from-exr --native: the sidecar's aspect {cam['aspect']} is not the EXR's {W0}x{H0}")
        W, H = W0, H0
        tan_x, tan_y = tan_x0, tan_y0
        cov = covered
        vz = np.where(covered, depth, 0.0)
        n = nv / np.maximum(np.linalg.norm(nv, axis=-1, keepdims=True), 1e-12)
        albedo, spec = alb, gloss
        r = np.clip(rough, 0.05, 1.0)
        how = "native, no resampling"
    else:
        W, H = a.width or 1280, a.height or 720
        W, H, tan_x, tan_y, cov, vz, n, albedo, spec, r, how = resample(
            W, H, W0, H0, tan_x0, tan_y0, covered, depth, nv, alb, gloss, rough, obj)
    power = np.clip(2.0 / r ** 4 - 2.0, 1.0, 2048.0)          # inverse of gbuf's roughness = (2/(p+2))^(1/4)
    write_from_gbuffer(a, W, H, W0, H0, tan_x, tan_y, cam, cov, vz, n, albedo, spec, power, how)


def resample(W, H, W0, H0, tan_x0, tan_y0, covered, depth, nv, alb, gloss, rough, obj):
    """Crops the source to W:H (keeping the horizontal field of view) and upsamples it to W x H."""
    # Crop rows (or columns) of the source to the target aspect, keeping the horizontal field of view.
    rows = W0 * H / W                                    # source rows that keep the pixel aspect
    if rows <= H0:
        y0, h_src, x0, w_src = (H0 - rows) / 2, rows, 0.0, float(W0)
    else:
        cols = H0 * W / H
        y0, h_src, x0, w_src = 0.0, float(H0), (W0 - cols) / 2, cols
    tan_x = tan_x0 * w_src / W0
    tan_y = tan_y0 * h_src / H0

    # Output pixel centres in source pixel coordinates.
    sx = x0 + (np.arange(W) + 0.5) * w_src / W - 0.5
    sy = y0 + (np.arange(H) + 0.5) * h_src / H - 0.5
    X, Y = np.meshgrid(sx, sy)
    ix = np.clip(np.floor(X).astype(int), 0, W0 - 2)
    iy = np.clip(np.floor(Y).astype(int), 0, H0 - 2)
    fx = np.clip(X - ix, 0, 1)
    fy = np.clip(Y - iy, 0, 1)
    nx = np.clip(np.rint(X).astype(int), 0, W0 - 1)
    ny = np.clip(np.rint(Y).astype(int), 0, H0 - 1)
    corners = [(iy, ix, (1 - fx) * (1 - fy)), (iy, ix + 1, fx * (1 - fy)), (iy + 1, ix, (1 - fx) * fy),
               (iy + 1, ix + 1, fx * fy)]
    same = np.ones((H, W), bool)
    for (cy, cx, _) in corners:
        same &= covered[cy, cx] & (obj[cy, cx] == obj[ny, nx])
    cov = covered[ny, nx]

    def interp(img):
        near_v = img[ny, nx]
        bil = sum(w[..., None] * img[cy, cx] if img.ndim == 3 else w * img[cy, cx] for cy, cx, w in corners)
        m = same if img.ndim == 2 else same[..., None]
        return np.where(m, bil, near_v)

    inv_z = interp(np.where(covered, 1.0 / np.where(covered, depth, 1.0), 0.0))
    vz = np.where(cov, 1.0 / np.maximum(inv_z, 1e-12), 0.0)     # planar depth, exact on planes
    n = interp(nv)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    albedo = interp(alb)
    spec = interp(gloss)
    r = np.clip(interp(rough), 0.05, 1.0)
    how = f"rows {y0:.1f}+{h_src:.1f}, cols {x0:.1f}+{w_src:.1f}"
    return W, H, tan_x, tan_y, cov, vz, n, albedo, spec, r, how


def write_from_gbuffer(a, W, H, W0, H0, tan_x, tan_y, cam, cov, vz, n, albedo, spec, power, how):
    """The .bin of a W x H view-space G-buffer (right-handed, -z forward) plus the scattered lights."""
    near, far = cam["znear"], cam["zfar"]
    proj = np.zeros((4, 4), np.float32)
    proj[0, 0], proj[1, 1] = 1 / tan_x, 1 / tan_y
    proj[2, 2], proj[2, 3], proj[3, 2] = far / (far - near), 1.0, -near * far / (far - near)
    z = np.where(cov, proj[2, 2] + proj[3, 2] / np.where(cov, vz, 1.0), 1.0).astype(np.float32)

    # File view space is left-handed (+z forward): negate z of normals (and of positions below).
    n_file = n * np.array([1, 1, -1.0])
    ex, ey = encode_spheremap(n_file)
    back = decode_spheremap(ex, ey)
    err = np.linalg.norm(back - n_file, axis=-1)[cov]
    assert err.max() < 1e-4, f"spheremap round trip error {err.max()}"

    arrays = {
        "zBuffer": z,
        "normalEncoded_x": np.where(cov, ex, 0).astype("<f2"),
        "normalEncoded_y": np.where(cov, ey, 0).astype("<f2"),
        "specularAmount": np.where(cov, spec, 0).astype("<f2"),
        "specularPower": np.where(cov, power, 0).astype("<f2"),
    }
    for k, c in enumerate("xyz"):
        arrays["albedo_" + c] = np.where(cov, np.rint(albedo[..., k] * 255), 0).astype("u1")

    # Lights: N point lights just above random visible surfaces (file view space), ranges R·(0.5..1.5).
    rng = np.random.default_rng(a.seed)
    ys, xs = np.nonzero(cov)
    pick = rng.integers(0, ys.size, a.lights)
    py, px = ys[pick], xs[pick]
    d = vz[py, px]
    sxn = (px + 0.5) * 2 / W - 1
    syn = -((py + 0.5) * 2 / H - 1)
    pos = np.stack([sxn * d / proj[0, 0], syn * d / proj[1, 1], d], -1)      # file view space (+z forward)
    pos = pos + n_file[py, px] * (a.range * 0.15)
    end = a.range * rng.uniform(0.5, 1.5, a.lights)
    begin = end * rng.uniform(0.0, 0.3, a.lights)
    col = rng.uniform(0.2, 1.0, (a.lights, 3)) * a.color
    for k, name in enumerate(["lightPositionView_x", "lightPositionView_y", "lightPositionView_z"]):
        arrays[name] = pos[:, k]
    arrays["lightAttenuationBegin"] = begin
    arrays["lightAttenuationEnd"] = end
    for k, c in enumerate("xyz"):
        arrays["lightColor_" + c] = col[:, k]
    write_bin(a.out, proj, near, far, W, H, arrays, a.lights)
    print(f"wrote {a.out}: {W}x{H} from {W0}x{H0} ({how}), "
          f"{100 * cov.mean():.1f}% covered, {a.lights} lights, range {a.range}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("info")
    s.add_argument("file")
    s = sub.add_parser("rescale")
    s.add_argument("inp")
    s.add_argument("out")
    s.add_argument("--range", type=float, required=True)
    s.add_argument("--color", type=float, default=1.0)
    s = sub.add_parser("from-exr")
    s.add_argument("exr")
    s.add_argument("out")
    s.add_argument("--width", type=int, help="default 1280 (the EXR's width with --native)")
    s.add_argument("--height", type=int, help="default 720 (the EXR's height with --native)")
    s.add_argument("--native", action="store_true", help="the EXR's own pixels, no crop or resampling")
    s.add_argument("--lights", type=int, default=1024)
    s.add_argument("--range", type=float, default=0.5)
    s.add_argument("--color", type=float, default=0.6)
    s.add_argument("--seed", type=int, default=1)
    a = p.parse_args()
    {"info": cmd_info, "rescale": cmd_rescale, "from-exr": cmd_from_exr}[a.cmd](a)


if __name__ == "__main__":
    main()
