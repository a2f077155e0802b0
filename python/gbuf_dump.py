"""Write gbuf's canonical G-buffer EXR from Python (numpy + the OpenEXR package, no build step).

    pip install openexr numpy        # OpenEXR 3.x Python bindings

    from gbuf_dump import write_canonical
    write_canonical("frame.exr", {"coverage": cov, "depth": d, "normal": n, "albedo": a},
                    camera={"world_to_view": w2v, "yfov": 0.9, "aspect": W / H, "znear": 0.1, "zfar": 100.0},
                    lights=[{"type": "point", "position": [0, 1, -3], "intensity": 5.0}])

The file is docs/FORMAT.md's "Canonical EXR" (`gbuf.format = gbuf-canonical`, version 1), what `gbuf scene`
and `gbuf convert` write and what `src/io/canonical.rs` reads: one scan-line part, ZIP, one channel
`s<i>.<attribute>.<component>` per sample and component (`s2.normal.X`), floats as 32-bit float, IDs and
coverage as 32-bit uint, and the text header attributes `gbuf.format`, `gbuf.version`, `gbuf.samples`,
`gbuf.sample_positions` (JSON, optional) and `gbuf.camera` (JSON, optional). Lights go to the sidecar
`<path stem>.json` beside it.

Command line: `python3 gbuf_dump.py --selftest OUT_DIR` writes a deterministic test frame (see `selftest`).
"""

import json
import math
import os
import secrets

import numpy as np

__all__ = ["write_canonical", "ATTRIBUTES", "selftest_frame", "selftest"]

FORMAT_NAME = "gbuf-canonical"
VERSION = 1
MAX_SAMPLES = 64

# gbuf attribute name -> (channel component suffixes, kind). Order = gbuf's `Attribute::ALL`.
ATTRIBUTES = {
    "depth": (("Z",), "float"),
    "position": (("X", "Y", "Z"), "float"),
    "normal": (("X", "Y", "Z"), "float"),
    "albedo": (("R", "G", "B"), "float"),
    "specular": (("V",), "float"),
    "specular_power": (("V",), "float"),
    "roughness": (("V",), "float"),
    "metallic": (("V",), "float"),
    "material_id": (("ID",), "id"),
    "object_id": (("ID",), "id"),
    "primitive_id": (("ID",), "id"),
    "motion": (("X", "Y"), "float"),
}
COVERAGE = "coverage"

_CAMERA_KEYS = {"world_to_view", "yfov", "aspect", "znear", "zfar", "principal_point", "intrinsics"}
_LIGHT_TYPES = {"point", "spot", "directional", "hemisphere"}
_LIGHT_VEC3 = ("position", "direction", "color", "ground")
_LIGHT_SCALARS = ("intensity", "range", "begin", "inner_cone_angle", "outer_cone_angle")
_LIGHT_KEYS = {"type", "name", *_LIGHT_VEC3, *_LIGHT_SCALARS}
_MAX_LIGHTS = 1 << 16
# gbuf refuses a sidecar camera whose aspect is more than this far (relative) from width / height.
_ASPECT_TOLERANCE = 0.01


def _channel(sample, layer, comp):
    return f"s{sample}.{layer}.{comp}"


def _f32(x, what):
    """A number as the Python float that prints as the shortest decimal reading back to the same float32."""
    try:
        v = np.float32(x)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: {x!r} is not a number") from None
    if isinstance(x, (bool, np.bool_)) or not np.isfinite(v):
        raise ValueError(f"{what}: {x!r} is not a finite number")
    s = str(v)  # numpy prints float32 in its shortest round-trip form
    out = float(s)
    if np.float32(out) != v:  # never expected; fall back to the exact value
        out = float(v)
    return out


def _floats(x, n, what):
    try:
        seq = list(x)
    except TypeError:
        raise ValueError(f"{what}: expected {n} numbers, got {x!r}") from None
    if len(seq) != n:
        raise ValueError(f"{what}: expected {n} numbers, got {len(seq)}")
    return [_f32(v, f"{what}[{i}]") for i, v in enumerate(seq)]


