"""The Python package against the CLI: the same FLIP statistics as `gbuf compare --json`, the same planes as
`gbuf convert` writes, pack/unpack equal to the library's roundtrip. Run: python3 -m unittest discover -s python/tests
(after `pip install ./python`; the CLI is target/release/gbuf or GBUF_BIN)."""

import json
import os
import subprocess
import tempfile
import unittest

import numpy as np

import gbuf

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIXTURES = os.path.join(ROOT, "fixtures")


def cli(*args):
    exe = os.environ.get("GBUF_BIN") or os.path.join(ROOT, "target", "release", "gbuf")
    out = subprocess.run([exe, *args], capture_output=True, text=True)
    if out.returncode not in (0, 1):
        raise AssertionError(f"gbuf {' '.join(args)}: exit {out.returncode}: {out.stderr}")
    return out.stdout


class Flip(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        d = cls.dir.name
        # Two images of the llvmpipe fixture the CLI writes: the reference and a resolve through minimal-8.
        cls.ref_exr, cls.test_exr = os.path.join(d, "ref.exr"), os.path.join(d, "test.exr")
        cls.ref_png, cls.test_png = os.path.join(d, "ref.png"), os.path.join(d, "test.png")
        raster = os.path.join(FIXTURES, "raster_4x.exr")
        cli("resolve", raster, "--detector", "ssaa", "--no-reference", "-o", cls.ref_exr, "--png", cls.ref_png)
        cli("resolve", raster, "--layout", "minimal-8", "--no-reference", "-o", cls.test_exr, "--png", cls.test_png)

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def check_against_cli(self, ref, test, key, **kw):
        got = gbuf.flip(ref, test, **kw)
        want = json.loads(cli("compare", ref, test, "--json", "--flip", key))
        pooled = want[f"flip_{key}"]
        for k in ("mean", "weighted_median", "weighted_q1", "weighted_q3", "min", "max"):
            self.assertEqual(got[k], pooled[k], k)
        self.assertEqual(list(got["histogram"]), pooled["histogram"])
        self.assertEqual(got["rmse"], want["numeric"]["rmse"])
        self.assertEqual(got["map"].shape, (want["size"][1], want["size"][0]))
        self.assertAlmostEqual(float(got["map"].astype(np.float64).mean()), got["mean"], places=6)
        self.assertGreater(got["mean"], 0.0)
        return got

    def test_ldr_and_hdr_equal_the_cli(self):
        self.check_against_cli(self.ref_png, self.test_png, "ldr")
        got = self.check_against_cli(self.ref_exr, self.test_exr, "hdr")
        self.assertTrue(got["hdr"])

    def test_arrays_equal_files(self):
        # The EXRs' pixels read by OpenEXR's own Python package, passed as arrays: the same HDR-FLIP bit for bit.
        import OpenEXR

        def rgb(path):
            with OpenEXR.File(path) as f:
                ch = f.channels()
                if "RGB" in ch:
                    return np.ascontiguousarray(ch["RGB"].pixels, dtype=np.float32)
                return np.stack([ch[c].pixels for c in "RGB"], -1).astype(np.float32)

        from_files = gbuf.flip(self.ref_exr, self.test_exr)
        from_arrays = gbuf.flip(rgb(self.ref_exr), rgb(self.test_exr), hdr=True)
        for k in ("mean", "weighted_median", "weighted_q1", "weighted_q3", "max"):
            self.assertEqual(from_files[k], from_arrays[k], k)
        np.testing.assert_array_equal(from_files["map"], from_arrays["map"])
        self.assertEqual(gbuf.flip(self.ref_png, self.ref_png)["mean"], 0.0)

    def test_bad_input_is_a_value_error(self):
        a = np.zeros((4, 5, 3), np.float32)
        with self.assertRaises(ValueError):
            gbuf.flip(a, np.zeros((4, 6, 3), np.float32))
        with self.assertRaises(ValueError):
            gbuf.flip(a, a + 2.0)  # LDR values outside [0, 1]
        with self.assertRaises(ValueError):
            gbuf.flip(a, np.full((4, 5, 3), np.nan, np.float32), hdr=True)
        with self.assertRaises(ValueError):
            gbuf.flip(os.path.join(FIXTURES, "missing.png"), a)
        self.assertEqual(gbuf.flip(a, a, hdr=True)["mean"], 0.0)


class Planes(unittest.TestCase):
    def test_load_matches_info(self):
        path = os.path.join(FIXTURES, "raster_4x.exr")
        p = gbuf.load(path)
        info = json.loads(cli("info", path, "--json"))
        self.assertEqual((p["width"], p["height"], p["samples"]), (info["width"], info["height"], info["samples"]))
        self.assertEqual(p["coverage"].shape, (p["height"], p["width"], p["samples"]))
        self.assertEqual(p["normal"].shape, p["coverage"].shape + (3,))
        self.assertEqual(int(p["coverage"].sum()), info["total_samples"] - info["background_samples"])
        covered = p["coverage"]
        lengths = np.linalg.norm(p["normal"][covered], axis=-1)
        self.assertLess(float(np.abs(lengths - 1.0).max()), 1e-3)

    def test_pack_unpack_roundtrip(self):
        p = gbuf.load(os.path.join(FIXTURES, "raster_4x.exr"))
        self.assertIn("minimal-8", gbuf.layouts())
        packed = gbuf.pack("minimal-8", p)
        total = sum(t.shape[-1] for t in packed["targets"].values())
        self.assertEqual(total, 8)
        back = gbuf.unpack("minimal-8", packed)
        cov = p["coverage"]
        err = np.degrees(np.arccos(np.clip((back["normal"][cov] * p["normal"][cov]).sum(-1), -1, 1)))
        self.assertGreater(float(err.max()), 0.0)  # lossy
        self.assertLess(float(err.max()), 2.0)  # rg8 octahedral: about a degree at worst
        # The lossless baseline gives the planes back bit for bit.
        exact = gbuf.unpack("reference-f32", gbuf.pack("reference-f32", p))
        np.testing.assert_array_equal(exact["albedo"][cov], p["albedo"][cov])
        with self.assertRaises(ValueError):
            gbuf.pack("no-such-layout", p)
        with self.assertRaises(ValueError):
            gbuf.pack("minimal-8", {"coverage": p["coverage"], "bogus": p["normal"]})

    def test_load_reads_every_input_kind_as_convert_writes_it(self):
        # Every kind of input in fixtures/ (and a folder `gbuf pack` wrote), loaded by Python, equals what
        # `gbuf convert` wrote for it as the canonical EXR, plane by plane, bit for bit.
        engine = os.path.join(FIXTURES, "engine_4x")
        with tempfile.TemporaryDirectory() as d:
            packed = os.path.join(d, "packed")
            cli("pack", os.path.join(FIXTURES, "raster_4x.exr"), "--layout", "unreal-like", "-o", packed)
            cases = [
                ("raster_4x.exr", {}, []),
                ("blender_gbuffer.exr", {}, []),
                ("mitsuba_gbuffer.exr", {}, []),
                ("ispc_deferred.bin", {}, []),
                ("luxcore", {}, []),
                (engine, {"input_layout": os.path.join(engine, "engine.toml")},
                 ["--input-layout", os.path.join(engine, "engine.toml")]),
                (packed, {}, []),
                ("raster_4x.exr", {"no_scene": True}, ["--no-scene"]),
            ]
            for i, (name, kw, flags) in enumerate(cases):
                path = os.path.join(FIXTURES, name)
                out = os.path.join(d, f"case{i}.exr")
                res = subprocess.run([os.environ.get("GBUF_BIN") or os.path.join(ROOT, "target", "release", "gbuf"),
                                      "convert", path, "-o", out, *flags], capture_output=True, text=True)
                self.assertEqual(res.returncode, 0, f"{name}: {res.stderr}")
                got = gbuf.load(path, **kw)
                want = gbuf.load(out, no_scene=True)
                self.assertEqual(sorted(got.keys()), sorted(want.keys()), name)
                for k, v in want.items():
                    if isinstance(v, np.ndarray):
                        np.testing.assert_array_equal(got[k], v, err_msg=f"{name}: {k}")
                    else:
                        self.assertEqual(got[k], v, f"{name}: {k}")
        with self.assertRaises(ValueError):
            gbuf.load(os.path.join(FIXTURES, "raster_4x.exr"), scene="x.json", no_scene=True)
        with self.assertRaises(ValueError) as e:
            gbuf.load(os.path.join(FIXTURES, "raster_4x.exr"), map="normal=A;B")
        # Loading errors name load's keyword arguments, not the command line's flags.
        self.assertNotIn("--map", str(e.exception))
        self.assertIn("map", str(e.exception))
        with self.assertRaises(ValueError) as e:
            gbuf.load(os.path.join(FIXTURES, "raster_4x.exr"), map="bogus")
        self.assertTrue(str(e.exception).startswith("map: "), str(e.exception))


if __name__ == "__main__":
    unittest.main()
