#!/usr/bin/python3
"""rostest node for perception_bad_input.test: feeds hand-made clouds to the perception
nodelets and asserts on their ~status. Every bad input (empty, all NaN, infinite coordinates,
60 million points, unknown frame, no plane, no cluster, object out of reach) must give a clear
status and the next good cloud must be processed again; a 20 million point cloud is read with
a coarser stride and processed. Also checks zero-copy: the cloud a
downstream nodelet receives has the very address the upstream one published."""
import os
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String, UInt64
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import perception_cloud_factory as factory  # noqa: E402

NODELETS = ('cloud_preprocess', 'table_segmentation', 'normal_estimation')
TIMEOUT_S = 20.0


class PerceptionBadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('perception_bad_input_test')
        cls.lock = threading.Lock()
        cls.statuses = {name: [] for name in NODELETS}
        cls.addresses = {}
        cls.diagnostic_names = {}
        subscribers = []
        for name in NODELETS:
            subscribers.append(rospy.Subscriber('/%s/status' % name, String, cls.on_status, callback_args=name))
            for kind in ('sent_address', 'received_address'):
                topic = '/%s/%s' % (name, kind)
                cls.addresses[topic] = []
                subscribers.append(rospy.Subscriber(topic, UInt64, cls.on_address, callback_args=topic))
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diagnostics)
        # Listening to the last output keeps the lazy chain subscribed end to end.
        subscribers.append(rospy.Subscriber('/normal_estimation/output', PointCloud2, lambda msg: None))
        subscribers.append(rospy.Subscriber('/table_segmentation/scene', PointCloud2, lambda msg: None))
        cls.tf_pub = rospy.Publisher('/tf_static', TFMessage, queue_size=1, latch=True)
        transform = TransformStamped()
        transform.header.frame_id = 'base_link'
        transform.child_frame_id = 'camera_rgb_optical_frame'
        (transform.transform.translation.x, transform.transform.translation.y,
         transform.transform.translation.z) = factory.CAMERA_TRANSLATION
        (transform.transform.rotation.x, transform.transform.rotation.y, transform.transform.rotation.z,
         transform.transform.rotation.w) = factory.CAMERA_ROTATION_XYZW
        cls.tf_pub.publish(TFMessage(transforms=[transform]))
        cls.cloud_pub = rospy.Publisher('/test_cloud_in', PointCloud2, queue_size=1)
        deadline = time.time() + TIMEOUT_S
        # Every first message counts (the address topics are not latched): start once all connect.
        while (cls.cloud_pub.get_num_connections() == 0 or any(s.get_num_connections() == 0 for s in subscribers)) \
                and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)  # let the tf listeners receive the static transform

    @classmethod
    def on_status(cls, msg, name):
        with cls.lock:
            cls.statuses[name].append(msg.data)

    @classmethod
    def on_address(cls, msg, topic):
        with cls.lock:
            cls.addresses[topic].append(msg.data)

    @classmethod
    def on_diagnostics(cls, msg):
        with cls.lock:
            for status in msg.status:
                cls.diagnostic_names.setdefault(status.name, set()).add(status.level)

    # -- helpers ---------------------------------------------------------------------------
    def publish_and_wait(self, cloud, nodelets):
        """Publishes one cloud, returns the first new ~status of each given nodelet."""
        with self.lock:
            before = {name: len(self.statuses[name]) for name in nodelets}
        cloud.header.stamp = rospy.Time.now()
        self.cloud_pub.publish(cloud)
        deadline = time.time() + TIMEOUT_S
        while time.time() < deadline:
            with self.lock:
                if all(len(self.statuses[name]) > before[name] for name in nodelets):
                    return {name: self.statuses[name][before[name]] for name in nodelets}
            time.sleep(0.02)
        with self.lock:
            got = {name: self.statuses[name][before[name]:] for name in nodelets}
        self.fail('no status from %s within %.0f s (got %s)' % (list(nodelets), TIMEOUT_S, got))

    def good_cloud(self):
        scene = np.concatenate([factory.table(), factory.box(0.5, 0.0, 0.06, 0.06, 0.10)])
        return factory.make_cloud(factory.base_to_camera(scene))

    def assert_good_cloud_processed(self):
        status = self.publish_and_wait(self.good_cloud(), NODELETS)
        for name in NODELETS:
            self.assertTrue(status[name].startswith('OK: '), '%s: %s' % (name, status[name]))

    def assert_status(self, cloud, nodelet, prefix, keyword, upstream_ok=()):
        status = self.publish_and_wait(cloud, tuple(upstream_ok) + (nodelet,))
        for name in upstream_ok:
            self.assertTrue(status[name].startswith('OK: '), '%s: %s' % (name, status[name]))
        self.assertTrue(status[nodelet].startswith(prefix), '%s: %s' % (nodelet, status[nodelet]))
        self.assertIn(keyword, status[nodelet])
        # Nothing crashed: the next good cloud goes all the way through.
        self.assert_good_cloud_processed()

    # -- tests -----------------------------------------------------------------------------
    def test_00_good_cloud_and_zero_copy(self):
        for _ in range(3):
            self.assert_good_cloud_processed()
        time.sleep(0.5)
        with self.lock:
            sent = self.addresses['/cloud_preprocess/sent_address']
            received = self.addresses['/table_segmentation/received_address']
            object_sent = self.addresses['/table_segmentation/sent_address']
            object_received = self.addresses['/normal_estimation/received_address']
            self.assertGreaterEqual(len(sent), 3)
            # Same manager: the downstream nodelet gets the very pointer the upstream one published.
            # (Each address is its own message: under load the last ones may still be in flight
            # or come in another order, so every received pointer must be one that was sent.)
            self.assertTrue(received and set(received[-3:]) <= set(sent), (sent, received))
            self.assertTrue(object_received and set(object_received[-3:]) <= set(object_sent),
                            (object_sent, object_received))
            self.assertTrue(all(a != 0 for a in sent))

    def test_01_empty_cloud(self):
        self.assert_status(factory.make_cloud(np.zeros((0, 3))), 'cloud_preprocess', 'ERROR: ', 'empty')

    def test_02_all_nan(self):
        nan = np.full((640 * 480, 3), np.nan, dtype=np.float32)
        self.assert_status(factory.make_cloud(nan, width=640, height=480), 'cloud_preprocess', 'ERROR: ',
                           'no finite point')

    def test_03_infinite_coordinates(self):
        inf = np.full((1000, 3), np.inf, dtype=np.float32)
        self.assert_status(factory.make_cloud(inf), 'cloud_preprocess', 'ERROR: ', 'infinite')
        # Some infinite points among good ones: dropped with a warning, the rest processed.
        points = factory.base_to_camera(np.concatenate([factory.table(), factory.box(0.5, 0.0, 0.06, 0.06, 0.1)]))
        points[::50, 2] = np.inf
        points[1::50, 0] = -np.inf
        self.assert_status(factory.make_cloud(points), 'cloud_preprocess', 'WARN: ', 'infinite')

    def test_04_twenty_million_points_downsampled(self):
        # A 5000 x 4000 organised cloud of the good scene (tiled): read with a coarser stride
        # (max_sampled_points), not rejected, and the whole chain still finds the object.
        scene = factory.base_to_camera(np.concatenate([factory.table(), factory.box(0.5, 0.0, 0.06, 0.06, 0.10)]))
        width, height = 5000, 4000
        tiled = np.tile(scene, (width * height // len(scene) + 1, 1))[:width * height]
        huge = factory.make_cloud(tiled, width=width, height=height)
        del tiled
        started = time.time()
        status = self.publish_and_wait(huge, NODELETS)
        del huge
        rospy.loginfo('20M-point cloud processed in %.2f s: %s', time.time() - started, status)
        self.assertTrue(status['cloud_preprocess'].startswith('WARN: '), status['cloud_preprocess'])
        self.assertIn('down-sampled', status['cloud_preprocess'])
        self.assertIn('20000000 points', status['cloud_preprocess'])
        for name in ('table_segmentation', 'normal_estimation'):
            self.assertTrue(status[name].startswith('OK: '), '%s: %s' % (name, status[name]))
        self.assert_good_cloud_processed()

    def test_04_too_large_for_any_camera(self):
        # Beyond max_input_points (50 M) the header alone is enough to refuse: no data needed.
        cloud = factory.make_cloud(np.zeros((0, 3)))
        cloud.width, cloud.height = 10000, 6000
        self.assert_status(cloud, 'cloud_preprocess', 'ERROR: ', 'too large')

    def test_05_unknown_frame(self):
        cloud = self.good_cloud()
        cloud.header.frame_id = 'no_such_frame'
        self.assert_status(cloud, 'cloud_preprocess', 'ERROR: ', 'no transform')

    def test_06_no_plane(self):
        self.assert_status(factory.make_cloud(factory.base_to_camera(factory.wall())), 'table_segmentation',
                           'WARN: ', 'no_plane', upstream_ok=('cloud_preprocess',))

    def test_07_no_cluster(self):
        self.assert_status(factory.make_cloud(factory.base_to_camera(factory.table())), 'table_segmentation',
                           'WARN: ', 'no_cluster', upstream_ok=('cloud_preprocess',))

    def test_08_object_out_of_reach(self):
        # Object centroid ~0.82 m from the base: inside reach_m 0.85 (points survive the
        # preprocessing) but beyond max_object_distance_m 0.80.
        scene = np.concatenate([factory.table(x0=0.5, x1=0.85), factory.box(0.82, 0.0, 0.03, 0.04, 0.05)])
        self.assert_status(factory.make_cloud(factory.base_to_camera(scene)), 'table_segmentation', 'WARN: ',
                           'object_out_of_reach', upstream_ok=('cloud_preprocess',))

    def test_09_everything_out_of_reach(self):
        scene = np.concatenate([factory.table(x0=0.9, x1=1.2), factory.box(1.0, 0.0, 0.06, 0.06, 0.1)])
        self.assert_status(factory.make_cloud(factory.base_to_camera(scene)), 'cloud_preprocess', 'ERROR: ',
                           'reach')

    def test_10_diagnostics(self):
        deadline = time.time() + 5.0
        while time.time() < deadline:
            with self.lock:
                names = set(self.diagnostic_names)
            if all(any(name in n for n in names) for name in NODELETS):
                break
            time.sleep(0.2)
        for name in NODELETS:
            self.assertTrue(any(name in n for n in names), 'no /diagnostics from %s: %s' % (name, names))
        with self.lock:
            levels = set().union(*[lv for n, lv in self.diagnostic_names.items() if 'cloud_preprocess' in n])
        self.assertIn(2, levels, 'cloud_preprocess never reported ERROR on /diagnostics')  # 2 == ERROR


if __name__ == '__main__':
    rostest.rosrun('fast_grasp', 'perception_bad_input', PerceptionBadInputTest)