def _check_samples(samples):
    """Validates `samples`; returns (H, W, S, coverage bool (H, W, S), {name: (H, W, S, C) array to write})."""
    if not isinstance(samples, dict):
        raise ValueError(f"samples must be a dict of attribute name -> numpy array, got {type(samples).__name__}")
    unknown = [k for k in samples if k != COVERAGE and k not in ATTRIBUTES]
    if unknown:
        raise ValueError(
            f"unknown attribute(s) {', '.join(map(repr, unknown))}: gbuf knows {COVERAGE!r}, "
            + ", ".join(map(repr, ATTRIBUTES))
        )
    if COVERAGE not in samples:
        raise ValueError(f"{COVERAGE!r} is required: a (H, W, S) bool array, True where a surface was hit")

    def shaped(name, ncomp):
        a = np.asarray(samples[name])
        if a.ndim == 3 and ncomp == 1:
            a = a[..., None]
        if a.ndim != 4:
            want = "(H, W, S) or (H, W, S, 1)" if ncomp == 1 else f"(H, W, S, {ncomp})"
            raise ValueError(f"{name}: shape {a.shape}, expected {want}")
        if a.shape[3] != ncomp:
            raise ValueError(f"{name}: {a.shape[3]} components (shape {a.shape}), expected {ncomp}")
        return a

    cov = shaped(COVERAGE, 1)
    h, w, s = cov.shape[:3]
    if h < 1 or w < 1:
        raise ValueError(f"{COVERAGE}: empty image, shape {cov.shape}")
    if not 1 <= s <= MAX_SAMPLES:
        raise ValueError(f"{COVERAGE}: {s} samples per pixel, gbuf reads 1..={MAX_SAMPLES}")
    if cov.dtype != np.bool_:
        if not np.issubdtype(cov.dtype, np.integer) or not np.isin(cov, (0, 1)).all():
            raise ValueError(f"{COVERAGE}: dtype {cov.dtype}, expected bool (or integers 0 and 1)")
    cov = cov[..., 0].astype(bool)

    out = {}
    for name, (comps, kind) in ATTRIBUTES.items():
        if name not in samples:
            continue
        a = shaped(name, len(comps))
        if a.shape[:3] != (h, w, s):
            raise ValueError(
                f"{name}: shape {a.shape} does not match coverage's (H, W, S) = {(h, w, s)}"
            )
        if kind == "id":
            if not np.issubdtype(a.dtype, np.integer) or a.dtype == np.bool_:
                raise ValueError(
                    f"{name}: dtype {a.dtype}, IDs must be an integer array (float IDs round above 2^24)"
                )
            if a.size and int(a.min()) < 0:
                raise ValueError(f"{name}: negative ID {int(a.min())}; IDs must be in 0..2^32-1")
            if a.size and int(a.max()) > 0xFFFFFFFF:
                raise ValueError(f"{name}: ID {int(a.max())} does not fit in 32 bits (max 2^32-1)")
            a = a.astype(np.uint32)
        else:
            if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)) or a.dtype == np.bool_:
                raise ValueError(f"{name}: dtype {a.dtype}, expected a float array (float32 is stored exactly)")
            a = a.astype(np.float32)
        # Background samples: every value 0 (docs/FORMAT.md).
        out[name] = np.where(cov[..., None], a, a.dtype.type(0))
    return h, w, s, cov, out


def _check_positions(sample_positions, s):
    if sample_positions is None:
        k = round(math.sqrt(s))
        if s not in (1, 2, 4, 8, 16) and k * k != s:
            raise ValueError(
                f"sample_positions: required for {s} samples per pixel (gbuf assumes a pattern only for "
                "1, 2, 4, 8, 16 samples and square counts)"
            )
        return None
    try:
        pos = [list(p) for p in sample_positions]
    except TypeError:
        raise ValueError("sample_positions: expected a list of (x, y) pairs") from None
    if len(pos) != s:
        raise ValueError(f"sample_positions: {len(pos)} positions for {s} samples per pixel")
    out = []
    for i, p in enumerate(pos):
        xy = _floats(p, 2, f"sample_positions[{i}]")
        if abs(xy[0]) > 0.5 or abs(xy[1]) > 0.5:
            raise ValueError(f"sample_positions[{i}] = {xy}: offsets must lie within ±0.5 pixel of the centre")
        out.append(xy)
    return out


