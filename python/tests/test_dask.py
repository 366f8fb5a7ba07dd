"""trilevel.dask on a LocalCluster of 2 worker processes (Debian python3-distributed): every mesh is
byte-identical to the CLI's, each worker process keeps one Reconstructor, --skip-existing resumes,
a frame whose worker process dies is rerun elsewhere, and a bad frame fails alone.

The CLI is TRILEVEL_CLI, else `trilevel` on PATH; skipped with a message without distributed or the CLI.
"""
import os
import shutil
import subprocess
import tempfile
import unittest

import trilevel

try:
    import distributed

    import trilevel.dask
except ImportError:  # the tests skip with a message saying what is missing
    distributed = None

R = 0.025
FRAMES = 4


def num(i):
    """Frame i as `trilevel generate --frames` writes it."""
    return f"{i:04d}"


def cli_path():
    return os.environ.get("TRILEVEL_CLI") or shutil.which("trilevel") or ""


def needs_dask():
    if distributed is None:
        raise unittest.SkipTest("SKIPPED: dask.distributed is not importable (Debian python3-distributed)")


def needs_dask_and_cli():
    needs_dask()
    if not os.path.isfile(cli_path()):
        raise unittest.SkipTest("SKIPPED: neither TRILEVEL_CLI nor PATH gives the trilevel binary")


def cli(*args):
    subprocess.run([cli_path(), *args], check=True)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def local_cluster():
    """2 worker processes, one thread each, as the CI machine has 2 cores."""
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = distributed.Client(cluster)
    client.wait_for_workers(2)
    return cluster, client


