#!/usr/bin/env python3
"""rdc_bridge.py: read the render targets of one action of a RenderDoc capture (.rdc) through RenderDoc's Python
replay module, for gbuf (which embeds this file and runs it). Standard library + the `renderdoc` module only.

Usage:
  PY rdc_bridge.py list CAPTURE
      JSON on stdout: {"api", "capture", "driver", "default_event" (what `extract` picks by default, or null),
      "actions": [...]}. One entry per action that draws, dispatches, clears, copies, resolves or generates mips
      and has a target bound (per the pipeline state at that event): "eventId", "name" (the marker path and the
      action's name, "GBuffer/rod/glDrawElementsInstanced()"), "marker" (the path of the enclosing markers, "" at
      top level), "flags" (RenderDoc's ActionFlags names), "colors" (one per bound colour slot: "slot", "resource"
      (RenderDoc's resource id, an integer), "name" (debug name, "" if the application set none), "format"
      (RenderDoc's format name), "dxgi" (the DXGI format `extract` writes, null if it cannot), "width", "height"
      (of the bound mip), "samples", "mip", "slice") and "depth" (the same fields but "slot", or null).
  PY rdc_bridge.py extract CAPTURE OUT_DIR [--event EID] [--marker NAME]
      Replays to the action and writes, for the targets bound there (their contents AFTER the action):
        colorN.dds  per bound colour slot N;  depth.dds  for the depth target;  manifest.json  (last):
        {"api", "capture", "event", "action", "marker", "rows": "top-first", "flipped_y",
         "targets": [{"file", "slot" (null for depth), "name", "format", "dxgi", "width", "height", "samples",
                      "mip", "slice", "resource", "note"}],
         "skipped": [{"slot", "name", "format", "reason"}]}
      Default action: the last draw that writes a colour target. --event EID: the action with that event id (see
      `list`). --marker NAME: the last such draw inside a marker region whose name or full path ("GBuffer/rod") is
      NAME. The two are exclusive.

DDS files: "DDS ", DDS_HEADER (flags CAPS|HEIGHT|WIDTH|PITCH|PIXELFORMAT = 0x100F, pitch = width * texel bytes,
one mip), DDS_PIXELFORMAT FourCC "DX10", DDS_HEADER_DXT10 (dxgiFormat, TEXTURE2D, arraySize = samples); array
slice s = MSAA sample s, rows top first, texels little-endian: what RenderDoc's own TextureSave writes with
"samples to array slices", and what gbuf reads.

Texel data comes from ReplayController.GetTextureData(resource, Subresource(mip, slice, sample)), one call per
sample (for colour formats bit-identical to TextureSave's DDS payload; unlike TextureSave it also works for D24).
OpenGL returns rows bottom first (GL's row 0 is the bottom of the image): for OpenGL captures the rows are
reversed, as RenderDoc's TextureSave and texture viewer do; other APIs' rows are written as returned (top first).
Formats, as written:
  colour: the DXGI format of the same bits (R10G10B10A2_UNORM 24, R8G8B8A8_UNORM_SRGB 29, ...), bytes as stored
          (sRGB bytes are the stored codes, not decoded). A format with no DXGI twin (e.g. GL RGB8) is skipped.
  D32 (D32F)   -> D32_FLOAT 40, the raw float bits.
  D16          -> D16_UNORM 55, the raw 16-bit code.
  D24S8        -> D24_UNORM_S8_UINT 45 in DXGI's bit layout: depth code (raw 24-bit unorm) in bits 0-23, stencil
                  in bits 24-31. OpenGL returns GL_UNSIGNED_INT_24_8 words (depth in bits 8-31, stencil in 0-7):
                  the bytes are rotated, as RenderDoc's TextureSave does for GL. Other APIs: written as returned.
  D24 (no stencil, GL_DEPTH_COMPONENT24) -> R24_UNORM_X8_TYPELESS 46: depth code in bits 0-23, bits 24-31 zero
                  (GL returns depth in bits 8-31 and an undefined low byte). TextureSave cannot save this one.
  D32S8        -> D32_FLOAT 40, the depth float only (the stencil is dropped; noted in the manifest).
  D16S8, S8    -> skipped.

Exit codes: 0 ok; 1 failure (one line on stderr); 2 usage; 3 the `renderdoc` module cannot be imported.
Environment: if EGL_PLATFORM is unset and neither DISPLAY nor WAYLAND_DISPLAY is set, EGL_PLATFORM=surfaceless is
set before the replay starts (Mesa's EGL then needs no display server; without it an OpenGL capture made through
EGL fails to open with "Couldn't create OpenGL ES 3.x replay context"). RenderDoc itself keeps a log under
/tmp/RenderDoc/ (deleted on a clean exit) and writes ~/.renderdoc/renderdoc.conf.
"""
import json
import os
import struct
import sys