def _check_camera(camera, w, h):
    """The camera as gbuf's header JSON wants it (`SidecarCamera`; intrinsics resolved for this image)."""
    if not isinstance(camera, dict):
        raise ValueError(f"camera must be a dict, got {type(camera).__name__}")
    unknown = set(camera) - _CAMERA_KEYS
    if unknown:
        raise ValueError(f"camera: unknown field(s) {sorted(unknown)}; known: {sorted(_CAMERA_KEYS)}")
    for k in ("world_to_view", "znear", "zfar"):
        if k not in camera:
            raise ValueError(f"camera: {k!r} is required")
    try:
        rows = [list(r) for r in camera["world_to_view"]]
    except TypeError:
        raise ValueError("camera.world_to_view: expected 4 rows of 4 numbers (row-major)") from None
    if len(rows) != 4:
        raise ValueError(f"camera.world_to_view: {len(rows)} rows, expected 4 (row-major 4x4)")
    m = [_floats(r, 4, f"camera.world_to_view[{i}]") for i, r in enumerate(rows)]
    if abs(np.linalg.det(np.array(m, dtype=np.float64))) <= 1e-12:
        raise ValueError("camera.world_to_view: the matrix is not invertible")
    cam = {"world_to_view": m}
    if camera.get("intrinsics") is not None:
        # The canonical header has no `intrinsics` (the reader ignores them there): resolve them for this image,
        # as gbuf does for a sidecar (SidecarCamera::to_camera_for).
        fx, fy, cx, cy = _floats(camera["intrinsics"], 4, "camera.intrinsics")
        if fx <= 0 or fy <= 0:
            raise ValueError("camera.intrinsics: fx and fy must be > 0")
        cam["yfov"] = _f32(2.0 * math.atan(0.5 * h / fy), "camera.yfov")
        cam["aspect"] = _f32((w / fx) / (h / fy), "camera.aspect")
        principal = [(cx - 0.5 * w) / (0.5 * w), -(cy - 0.5 * h) / (0.5 * h)]
    else:
        for k in ("yfov", "aspect"):
            if k not in camera:
                raise ValueError(f"camera: {k!r} is required (or give intrinsics)")
        cam["yfov"] = _f32(camera["yfov"], "camera.yfov")
        cam["aspect"] = _f32(camera["aspect"], "camera.aspect")
        principal = camera.get("principal_point")
    cam["znear"] = _f32(camera["znear"], "camera.znear")
    cam["zfar"] = _f32(camera["zfar"], "camera.zfar")
    if not 0.0 < cam["yfov"] < math.pi:
        raise ValueError(f"camera.yfov = {cam['yfov']}: must be in (0, π) radians")
    if not cam["aspect"] > 0.0:
        raise ValueError(f"camera.aspect = {cam['aspect']}: must be > 0")
    image_aspect = w / h
    if abs(cam["aspect"] / image_aspect - 1.0) > _ASPECT_TOLERANCE:
        raise ValueError(
            f"camera.aspect = {cam['aspect']} does not match the image ({w}×{h} pixels, aspect {image_aspect:.4f})"
        )
    if not 0.0 < cam["znear"] < cam["zfar"]:
        raise ValueError(f"camera: need 0 < znear < zfar, got znear {cam['znear']}, zfar {cam['zfar']}")
    if principal is not None:
        pp = _floats(principal, 2, "camera.principal_point")
        if pp != [0.0, 0.0]:
            cam["principal_point"] = pp
    return cam


def _check_lights(lights, camera):
    """The sidecar document for `lights` (a list → view space; or {"lights": [...], "lights_space": ...})."""
    if isinstance(lights, dict):
        unknown = set(lights) - {"lights", "lights_space"}
        if unknown or "lights_space" not in lights or "lights" not in lights:
            raise ValueError(
                "lights: give a list of light dicts (view space), or a dict with exactly "
                "'lights' and 'lights_space' ('view' or 'world')"
            )
        space, items = lights["lights_space"], lights["lights"]
    else:
        space, items = "view", lights
    if space not in ("view", "world"):
        raise ValueError(f"lights_space {space!r}: expected 'view' or 'world'")
    if space == "world" and camera is None:
        raise ValueError("lights: world-space lights need the camera (pass camera=...)")
    try:
        items = list(items)
    except TypeError:
        raise ValueError("lights: expected a list of light dicts") from None
    if len(items) > _MAX_LIGHTS:
        raise ValueError(f"lights: {len(items)} lights, more than the {_MAX_LIGHTS} a sidecar may hold")
    out = []
    for i, l in enumerate(items):
        what = f"lights[{i}]"
        if not isinstance(l, dict):
            raise ValueError(f"{what}: expected a dict, got {type(l).__name__}")
        unknown = set(l) - _LIGHT_KEYS
        if unknown:
            raise ValueError(f"{what}: unknown field(s) {sorted(unknown)}; known: {sorted(_LIGHT_KEYS)}")
        kind = l.get("type")
        if kind not in _LIGHT_TYPES:
            raise ValueError(f"{what}: type {kind!r}, expected one of {sorted(_LIGHT_TYPES)}")
        d = {"type": kind}
        if "name" in l:
            d["name"] = str(l["name"])
        for k in _LIGHT_VEC3:
            if l.get(k) is not None:
                d[k] = _floats(l[k], 3, f"{what}.{k}")
        for k in _LIGHT_SCALARS:
            if l.get(k) is not None:
                d[k] = _f32(l[k], f"{what}.{k}")
        if kind in ("point", "spot") and "position" not in d:
            raise ValueError(f"{what}: a {kind} light needs 'position'")
        if kind in ("spot", "directional", "hemisphere"):
            if "direction" not in d:
                raise ValueError(f"{what}: a {kind} light needs 'direction'")
            if d["direction"] == [0.0, 0.0, 0.0]:
                raise ValueError(f"{what}: direction is zero")
        if "range" in d and d["range"] <= 0:
            raise ValueError(f"{what}: range must be > 0 (leave it out for unbounded)")
        if kind == "hemisphere" and "ground" in d and min(d["ground"]) < 0:
            raise ValueError(f"{what}: hemisphere ground colour must be ≥ 0")
        out.append(d)
    return {"lights": out, "lights_space": space}


