#!/usr/bin/python3
"""The clutter bags' per-object ground truth (bags/clutter_*.truth.yaml, the `objects:` list
render_bag writes; issue 11 part 1) against facts that hold whatever produced it:

- at least four clutter bags, packed and piled, each beside its truth file;
- 3 or more objects, exactly one target, which is the truth's `object`; the others are its
  `distractors` in scene order; part labels 1 (target), 2, 3, ... are unique;
- every object seen (>= 150 noise-free points in frame 0), its 1 cm visible voxels on its own
  surface (within 1 cm) and not on another object's (each is nearer its own surface points than
  any other object's, up to a 2 mm tie where two objects touch), in front of the camera;
- each object's surface points span its height (top within 3 mm of height_m) and stay on or above
  the table plane;
- packed: every object stands on the table (lowest point within 5 mm of it) and within 1 cm of
  another object (they touch); piled: every object within 1 cm of another, and at least one lies
  on the others (lowest point > 2 cm above the table).

    /usr/bin/python3 test/clutter_truth_test.py
"""
import glob
import os
import sys
import unittest

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
BAGS = os.path.join(HERE, "..", "bags")
MIN_VISIBLE_POINTS = 150
TOUCH_M = 0.01          # 5 mm voxel centroids of two touching surfaces sit up to ~5 mm apart
ON_OWN_SURFACE_M = 0.01
CONTACT_TIE_M = 0.002   # where two objects touch, a visible voxel is as near one as the other
STANDING_M = 0.005
PILED_ABOVE_TABLE_M = 0.02
MAX_TRUTH_BYTES = 512 * 1024


def load(path):
    with open(path) as f:
        return yaml.load(f, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))


def nearest_distances(queries, points, chunk=2048):
    """Distance from each query to its nearest point (brute force in chunks; no scipy needed)."""
    out = np.empty(len(queries))
    for start in range(0, len(queries), chunk):
        q = queries[start:start + chunk]
        out[start:start + chunk] = np.sqrt(((q[:, None, :] - points[None, :, :]) ** 2).sum(axis=2).min(axis=1))
    return out


def quaternion_matrix(x, y, z, w):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


class ClutterTruthTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.paths = sorted(glob.glob(os.path.join(BAGS, "clutter_*.truth.yaml")))
        cls.truths = {os.path.basename(p)[:-len(".truth.yaml")]: load(p) for p in cls.paths}

    def scenes(self):
        for name, truth in self.truths.items():
            objects = truth["objects"]
            surfaces = [np.asarray(o["surface_points_5mm"], float) for o in objects]
            plane = np.asarray(truth["table_plane"], float)
            yield name, truth, objects, surfaces, plane

    def test_bundled_clutter_bags(self):
        names = list(self.truths)
        self.assertGreaterEqual(len(names), 4, names)
        self.assertTrue(any(n.startswith("clutter_packed") for n in names), names)
        self.assertTrue(any(n.startswith("clutter_piled") for n in names), names)
        for path in self.paths:
            bag = path[:-len(".truth.yaml")] + ".bag"
            self.assertTrue(os.path.exists(bag), bag)
            self.assertLess(os.path.getsize(bag), 4 * 1024 * 1024, bag)
            self.assertLess(os.path.getsize(path), MAX_TRUTH_BYTES, path)

    def test_objects_target_and_labels(self):
        for name, truth, objects, _, _ in self.scenes():
            with self.subTest(scene=name):
                self.assertEqual(truth["scene"], name)
                self.assertGreaterEqual(len(objects), 3)
                targets = [o for o in objects if o["target"]]
                self.assertEqual(len(targets), 1, [o["name"] for o in targets])
                target = targets[0]
                self.assertEqual(target["name"], truth["object"]["name"])
                self.assertEqual(target["label"], 1)
                self.assertEqual(target["visible_points"], truth["visible_points"])
                self.assertEqual(target["visible_points_1cm"], truth["visible_points_1cm"])
                self.assertEqual([o["name"] for o in objects if not o["target"]],
                                 [d["name"] for d in truth["distractors"]])
                labels = [o["label"] for o in objects]
                self.assertEqual(sorted(labels), list(range(1, len(objects) + 1)))
                self.assertEqual(len({o["name"] for o in objects}), len(objects))

    def test_every_object_seen_on_its_own_surface(self):
        for name, truth, objects, surfaces, _ in self.scenes():
            camera = truth["camera_pose"]
            eye = np.asarray(camera["position"], float)
            optical_z = quaternion_matrix(*camera["orientation_xyzw"])[:, 2]
            for i, o in enumerate(objects):
                with self.subTest(scene=name, object=o["name"]):
                    self.assertGreaterEqual(o["visible_points"], MIN_VISIBLE_POINTS)
                    visible = np.asarray(o["visible_points_1cm"], float)
                    self.assertGreater(len(visible), 0)
                    self.assertTrue(((visible - eye) @ optical_z > 0.4).all(), "points behind or too near the camera")
                    own = nearest_distances(visible, surfaces[i])
                    self.assertLess(own.max(), ON_OWN_SURFACE_M, "a visible voxel %.1f mm off the object"
                                    % (1e3 * own.max()))
                    others = np.min([nearest_distances(visible, s) for j, s in enumerate(surfaces) if j != i], axis=0)
                    on_other = int(np.sum(others < own - CONTACT_TIE_M))
                    self.assertEqual(on_other, 0, "%d visible voxels lie nearer another object" % on_other)
                    self.assertGreaterEqual(float(np.mean(own < others)), 0.9)

    def test_surfaces_on_the_table_up_to_their_height(self):
        for name, _, objects, surfaces, plane in self.scenes():
            for o, surface in zip(objects, surfaces):
                with self.subTest(scene=name, object=o["name"]):
                    self.assertGreater(len(surface), 20)
                    above = surface @ plane[:3] + plane[3]
                    self.assertGreater(above.min(), -0.002, "surface below the table")
                    self.assertAlmostEqual(above.max(), o["height_m"], delta=0.003)

    def test_packed_objects_stand_touching(self):
        for name, _, objects, surfaces, plane in self.scenes():
            if not name.startswith("clutter_packed"):
                continue
            for i, o in enumerate(objects):
                with self.subTest(scene=name, object=o["name"]):
                    self.assertLess((surfaces[i] @ plane[:3] + plane[3]).min(), STANDING_M, "not on the table")
                    gap = min(nearest_distances(surfaces[i], s).min() for j, s in enumerate(surfaces) if j != i)
                    self.assertLess(gap, TOUCH_M, "%.1f mm from every other object" % (1e3 * gap))

    def test_piled_objects_lie_on_each_other(self):
        piles = 0
        for name, _, objects, surfaces, plane in self.scenes():
            if not name.startswith("clutter_piled"):
                continue
            piles += 1
            lowest = [(s @ plane[:3] + plane[3]).min() for s in surfaces]
            with self.subTest(scene=name):
                self.assertGreater(max(lowest), PILED_ABOVE_TABLE_M, "nothing lies on another object")
            for i, o in enumerate(objects):
                with self.subTest(scene=name, object=o["name"]):
                    gap = min(nearest_distances(surfaces[i], s).min() for j, s in enumerate(surfaces) if j != i)
                    self.assertLess(gap, TOUCH_M, "%.1f mm from every other object" % (1e3 * gap))
        self.assertGreater(piles, 0)


if __name__ == "__main__":
    sys.path.insert(0, HERE)
    import pyunit_main
    pyunit_main.run("clutter_truth", ClutterTruthTest, sys.argv[1:])