EXIT_FAIL, EXIT_USAGE, EXIT_NO_MODULE = 1, 2, 3
DEBIAN_DIST_PACKAGES = "/usr/lib/python3/dist-packages"  # where Debian's python3-renderdoc puts renderdoc.so


class Failure(Exception):
    pass


def die(msg, code=EXIT_FAIL):
    sys.stderr.write("rdc_bridge: error: %s\n" % " ".join(str(msg).split()))
    sys.stderr.flush()
    sys.exit(code)


def import_renderdoc():
    try:
        import renderdoc  # noqa: F401
        return renderdoc
    except ImportError as first:
        err = first
    # Debian's python3-renderdoc installs renderdoc.so for Debian's own python3 (/usr/bin/python3). Another
    # interpreter may load it only if it is the same CPython minor version: try that directory only when it holds
    # other extension modules of this interpreter's ABI tag (evidence the versions match).
    tag = ".cpython-%d%d-" % sys.version_info[:2]
    if (sys.implementation.name == "cpython" and DEBIAN_DIST_PACKAGES not in sys.path
            and os.path.exists(os.path.join(DEBIAN_DIST_PACKAGES, "renderdoc.so"))
            and any(tag in f for f in os.listdir(DEBIAN_DIST_PACKAGES))):
        sys.path.append(DEBIAN_DIST_PACKAGES)
        try:
            import renderdoc  # noqa: F401
            return renderdoc
        except ImportError as second:
            err = second
    die("cannot import the RenderDoc Python module (%s) with %s (Python %d.%d): install it (Debian/Ubuntu: apt-get "
        "install python3-renderdoc, which serves /usr/bin/python3; otherwise RenderDoc's renderdoc.so/.pyd built "
        "for this Python) and put its directory on PYTHONPATH" % (err, sys.executable, *sys.version_info[:2]),
        EXIT_NO_MODULE)


# ------------------------------------------------------------------------------------------------ formats
# (component bytes, component count) -> {CompType name: DXGI}, for ResourceFormatType.Regular.
REGULAR_DXGI = {
    (4, 4): {"Typeless": 1, "Float": 2, "UInt": 3, "SInt": 4},
    (4, 3): {"Typeless": 5, "Float": 6, "UInt": 7, "SInt": 8},
    (2, 4): {"Typeless": 9, "Float": 10, "UNorm": 11, "UInt": 12, "SNorm": 13, "SInt": 14},
    (4, 2): {"Typeless": 15, "Float": 16, "UInt": 17, "SInt": 18},
    (1, 4): {"Typeless": 27, "UNorm": 28, "UNormSRGB": 29, "UInt": 30, "SNorm": 31, "SInt": 32},
    (2, 2): {"Typeless": 33, "Float": 34, "UNorm": 35, "UInt": 36, "SNorm": 37, "SInt": 38},
    (4, 1): {"Typeless": 39, "Depth": 40, "Float": 41, "UInt": 42, "SInt": 43},
    (1, 2): {"Typeless": 48, "UNorm": 49, "UInt": 50, "SNorm": 51, "SInt": 52},
    (2, 1): {"Typeless": 53, "Float": 54, "Depth": 55, "UNorm": 56, "UInt": 57, "SNorm": 58, "SInt": 59},
    (1, 1): {"Typeless": 60, "UNorm": 61, "UInt": 62, "SNorm": 63, "SInt": 64},
}
BGRA_DXGI = {"UNorm": 87, "UNormSRGB": 91, "Typeless": 90}


def enum_name(v):
    return getattr(v, "name", str(v).split(".")[-1])


