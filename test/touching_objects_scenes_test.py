#!/usr/bin/env python3
"""Touching and hidden objects come out as one cluster each (issue 11 part 2), end to end.

Each scene of test/scenes/ is rendered by grasp_offline's Xtion renderer (noise, quantisation,
projector shadows) and segmented as `demo.launch split_touching_objects:=true all_objects:=true`
does; every object of the scene must be one cluster, found where the scene puts it:
- two boxes standing side by side, touching: two clusters (Euclidean clustering alone: one);
- a cup leaning on a bottle, its rim touching the bottle's side: two (Euclidean alone: one);
- a box whose middle a nearer bottle hides: two, the box's two visible ends joined (the
  occlusion join; without it three).

    /usr/bin/python3 test/touching_objects_scenes_test.py --grasp-offline .ws/devel/lib/fast_grasp/grasp_offline
"""
import json
import os
import subprocess
import sys
import unittest

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import pyunit_main  # noqa: E402

GRASP_OFFLINE = None  # set from --grasp-offline
# Scene -> where each object's middle is (x, y of base_link, from the scene YAML's geometry).
OBJECTS = {
    "two_touching_boxes": {"tall_box": (0.50, 0.04), "low_box": (0.52, -0.03)},
    # the cup's axis leans 20 deg toward +y from its base centre (0.5, -0.0435): mid-height y
    # = -0.0435 + 0.045 sin(20 deg)
    "cup_leaning_on_bottle": {"bottle": (0.50, 0.06), "cup": (0.50, -0.028)},
    "box_behind_bottle": {"bottle": (0.45, 0.0), "box": (0.60, 0.0)},
}
# The camera sees an object's near side, so a cluster's centroid lies up to half the object's
# depth nearer than its middle; the objects' middles are >= 7 cm apart.
MATCH_M = 0.035


def clusters(scene, *flags):
    """Centroids (x, y) of the clusters grasp_offline's perception found in the scene."""
    run = subprocess.run([GRASP_OFFLINE, "--scene", os.path.join(HERE, "scenes", scene + ".yaml"), "--all-objects",
                          "--algorithm", "fused", "--gripper", "robotiq_2f85", "--format", "json"] + list(flags),
                         capture_output=True, text=True)
    report = json.loads(run.stdout)
    return [np.array(o["centroid"][:2]) for o in report.get("objects", [])], report


class TouchingObjectsScenesTest(unittest.TestCase):
    def check_one_cluster_each(self, scene, *flags):
        found, report = clusters(scene, *flags)
        expected = OBJECTS[scene]
        summary = "%s %s: clusters at %s (%s)" % (scene, " ".join(flags), [list(np.round(c, 3)) for c in found],
                                                 report.get("message", "")[:200])
        self.assertEqual(len(found), len(expected), summary)
        for name, middle in expected.items():
            near = [c for c in found if np.linalg.norm(c - np.array(middle)) < MATCH_M]
            self.assertEqual(len(near), 1, "%s: %s, not one cluster within %.3f m of %s" % (summary, name, MATCH_M, middle))

    def test_two_touching_boxes_are_two_clusters(self):
        self.check_one_cluster_each("two_touching_boxes", "--split-touching-objects")
        self.assertEqual(len(clusters("two_touching_boxes")[0]), 1, "Euclidean clusters alone merge them")

    def test_a_cup_leaning_on_a_bottle_is_two_clusters(self):
        self.check_one_cluster_each("cup_leaning_on_bottle", "--split-touching-objects")
        self.assertEqual(len(clusters("cup_leaning_on_bottle")[0]), 1, "Euclidean clusters alone merge them")

    def test_a_box_hidden_in_the_middle_is_one_cluster(self):
        self.check_one_cluster_each("box_behind_bottle")
        self.check_one_cluster_each("box_behind_bottle", "--split-touching-objects")


if __name__ == "__main__":
    args = sys.argv[1:]
    GRASP_OFFLINE = pyunit_main.take_flag(args, "--grasp-offline")
    pyunit_main.run("touching_objects_scenes", TouchingObjectsScenesTest, args)
