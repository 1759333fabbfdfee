#!/usr/bin/python3
"""rostest node for cloud_fusion.test: publishes hand/head cloud pairs to CloudFusion and
checks the fused output (point count = sum, base frame, newest stamp) and the ~status for bad
pairs (frame mismatch, both empty, one empty), after which the nodelet still works."""
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header, String

TIMEOUT_S = 10.0
INSTANCES = ('cloud_fusion', 'cloud_fusion_exact')


def make_cloud(frame_id, stamp, count, x0):
    header = Header(frame_id=frame_id, stamp=stamp)
    return point_cloud2.create_cloud_xyz32(header, [(x0 + 0.001 * i, 0.0, 0.1) for i in range(count)])


class CloudFusionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('cloud_fusion_check')
        cls.lock = threading.Lock()
        cls.outputs = {name: [] for name in INSTANCES}
        cls.statuses = {name: [] for name in INSTANCES}
        cls.hand_pubs, cls.head_pubs = {}, {}
        for name in INSTANCES:
            # Listening to ~output makes the lazy nodelet subscribe to its inputs.
            rospy.Subscriber('/%s/output' % name, PointCloud2, cls.on_output, callback_args=name)
            rospy.Subscriber('/%s/status' % name, String, cls.on_status, callback_args=name)
            cls.hand_pubs[name] = rospy.Publisher('/%s/hand' % name, PointCloud2, queue_size=10)
            cls.head_pubs[name] = rospy.Publisher('/%s/head' % name, PointCloud2, queue_size=10)
        deadline = time.time() + TIMEOUT_S
        for name in INSTANCES:
            while (cls.hand_pubs[name].get_num_connections() == 0 or cls.head_pubs[name].get_num_connections() == 0
                   or not cls.statuses[name]) and time.time() < deadline:
                time.sleep(0.1)
        time.sleep(0.5)

    @classmethod
    def on_output(cls, msg, name):
        with cls.lock:
            cls.outputs[name].append(msg)

    @classmethod
    def on_status(cls, msg, name):
        with cls.lock:
            cls.statuses[name].append(msg.data)

    def counts(self, name):
        with self.lock:
            return len(self.outputs[name]), len(self.statuses[name])

    def since(self, name, marks):
        with self.lock:
            return self.outputs[name][marks[0]:], self.statuses[name][marks[1]:]

    def send_exact_pair(self, hand, head):
        """Publishes one pair to the exact-sync instance; returns (new outputs, new statuses)."""
        name = 'cloud_fusion_exact'
        marks = self.counts(name)
        self.hand_pubs[name].publish(hand)
        self.head_pubs[name].publish(head)
        deadline = time.time() + TIMEOUT_S
        while time.time() < deadline and self.counts(name)[1] == marks[1]:
            time.sleep(0.05)
        time.sleep(0.3)  # an output, if any, is published before the status
        return self.since(name, marks)

    def test_1_approximate_sync_fuses_a_stream(self):
        name = 'cloud_fusion'
        marks = self.counts(name)
        start = rospy.Time.now()
        for i in range(8):
            stamp = start + rospy.Duration(0.1 * i)
            self.hand_pubs[name].publish(make_cloud('base_link', stamp, 30, 0.0))
            self.head_pubs[name].publish(make_cloud('base_link', stamp + rospy.Duration(0.01), 20, 1.0))
            time.sleep(0.05)
        time.sleep(1.0)
        outputs, statuses = self.since(name, marks)
        # ApproximateTime holds the newest set back until a later message proves it best.
        self.assertGreaterEqual(len(outputs), 6, statuses)
        for fused in outputs:
            self.assertEqual(fused.width * fused.height, 50)
            self.assertEqual(fused.header.frame_id, 'base_link')
        self.assertTrue(all(s.startswith('OK: fused 30 hand + 20 head') for s in statuses), statuses)
        first = outputs[0]
        # The newer of the two stamps (PCL keeps microseconds).
        self.assertAlmostEqual(first.header.stamp.to_sec(), (start + rospy.Duration(0.01)).to_sec(), delta=2e-6)
        xs = sorted(p[0] for p in point_cloud2.read_points(first, field_names=('x',)))
        self.assertAlmostEqual(xs[0], 0.0, places=5)
        self.assertAlmostEqual(xs[-1], 1.019, places=5)

    def test_2_frame_mismatch_is_an_error_without_output(self):
        stamp = rospy.Time.now()
        outputs, statuses = self.send_exact_pair(make_cloud('base_link', stamp, 10, 0.0),
                                                 make_cloud('head_camera_optical_frame', stamp, 10, 0.0))
        self.assertTrue(statuses and statuses[-1].startswith('ERROR: frame mismatch'), statuses)
        self.assertEqual(outputs, [])

    def test_3_both_empty_is_an_error_without_output(self):
        stamp = rospy.Time.now()
        outputs, statuses = self.send_exact_pair(make_cloud('base_link', stamp, 0, 0.0),
                                                 make_cloud('base_link', stamp, 0, 0.0))
        self.assertTrue(statuses and statuses[-1].startswith('ERROR: both input clouds are empty'), statuses)
        self.assertEqual(outputs, [])

    def test_4_one_empty_warns_and_passes_the_other(self):
        stamp = rospy.Time.now()
        outputs, statuses = self.send_exact_pair(make_cloud('base_link', stamp, 0, 0.0),
                                                 make_cloud('base_link', stamp, 15, 0.0))
        self.assertTrue(statuses and statuses[-1].startswith('WARN: one input cloud is empty'), statuses)
        self.assertEqual(len(outputs), 1)
        self.assertEqual(outputs[0].width * outputs[0].height, 15)

    def test_5_still_alive_after_bad_pairs(self):
        stamp = rospy.Time.now()
        outputs, statuses = self.send_exact_pair(make_cloud('base_link', stamp, 5, 0.0),
                                                 make_cloud('base_link', stamp, 5, 0.5))
        self.assertTrue(statuses and statuses[-1].startswith('OK: fused 5 hand + 5 head'), statuses)
        self.assertEqual(len(outputs), 1)
        self.assertEqual(outputs[0].width * outputs[0].height, 10)


if __name__ == '__main__':
    rostest.rosrun('fast_grasp', 'cloud_fusion_check', CloudFusionTest)