def rotate_gl_d24s8(data):
    """GL_UNSIGNED_INT_24_8 words (stencil byte first in memory) -> DXGI D24_UNORM_S8_UINT (stencil byte last)."""
    out = bytearray(len(data))
    out[0::4], out[1::4], out[2::4], out[3::4] = data[1::4], data[2::4], data[3::4], data[0::4]
    return bytes(out)


def gl_d24x8(data):
    """GL depth-24 words (depth in bits 8-31, undefined low byte) -> R24_UNORM_X8 (depth in 0-23, bits 24-31 0)."""
    out = bytearray(len(data))
    out[0::4], out[1::4], out[2::4] = data[1::4], data[2::4], data[3::4]
    return bytes(out)


def d32s8_depth(data):
    """D32_FLOAT_S8X24 texels (float, stencil byte, 3 unused) -> the depth floats."""
    out = bytearray(len(data) // 2)
    for k in range(4):
        out[k::4] = data[k::8]
    return bytes(out)


def plan_format(rd, fmt, is_gl):
    """How to write a texture of ResourceFormat `fmt`: (dxgi, bytes per texel as returned by GetTextureData or
    None if any, convert(data) or None, note) or (None, reason) when it cannot be written."""
    t, ct = fmt.type, enum_name(fmt.compType)
    T = rd.ResourceFormatType
    if t == T.Regular:
        if ct == "Depth" and fmt.compByteWidth == 3:  # D24 without stencil
            if not is_gl:
                return None, "D24 (no stencil) readback layout known for OpenGL only"
            return 46, 4, gl_d24x8, "GL depth-24 words: depth code moved to bits 0-23, bits 24-31 zeroed"
        if fmt.BGRAOrder():
            dxgi = BGRA_DXGI.get(ct) if (fmt.compByteWidth, fmt.compCount) == (1, 4) else None
        else:
            dxgi = REGULAR_DXGI.get((fmt.compByteWidth, fmt.compCount), {}).get(ct)
        if dxgi is None:
            return None, "no DXGI format for %s" % fmt.Name()
        return dxgi, fmt.compByteWidth * fmt.compCount, None, ""
    if t == T.R10G10B10A2:
        dxgi = {"UNorm": 24, "UInt": 25, "Typeless": 23}.get(ct)
        if dxgi is None or fmt.BGRAOrder():
            return None, "no DXGI format for %s" % fmt.Name()
        return dxgi, 4, None, ""
    if t == T.R11G11B10:
        return 26, 4, None, ""
    if t == T.R9G9B9E5:
        return 67, 4, None, ""
    if t == T.D24S8:
        if is_gl:
            return 45, 4, rotate_gl_d24s8, "GL 24_8 words rotated to DXGI layout: depth bits 0-23, stencil 24-31"
        return 45, 4, None, "as returned (non-GL API: assumed DXGI layout)"
    if t == T.D32S8:
        return 40, 8, d32s8_depth, "depth float only: the stencil of D32S8 is dropped"
    return None, "format %s is not written (no DXGI twin gbuf reads)" % fmt.Name()


# ------------------------------------------------------------------------------------------------ DDS
def dds_header(width, height, texel_bytes, dxgi, slices):
    fourcc = struct.unpack("<I", b"DX10")[0]
    h = struct.pack("<4s", b"DDS ")
    h += struct.pack("<7I", 124, 0x100F, height, width, width * texel_bytes, 0, 1) + bytes(44)
    h += struct.pack("<8I", 32, 0x4, fourcc, 0, 0, 0, 0, 0)
    h += struct.pack("<5I", 0x1000, 0, 0, 0, 0)
    h += struct.pack("<5I", dxgi, 3, 0, slices, 0)
    return h


def write_atomic(path, data):
    tmp = os.path.join(os.path.dirname(path), "." + os.path.basename(path) + ".tmp%d" % os.getpid())
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def flip_rows(data, width, height, texel_bytes):
    row = width * texel_bytes
    return b"".join(data[(height - 1 - y) * row:(height - y) * row] for y in range(height))


# ------------------------------------------------------------------------------------------------ replay
def result_ok(rd, res):
    """RenderDoc >= 1.24 returns ResultDetails (OK(), Message()); older versions a ReplayStatus enum."""
    if hasattr(res, "OK"):
        return res.OK()
    return res == rd.ReplayStatus.Succeeded


def result_text(res):
    return res.Message() if hasattr(res, "Message") else str(res)


class Replay:
    def __init__(self, rd, path):
        self.rd = rd
        if not os.path.isfile(path):
            raise Failure("no such capture file: %s" % path)
        if "EGL_PLATFORM" not in os.environ and not os.environ.get("DISPLAY") and not os.environ.get(
                "WAYLAND_DISPLAY"):
            os.environ["EGL_PLATFORM"] = "surfaceless"
        rd.InitialiseReplay(rd.GlobalEnvironment(), [])
        self.cap = self.ctrl = None
        try:
            self._open(path)
        except BaseException:
            self.close()
            raise

    def _open(self, path):
        rd = self.rd
        self.cap = rd.OpenCaptureFile()
        res = self.cap.OpenFile(path, "", None)
        if not result_ok(rd, res):
            raise Failure("cannot open %s as a RenderDoc capture: %s" % (path, result_text(res)))
        if self.cap.LocalReplaySupport() != rd.ReplaySupport.Supported:
            raise Failure("this machine cannot replay %s (%s capture): %s" % (
                path, self.cap.DriverName(), self.cap.LocalReplaySupport()))
        res, self.ctrl = self.cap.OpenCapture(rd.ReplayOptions(), None)
        if not result_ok(rd, res):
            hint = ""
            if self.cap.DriverName() in ("OpenGL", "OpenGL ES"):
                hint = (" (for OpenGL replay without a display server set EGL_PLATFORM=surfaceless and unset "
                        "DISPLAY; EGL_PLATFORM is %r)" % os.environ.get("EGL_PLATFORM"))
            raise Failure("RenderDoc cannot start the replay of %s: %s%s" % (path, result_text(res), hint))
        self.api = enum_name(self.ctrl.GetAPIProperties().pipelineType)
        self.is_gl = self.api == "OpenGL"
        self.sdfile = self.ctrl.GetStructuredFile()
        self.textures = {int(t.resourceId): t for t in self.ctrl.GetTextures()}
        # Debug names; "" for the ones RenderDoc generates ("Texture 26"). "Backbuffer Color" is RenderDoc's too
        # but not flagged autogenerated: it is kept.
        self.names = {int(r.resourceId): "" if getattr(r, "autogeneratedName", False) else r.name
                      for r in self.ctrl.GetResources()}
        self.actions = []  # (action, marker path) in event order, markers included
        self._walk(self.ctrl.GetRootActions(), [])

    def close(self):
        if self.ctrl is not None:
            self.ctrl.Shutdown()
        if self.cap is not None:
            self.cap.Shutdown()
        self.rd.ShutdownReplay()

    def _walk(self, actions, path):
        for a in actions:
            self.actions.append((a, "/".join(path)))
            if len(a.children):
                self._walk(a.children, path + [a.GetName(self.sdfile)])

    def debug_name(self, rid):
        return self.names.get(rid, "")

    def bound(self, event_id):
        """The targets bound at an event, from the pipeline state: ([(slot, BoundResource)], BoundResource or
        None). (ActionDescription.outputs is not used: on OpenGL, RenderDoc 1.24 reports the backbuffer there for
        the actions that precede the capture's first glBindFramebuffer, though they write the bound FBO.)"""
        self.ctrl.SetFrameEvent(event_id, False)
        pipe = self.ctrl.GetPipelineState()
        colours = [(i, b) for i, b in enumerate(pipe.GetOutputTargets()) if int(bound_id(b)) != 0]
        depth = pipe.GetDepthTarget()
        return colours, (depth if int(bound_id(depth)) != 0 else None)

    def describe(self, b):
        rid = int(bound_id(b))
        tex = self.textures.get(rid)
        mip, slc = max(0, b.firstMip), max(0, b.firstSlice)
        d = {"resource": rid, "name": self.debug_name(rid)}
        if tex is None:
            d.update(format="", dxgi=None, width=0, height=0, samples=0, mip=mip, slice=slc)
            return d
        planned = plan_format(self.rd, tex.format, self.is_gl)
        d.update(format=tex.format.Name(), dxgi=planned[0], width=max(1, tex.width >> mip),
                 height=max(1, tex.height >> mip), samples=max(1, tex.msSamp), mip=mip, slice=slc)
        return d


def flag_names(rd, flags):
    names = getattr(rd.ActionFlags, "__members__", None) or [n for n in dir(rd.ActionFlags) if n[0].isupper()]
    bits = [(n, int(getattr(rd.ActionFlags, n))) for n in names]
    return [n for n, b in bits if b and int(flags) & b == b]


def is_work(rd, a):
    f = rd.ActionFlags
    mask = f.Clear | f.Drawcall | f.Dispatch | f.Copy | f.Resolve | f.GenMips
    return bool(int(a.flags) & int(mask))


def is_draw(rd, a):
    return bool(int(a.flags) & int(rd.ActionFlags.Drawcall))


def full_name(rp, a, marker):
    n = a.GetName(rp.sdfile)
    return marker + "/" + n if marker else n


def default_action(rd, rp, candidates, bound=None):
    """The last draw among candidates with a colour target bound (bound: event -> rp.bound(event), if known)."""
    for a, m in reversed(candidates):
        if is_draw(rd, a) and (bound[a.eventId] if bound is not None and a.eventId in bound
                               else rp.bound(a.eventId))[0]:
            return a, m
    return None, None


def cmd_list(rd, path):
    rp = Replay(rd, path)
    try:
        out, bound = [], {}
        for a, marker in rp.actions:
            if not is_work(rd, a):
                continue
            colours, depth = bound[a.eventId] = rp.bound(a.eventId)
            if not colours and depth is None:
                continue
            out.append({"eventId": a.eventId, "name": full_name(rp, a, marker), "marker": marker,
                        "flags": flag_names(rd, a.flags),
                        "colors": [dict(slot=slot, **rp.describe(b)) for slot, b in colours],
                        "depth": rp.describe(depth) if depth is not None else None})
        dflt, _ = default_action(rd, rp, rp.actions, bound)
        doc = {"api": rp.api, "capture": os.path.abspath(path), "driver": rp.cap.DriverName(),
               "default_event": dflt.eventId if dflt is not None else None, "actions": out}
    finally:
        rp.close()
    sys.stdout.write(json.dumps(doc, indent=1) + "\n")


def pick_action(rd, rp, event, marker):
    if event is not None:
        for a, m in rp.actions:
            if a.eventId == event:
                return a, m
        raise Failure("event %d is not an action of the capture (`list` shows the actions)" % event)
    if marker is not None:
        inside = []
        for a, m in rp.actions:
            parts = m.split("/") if m else []
            paths = ["/".join(parts[:k + 1]) for k in range(len(parts))]
            if marker in parts or marker in paths:
                inside.append((a, m))
        if not inside:
            markers = sorted({m for _, m in rp.actions if m})
            raise Failure("no marker %r in the capture (markers: %s)" % (marker, ", ".join(markers) or "none"))
        a, m = default_action(rd, rp, inside)
        if a is None:
            raise Failure("no draw writing a colour target inside marker %r" % marker)
        return a, m
    a, m = default_action(rd, rp, rp.actions)
    if a is None:
        raise Failure("the capture has no draw that writes a colour target (use --event; `list` shows actions)")
    return a, m


def bound_id(b):
    """The resource of a bound target: `BoundResource.resourceId` (RenderDoc 1.24), `Descriptor.resource` (later)."""
    return b.resource if hasattr(b, "resource") else b.resourceId


def read_target(rp, bound, out_dir, file_name, slot, skipped):
    """Writes one bound target (a BoundResource) as file_name; returns its manifest entry or None (skipped)."""
    rd = rp.rd
    rid = int(bound_id(bound))
    tex = rp.textures.get(rid)
    name = rp.debug_name(rid)
    if tex is None:
        skipped.append({"slot": slot, "name": name, "format": "", "reason": "resource %d is not a texture" % rid})
        return None
    planned = plan_format(rd, tex.format, rp.is_gl)
    if planned[0] is None:
        skipped.append({"slot": slot, "name": name, "format": tex.format.Name(), "reason": planned[1]})
        return None
    dxgi, in_bytes, convert, note = planned
    mip, slc = max(0, bound.firstMip), max(0, bound.firstSlice)
    w, h = max(1, tex.width >> mip), max(1, tex.height >> mip)
    samples = max(1, tex.msSamp)
    chunks = []
    for s in range(samples):
        data = rp.ctrl.GetTextureData(bound_id(bound), rd.Subresource(mip, slc, s))
        data = bytes(data)
        if not data or len(data) % (w * h):
            raise Failure("%s (%s, %dx%d): GetTextureData returned %d bytes" % (
                file_name, tex.format.Name(), w, h, len(data)))
        got = len(data) // (w * h)
        if in_bytes is not None and got != in_bytes:
            raise Failure("%s (%s): %d bytes per texel returned, expected %d" % (
                file_name, tex.format.Name(), got, in_bytes))
        if rp.is_gl:
            data = flip_rows(data, w, h, got)
        if convert is not None:
            data = convert(data)
        chunks.append(data)
    texel = len(chunks[0]) // (w * h)
    write_atomic(os.path.join(out_dir, file_name), dds_header(w, h, texel, dxgi, samples) + b"".join(chunks))
    return {"file": file_name, "slot": slot, "name": name, "format": tex.format.Name(), "dxgi": dxgi, "width": w,
            "height": h, "samples": samples, "mip": mip, "slice": slc, "resource": rid, "note": note}


def cmd_extract(rd, path, out_dir, event, marker):
    rp = Replay(rd, path)
    try:
        a, m = pick_action(rd, rp, event, marker)
        colours, depth = rp.bound(a.eventId)
        os.makedirs(out_dir, exist_ok=True)
        targets, skipped = [], []
        for slot, b in colours:
            t = read_target(rp, b, out_dir, "color%d.dds" % slot, slot, skipped)
            if t:
                targets.append(t)
        if depth is not None:
            t = read_target(rp, depth, out_dir, "depth.dds", None, skipped)
            if t:
                targets.append(t)
        if not targets:
            raise Failure("event %d (%s) has no target that can be written%s" % (
                a.eventId, full_name(rp, a, m), "".join("; %s: %s" % (s["format"], s["reason"]) for s in skipped)))
        for s in skipped:
            sys.stderr.write("rdc_bridge: warning: slot %s (%s, %s) skipped: %s\n" % (
                s["slot"], s["name"], s["format"], s["reason"]))
        manifest = {"api": rp.api, "capture": os.path.abspath(path), "event": a.eventId,
                    "action": a.GetName(rp.sdfile), "marker": m, "rows": "top-first", "flipped_y": rp.is_gl,
                    "targets": targets, "skipped": skipped}
        write_atomic(os.path.join(out_dir, "manifest.json"), (json.dumps(manifest, indent=1) + "\n").encode())
    finally:
        rp.close()


USAGE = ("usage: rdc_bridge.py list CAPTURE\n"
         "       rdc_bridge.py extract CAPTURE OUT_DIR [--event EID] [--marker NAME]")


def main(argv):
    if len(argv) < 2 or argv[0] not in ("list", "extract"):
        die("bad arguments\n" + USAGE, EXIT_USAGE)
    cmd, rest = argv[0], argv[1:]
    event = marker = None
    pos = []
    i = 0
    while i < len(rest):
        if rest[i] in ("--event", "--marker") and cmd == "extract":
            if i + 1 >= len(rest):
                die("%s needs a value" % rest[i], EXIT_USAGE)
            if rest[i] == "--event":
                try:
                    event = int(rest[i + 1])
                except ValueError:
                    die("--event needs an integer event id, got %r" % rest[i + 1], EXIT_USAGE)
            else:
                marker = rest[i + 1]
            i += 2
        elif rest[i].startswith("--"):
            die("unknown option %s\n%s" % (rest[i], USAGE), EXIT_USAGE)
        else:
            pos.append(rest[i])
            i += 1
    if (cmd == "list" and len(pos) != 1) or (cmd == "extract" and len(pos) != 2):
        die("bad arguments\n" + USAGE, EXIT_USAGE)
    if event is not None and marker is not None:
        die("--event and --marker are exclusive", EXIT_USAGE)
    rd = import_renderdoc()
    try:
        if cmd == "list":
            cmd_list(rd, pos[0])
        else:
            cmd_extract(rd, pos[0], pos[1], event, marker)
    except Failure as e:
        die(e)
    except Exception as e:  # anything from the replay or the file system: one line, not a traceback
        die("%s: %s" % (type(e).__name__, e))


if __name__ == "__main__":
    main(sys.argv[1:])
