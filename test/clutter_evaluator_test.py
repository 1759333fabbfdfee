#!/usr/bin/env python3
"""The clutter scenes and clearance loop (scripts/grasp_physics/clutter.py,
scripts/evaluate_clutter_physics.py, issue 11 parts 1 and 4): a packed table's objects end
upright and touching, a piled table settles with every object on the table and some resting on
others, and at rest (one more second of physics moves nothing), a grasp in clutter that lifts
one object names it, and a fixed 3-object packed table is cleared end to end through
grasp_offline with the same result twice (the second time picked out of a longer run with
--only-tables, its scenes kept with --keep-scenes).

Runs in the evaluator's venv (scripts/setup_venv.sh):
    .ws/venv/bin/python test/clutter_evaluator_test.py --grasp-offline .ws/devel/lib/fast_grasp/grasp_offline
"""
import csv
import math
import os
import subprocess
import sys
import tempfile
import unittest

import mujoco
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "scripts"))
sys.path.insert(0, HERE)
from grasp_physics import clutter  # noqa: E402
from grasp_physics import gripper as gripper_lib  # noqa: E402
from grasp_physics import objects as objects_lib  # noqa: E402
import pyunit_main  # noqa: E402

GRASP_OFFLINE = None
OBJECTS_YAML = os.path.join(ROOT, "config/evaluation/objects.yaml")
# parametric training objects only: the suite needs no YCB download and no convex decomposition
PACKED_OBJECTS = ["can_soup", "box_juice", "cup_paper", "bottle_small"]
PILED_OBJECTS = ["can_soup", "box_soap", "box_juice", "can_tuna", "sphere_d60"]
# cups and round bodies: they rock for seconds where they land on each other
ROCKING_OBJECTS = ["glass_shot", "cup_paper", "ellipsoid_flat", "ellipsoid_lemon", "cup_mug_plain"]


def parametric(names):
    objs = objects_lib.load_objects(OBJECTS_YAML, None, tempfile.gettempdir(), names=names, kinds=("parametric",))
    by_name = {o.name: o for o in objs}
    return [by_name[n] for n in names]


def robotiq():
    return gripper_lib.load_gripper(os.path.join(ROOT, "config/grippers/robotiq_2f85.yaml"))


def footprint_gap(scene, poses, a, b):
    """Closest distance between the convex footprints of objects a and b (0 when overlapping)."""
    from scipy.spatial import Delaunay, cKDTree
    fa = clutter._footprint(scene.world_vertices(a, poses[a])[:, :2])
    fb = clutter._footprint(scene.world_vertices(b, poses[b])[:, :2])
    if (Delaunay(fa).find_simplex(fb) >= 0).any() or (Delaunay(fb).find_simplex(fa) >= 0).any():
        return 0.0
    return float(cKDTree(fa).query(fb)[0].min())


