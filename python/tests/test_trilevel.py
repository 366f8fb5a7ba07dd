"""Tests of the trilevel Python module, run by CTest (`ctest -R python_module`).

CTest sets PYTHONPATH to the built module, TRILEVEL_CLI to the CLI binary and TRILEVEL_SHARED_DIR
to ../shared (real SPH frames; those tests are skipped with a message when it is absent).
"""
import json
import os
import subprocess
import tempfile
import threading
import unittest

import numpy as np

import trilevel

R = 0.025  # particle radius of the generated scenes and of the SPlisHSPlasH frames, world units


def directed_edges(triangles, vertex_count):
    """Every directed edge a -> b of the triangles as one integer a * vertex_count + b."""
    t = triangles.astype(np.uint64)
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    return a * np.uint64(vertex_count) + b, b * np.uint64(vertex_count) + a


def assert_closed(test, vertices, triangles):
    """Closed and consistently oriented: every directed edge once, and its reverse once."""
    test.assertGreater(len(triangles), 0)
    test.assertLess(int(triangles.max()), len(vertices))
    edges, reverse = directed_edges(triangles, len(vertices))
    test.assertEqual(len(np.unique(edges)), len(edges), "a directed edge is used twice")
    test.assertTrue(np.array_equal(np.sort(edges), np.sort(reverse)), "an edge has no opposite edge")


def assert_bit_equal(test, a, b):
    test.assertEqual(a.shape, b.shape)
    test.assertEqual(a.dtype, b.dtype)
    test.assertTrue(np.array_equal(a.view(np.uint8), b.view(np.uint8)), "arrays differ bit for bit")


def shared_frame(name):
    shared = os.environ.get("TRILEVEL_SHARED_DIR", "")
    path = os.path.join(shared, "data", name)
    if not shared or not os.path.isfile(path):
        raise unittest.SkipTest(f"SKIPPED: {path} is absent (../shared/data beside the checkout)")
    return path


class ReconstructTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.rec = trilevel.Reconstructor()
        cls.sphere = trilevel.generate_scene("sphere", R, seed=3)

    def test_generated_scene_gives_a_closed_mesh_and_matching_stats(self):
        v, t, stats = self.rec.reconstruct(self.sphere, particle_radius=R)
        self.assertEqual((v.dtype, t.dtype), (np.float32, np.uint32))
        self.assertEqual((v.ndim, v.shape[1], t.ndim, t.shape[1]), (2, 3, 2, 3))
        assert_closed(self, v, t)
        self.assertEqual(stats["particles"], len(self.sphere))
        self.assertEqual(stats["vertices"], len(v))
        self.assertEqual(stats["triangles"], len(t))
        self.assertEqual(sum(stats["triangles_by_kind"].values()), len(t))
        self.assertIs(stats["closed"], True)
        self.assertEqual(stats["device"], self.rec.device["name"])
        self.assertEqual(stats["parameters"]["particle_radius"], np.float32(R))
        # The surface lies about one radius outside the outermost particle centres.
        lo, hi = self.sphere.min(axis=0), self.sphere.max(axis=0)
        self.assertTrue(np.all(v.min(axis=0) < lo) and np.all(v.min(axis=0) > lo - 2 * R))
        self.assertTrue(np.all(v.max(axis=0) > hi) and np.all(v.max(axis=0) < hi + 2 * R))

    def test_parameters_reach_the_library(self):
        _, t_adaptive, s_adaptive = self.rec.reconstruct(self.sphere, R)
        v, t, s = self.rec.reconstruct(self.sphere, R, mode="uniform", cell=2.0)
        assert_closed(self, v, t)
        self.assertEqual(s["parameters"]["mode"], "uniform")
        self.assertEqual(s["parameters"]["cell"], 2.0)
        self.assertEqual(s["triangles_by_kind"]["level3"], 0)
        _, t_fine, s_fine = self.rec.reconstruct(self.sphere, R, mode="uniform", cell=1.0)
        self.assertGreater(len(t_fine), 2 * len(t))
        _, _, s_low = self.rec.reconstruct(self.sphere, R, curvature_threshold=0.05)
        self.assertEqual(s_low["parameters"]["curvature_threshold"], np.float32(0.05))
        self.assertEqual(s_adaptive["parameters"]["curvature_threshold"], np.float32(trilevel.default_curvature_threshold()))
        self.assertGreater(s_low["surface_cells_by_level"]["3"], s_adaptive["surface_cells_by_level"]["3"])

    def test_reused_reconstructor_and_one_shot_call_agree_bit_for_bit(self):
        v1, t1, _ = self.rec.reconstruct(self.sphere, R)
        v2, t2, _ = self.rec.reconstruct(self.sphere, R)
        v3, t3, _ = trilevel.reconstruct(self.sphere, particle_radius=R)
        for v, t in ((v2, t2), (v3, t3)):
            assert_bit_equal(self, v, v1)
            assert_bit_equal(self, t, t1)

    def test_other_dtypes_and_layouts_are_converted(self):
        v, t, _ = self.rec.reconstruct(self.sphere, R)
        for converted in (self.sphere.astype(np.float64), np.asfortranarray(self.sphere),
                          np.repeat(self.sphere, 2, axis=0)[::2]):
            cv, ct, _ = self.rec.reconstruct(converted, R)
            assert_bit_equal(self, cv, v)
            assert_bit_equal(self, ct, t)

    def test_results_are_handed_over_without_copies(self):
        v, t, _, level, kind = self.rec.reconstruct(self.sphere, R, return_levels=True)
        for a in (v, t, level, kind, self.sphere):
            self.assertFalse(a.flags.owndata)  # numpy did not allocate it ...
            self.assertEqual(type(a.base).__name__, "PyCapsule")  # ... the library's vector did
        self.assertEqual((level.shape, kind.shape), ((len(v),), (len(t),)))
        self.assertEqual(set(np.unique(level)) - {2, 3}, set())
        self.assertEqual(set(np.unique(kind)) - {0, 1, 2}, set())

    def test_one_reconstructor_shared_by_threads(self):
        v, t, _ = self.rec.reconstruct(self.sphere, R)
        results = [None] * 3

        def work(i):
            results[i] = self.rec.reconstruct(self.sphere, R)[:2]

        threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        for tv, tt in results:
            assert_bit_equal(self, tv, v)
            assert_bit_equal(self, tt, t)


class ErrorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.rec = trilevel.Reconstructor()
        cls.ok = trilevel.generate_scene("block", R)[:500]

    def assert_error(self, pattern, call, *args, **kwargs):
        with self.assertRaises(trilevel.Error) as caught:
            call(*args, **kwargs)
        message = str(caught.exception)
        self.assertIn(pattern, message)
        self.assertNotIn("\n", message)

    def test_error_is_a_runtime_error(self):
        self.assertTrue(issubclass(trilevel.Error, RuntimeError))

    def test_bad_input(self):
        bad = self.ok.copy()
        bad[7, 1] = np.nan
        self.assert_error("particle 7 has a non-finite coordinate", self.rec.reconstruct, bad, R)
        self.assert_error("positions must be an array of shape (n, 3), got shape (4, 2)",
                          self.rec.reconstruct, np.zeros((4, 2), np.float32), R)
        self.assert_error("got shape (12)", self.rec.reconstruct, np.zeros(12, np.float32), R)
        self.assert_error("no particles", self.rec.reconstruct, np.zeros((0, 3), np.float32), R)

    def test_bad_parameters(self):
        self.assert_error("particle radius", self.rec.reconstruct, self.ok, 0.0)
        self.assert_error("particle radius", self.rec.reconstruct, self.ok, float("nan"))
        self.assert_error("mode must be 'adaptive' or 'uniform', got 'fast'", self.rec.reconstruct, self.ok, R, mode="fast")
        self.assert_error("cell size", self.rec.reconstruct, self.ok, R, mode="uniform", cell=3.0)
        self.assert_error("kernel radius", self.rec.reconstruct, self.ok, R, kernel_radius=40.0)
        self.assert_error("curvature threshold", self.rec.reconstruct, self.ok, R, curvature_threshold=float("inf"))

    def test_io_errors_name_the_file(self):
        with tempfile.TemporaryDirectory() as tmp:
            missing = os.path.join(tmp, "missing.vtk")
            self.assert_error(missing, trilevel.read_particles, missing)
            self.assert_error(missing, trilevel.read_mesh, missing)
            out = os.path.join(tmp, "bad.ply")
            self.assert_error("references vertex 9", trilevel.write_mesh, out,
                              np.zeros((3, 3), np.float32), np.array([[0, 1, 9]], np.uint32))
            self.assertEqual(os.listdir(tmp), [])  # no partial file left behind


