"""Tests of the trilevel Python module, run by CTest (`ctest -R python_module`) on the build tree
and by pytest on the pip-installed package (.ci/python-package.sh).

CTest sets PYTHONPATH to the built package, TRILEVEL_CLI to the CLI binary and TRILEVEL_SHARED_DIR
to ../shared (real SPH frames; those tests are skipped with a message when it is absent). Unset,
TRILEVEL_CLI is the `trilevel` command on PATH (a venv's, after `pip install .`) and
TRILEVEL_SHARED_DIR is ../shared beside this checkout.
"""
import json
import os
import pathlib
import shutil
import subprocess
import tempfile
import threading
import unittest
import warnings

import numpy as np

import trilevel

CHECKOUT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
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
    shared = os.environ.get("TRILEVEL_SHARED_DIR", os.path.join(CHECKOUT, "..", "shared"))
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
        _, _, s_checked = self.rec.reconstruct(self.sphere, R, curvature_threshold=8.0, level2_tolerance=0.5)
        self.assertEqual(s_checked["parameters"]["level2_tolerance"], np.float32(0.5))
        self.assertEqual(s_adaptive["parameters"]["level2_tolerance"], np.float32(0.32))  # on by default
        self.assertTrue(s_checked["closed"])

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

    def test_normals_are_unit_and_outward(self):
        v, t, _ = self.rec.reconstruct(self.sphere, R)
        radial = v - self.sphere.mean(axis=0)
        radial /= np.linalg.norm(radial, axis=1)[:, None]
        for mode in ("gradient", "area"):
            nv, nt, stats, normals = self.rec.reconstruct(self.sphere, R, normals=mode)
            assert_bit_equal(self, nv, v)  # normals do not change the mesh
            assert_bit_equal(self, nt, t)
            self.assertEqual(stats["parameters"]["normals"], mode)
            self.assertEqual((normals.shape, normals.dtype), (v.shape, np.float32))
            self.assertEqual(type(normals.base).__name__, "PyCapsule")
            length = np.linalg.norm(normals, axis=1)
            self.assertLess(np.abs(length - 1).max(), 1e-5, mode)
            self.assertGreater(np.mean(np.sum(normals * radial, axis=1)), 0.95, mode)
        _, _, stats = self.rec.reconstruct(self.sphere, R)
        self.assertEqual(stats["parameters"]["normals"], "none")

    def test_attributes_are_interpolated_at_the_vertices(self):
        n = len(self.sphere)
        rng = np.random.default_rng(5)
        noise = rng.uniform(-3.0, 7.0, n)
        attributes = {"density": np.full(n, 1000.5), "velocity": np.tile([0.25, -1.5, 3.0], (n, 1)), "noise": noise}
        v, t, _, level, kind, normals, out = self.rec.reconstruct(
            self.sphere, R, normals="area", attributes=attributes, return_levels=True)
        self.assertEqual((level.shape, kind.shape, normals.shape), ((len(v),), (len(t),), v.shape))
        self.assertEqual(list(out), ["density", "velocity", "noise"])  # the input's order
        self.assertEqual({k: (a.shape, a.dtype) for k, a in out.items()},
                         {"density": ((len(v),), np.float32), "velocity": ((len(v), 3), np.float32),
                          "noise": ((len(v),), np.float32)})
        # Shepard weights sum to one: constants come back exactly, anything else stays in its range.
        self.assertTrue(np.all(out["density"] == np.float32(1000.5)))
        self.assertTrue(np.all(out["velocity"] == np.float32([0.25, -1.5, 3.0])))
        self.assertGreaterEqual(out["noise"].min(), noise.astype(np.float32).min())
        self.assertLessEqual(out["noise"].max(), noise.astype(np.float32).max())
        self.assertGreater(np.std(out["noise"]), 0.0)
        # Attributes do not change the mesh.
        v0, t0, _ = self.rec.reconstruct(self.sphere, R)
        assert_bit_equal(self, v, v0)
        assert_bit_equal(self, t, t0)
        _, _, _, empty = self.rec.reconstruct(self.sphere, R, attributes={})
        self.assertEqual(empty, {})

    def test_crack_closing(self):
        scene = trilevel.generate_scene("pool-and-drop", R)
        _, tp, sp = self.rec.reconstruct(scene, R, curvature_threshold=0.5, crack_closing="patches")
        _, tc, sc = self.rec.reconstruct(scene, R, curvature_threshold=0.5)
        self.assertEqual(sp["crack_vertices_collapsed"], 0)
        self.assertGreater(sp["triangles_by_kind"]["patch"], 0)
        self.assertGreater(sc["crack_vertices_collapsed"], 0)
        self.assertEqual(len(tc) + 2 * sc["crack_vertices_collapsed"], len(tp))  # Euler: 2 triangles a vertex
        self.assertTrue(sc["closed"])
        self.assertEqual(sc["parameters"]["crack_closing"], "collapse")
        with self.assertRaisesRegex(trilevel.Error, "crack_closing must be 'collapse' or 'patches', got 'weld'"):
            self.rec.reconstruct(scene, R, crack_closing="weld")

    def test_clip_box_particle_box_and_small_components(self):
        scene = trilevel.generate_scene("pool-and-drop", R)
        box = (0.4, 0.1, 0.3, 2.4, 1.6, 2.6)
        v, t, stats, levels, kinds = trilevel.reconstruct(scene, R, clip_box=box, remove_components_below=20,
                                                          return_levels=True)
        assert_closed(self, v, t)
        self.assertTrue(stats["closed"])
        lo, hi = np.float32(box[:3]), np.float32(box[3:])
        self.assertTrue(np.all(v >= lo - 1e-4 * R) and np.all(v <= hi + 1e-4 * R))
        self.assertGreater(stats["clip_cap_triangles"], 0)
        self.assertLessEqual(stats["clip_cap_triangles"], int(np.sum(kinds == 2)))
        self.assertEqual(len(levels), len(v))
        self.assertEqual(stats["parameters"]["clip_box"]["min"], [np.float32(x) for x in box[:3]])
        # the particle box is the same as giving the particles inside
        pbox = (0.5, -1.0, 0.2, 2.0, 3.0, 2.2)
        inside = scene[np.all((scene >= np.float32(pbox[:3])) & (scene <= np.float32(pbox[3:])), axis=1)]
        v1, t1, s1 = trilevel.reconstruct(scene, R, particle_box=pbox)
        v2, t2, _ = trilevel.reconstruct(inside, R)
        assert_bit_equal(self, v1, v2)
        assert_bit_equal(self, t1, t2)
        self.assertEqual(s1["particles"], len(scene))
        self.assertEqual(s1["particles_outside_box"], len(scene) - len(inside))
        with self.assertRaisesRegex(trilevel.Error, "^clip_box must be six numbers"):
            trilevel.reconstruct(scene, R, clip_box=(0, 0, 0, 1, 1))
        with self.assertRaisesRegex(trilevel.Error, "^no particles inside the particle box"):
            trilevel.reconstruct(scene, R, particle_box=(9, 9, 9, 10, 10, 10))
        with self.assertRaisesRegex(trilevel.Error, "^remove-components-below must be finite"):
            trilevel.reconstruct(scene, R, remove_components_below=-1.0)

    def test_level_hysteresis_and_reset_history(self):
        frames = [trilevel.generate_scene("falling-drop", R, frame=f) for f in range(0, 24, 2)]
        held = {}  # curvature alone (check off) at threshold 4, which the scene's drops cross
        for h in (0.0, 0.2):
            rec = trilevel.Reconstructor()
            _, _, first = rec.reconstruct(frames[0], R, level_hysteresis=h, curvature_threshold=4.0, level2_tolerance=0.0)
            self.assertNotIn("level_flips", first)  # nothing to compare the first frame with
            self.assertEqual(first["parameters"]["level_hysteresis"], np.float32(h))
            held[h] = 0
            for p in frames[1:]:
                _, _, stats = rec.reconstruct(p, R, level_hysteresis=h, curvature_threshold=4.0, level2_tolerance=0.0)
                flips = stats["level_flips"]
                self.assertGreater(flips["compared"], 0)
                self.assertLessEqual(flips["changed"], flips["compared"])
                held[h] += flips["held_by_hysteresis"]
            # After reset_history the next frame is reconstructed as if alone: no comparison, and
            # the same mesh as a fresh Reconstructor gives.
            rec.reset_history()
            v, t, stats = rec.reconstruct(frames[-1], R, level_hysteresis=h, curvature_threshold=4.0, level2_tolerance=0.0)
            self.assertNotIn("level_flips", stats)
            fv, ft, _ = trilevel.reconstruct(frames[-1], R, level_hysteresis=h, curvature_threshold=4.0, level2_tolerance=0.0)
            assert_bit_equal(self, v, fv)
            assert_bit_equal(self, t, ft)
        self.assertEqual(held[0.0], 0)
        self.assertGreater(held[0.2], 0)


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
        self.assert_error("got shape (12,)", self.rec.reconstruct, np.zeros(12, np.float32), R)
        self.assert_error("no particles", self.rec.reconstruct, np.zeros((0, 3), np.float32), R)

    def test_bad_parameters(self):
        self.assert_error("particle radius", self.rec.reconstruct, self.ok, 0.0)
        self.assert_error("particle radius", self.rec.reconstruct, self.ok, float("nan"))
        self.assert_error("mode must be 'adaptive' or 'uniform', got 'fast'", self.rec.reconstruct, self.ok, R, mode="fast")
        self.assert_error("cell size", self.rec.reconstruct, self.ok, R, mode="uniform", cell=3.0)
        self.assert_error("kernel radius", self.rec.reconstruct, self.ok, R, kernel_radius=40.0)
        self.assert_error("curvature threshold", self.rec.reconstruct, self.ok, R, curvature_threshold=float("inf"))
        self.assert_error("level hysteresis must lie in [0, 1)", self.rec.reconstruct, self.ok, R, level_hysteresis=1.0)
        self.assert_error("normals must be None, 'gradient' or 'area', got 'flat'",
                          self.rec.reconstruct, self.ok, R, normals="flat")

    def test_bad_attributes(self):
        n = len(self.ok)
        self.assert_error(f"attribute 'velocity' must have shape ({n},) or ({n}, 3), one value per particle, "
                          f"got shape ({n}, 2)", self.rec.reconstruct, self.ok, R, attributes={"velocity": np.zeros((n, 2))})
        self.assert_error(f"got shape ({n - 1},)", self.rec.reconstruct, self.ok, R, attributes={"d": np.zeros(n - 1)})
        bad = np.ones(n)
        bad[3] = np.inf
        self.assert_error("particle attribute 'd': particle 3 has a non-finite value",
                          self.rec.reconstruct, self.ok, R, attributes={"d": bad})
        self.assert_error("attribute 'a' must be an array of numbers: ValueError: could not convert string to float",
                          self.rec.reconstruct, self.ok, R, attributes={"a": "abc"})
        self.assert_error("attribute 'o' must be an array of numbers", self.rec.reconstruct, self.ok, R,
                          attributes={"o": np.array([object()] * n)})

    def test_io_errors_name_the_file(self):
        with tempfile.TemporaryDirectory() as tmp:
            missing = os.path.join(tmp, "missing.vtk")
            self.assert_error(missing, trilevel.read_particles, missing)
            self.assert_error(missing, trilevel.read_mesh, missing)
            out = os.path.join(tmp, "bad.ply")
            self.assert_error("references vertex 9", trilevel.write_mesh, out,
                              np.zeros((3, 3), np.float32), np.array([[0, 1, 9]], np.uint32))
            self.assertEqual(os.listdir(tmp), [])  # no partial file left behind

    def test_write_mesh_refuses_values_a_cast_would_change(self):
        v = np.zeros((3, 3), np.float32)
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "m.ply")
            self.assert_error("triangles must be an integer array, got dtype float64",
                              trilevel.write_mesh, out, v, np.array([[0.0, 1.9, 2.0]]))
            self.assert_error("triangles must hold vertex indices from 0, got -4294967296 in triangle 0",
                              trilevel.write_mesh, out, v, np.array([[0, 1, 2]]) - 2**32)
            self.assert_error("vertex_level must be 2 or 3 per vertex, got 300 at vertex 0",
                              trilevel.write_mesh, out, v, [[0, 1, 2]], vertex_level=np.full(3, 300))
            self.assert_error("vertex_level must be an integer array", trilevel.write_mesh, out, v, [[0, 1, 2]],
                              vertex_level=np.full(3, 2.7))
            self.assertEqual(os.listdir(tmp), [])
            trilevel.write_mesh(out, v, [[0, 1, 2]], vertex_level=[2, 3, 3])  # lists of whole numbers are fine
            self.assertEqual(trilevel.read_mesh(out)[1].tolist(), [[0, 1, 2]])

    def test_frame_pipeline_checks_its_options_at_once(self):
        self.assert_error("kernel radius must lie in [1, 16]", trilevel.FramePipeline, self.rec, R, kernel_radius=100.0)
        self.assert_error("cell size 3 must be 4/n radii", trilevel.FramePipeline, self.rec, R, mode="uniform", cell=3.0)
        self.assert_error("particle radius", trilevel.FramePipeline, self.rec, 0.0)


