"""Runs gbuf's RenderDoc display shaders (`gbuf layouts L --emit renderdoc`) inside RenderDoc's own replay and
writes what they output, for tests/packed_input.rs to compare with gbuf's decode of the same capture.

    /usr/bin/python3 renderdoc_views.py CAPTURE EVENT OUT_DIR TARGET=SHADER.glsl ...

For each TARGET=SHADER (TARGET: the resource's debug name), for each MSAA sample s and for "average value": the
target is shown in a headless texture output with the shader as its custom shader (TextureDisplay.subresource
selects the sample, as the texture viewer's sample selector does) and the shader's output texture
(ReplayOutput.GetCustomShaderTexID, RGBA16F) is read back with GetTextureData: OUT_DIR/SHADER.<s|avg>.f16, rows
top first (OpenGL's rows, bottom first, are reversed), 4 little-endian halves per pixel. OUT_DIR/compile.json holds
each shader's compile errors (empty when it built). Exit 1 with one line on stderr when anything fails.
"""
import json
import os
import sys

os.environ.setdefault("EGL_PLATFORM", "surfaceless")
os.environ.pop("DISPLAY", None)
try:
    import renderdoc as rd
except ImportError:
    sys.path.append("/usr/lib/python3/dist-packages")
    import renderdoc as rd


def fail(msg):
    sys.stderr.write("renderdoc_views: %s\n" % msg)
    sys.exit(1)


def main():
    capture, event, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    pairs = [a.split("=", 1) for a in sys.argv[4:]]
    rd.InitialiseReplay(rd.GlobalEnvironment(), [])
    cap = rd.OpenCaptureFile()
    res = cap.OpenFile(capture, "", None)
    if not res.OK():
        fail("cannot open %s: %s" % (capture, res.Message()))
    res, ctrl = cap.OpenCapture(rd.ReplayOptions(), None)
    if not res.OK():
        fail("cannot replay %s: %s" % (capture, res.Message()))
    compiled = {}
    try:
        ctrl.SetFrameEvent(event, True)
        flip = ctrl.GetAPIProperties().pipelineType == rd.GraphicsAPI.OpenGL
        names = {r.name: r.resourceId for r in ctrl.GetResources()}
        texs = {t.resourceId: t for t in ctrl.GetTextures()}
        for target, shader in pairs:
            if target not in names:
                fail("no resource named %r in %s" % (target, capture))
            tex = texs[names[target]]
            w, h, samples = tex.width, tex.height, tex.msSamp
            src = open(shader, "rb").read()
            sid, errors = ctrl.BuildCustomShader("main", rd.ShaderEncoding.GLSL, src, rd.ShaderCompileFlags(),
                                                 rd.ShaderStage.Pixel)
            base = os.path.basename(shader)
            compiled[base] = errors if sid == rd.ResourceId.Null() else ""
            if sid == rd.ResourceId.Null():
                continue
            output = ctrl.CreateOutput(rd.CreateHeadlessWindowingData(w, h), rd.ReplayOutputType.Texture)
            selections = [(s, str(s)) for s in range(samples)] + [(rd.TextureDisplay.ResolveSamples, "avg")]
            for sel, label in selections:
                td = rd.TextureDisplay()
                td.resourceId = names[target]
                td.customShaderId = sid
                td.subresource = rd.Subresource(0, 0, sel)
                td.rangeMin, td.rangeMax = 0.0, 1.0
                td.scale = 1.0
                td.flipY = False
                td.rawOutput = False
                output.SetTextureDisplay(td)
                output.Display()
                cid = output.GetCustomShaderTexID()
                data = bytes(ctrl.GetTextureData(cid, rd.Subresource(0, 0, 0)))
                if len(data) != w * h * 8:
                    fail("%s: the custom output holds %d bytes, not %d×%d RGBA16F" % (base, len(data), w, h))
                row = w * 8
                if flip:
                    data = b"".join(data[(h - 1 - y) * row:(h - y) * row] for y in range(h))
                with open(os.path.join(out, "%s.%s.f16" % (base, label)), "wb") as f:
                    f.write(data)
            output.Shutdown()
    finally:
        ctrl.Shutdown()
        cap.Shutdown()
        with open(os.path.join(out, "compile.json"), "w") as f:
            json.dump(compiled, f)


if __name__ == "__main__":
    main()