def _reserve(path):
    """A new, empty temporary file beside `path` (same folder, so os.replace is atomic); created with the
    process's umask like any new file."""
    folder, name = os.path.split(os.path.abspath(path))
    for _ in range(100):
        tmp = os.path.join(folder, f".{name}.{os.getpid()}.{secrets.token_hex(6)}.tmp")
        try:
            os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
            return tmp
        except FileExistsError:
            continue
    raise OSError(f"could not create a temporary file beside {path}")


def _fsync(path):
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_canonical(path, samples, camera=None, sample_positions=None, lights=None):
    """Writes a multisampled G-buffer as gbuf's canonical EXR at `path`, atomically.

    samples: dict, gbuf attribute name -> numpy array of shape (H, W, S, C), row 0 = the top row, sample s of
        pixel (y, x) at [y, x, s]. Names and components C:
          coverage (required)                   1  bool, True = a surface was hit, False = background (sky);
                                                   shape (H, W, S) or (H, W, S, 1)
          depth                                 1  positive view depth (= -position.z)
          position                              3  view space X, Y, Z
          normal                                3  unit, view space (facing the camera: Z > 0)
          albedo                                3  linear RGB
          specular, specular_power, roughness, metallic   1
          motion                                2  screen-space motion in pixels
          material_id, object_id, primitive_id  1  integer arrays, 0 <= ID <= 2^32-1 (stored as uint32)
        One-component attributes may also be (H, W, S). Float attributes are stored as float32: float32 input is
        written bit for bit (NaN and ±Inf too; gbuf reports and replaces them when it loads), float64 is rounded
        to float32. View space is glTF/OpenGL's: +X right, +Y up, the camera looks along -Z.
        Background samples (coverage False) are written as 0 in every attribute, whatever the array holds there.
    camera: optional dict, the sidecar camera (src/io/sidecar.rs `SidecarCamera`): world_to_view (4 rows of 4,
        row-major), yfov (radians), aspect (= W / H, within 1%), znear, zfar, optional principal_point (NDC
        offset, +y up); or intrinsics [fx, fy, cx, cy] in pixels (+y down) instead of yfov / aspect, resolved
        here for this image because the canonical header stores yfov, aspect and principal_point. Written as
        the `gbuf.camera` header attribute.
    sample_positions: optional list of S (x, y) offsets from the pixel centre in pixels, +x right, +y down,
        within ±0.5. Written as `gbuf.sample_positions`. When omitted the attribute is left out and gbuf's
        reader assumes the standard D3D/Vulkan pattern for 1, 2, 4, 8 or 16 samples, or an ordered grid for
        square counts (and `gbuf info` warns `sample-positions-assumed` for S > 1); other counts need them.
    lights: optional list of glTF-style light dicts (KHR_lights_punctual fields: type point|spot|directional|
        hemisphere, position, direction, color, intensity, range, begin, inner_cone_angle, outer_cone_angle,
        ground; see docs/FORMAT.md), in view space; or a dict {"lights": [...], "lights_space": "view"|"world"}
        (world space needs `camera`). Written to the sidecar `<path without extension>.json`
        ({"lights": [...], "lights_space": ...}), which gbuf loads beside the EXR. Without lights no sidecar is
        written (an old one beside `path` would still be read by gbuf).

    Raises ValueError (naming the attribute and the problem) for bad input, before anything is written. The EXR
    (and sidecar) are written to temporary files in the same folder and renamed over the targets.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a file name, got {type(path).__name__}")
    path = os.fspath(path)
    h, w, s, cov, attrs = _check_samples(samples)
    positions = _check_positions(sample_positions, s)
    cam = None if camera is None else _check_camera(camera, w, h)
    sidecar = None if lights is None else _check_lights(lights, cam)
    sidecar_path = os.path.splitext(path)[0] + ".json"
    if sidecar is not None and os.path.abspath(sidecar_path) == os.path.abspath(path):
        raise ValueError(f"{path}: the EXR would be overwritten by its own sidecar; name the output .exr")
    if os.path.isdir(path):
        raise ValueError(f"{path}: is a directory")

    import OpenEXR  # here, so that validation works (and the module imports) without the package

    compact = {"separators": (",", ":"), "allow_nan": False}
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "gbuf.format": FORMAT_NAME,
        "gbuf.version": str(VERSION),
        "gbuf.samples": str(s),
    }
    if positions is not None:
        header["gbuf.sample_positions"] = json.dumps(positions, **compact)
    if cam is not None:
        header["gbuf.camera"] = json.dumps(cam, **compact)
    channels = {}
    for i in range(s):
        channels[_channel(i, COVERAGE, "V")] = np.ascontiguousarray(cov[:, :, i], dtype=np.uint32)
        for name, a in attrs.items():
            for c, comp in enumerate(ATTRIBUTES[name][0]):
                channels[_channel(i, name, comp)] = np.ascontiguousarray(a[:, :, i, c])

    written = []
    try:
        tmp = _reserve(path)
        written.append(tmp)
        OpenEXR.File(header, channels).write(tmp)
        _fsync(tmp)
        if sidecar is not None:
            stmp = _reserve(sidecar_path)
            written.append(stmp)
            with open(stmp, "w", encoding="utf-8") as f:
                json.dump(sidecar, f, indent=2, allow_nan=False)
                f.write("\n")
                f.flush()
                os.fsync(f.fileno())
            os.replace(stmp, sidecar_path)
            written.remove(stmp)
        os.replace(tmp, path)
        written.remove(tmp)
    finally:
        for t in written:
            try:
                os.remove(t)
            except OSError:
                pass


# --- self-test frame ------------------------------------------------------------------------------------------

# D3D's standard 4x MSAA positions, in 1/16 pixel (+y down): gbuf's own 4-sample pattern.
D3D_4X = [(-2, -6), (6, -2), (-6, 2), (2, 6)]


def selftest_frame(seed=20240611, width=17, height=9):
    """A deterministic 4-sample frame with every attribute: (samples, camera, sample_positions, lights).

    Geometry is consistent (positions on each sample's camera ray at its depth, depth = -position.z, unit normals
    facing the camera), so gbuf loads it without warnings; the other attributes are random. About 10% of the
    samples are background (all values 0 there). IDs span 0..2^32-1 and include 2^32-1.
    """
    rng = np.random.default_rng(seed)
    h, w, s = height, width, 4
    positions = [[x / 16.0, y / 16.0] for x, y in D3D_4X]
    camera = {
        "world_to_view": [[1.0, 0.0, 0.0, -0.5], [0.0, 1.0, 0.0, -1.5], [0.0, 0.0, 1.0, -6.0], [0.0, 0.0, 0.0, 1.0]],
        "yfov": 0.9,
        "aspect": w / h,
        "znear": 0.1,
        "zfar": 100.0,
    }
    cov = rng.random((h, w, s)) >= 0.1
    cov[0, 0, :] = False  # at least one background pixel, and one covered one
    cov[h - 1, w - 1, :] = True
    depth = rng.uniform(1.0, 50.0, (h, w, s)).astype(np.float32)
    # Each sample's camera ray (Camera::view_ray / Projector::project, principal point 0).
    px = np.arange(w)[None, :, None] + 0.5 + np.array([p[0] for p in positions])[None, None, :]
    py = np.arange(h)[:, None, None] + 0.5 + np.array([p[1] for p in positions])[None, None, :]
    t = math.tan(0.5 * np.float32(camera["yfov"]))
    aspect = float(np.float32(camera["aspect"]))
    ndc_x = px / w * 2.0 - 1.0
    ndc_y = 1.0 - py / h * 2.0
    d64 = depth.astype(np.float64)
    position = np.stack(
        np.broadcast_arrays(ndc_x * t * aspect * d64, ndc_y * t * d64, -d64), axis=-1
    ).astype(np.float32)
    depth = -position[..., 2]
    n = rng.normal(size=(h, w, s, 3))
    n[..., 2] = np.abs(n[..., 2]) + 0.2
    normal = (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)
    samples = {
        "coverage": cov,
        "depth": depth[..., None],
        "position": position,
        "normal": normal,
        "albedo": rng.random((h, w, s, 3), dtype=np.float32),
        "specular": rng.random((h, w, s, 1), dtype=np.float32),
        "specular_power": rng.uniform(1.0, 256.0, (h, w, s, 1)).astype(np.float32),
        "roughness": rng.random((h, w, s, 1), dtype=np.float32),
        "metallic": rng.random((h, w, s, 1), dtype=np.float32),
        "material_id": rng.integers(0, 2**32, (h, w, s, 1), dtype=np.uint64).astype(np.uint32),
        "object_id": rng.integers(0, 2**32, (h, w, s, 1), dtype=np.uint64).astype(np.uint32),
        "primitive_id": rng.integers(0, 2**32, (h, w, s, 1), dtype=np.uint64).astype(np.uint32),
        "motion": rng.normal(0.0, 3.0, (h, w, s, 2)).astype(np.float32),
    }
    for k in ("material_id", "object_id", "primitive_id"):
        samples[k][h - 1, w - 1, 0, 0] = 0xFFFFFFFF
        samples[k][h - 1, w - 1, 1, 0] = 0
    # Background samples hold 0 everywhere, so these arrays are exactly what the file holds.
    for k, a in samples.items():
        if k != "coverage":
            a[~cov] = 0
    lights = [
        {"type": "point", "position": [0.0, 1.0, -4.0], "color": [1.0, 0.9, 0.8], "intensity": 5.0, "range": 10.0},
        {"type": "directional", "direction": [0.0, -1.0, -1.0], "intensity": 2.0},
    ]
    return samples, camera, positions, lights


def selftest(out_dir):
    """Writes `selftest_frame()` to OUT_DIR/selftest.exr (+ selftest.json, the lights) and its arrays to
    OUT_DIR/selftest.npz.

    selftest.npz keys: every attribute name of the frame ("coverage" bool (H, W, S); "depth", "specular",
    "specular_power", "roughness", "metallic" float32 (H, W, S, 1); "position", "normal", "albedo" float32
    (H, W, S, 3); "motion" float32 (H, W, S, 2); "material_id", "object_id", "primitive_id" uint32 (H, W, S, 1)),
    exactly the values written (0 at background samples), with H = 9, W = 17, S = 4; plus "sample_positions"
    float32 (S, 2) (pixels, +y down), "world_to_view" float32 (4, 4) row-major and "camera" float32
    [yfov, aspect, znear, zfar]. Channel `s<i>.<attr>.<comp>` of the EXR is npz[attr][:, :, i, c].
    Returns the EXR's path.
    """
    os.makedirs(out_dir, exist_ok=True)
    samples, camera, positions, lights = selftest_frame()
    exr = os.path.join(out_dir, "selftest.exr")
    write_canonical(exr, samples, camera=camera, sample_positions=positions, lights=lights)
    arrays = dict(samples)
    arrays["sample_positions"] = np.array(positions, dtype=np.float32)
    arrays["world_to_view"] = np.array(camera["world_to_view"], dtype=np.float32)
    arrays["camera"] = np.array(
        [camera["yfov"], camera["aspect"], camera["znear"], camera["zfar"]], dtype=np.float32
    )
    npz = os.path.join(out_dir, "selftest.npz")
    tmp = _reserve(npz)
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, npz)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return exr


def _main(argv):
    import argparse

    p = argparse.ArgumentParser(description="gbuf canonical EXR writer (module: write_canonical)")
    p.add_argument("--selftest", metavar="OUT_DIR", required=True,
                   help="write the deterministic test frame to OUT_DIR/selftest.exr (+ .json, .npz)")
    args = p.parse_args(argv)
    exr = selftest(args.selftest)
    print(exr)
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(_main(sys.argv[1:]))