class IoTest(unittest.TestCase):
    def test_paths_may_be_path_objects(self):
        p = trilevel.generate_scene("sphere", R)
        v, t, _ = trilevel.reconstruct(p, R)
        with tempfile.TemporaryDirectory() as tmp:
            base = pathlib.Path(tmp)
            trilevel.write_particles(base / "p.ply", p)
            assert_bit_equal(self, trilevel.read_particles(base / "p.ply"), p)
            trilevel.write_mesh(base / "m.ply", v, t)
            rv, rt = trilevel.read_mesh(base / "m.ply")
            assert_bit_equal(self, rv, v)
            assert_bit_equal(self, rt, t)

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

    def test_normals_and_attributes_round_trip(self):
        p = trilevel.generate_scene("sphere", R)
        v, t, _, level, _, normals, attributes = trilevel.reconstruct(
            p, R, return_levels=True, normals="gradient",
            attributes={"speed": np.linalg.norm(p, axis=1), "velocity": p * 2})
        with tempfile.TemporaryDirectory() as tmp:
            for ext in ("ply", "vtk", "obj"):
                path = os.path.join(tmp, "m." + ext)
                trilevel.write_mesh(path, v, t, vertex_level=level, normals=normals, attributes=attributes)
                rv, rt, rn, ra = trilevel.read_mesh(path, return_normals=True, return_attributes=True)
                assert_bit_equal(self, rv, v)
                assert_bit_equal(self, rt, t)
                assert_bit_equal(self, rn, normals)
                if ext == "obj":  # OBJ cannot hold attributes
                    self.assertEqual(ra, {})
                    continue
                self.assertEqual(list(ra), ["speed", "velocity"])
                for name in ra:
                    assert_bit_equal(self, ra[name], attributes[name])
            trilevel.write_mesh(os.path.join(tmp, "plain.ply"), v, t)
            self.assertIsNone(trilevel.read_mesh(os.path.join(tmp, "plain.ply"), return_normals=True)[2])

    def test_read_particles_with_attributes(self):
        frame = shared_frame("double_dam_break_frame_26_4732_particles.vtk")
        positions, attributes = trilevel.read_particles(frame, attributes=["velocity"])
        assert_bit_equal(self, positions, trilevel.read_particles(frame))  # the plain call: an array
        self.assertEqual(list(attributes), ["velocity"])
        velocity = attributes["velocity"]
        self.assertEqual((velocity.shape, velocity.dtype), ((4732, 3), np.float32))
        self.assertTrue(np.all(np.isfinite(velocity)))
        self.assertGreater(np.abs(velocity).max(), 0.1)  # a moving fluid, not zeros
        only_positions, none = trilevel.read_particles(frame, [])  # a list, even empty: a pair
        assert_bit_equal(self, only_positions, positions)
        self.assertEqual(none, {})
        with self.assertRaises(trilevel.Error) as caught:
            trilevel.read_particles(frame, attributes=["pressure"])
        self.assertIn("no point attribute 'pressure' (the file has: id, velocity)", str(caught.exception))

    def test_read_particles_drops_invalid_ones_when_asked(self):
        p = trilevel.generate_scene("block", R)[:100].copy()
        p[5, 1] = np.nan
        p[70, 2] = np.inf
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "nan.xyz")  # .xyz: little-endian float32 triplets
            p.astype("<f4").tofile(path)
            with self.assertRaises(trilevel.Error) as caught:
                trilevel.read_particles(path)
            self.assertIn("particle 5: non-finite coordinate", str(caught.exception))
            with warnings.catch_warnings(record=True) as caught_warnings:
                warnings.simplefilter("always")
                kept = trilevel.read_particles(path, drop_invalid=True)
            self.assertEqual([str(w.message) for w in caught_warnings],
                             [f"{path}: dropped 2 particles with NaN/Inf coordinates"])
            self.assertIs(caught_warnings[0].category, RuntimeWarning)
            assert_bit_equal(self, kept, np.delete(p, [5, 70], axis=0))