class KillOnce:
    """Worker plugin: the worker process that starts the task of frame `number` first exits at once
    (os._exit, as a crash or an OOM kill would), leaving its pid in `marker`. Later attempts run."""

    name = "trilevel-test-kill-once"

    def __init__(self, number, marker):
        self.number, self.marker = number, marker

    def setup(self, worker):
        pass

    def teardown(self, worker):
        pass

    def transition(self, key, start, finish, **kwargs):
        if finish != "executing" or not str(key).startswith(f"trilevel-frame-{self.number}-"):
            return
        try:
            fd = os.open(self.marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        os._exit(1)


class FindFramesTest(unittest.TestCase):
    def setUp(self):
        needs_dask()

    def test_frames_are_found_and_ordered_as_the_cli_does(self):
        with tempfile.TemporaryDirectory() as tmp:
            for name in ("f_10.xyz", "f_2.xyz", "f_007.xyz", "f_7.xyz", "f_x.xyz", "f_.xyz", "g_3.xyz", "f_3.xyz.bak"):
                open(os.path.join(tmp, name), "w").close()
            self.assertEqual(trilevel.dask.find_frames(os.path.join(tmp, "f_{}.xyz")), ["2", "007", "7", "10"])
            jobs = trilevel.dask.plan_frames(os.path.join(tmp, "f_{}.xyz"), os.path.join(tmp, "m_{}.ply"), "", 3, 9)
            self.assertEqual([(j.number, os.path.basename(j.output)) for j in jobs], [("007", "m_007.ply"), ("7", "m_7.ply")])
            with self.assertRaisesRegex(ValueError, r"no frame in \[11, last\]; the files hold frames 2 to 10"):
                trilevel.dask.plan_frames(os.path.join(tmp, "f_{}.xyz"), os.path.join(tmp, "m_{}.ply"), start=11)
            with self.assertRaisesRegex(ValueError, "must contain"):
                trilevel.dask.plan_frames(os.path.join(tmp, "f_{}.xyz"), os.path.join(tmp, "m.ply"))
            with self.assertRaisesRegex(FileNotFoundError, "no frame files match"):
                trilevel.dask.find_frames(os.path.join(tmp, "h_{}.xyz"))
            with self.assertRaisesRegex(ValueError, "no level_hysteresis"):
                trilevel.dask.reconstruct_frames(os.path.join(tmp, "f_{}.xyz"), os.path.join(tmp, "m_{}.ply"), R,
                                                 level_hysteresis=0.2)

    def test_bad_runs_are_refused_before_any_work(self):
        with tempfile.TemporaryDirectory() as tmp:
            frames = os.path.join(tmp, "f_{}.ply")
            for i in (1, 2):
                trilevel.write_particles(frames.replace("{}", num(i)), trilevel.generate_scene("sphere", R))
            before = read(frames.replace("{}", num(1)))
            # Option values as reconstruct checks them, on this process: no cluster is started.
            with self.assertRaisesRegex(trilevel.Error, r"kernel radius must lie in \[1, 16\]"):
                trilevel.dask.reconstruct_frames(frames, os.path.join(tmp, "m_{}.ply"), R, kernel_radius=100.0)
            with self.assertRaisesRegex(trilevel.Error, "cell size 3 must be 4/n radii"):
                trilevel.dask.reconstruct_frames(frames, os.path.join(tmp, "m_{}.ply"), R, mode="uniform", cell=3.0)
            # Outputs that would overwrite a frame's input, or the mesh.
            with self.assertRaisesRegex(ValueError, f"frame {num(1)}: the mesh .* would overwrite the input"):
                trilevel.dask.reconstruct_frames(frames, frames, R)
            with self.assertRaisesRegex(ValueError, f"frame {num(1)}: the stats .* would overwrite the mesh"):
                trilevel.dask.plan_frames(frames, os.path.join(tmp, "m_{}.ply"), os.path.join(tmp, "m_{}.ply"))
            # Output names the writers do not take: refused before any frame is reconstructed.
            with self.assertRaisesRegex(trilevel.Error, "unknown mesh output extension 'foo'"):
                trilevel.dask.reconstruct_frames(frames, os.path.join(tmp, "m_{}.foo"), R)
            with self.assertRaisesRegex(ValueError, "unknown statistics extension 'txt', expected .json"):
                trilevel.dask.reconstruct_frames(frames, os.path.join(tmp, "m_{}.ply"), R,
                                                 stats_pattern=os.path.join(tmp, "s_{}.txt"))
            job = trilevel.dask.FrameJob(num(1), frames.replace("{}", num(1)), frames.replace("{}", num(1)))
            with self.assertRaisesRegex(ValueError, "would overwrite the input"):
                trilevel.dask.reconstruct_frame(job, R)
            # A lone name is not a sequence of its letters.
            with self.assertRaisesRegex(TypeError, "attributes must be a sequence of names"):
                trilevel.dask.reconstruct_frames(frames, os.path.join(tmp, "m_{}.ply"), R, attributes="velocity")
            self.assertEqual(read(frames.replace("{}", num(1))), before)
            self.assertEqual(sorted(os.listdir(tmp)), [f"f_{num(1)}.ply", f"f_{num(2)}.ply"])


class DaskTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        needs_dask_and_cli()
        cls.tmp = tempfile.mkdtemp()
        cls.pattern = os.path.join(cls.tmp, "d_{}.xyz")
        cli("generate", "falling-drop", "-o", cls.pattern, "--radius", str(R), "--frames", str(FRAMES))
        # The CLI's meshes of the frames as independent ones: a sequence with level hysteresis 0
        # (its default 0.2 holds levels from frame to frame; trilevel.dask does not).
        cli("reconstruct", cls.pattern, "-r", str(R), "-o", os.path.join(cls.tmp, "cli_{}.ply"), "-q",
            "--level-hysteresis", "0")
        cls.cluster, cls.client = local_cluster()

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.cluster.close()
        shutil.rmtree(cls.tmp)

    def out(self, name, number):
        return os.path.join(self.tmp, f"{name}_{number}.ply")

    def test_meshes_are_byte_identical_to_the_cli_and_each_worker_keeps_one_reconstructor(self):
        results = trilevel.dask.reconstruct_frames(self.pattern, os.path.join(self.tmp, "m_{}.ply"), R,
                                                   scheduler=self.client, stats_pattern=os.path.join(self.tmp, "s_{}.json"))
        self.assertEqual([r.number for r in results], [num(i) for i in range(FRAMES)])
        for r in results:
            self.assertEqual((r.status, r.closed, r.error), ("done", True, ""))
            self.assertEqual(read(self.out("m", r.number)), read(self.out("cli", r.number)), f"frame {r.number}")
            v, t = trilevel.read_mesh(self.out("m", r.number))
            self.assertEqual(r.triangles, len(t))
            self.assertTrue(os.path.isfile(os.path.join(self.tmp, f"s_{r.number}.json")))
        # Both processes worked, each with one Reconstructor for all its frames.
        by_worker = {}
        for r in results:
            by_worker.setdefault(r.worker, set()).add(r.reconstructor)
        self.assertEqual(len(by_worker), 2, by_worker)
        self.assertTrue(all(len(ids) == 1 for ids in by_worker.values()), by_worker)
        self.assertGreater(max(r.frames_on_reconstructor for r in results), 1)
        # A frame alone through the CLI (no sequence) gives the same bytes too.
        single = os.path.join(self.tmp, "single.ply")
        cli("reconstruct", os.path.join(self.tmp, f"d_{num(FRAMES - 1)}.xyz"), "-r", str(R), "-o", single, "-q")
        self.assertEqual(read(single), read(self.out("m", num(FRAMES - 1))))
        self.assertFalse([f for f in os.listdir(self.tmp) if ".tmp" in f])  # no temporary files left

    def test_smoothing_and_clipping_reach_the_frames_as_in_the_cli(self):
        box = "0.1,0.0,0.1,0.9,1.0,0.9"
        code = trilevel.dask.main([self.pattern, "-r", str(R), "-o", os.path.join(self.tmp, "sm_{}.ply"), "--end", "1",
                                   "--smooth", "--clip-box", box, "--scheduler", self.cluster.scheduler_address, "-q"])
        self.assertEqual(code, 0)
        for i in range(2):
            expected = os.path.join(self.tmp, f"smcli_{num(i)}.ply")
            cli("reconstruct", os.path.join(self.tmp, f"d_{num(i)}.xyz"), "-r", str(R), "-o", expected, "-q",
                "--smooth", "--clip-box", box)
            self.assertEqual(read(self.out("sm", num(i))), read(expected), f"frame {i}")

    def test_skip_existing_resumes(self):
        output = os.path.join(self.tmp, "r_{}.ply")
        first = trilevel.dask.reconstruct_frames(self.pattern, output, R, scheduler=self.client, end=2)
        self.assertEqual([r.status for r in first], ["done"] * 3)
        kept = os.stat(self.out("r", num(1))).st_mtime_ns
        os.remove(self.out("r", num(2)))
        again = trilevel.dask.reconstruct_frames(self.pattern, output, R, scheduler=self.client, skip_existing=True)
        self.assertEqual([r.status for r in again], ["skipped", "skipped"] + ["done"] * (FRAMES - 2))
        self.assertEqual(os.stat(self.out("r", num(1))).st_mtime_ns, kept)
        for i in range(FRAMES):
            self.assertEqual(read(self.out("r", num(i))), read(self.out("cli", num(i))))

    def test_a_bad_frame_fails_alone(self):
        with tempfile.TemporaryDirectory() as tmp:
            for i in range(3):
                shutil.copy(os.path.join(self.tmp, f"d_{num(i)}.xyz"), os.path.join(tmp, f"d_{i}.xyz"))
            with open(os.path.join(tmp, "d_1.xyz"), "w") as f:
                f.write("0 0 0\nnot a number\n")
            results = trilevel.dask.reconstruct_frames(os.path.join(tmp, "d_{}.xyz"), os.path.join(tmp, "m_{}.ply"), R,
                                                       scheduler=self.client, retries=1)
            self.assertEqual([r.status for r in results], ["done", "failed", "done"])
            self.assertTrue(results[1].error.startswith("frame 1: "), results[1].error)
            self.assertIn("d_1.xyz", results[1].error)
            self.assertFalse(os.path.exists(os.path.join(tmp, "m_1.ply")))
            self.assertEqual(read(os.path.join(tmp, "m_2.ply")), read(self.out("cli", num(2))))


class WorkerDeathTest(unittest.TestCase):
    def test_a_frame_whose_worker_dies_is_rerun_on_another(self):
        needs_dask_and_cli()
        with tempfile.TemporaryDirectory() as tmp:
            pattern = os.path.join(tmp, "d_{}.xyz")
            cli("generate", "falling-drop", "-o", pattern, "--radius", str(R), "--frames", "3")
            cli("reconstruct", pattern, "-r", str(R), "-o", os.path.join(tmp, "cli_{}.ply"), "-q", "--level-hysteresis", "0")
            marker = os.path.join(tmp, "killed.pid")
            cluster, client = local_cluster()
            try:
                client.register_worker_plugin(KillOnce(num(1), marker))
                results = trilevel.dask.reconstruct_frames(pattern, os.path.join(tmp, "m_{}.ply"), R, scheduler=client)
            finally:
                client.close()
                cluster.close()
            with open(marker) as f:
                killed = f.read()
            self.assertEqual([r.status for r in results], ["done"] * 3)
            self.assertNotEqual(results[1].worker.rsplit(":", 1)[1], killed)  # rerun in another process
            for i in range(3):
                self.assertEqual(read(os.path.join(tmp, f"m_{num(i)}.ply")), read(os.path.join(tmp, f"cli_{num(i)}.ply")))


if __name__ == "__main__":
    unittest.main()
