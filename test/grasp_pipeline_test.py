#!/usr/bin/python3
"""rostest: a bundled bag replayed through perception and the grasp planners.

For every planner named in ~planners (nodelet names), the best grasp of the first frame that
has one must: hold object points in its closing region, fit the gripper opening, leave the
open fingers and the palm free of object points, keep the gripper out of the space hidden
behind the seen surface (checked independently from the camera pose in the bag's truth
file), and approach from the camera's side.
"""
import os
import sys
import threading
import unittest

import numpy as np
import rospy
import rostest
import yaml
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointCloud2

from fast_grasp.msg import GraspArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import grasp_checks  # noqa: E402


def load_yaml(path):
    with open(path) as f:
        return yaml.safe_load(f)


def camera_from_truth(pose):
    q = pose["orientation_xyzw"]
    return np.array(pose["position"], dtype=float), grasp_checks.quaternion_matrix(*q)


class GraspPipelineTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("grasp_pipeline_test")
        cls.truth = load_yaml(rospy.get_param("~truth"))
        cls.gripper = load_yaml(rospy.get_param("~gripper_file"))
        cls.planners = rospy.get_param("~planners")
        cls.timeout_s = rospy.get_param("~timeout_s", 60.0)
        cls.lock = threading.Lock()
        cls.objects = {}  # stamp ns -> N x 3
        cls.grasps = {name: [] for name in cls.planners}
        rospy.Subscriber("/normal_estimation/output", PointCloud2, cls.on_object, queue_size=5)
        for name in cls.planners:
            rospy.Subscriber("/%s/grasps" % name, GraspArray, cls.on_grasps, callback_args=name, queue_size=5)
        deadline = rospy.Time.now().to_sec() + 0  # sim time may not run yet: use wall clock below
        import time
        end = time.monotonic() + cls.timeout_s
        while time.monotonic() < end and not rospy.is_shutdown():
            with cls.lock:
                done = all(any(g.grasps for g in cls.grasps[name]) or len(cls.grasps[name]) >= cls.truth["frames"]
                           for name in cls.planners)
            if done:
                break
            time.sleep(0.1)
        del deadline

    @classmethod
    def on_object(cls, msg):
        points = np.array(list(point_cloud2.read_points(msg, field_names=("x", "y", "z"), skip_nans=True)))
        with cls.lock:
            cls.objects[msg.header.stamp.to_nsec()] = points.reshape(-1, 3)

    @classmethod
    def on_grasps(cls, msg, name):
        with cls.lock:
            cls.grasps[name].append(msg)

    def occlusions(self, points):
        cams = [self.truth["camera_pose"]]
        if "head_camera_pose" in self.truth:
            cams.append(self.truth["head_camera_pose"])
        result = []
        for cam in cams:
            position, rotation = camera_from_truth(cam)
            result.append(grasp_checks.CameraOcclusion(points, position, rotation))
        return result

    def check_planner(self, name):
        with self.lock:
            arrays = list(self.grasps[name])
            objects = dict(self.objects)
        self.assertTrue(arrays, "%s published no GraspArray within %.0f s" % (name, self.timeout_s))
        with_grasps = [a for a in arrays if a.grasps]
        self.assertTrue(with_grasps, "%s found no grasp; statuses: %s" % (name, [a.status for a in arrays]))
        array = with_grasps[0]
        self.assertEqual(array.status, "ok")
        key = array.header.stamp.to_nsec()
        self.assertIn(key, objects, "no object cloud with the grasps' stamp")
        points = objects[key]
        grasp = array.grasps[0]
        q = grasp.pose.orientation
        rotation = grasp_checks.quaternion_matrix(q.x, q.y, q.z, q.w)
        position = np.array([grasp.pose.position.x, grasp.pose.position.y, grasp.pose.position.z])
        local = grasp_checks.to_grasp_frame(points, position, rotation)
        max_opening = self.gripper["max_opening_m"]
        label = "%s on %s" % (name, self.truth["scene"])

        self.assertGreater(grasp.width_m, 0.0, label)
        self.assertLessEqual(grasp.width_m, max_opening + 1e-6, label)
        inside = grasp_checks.closing_region_count(local, grasp.width_m, self.gripper)
        self.assertGreaterEqual(inside, 5, "%s: only %d object points between the fingers" % (label, inside))
        # Open gripper (max opening) must not contain object points: 2 allowed for sensor noise.
        colliding = grasp_checks.points_in_gripper(local, self.gripper, max_opening)
        self.assertLessEqual(colliding, 2, "%s: %d object points inside the open gripper" % (label, colliding))
        hidden, total = grasp_checks.gripper_in_unseen(position, rotation, self.gripper, max_opening,
                                                       self.occlusions(points))
        self.assertLessEqual(hidden, max(3, total // 100),
                             "%s: %d of %d gripper samples lie in the unseen part" % (label, hidden, total))
        # Seen side: the hand comes from the camera's half-space.
        camera, _ = camera_from_truth(self.truth["camera_pose"])
        approach = rotation[:, 0]
        self.assertGreater(float(approach @ (position - camera)), 0.0, "%s approaches from the unseen side" % label)

    def test_planners(self):
        for name in self.planners:
            with self.subTest(planner=name):
                self.check_planner(name)


if __name__ == "__main__":
    rostest.rosrun("fast_grasp", "grasp_pipeline_test", GraspPipelineTest, sys.argv)