class CliAgreementTest(unittest.TestCase):
    """The module and the CLI run the same library: same frame, same mesh, bit for bit."""

    def cli(self, *args):
        cli = os.environ.get("TRILEVEL_CLI") or shutil.which("trilevel") or ""
        if not os.path.isfile(cli):
            self.skipTest("SKIPPED: neither TRILEVEL_CLI nor PATH gives the trilevel binary")
        subprocess.run([cli, *args], check=True)

    def assert_same_stats(self, stats, cli_stats_path):
        with open(cli_stats_path) as f:
            expected = json.load(f)
        self.assertEqual(stats.keys(), expected.keys())
        for key in ("time_ms", "kernel_ms", "peak_memory_bytes"):  # measurements, not results
            del stats[key], expected[key]
        self.assertEqual(stats, expected)

    def run_both(self, frame, tmp, cli_args, attributes=(), **kwargs):
        """Reconstructs `frame` with the CLI given `cli_args` and with the module given `kwargs` (the
        same parameters, and the particle `attributes` named); checks that the meshes, normals,
        attributes and statistics agree and that write_mesh writes the CLI's PLY file byte for byte."""
        cli_mesh, cli_stats = os.path.join(tmp, "cli.ply"), os.path.join(tmp, "cli.json")
        self.cli("reconstruct", frame, "-r", str(R), "-o", cli_mesh, "--stats", cli_stats, "-q", *cli_args)
        if attributes:
            positions, kwargs["attributes"] = trilevel.read_particles(frame, attributes=list(attributes))
        else:
            positions = trilevel.read_particles(frame)
        v, t, stats, level, _, *extra = trilevel.reconstruct(positions, R, return_levels=True, **kwargs)
        normals = extra.pop(0) if kwargs.get("normals") else None
        vertex_attributes = extra.pop(0) if attributes else {}
        cv, ct, cn, ca = trilevel.read_mesh(cli_mesh, return_normals=True, return_attributes=True)
        assert_bit_equal(self, v, cv)
        assert_bit_equal(self, t, ct)
        if normals is None:
            self.assertIsNone(cn)
        else:
            assert_bit_equal(self, normals, cn)
        self.assertEqual(list(ca), list(attributes))
        for name in attributes:
            assert_bit_equal(self, vertex_attributes[name], ca[name])
        self.assert_same_stats(stats, cli_stats)
        mine = os.path.join(tmp, "python.ply")
        trilevel.write_mesh(mine, v, t, vertex_level=level, normals=normals, attributes=vertex_attributes or None)
        with open(mine, "rb") as a, open(cli_mesh, "rb") as b:
            self.assertEqual(a.read(), b.read())
        return v, t

    def test_dam_break_frame_adaptive(self):
        frame = shared_frame("dam_break_frame_23_24389_particles.bgeo")
        with tempfile.TemporaryDirectory() as tmp:
            # 0.2: the CLI's level hysteresis (README); on a single file it only shows in the parameters.
            v, t = self.run_both(frame, tmp, [], level_hysteresis=0.2)
            assert_closed(self, v, t)
            self.assertEqual(len(trilevel.read_particles(frame)), 24389)

    def test_dam_break_frame_uniform(self):
        frame = shared_frame("dam_break_frame_23_24389_particles.bgeo")
        with tempfile.TemporaryDirectory() as tmp:
            self.run_both(frame, tmp, ["--mode", "uniform", "--cell", "2", "--level-hysteresis", "0"],
                          mode="uniform", cell=2.0)

    def test_normals_and_attributes(self):
        frame = shared_frame("double_dam_break_frame_26_4732_particles.vtk")
        with tempfile.TemporaryDirectory() as tmp:
            v, t = self.run_both(frame, tmp, ["--normals", "--attribute", "velocity"], attributes=["velocity"],
                                 normals="gradient", level_hysteresis=0.2)
            assert_closed(self, v, t)
            self.run_both(frame, tmp, ["--normals", "area", "--level-hysteresis", "0"], normals="area")

    def test_frame_sequence_with_level_hysteresis(self):
        """The CLI reconstructs a sequence on one Reconstructor with level hysteresis 0.2; so does a
        Reconstructor in Python, frame by frame, level changes included."""
        with tempfile.TemporaryDirectory() as tmp:
            frames = [trilevel.generate_scene("falling-drop", R, frame=f) for f in (0, 3, 6, 9)]
            for i, p in enumerate(frames):
                trilevel.write_particles(os.path.join(tmp, f"d_{i}.xyz"), p)
            self.cli("reconstruct", os.path.join(tmp, "d_{}.xyz"), "-r", str(R), "-o", os.path.join(tmp, "m_{}.ply"),
                     "--stats", os.path.join(tmp, "s_{}.json"), "-q")
            rec = trilevel.Reconstructor()
            for i, p in enumerate(frames):
                v, t, stats = rec.reconstruct(p, R, level_hysteresis=0.2)
                self.assertEqual("level_flips" in stats, i > 0)
                cv, ct = trilevel.read_mesh(os.path.join(tmp, f"m_{i}.ply"))
                assert_bit_equal(self, v, cv)
                assert_bit_equal(self, t, ct)
                self.assert_same_stats(stats, os.path.join(tmp, f"s_{i}.json"))


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
            sv, st, normals, attributes = trilevel.read_mesh(os.path.join(tmp, "shaded.ply"), return_normals=True,
                                                             return_attributes=True)
        assert_closed(self, v, t)
        assert_bit_equal(self, sv, v)
        assert_bit_equal(self, st, t)
        self.assertEqual((normals.shape, list(attributes), attributes["velocity"].shape), (v.shape, ["velocity"], v.shape))
        # The drop's vertices move down at 2, the pool's rest; in between only where both are near.
        vy = attributes["velocity"][:, 1]
        self.assertTrue(np.all(attributes["velocity"][:, [0, 2]] == 0))
        self.assertEqual((vy.min(), vy.max()), (-2, 0))
        self.assertGreater(np.mean((vy == -2) | (vy == 0)), 0.99)
        self.assertEqual(scope["stats"]["parameters"]["level_hysteresis"], np.float32(0.2))
        self.assertGreater(scope["stats"]["level_flips"]["compared"], 0)
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
