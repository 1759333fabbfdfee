#!/usr/bin/python3
"""rostest node for all_objects_pipeline.test: a bag with a target and distractors through
perception and a grasp planner with all_objects:=true. Checks, against the bag's truth file (the
objects' positions as rendered), that TableSegmentation's ~objects holds one labelled cluster
per object (label 0 the target), that the planner publishes grasps for every object in one
GraspArray, that each grasp lies on the object its object_id names, and that the arm planner
(all_objects) plans a trajectory whose executed grasp lies on the object its status names."""
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
from sensor_msgs import point_cloud2
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from fast_grasp.msg import GraspArray

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
import bag_start  # noqa: E402

# A cluster's seen points are its near side: its centroid lies within this of the object's
# truth position (the object's base centre), horizontally.
CENTROID_TOLERANCE_M = 0.05
# A grasp's closing centre lies within the object's footprint grown by half a finger depth.
GRASP_TOLERANCE_M = 0.08


class AllObjectsPipelineTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("all_objects_pipeline_test")
        with open(rospy.get_param("~truth")) as f:
            cls.truth = yaml.safe_load(f)
        cls.lock = threading.Lock()
        cls.labelled = {}  # stamp ns -> {label: N x 3}
        cls.arrays = []
        cls.arm = {}  # stamp ns -> {"status": str, "executed": PoseStamped, "trajectory": JointTrajectory}
        subscribers = [rospy.Subscriber("/table_segmentation/objects", PointCloud2, cls.on_objects, queue_size=5),
                       rospy.Subscriber("/all_objects_planner/grasps", GraspArray, cls.on_grasps, queue_size=5),
                       rospy.Subscriber("/arm_planner/executed_grasp", PoseStamped, cls.on_executed, queue_size=5),
                       rospy.Subscriber("/arm_planner/trajectory", JointTrajectory, cls.on_trajectory, queue_size=5)]
        cls.arm_statuses = []
        rospy.Subscriber("/arm_planner/status", String, cls.on_arm_status, queue_size=10)
        # The arm planner must listen to the grasps and the labelled objects before frame 0 plays.
        bag_start.resume_when_listening(subscribers, rospy.get_param("~pause_service"), None,
                                        other_listeners=["/all_objects_planner/grasps", "/table_segmentation/objects"])
        end = time.monotonic() + rospy.get_param("~timeout_s", 60.0)
        while time.monotonic() < end and not rospy.is_shutdown():
            with cls.lock:
                grasped = any(a.grasps and a.header.stamp.to_nsec() in cls.labelled for a in cls.arrays)
                planned = any("trajectory" in v and "executed" in v for v in cls.arm.values())
                if grasped and planned:
                    break
            time.sleep(0.1)

    @classmethod
    def on_objects(cls, msg):
        by_label = {}
        for x, y, z, label in point_cloud2.read_points(msg, field_names=("x", "y", "z", "label"), skip_nans=True):
            by_label.setdefault(int(label), []).append((x, y, z))
        with cls.lock:
            cls.labelled[msg.header.stamp.to_nsec()] = {k: np.array(v) for k, v in by_label.items()}

    @classmethod
    def on_grasps(cls, msg):
        with cls.lock:
            cls.arrays.append(msg)

    @classmethod
    def on_executed(cls, msg):
        with cls.lock:
            cls.arm.setdefault(msg.header.stamp.to_nsec(), {})["executed"] = msg

    @classmethod
    def on_trajectory(cls, msg):
        with cls.lock:
            cls.arm.setdefault(msg.header.stamp.to_nsec(), {})["trajectory"] = msg

    @classmethod
    def on_arm_status(cls, msg):
        with cls.lock:
            cls.arm_statuses.append(msg.data)

    def frame(self):
        with self.lock:
            for array in self.arrays:
                if array.grasps and array.header.stamp.to_nsec() in self.labelled:
                    return array, self.labelled[array.header.stamp.to_nsec()]
            statuses = [a.status for a in self.arrays]
        self.fail("no GraspArray with grasps and its frame's ~objects; planner statuses: %s" % statuses)

    def truth_objects(self):
        """name -> truth position (x, y) of the target and each distractor."""
        objects = {self.truth["object"]["name"]: np.array(self.truth["object"]["position"][:2])}
        for d in self.truth.get("distractors", []):
            objects[d["name"]] = np.array(d["position"][:2])
        return objects

    def test_every_object_is_a_labelled_cluster(self):
        _, labelled = self.frame()
        truth = self.truth_objects()
        self.assertEqual(len(labelled), len(truth), "labels %s for objects %s" % (sorted(labelled), sorted(truth)))
        for label, points in labelled.items():
            centroid = points.mean(axis=0)[:2]
            distances = {name: np.linalg.norm(centroid - xy) for name, xy in truth.items()}
            nearest = min(distances, key=distances.get)
            self.assertLess(distances[nearest], CENTROID_TOLERANCE_M,
                            "label %d (centroid %s) is none of the objects %s" % (label, centroid, distances))
            if label == 0:
                self.assertEqual(nearest, self.truth["object"]["name"], "label 0 must be the target")

    def test_every_object_gets_grasps_that_lie_on_it(self):
        array, labelled = self.frame()
        self.assertEqual(array.status, "ok")
        ids = sorted({g.object_id for g in array.grasps})
        self.assertEqual(ids, sorted(labelled), "grasps name objects %s, ~objects has %s" % (ids, sorted(labelled)))
        for g in array.grasps:
            points = labelled[g.object_id]
            position = np.array([g.position.x, g.position.y, g.position.z])
            lo, hi = points.min(axis=0) - GRASP_TOLERANCE_M, points.max(axis=0) + GRASP_TOLERANCE_M
            self.assertTrue(np.all(position >= lo) and np.all(position <= hi),
                            "grasp %s of object %d is off its points (%s .. %s)" % (position, g.object_id, lo, hi))
            others = [k for k in labelled if k != g.object_id]
            for k in others:
                nearest_own = np.min(np.linalg.norm(points - position, axis=1))
                nearest_other = np.min(np.linalg.norm(labelled[k] - position, axis=1))
                self.assertLess(nearest_own, nearest_other,
                                "grasp %s of object %d is nearer object %d" % (position, g.object_id, k))
        # grouped in pick order: one object's grasps together, best first within it
        order = [g.object_id for g in array.grasps]
        self.assertEqual(order, sorted(order, key=lambda k: order.index(k)))

    def test_the_arm_plans_to_the_object_its_status_names(self):
        with self.lock:
            planned = {k: v for k, v in self.arm.items() if "trajectory" in v and "executed" in v}
            labelled = dict(self.labelled)
            statuses = list(self.arm_statuses)
        self.assertTrue(planned, "no arm trajectory; arm planner statuses: %s" % statuses)
        # Statuses and trajectories come on different topics: match them by the object named.
        named = {int(m.group(1)) for m in (re.search(r"object (\d+), grasp \d+:", t) for t in statuses) if m}
        self.assertTrue(named, "no arm status names the object it planned for: %s" % statuses)
        for stamp, plan in planned.items():
            self.assertGreater(len(plan["trajectory"].points), 1)
            if stamp not in labelled:
                continue
            p = plan["executed"].pose.position
            position = np.array([p.x, p.y, p.z])
            nearest = {k: np.min(np.linalg.norm(points - position, axis=1)) for k, points in labelled[stamp].items()}
            grasped = min(nearest, key=nearest.get)
            self.assertIn(grasped, named, "executed grasp %s is nearest object %d; the arm statuses name %s (%s)"
                          % (position, grasped, sorted(named), statuses))
            self.assertLess(nearest[grasped], GRASP_TOLERANCE_M)


if __name__ == "__main__":
    rostest.rosrun("fast_grasp", "all_objects_pipeline", AllObjectsPipelineTest)
