#!/usr/bin/python3
"""The soak's memory target (scripts/soak.py MemorySampler.growth) on VmRSS series whose answer
is known by construction: a manager whose RSS swings by whole camera frames from sample to
sample but holds its level is not growing; one that keeps one more frame per minute is."""
import os
import random
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import soak  # noqa: E402

FRAME_KB = 9600  # one 640x480 XYZRGB PointCloud2 (32 B a point), 9.4 MiB
BASE_KB = 88 * 1024
NAME = "/fast_grasp_manager"


def sampler_with(series, pid=4242):
    sampler = soak.MemorySampler.__new__(soak.MemorySampler)  # no thread: samples given
    sampler.samples = {NAME: [(t, pid, kb) for t, kb in series]}
    return sampler


def ten_minutes(rss_at):
    return [(t, rss_at(t)) for t in range(0, 601, 2)]


class SoakMemoryTest(unittest.TestCase):
    def test_frames_in_flight_at_a_steady_level_are_not_growth(self):
        # 0-4 frames in flight at each sample (as with one malloc arena at 30 Hz), no trend.
        rng = random.Random(3)
        sampler = sampler_with(ten_minutes(lambda t: BASE_KB + FRAME_KB * rng.choice([0, 0, 0, 1, 2, 4])))
        base, last, pct = sampler.growth(NAME, 60.0)
        self.assertLess(abs(pct), 5.0, (base, last, pct))

    def test_one_frame_kept_per_minute_is_growth(self):
        # A leak of one frame a minute: 9 frames over the 9 minutes after warm-up (~+90 %).
        sampler = sampler_with(ten_minutes(lambda t: BASE_KB + FRAME_KB * (t // 60)))
        base, last, pct = sampler.growth(NAME, 60.0)
        self.assertEqual(base, BASE_KB + FRAME_KB)
        self.assertEqual(last, BASE_KB + FRAME_KB * 9)
        self.assertGreater(pct, 50.0)

    def test_a_respawned_manager_is_measured_on_its_own_samples(self):
        # Respawned during the warm-up: the dead process's larger RSS is not the new one's growth.
        first = [(t, BASE_KB * 3) for t in range(0, 30, 2)]
        second = [(t, BASE_KB) for t in range(30, 601, 2)]
        sampler = sampler_with(first)
        sampler.samples[NAME] += [(t, 777, kb) for t, kb in second]
        base, last, pct = sampler.growth(NAME, 60.0)
        self.assertEqual((base, last), (BASE_KB, BASE_KB))

    def test_too_few_samples(self):
        self.assertIsNone(sampler_with([]).growth(NAME, 60.0))
        self.assertIsNone(sampler_with([(0.0, BASE_KB)]).growth(NAME, 60.0))


if __name__ == "__main__":
    sys.path.insert(0, HERE)
    import pyunit_main
    pyunit_main.run("soak_memory", SoakMemoryTest, sys.argv[1:])