class IoTest(unittest.TestCase):
    def test_particles_and_meshes_round_trip(self):
        p = trilevel.generate_scene("dam-break", R)
        v, t, _, level, _ = trilevel.reconstruct(p, R, return_levels=True)
        with tempfile.TemporaryDirectory() as tmp:
            for ext in ("xyz", "ply", "vtk"):
                path = os.path.join(tmp, "p." + ext)
                trilevel.write_particles(path, p)
                assert_bit_equal(self, trilevel.read_particles(path), p)
            for ext in ("ply", "obj", "vtk"):
                path = os.path.join(tmp, "m." + ext)
                trilevel.write_mesh(path, v, t, vertex_level=level)
                rv, rt = trilevel.read_mesh(path)
                assert_bit_equal(self, rv, v)
                assert_bit_equal(self, rt, t)


class CliAgreementTest(unittest.TestCase):
    """The module and the CLI run the same library: same frame, same mesh, bit for bit."""

    def run_both(self, frame, tmp, *cli_args, **kwargs):
        cli = os.environ.get("TRILEVEL_CLI", "")
        if not os.path.isfile(cli):
            self.skipTest("SKIPPED: TRILEVEL_CLI does not name the trilevel binary")
        cli_mesh, cli_stats = os.path.join(tmp, "cli.ply"), os.path.join(tmp, "cli.json")
        subprocess.run([cli, "reconstruct", frame, "-r", str(R), "-o", cli_mesh, "--stats", cli_stats, "-q", *cli_args],
                       check=True)
        v, t, stats, level, _ = trilevel.reconstruct(trilevel.read_particles(frame), R, return_levels=True, **kwargs)
        cv, ct = trilevel.read_mesh(cli_mesh)
        assert_bit_equal(self, v, cv)
        assert_bit_equal(self, t, ct)
        with open(cli_stats) as f:
            expected = json.load(f)
        self.assertEqual(stats.keys(), expected.keys())
        for key in ("time_ms", "kernel_ms", "peak_memory_bytes"):  # measurements, not results
            del stats[key], expected[key]
        self.assertEqual(stats, expected)
        return v, t, level, cli_mesh

    def test_dam_break_frame_adaptive(self):
        frame = shared_frame("dam_break_frame_23_24389_particles.bgeo")
        with tempfile.TemporaryDirectory() as tmp:
            v, t, level, cli_mesh = self.run_both(frame, tmp)
            assert_closed(self, v, t)
            self.assertEqual(len(trilevel.read_particles(frame)), 24389)
            # Written from Python with the levels, the PLY file is the CLI's byte for byte.
            mine = os.path.join(tmp, "python.ply")
            trilevel.write_mesh(mine, v, t, vertex_level=level)
            with open(mine, "rb") as a, open(cli_mesh, "rb") as b:
                self.assertEqual(a.read(), b.read())

    def test_dam_break_frame_uniform(self):
        frame = shared_frame("dam_break_frame_23_24389_particles.bgeo")
        with tempfile.TemporaryDirectory() as tmp:
            self.run_both(frame, tmp, "--mode", "uniform", "--cell", "2", mode="uniform", cell=2.0)


class ReadmeTest(unittest.TestCase):
    def test_the_readme_python_snippet_runs(self):
        """README.md, section "Python": its code block runs as written and does what it says."""
        readme = os.path.join(os.path.dirname(__file__), "..", "..", "README.md")
        with open(readme) as f:
            section = f.read().split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
        code = section.split("```python\n", 1)[1].split("```", 1)[0]
        with tempfile.TemporaryDirectory() as tmp:
            cwd = os.getcwd()
            os.chdir(tmp)
            try:
                scope = {}
                exec(compile(code, "README.md", "exec"), scope)
            finally:
                os.chdir(cwd)
            v, t = trilevel.read_mesh(os.path.join(tmp, "surface.ply"))
        assert_closed(self, v, t)
        self.assertEqual(scope["stats"]["parameters"]["mode"], "uniform")
        self.assertIn("# %d triangles, closed: True" % len(t), code)  # the output the README shows


class DevicesTest(unittest.TestCase):
    def test_devices_are_listed(self):
        devices = trilevel.devices()
        self.assertGreater(len(devices), 0)
        self.assertEqual([d["index"] for d in devices], list(range(len(devices))))
        rec = trilevel.Reconstructor(devices[0]["index"])
        self.assertEqual(rec.device["name"], devices[0]["name"])
        with self.assertRaises(trilevel.Error):
            trilevel.Reconstructor(len(devices) + 5)


if __name__ == "__main__":
    unittest.main()