class ClutterTest(unittest.TestCase):
    def test_packed_objects_stand_touching(self):
        objs = parametric(PACKED_OBJECTS)
        scene, poses = clutter.make_table("packed", objs, robotiq(), np.random.default_rng(5))
        self.assertEqual([o.name for o in scene.objs], PACKED_OBJECTS)
        for k, (pos, quat) in enumerate(poses):
            # standing: upright (the config orientation, turned about z only) on the table top
            self.assertLess(np.linalg.norm(quat[1:3]), 0.02, (objs[k].name, quat))
            self.assertAlmostEqual(scene.world_vertices(k, (pos, quat))[:, 2].min(), 0.0, delta=0.003)
            # touching: every object within 2 mm of another (what a depth camera cannot separate)
            gaps = [footprint_gap(scene, poses, k, j) for j in range(len(objs)) if j != k]
            self.assertLess(min(gaps), 0.002, (objs[k].name, gaps))
        spread = np.ptp([p[0][:2] for p in poses], axis=0)
        self.assertLess(spread.max(), 0.25)

    def test_piled_objects_settle_on_the_table_and_on_each_other(self):
        objs = parametric(PILED_OBJECTS)
        # seed 0: the first seed whose drops come to rest on each other (11 of seeds 0-15 do; the
        # others roll apart on the table, which the clearance protocol also allows)
        scene, poses = clutter.make_table("piled", objs, robotiq(), np.random.default_rng(0))
        self.assertGreaterEqual(len(scene.objs), 3)
        for k, pose in enumerate(poses):
            z = scene.world_vertices(k, pose)[:, 2]
            self.assertGreater(z.min(), -0.003, scene.objs[k].name)  # above the table top
            self.assertLess(np.linalg.norm(pose[0][:2] - np.asarray(clutter.CLUTTER_CENTRE_XY_M)),
                            clutter.WORKSPACE_RADIUS_M)
        # settled: nothing moves any more
        scene.set_poses(poses)
        again = scene.settle(max_s=0.3, min_s=0.3)
        for (p0, _), (p1, _) in zip(poses, again):
            self.assertLess(np.linalg.norm(p1 - p0), 0.003)
        # a pile: at least one object rests on another one, not only on the table
        pairs = scene.contact_pairs()
        self.assertTrue(any(a.startswith("object") and b.startswith("object") for a, b in pairs), pairs)

    def test_a_piled_table_is_at_rest(self):
        # Seed 19: a pile the first-slow-step settle (until session 40) left moving, 8.5 mm and
        # 11.5 deg in the next second (with it, 6 of seeds 0-39 of these objects did; now 1). At
        # rest means it stays put under one more second of physics.
        scene, poses = clutter.make_table("piled", parametric(ROCKING_OBJECTS), robotiq(), np.random.default_rng(19))
        scene.set_poses(poses)
        for _ in range(int(1.0 / scene.model.opt.timestep)):
            mujoco.mj_step(scene.model, scene.data)
        for k, ((p0, q0), (p1, q1)) in enumerate(zip(poses, scene.poses())):
            turned_deg = math.degrees(2.0 * math.acos(min(1.0, abs(float(np.dot(q0, q1))))))
            self.assertLess(np.linalg.norm(p1 - p0), 0.003, scene.objs[k].name)
            self.assertLess(turned_deg, 3.0, scene.objs[k].name)

    def test_same_seed_same_table(self):
        a = clutter.make_table("piled", parametric(PILED_OBJECTS), robotiq(), np.random.default_rng(11))[1]
        b = clutter.make_table("piled", parametric(PILED_OBJECTS), robotiq(), np.random.default_rng(11))[1]
        self.assertEqual(len(a), len(b))
        for (pa, qa), (pb, qb) in zip(a, b):
            np.testing.assert_array_equal(pa, pb)
            np.testing.assert_array_equal(qa, qb)

    def test_top_down_grasp_lifts_one_object_out_of_a_packed_row(self):
        # box_juice (6.3 x 4 x 10.5 cm) between two cans touching its 4 cm ends: closing from
        # above across the free 4 cm side lifts the box alone, the cans stay
        objs = parametric(["can_soup", "box_juice", "can_energy"])
        g = robotiq()
        scene = clutter.ClutterScene(objs, g)
        xs = (0.5 - 0.0315 - 0.0335 - 0.001, 0.5, 0.5 + 0.0315 + 0.0265 + 0.001)
        poses = [(np.array([x, 0.0, 0.001]), np.array([1.0, 0, 0, 0])) for x in xs]
        scene.set_poses(poses)
        poses = scene.settle()
        top = poses[1][0][2] + 0.105
        approach, closing = np.array([0, 0, -1.0]), np.array([0, 1.0, 0])
        rotation = np.stack([approach, closing, np.cross(approach, closing)], axis=1)
        centre = np.array([poses[1][0][0], poses[1][0][1], top - g["finger_depth_m"] / 2.0 + 0.006])
        outcome = scene.execute(poses, rotation, centre)
        self.assertTrue(outcome["success"], outcome)
        self.assertEqual(outcome["grasped"], 1, outcome)
        self.assertEqual(outcome["lifted_together"], 1, outcome)
        self.assertEqual(outcome["touched_first"], -1, outcome)  # the open fingers clear all three

        # Closing along the row instead (across the box's 6.3 cm, the hand open 8.5 cm): the
        # fingers come down on the cans beside the box, and the first object touched is a can.
        along = np.array([1.0, 0, 0])
        rotation = np.stack([approach, along, np.cross(approach, along)], axis=1)
        scene.set_poses(poses)
        outcome = scene.execute(poses, rotation, centre)
        self.assertTrue(outcome["unexpected_contact"], outcome)
        self.assertIn(outcome["touched_first"], (0, 2), outcome)

    def test_interval_over_tables(self):
        import evaluate_clutter_physics as clutter_eval
        # every table alike: any resample of them has the same rate, so the interval is that rate
        same = [{"successes": 4, "attempts": 5}] * 10
        self.assertEqual(clutter_eval.interval_over_tables(same, "successes", "attempts"), (80.0, 80.0))
        # half the tables 5 of 5, half 0 of 5 (50 %): resampling 10 tables moves the rate a lot
        # (binomial(10, 1/2) tables of 5 / 10: 2.5 % of resamples at or below 2 of 10, 20 %)
        split = [{"successes": 5, "attempts": 5}] * 5 + [{"successes": 0, "attempts": 5}] * 5
        lo, hi = clutter_eval.interval_over_tables(split, "successes", "attempts")
        self.assertTrue(10.0 <= lo <= 30.0 and 70.0 <= hi <= 90.0, (lo, hi))
        self.assertEqual((lo, hi), clutter_eval.interval_over_tables(split, "successes", "attempts"))  # seeded
        nan = clutter_eval.interval_over_tables([], "successes", "attempts")
        self.assertTrue(all(v != v for v in nan))

    def test_the_summary_line_names_the_views_a_planning_call_may_take(self):
        import evaluate_clutter_physics as clutter_eval
        # One table of 3 objects, 2 attempts, 1 success: 50 % success, 33 % cleared. The issue's
        # protocol plans from one view; following the table's next view is labelled apart.
        tables = [{"planner": "fused", "arrangement": "packed", "attempts": 2, "successes": 1, "objects_placed": 3,
                   "cleared": 1, "end": "no grasp"}]
        rows = [{"planner": "fused", "arrangement": "packed", "target_cluster_objects": 1}]
        for views, label in ((0, "clutter-packed"), (1, "clutter-packed-within-2-views")):
            _, lines = clutter_eval.summarise(tables, rows, ["fused"], ["packed"], "robotiq_2f85", views)
            self.assertEqual(lines, ["fused robotiq_2f85 %s: success 50 %% cleared 33 %%" % label])
        with self.assertRaises(SystemExit):
            clutter_eval.parse_args(["--follow-next-view", "-1"])

    def test_fixed_packed_table_cleared_twice_the_same(self):
        def run(out_dir, extra=("--tables", "1")):
            cmd = [sys.executable, os.path.join(ROOT, "scripts/evaluate_clutter_physics.py"), "--planners", "fused",
                   "--gripper", "robotiq_2f85", "--objects-per-table", "3,3",
                   "--arrangements", "packed", "--kinds", "parametric", "--objects", ",".join(PACKED_OBJECTS[:3]),
                   "--seed", "3", "--jobs", "1", "--out-dir", out_dir, "--grasp-offline", GRASP_OFFLINE] + list(extra)
            result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
            with open(os.path.join(out_dir, "attempts.csv")) as f:
                attempts = list(csv.DictReader(f))
            with open(os.path.join(out_dir, "tables.csv")) as f:
                tables = list(csv.DictReader(f))
            return result.stdout.strip().splitlines(), attempts, tables

        lines, attempts, tables = run(tempfile.mkdtemp(prefix="fg_clutter_a_"))
        self.assertRegex(lines[-1], r"^fused robotiq_2f85 clutter-packed: success \d+ % cleared \d+ %$")
        self.assertIn("ONE target cluster", "\n".join(lines))
        self.assertEqual(len(tables), 1)
        self.assertEqual(tables[0]["objects_placed"], "3")
        self.assertIn(tables[0]["end"], ("empty", "no grasp", "two failures in a row"))
        self.assertGreaterEqual(len(attempts), 1)
        for a in attempts:
            self.assertNotEqual(a["unstable"], "True", a)
        # counts agree with the attempts
        successes = sum(a["success"] == "True" for a in attempts)
        self.assertEqual(int(tables[0]["successes"]), successes)
        self.assertEqual(int(tables[0]["cleared"]), successes)
        self.assertEqual(sum(a["grasped_object"] != "" for a in attempts), successes)
        # determinism: the same seed gives the same attempts, grasps and summary; a table
        # picked out of a longer run with --only-tables is that same table, and --keep-scenes
        # leaves each attempt's scene to replay
        kept = tempfile.mkdtemp(prefix="fg_clutter_scenes_")
        lines_b, attempts_b, tables_b = run(tempfile.mkdtemp(prefix="fg_clutter_b_"),
                                            ("--tables", "3", "--only-tables", "0", "--keep-scenes", kept))
        for a in attempts:
            folder = os.path.join(kept, "fused_packed_table0_attempt%s" % a["attempt"])
            self.assertTrue(os.path.exists(os.path.join(folder, "scene.yaml")), folder)
            if a["success"] != "":  # grasp_offline saves the target cluster when it planned a grasp
                self.assertTrue(os.path.exists(os.path.join(folder, "cluster_%s.pcd" % a["attempt"])), folder)
        self.assertEqual(lines[-1], lines_b[-1])
        self.assertEqual(tables, tables_b)
        drop = ("planning_ms", "message")  # timing differs; the message carries timings of some planners
        self.assertEqual([{k: v for k, v in a.items() if k not in drop} for a in attempts],
                         [{k: v for k, v in a.items() if k not in drop} for a in attempts_b])


if __name__ == "__main__":
    args = sys.argv[1:]
    GRASP_OFFLINE = pyunit_main.take_flag(args, "--grasp-offline") or os.path.join(
        ROOT, ".ws/devel/lib/fast_grasp/grasp_offline")
    pyunit_main.run("clutter_evaluator", ClutterTest, args)
