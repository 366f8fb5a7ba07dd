"""trilevel.FramePipeline: the meshes of Reconstructor.reconstruct frame by frame, in frame order."""
import os
import unittest
from unittest import mock

import numpy as np

import trilevel


def drop(frame):
    """A falling drop over a pool, moving with `frame` (the generated falling-drop, made here)."""
    rng = np.random.default_rng(7)
    g = np.mgrid[0:20, 0:6, 0:20].reshape(3, -1).T * 0.05
    pool = g + rng.uniform(-0.002, 0.002, g.shape)
    s = np.mgrid[-3:4, -3:4, -3:4].reshape(3, -1).T
    s = s[(s ** 2).sum(1) <= 9] * 0.05
    ball = s + np.array([0.5, 0.8 - 0.02 * frame, 0.5])
    return np.concatenate([pool, ball]).astype(np.float32)


class FramePipelineTest(unittest.TestCase):
    def test_same_meshes_as_frame_by_frame(self):
        one = trilevel.Reconstructor()
        expected = [one.reconstruct(drop(f), 0.025, level_hysteresis=0.2) for f in range(5)]
        rec = trilevel.Reconstructor()
        pipe = trilevel.FramePipeline(rec, 0.025, level_hysteresis=0.2)
        got = []
        for f in range(5):
            got += pipe.push(drop(f))
            if f == 2:
                got += pipe.push(np.full((10, 3), np.nan, np.float32))  # a bad frame fails alone
        got += pipe.finish()
        self.assertEqual([g[0] for g in got], list(range(6)))
        self.assertIsNone(got[3][1])
        self.assertIn("non-finite", got[3][3])
        good = got[:3] + got[4:]
        for (index, v, t, stats), (ev, et, estats) in zip(good, expected):
            self.assertTrue(np.array_equal(v, ev))
            self.assertTrue(np.array_equal(t, et))
            self.assertEqual(stats.get("level_flips"), estats.get("level_flips"))

    def test_triangulation_on_the_finisher_gives_the_same_meshes(self):
        # TRILEVEL_PIPELINE_FINISHER=1: each frame is triangulated on the pipeline's finisher thread
        # while the next frame's device stages run (the GPU default), here on the CPU device.
        expected = []
        one = trilevel.Reconstructor()
        for f in range(4):
            expected.append(one.reconstruct(drop(f), 0.025, level_hysteresis=0.2))
        with mock.patch.dict(os.environ, {"TRILEVEL_PIPELINE_FINISHER": "1"}):
            pipe = trilevel.FramePipeline(trilevel.Reconstructor(), 0.025, level_hysteresis=0.2)
            got = []
            for f in range(4):
                got += pipe.push(drop(f))
            got += pipe.finish()
        self.assertEqual([g[0] for g in got], list(range(4)))
        for (index, v, t, stats), (ev, et, estats) in zip(got, expected):
            self.assertTrue(np.array_equal(v, ev))
            self.assertTrue(np.array_equal(t, et))
            self.assertTrue(stats["closed"])
            self.assertEqual(stats.get("level_flips"), estats.get("level_flips"))
            self.assertEqual(stats["fine_points"], estats["fine_points"])

    def test_post_processing_keywords_as_in_reconstruct(self):
        box = (0.1, 0.0, 0.1, 0.9, 1.0, 0.9)
        options = dict(smooth=True, clip_box=box, remove_components_below=8.0)
        expected = [trilevel.Reconstructor().reconstruct(drop(f), 0.025, **options) for f in (0, 4)]
        pipe = trilevel.FramePipeline(trilevel.Reconstructor(), 0.025, **options)
        got = pipe.push(drop(0)) + pipe.push(drop(4)) + pipe.finish()
        self.assertEqual(len(got), 2)
        for (index, v, t, stats), (ev, et, estats) in zip(got, expected):
            self.assertTrue(np.array_equal(v, ev))
            self.assertTrue(np.array_equal(t, et))
            self.assertTrue(stats["closed"])
            self.assertTrue((v >= np.array(box[:3], np.float32) - 1e-6).all() and (v <= np.array(box[3:], np.float32) + 1e-6).all())


if __name__ == "__main__":
    unittest.main()
