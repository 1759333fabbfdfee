#!/usr/bin/python3
"""rostest node for clear_table.test: a clutter scene cleared live (scene_camera ~clear_table).

Checks, against the scene's ground truth (bags/<scene>.truth.yaml `objects`: every object's
full mesh surface, seen or not), that
- the table is cleared: scene_camera reports one pick per object, each a different object;
- no grasp the planner publishes (all objects', every frame) has a finger or the palm of the
  open hand (the gripper YAML's boxes at its maximum opening) inside another object still on
  the table: the truth surface of every other object stays out of the hand's boxes."""
import os
import re
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import yaml
from std_msgs.msg import String

from fast_grasp.msg import GraspArray

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", "scripts"))
sys.path.insert(0, here)
import bag_start  # noqa: E402
import grasp_checks  # noqa: E402


def surface_points(entry):
    """The truth's full-surface sample of one object (key surface_points_<spacing>)."""
    for key, value in entry.items():
        if key.startswith("surface_points"):
            return np.array(value, dtype=float)
    raise KeyError("no surface_points_* key in the truth entry of %s" % entry.get("name"))


class ClearTableTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("clear_table_test")
        with open(rospy.get_param("~truth")) as f:
            cls.truth = yaml.safe_load(f)
        with open(rospy.get_param("~gripper_file")) as f:
            cls.gripper = yaml.safe_load(f)
        cls.objects = {o["name"]: surface_points(o) for o in cls.truth["objects"]}
        cls.lock = threading.Lock()
        cls.arrays = []   # GraspArray
        cls.picks = []    # (wall time received, object name)
        cls.statuses = []
        cls.cleared = threading.Event()
        subscribers = [rospy.Subscriber("/grasp_planner/grasps", GraspArray, cls.on_grasps, queue_size=20),
                       rospy.Subscriber("/scene_camera/status", String, cls.on_camera, queue_size=20)]
        bag_start.resume_when_listening(subscribers, "/scene_camera/pause_playback", None,
                                        other_listeners=["/grasp_planner/grasps", "/table_segmentation/objects"])
        pick_timeout_s = rospy.get_param("~pick_timeout_s", 60.0)
        last, seen = time.monotonic(), 0
        while not rospy.is_shutdown() and not cls.cleared.is_set():
            with cls.lock:
                if len(cls.picks) != seen:
                    last, seen = time.monotonic(), len(cls.picks)
            if time.monotonic() - last > pick_timeout_s:
                break
            time.sleep(0.1)

    @classmethod
    def on_grasps(cls, msg):
        with cls.lock:
            cls.arrays.append(msg)

    @classmethod
    def on_camera(cls, msg):
        with cls.lock:
            cls.statuses.append(msg.data)
            match = re.search(r"pick \d+: (\S+) ", msg.data)
            if match:
                cls.picks.append((rospy.Time.now(), match.group(1)))
            if "table cleared" in msg.data:
                cls.cleared.set()

    def test_the_table_is_cleared_one_object_per_pick(self):
        with self.lock:
            picks = [name for _, name in self.picks]
            statuses = list(self.statuses)
        self.assertTrue(self.cleared.is_set(), "not cleared; scene_camera said: %s" % statuses)
        self.assertEqual(sorted(picks), sorted(self.objects), "picks %s for objects %s" % (picks, sorted(self.objects)))

    def test_no_open_hand_enters_another_object_on_the_table(self):
        with self.lock:
            arrays = [a for a in self.arrays if a.grasps]
            picks = list(self.picks)
        self.assertTrue(arrays, "the planner published no grasp")
        checked = 0
        for array in arrays:
            # Objects picked before this frame was rendered are gone from it.
            gone = {name for when, name in picks if when < array.header.stamp}
            present = {name: pts for name, pts in self.objects.items() if name not in gone}
            for g in array.grasps:
                q = g.pose.orientation
                rotation = grasp_checks.quaternion_matrix(q.x, q.y, q.z, q.w)
                position = np.array([g.pose.position.x, g.pose.position.y, g.pose.position.z])
                # The grasp's own object: the one whose surface is nearest the closing centre.
                nearest = {n: np.min(np.linalg.norm(p - position, axis=1)) for n, p in present.items()}
                own = min(nearest, key=nearest.get)
                for name, points in present.items():
                    if name == own:
                        continue
                    local = grasp_checks.to_grasp_frame(points, position, rotation)
                    inside = grasp_checks.points_in_gripper(local, self.gripper, self.gripper["max_opening_m"])
                    self.assertEqual(inside, 0, "grasp at %s on %s (object_id %d, %s): %d surface points of %s "
                                     "inside the open hand" % (position, own, g.object_id, g.algorithm, inside, name))
                checked += 1
        rospy.loginfo("clear_table_test: %d grasps checked against their neighbours", checked)


if __name__ == "__main__":
    rostest.rosrun("fast_grasp", "clear_table", ClearTableTest)
