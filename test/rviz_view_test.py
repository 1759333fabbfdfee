#!/usr/bin/python3
"""rostest node for rviz_view.test: rviz with config/fast_grasp.rviz against the running demo
(a bag through perception, the fused planner and the arm planner), under its own Xvfb, and a
screenshot that must show the object cloud, the grasp markers and the robot where they are.

The displays and topics are the shipped config's; only what a pixel check needs is changed in a
test copy: a fixed orbit view (TEST_VIEW) and the displays that would cover everything (raw cloud, table, scene, all objects, grid, normals, next view, arm planner markers)
switched off. Known 3-D points (the object cloud's centroid, the best grasp's position, the
robot links' origins from tf) are projected with the orbit camera into the render area (found
in the screenshot as the bounding box of the background colour) and each region must hold
pixels of the expected kind: the Object display's flat red, the gripper marker's blue, any
non-background colour for the robot; points in empty space (above the object, beside the
robot) must stay background. The
screenshot is kept at $ROS_HOME/test_results/fast_grasp/rviz_view.png."""
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
import rosgraph
import rospy
import rostest
import tf2_ros
import yaml
from fast_grasp.msg import GraspArray
from sensor_msgs.msg import PointCloud2
from sensor_msgs import point_cloud2

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
import bag_start  # noqa: E402

TIMEOUT_S = 120.0
# Orbit view (rviz/Orbit: the eye sits at focal + distance * (cos p cos y, cos p sin y, sin p)
# and looks at the focal point, z up): the whole UR5 at its home pose and the table in front.
TEST_VIEW = {"Distance": 1.9, "Focal Point": {"X": 0.25, "Y": 0.0, "Z": 0.25}, "Pitch": 0.45, "Yaw": 0.9,
             "Field of View": 0.785}
HIDDEN = ("Raw cloud", "Table", "Scene", "All objects", "Grid", "Normals", "Next view (Ch3.2.3)", "Arm planner", "TF")
ROBOT_LINKS = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_2_link", "gripper_palm_link")
OBJECT_RGB = (255, 40, 40)
# Controls: nothing is there (0.3 m above the object; beside the arm at its home pose).
EMPTY_POINTS = ([0.5, 0.0, 0.55], [0.2, 0.3, 0.1])


def test_config(shipped_path, out_path):
    with open(shipped_path) as f:
        config = yaml.safe_load(f)
    manager = config["Visualization Manager"]
    names = [d["Name"] for d in manager["Displays"]]
    for needed in ("Robot", "Object", "Grasp planner"):
        assert needed in names, "%s display missing from %s" % (needed, shipped_path)
    for display in manager["Displays"]:
        if display["Name"] in HIDDEN:
            display["Enabled"] = False
        if display["Name"] == "Object":
            display["Size (Pixels)"] = 4
            display["Color"] = "%d; %d; %d" % OBJECT_RGB
    current = manager["Views"]["Current"]
    assert current["Class"] == "rviz/Orbit", current
    current.update(TEST_VIEW)
    current["Target Frame"] = "base_link"
    config["Window Geometry"].update({"X": 0, "Y": 0})
    background = tuple(int(c) for c in str(manager["Global Options"]["Background Color"]).split(";"))
    with open(out_path, "w") as f:
        yaml.safe_dump(config, f)
    return background


def project(points, render_box):
    """Pixel (column, row) of base_link points in the render area (x0, y0, x1, y1) under TEST_VIEW."""
    focal = np.array([TEST_VIEW["Focal Point"][k] for k in ("X", "Y", "Z")])
    pitch, yaw, distance = TEST_VIEW["Pitch"], TEST_VIEW["Yaw"], TEST_VIEW["Distance"]
    eye = focal + distance * np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw),
                                       math.sin(pitch)])
    forward = (focal - eye) / np.linalg.norm(focal - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    x0, y0, x1, y1 = render_box
    width, height = x1 - x0, y1 - y0
    tan_half = math.tan(TEST_VIEW["Field of View"] / 2.0)  # vertical field of view (Ogre)
    pixels = []
    for p in np.atleast_2d(points):
        d = np.asarray(p) - eye
        depth = d.dot(forward)
        u = d.dot(right) / (depth * tan_half * width / height)
        v = d.dot(up) / (depth * tan_half)
        pixels.append((x0 + (u + 1.0) / 2.0 * width, y0 + (1.0 - v) / 2.0 * height))
    return pixels


def free_display_xvfb():
    """Starts Xvfb on a display it picks itself (-displayfd); returns (process, ':N')."""
    read_fd, write_fd = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                            pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_fd)
    with os.fdopen(read_fd) as f:
        number = f.readline().strip()
    if not number:
        xvfb.kill()
        raise RuntimeError("Xvfb reported no display")
    return xvfb, ":" + number


class RvizViewTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rviz_view_test")
        cls.lock = threading.Lock()
        cls.object_cloud = None
        cls.grasps = None
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        cls.workdir = tempfile.mkdtemp(prefix="rviz_view_")
        shipped = rospy.get_param("~rviz_config")
        cls.config_path = os.path.join(cls.workdir, "fast_grasp_test.rviz")
        cls.background = test_config(shipped, cls.config_path)
        cls.xvfb, cls.display = free_display_xvfb()
        env = dict(os.environ, DISPLAY=cls.display, LIBGL_ALWAYS_SOFTWARE="1")
        cls.rviz_log = open(os.path.join(cls.workdir, "rviz.log"), "w")
        cls.rviz = subprocess.Popen(["rviz", "-d", cls.config_path, "__name:=rviz_view_test_rviz"], env=env,
                                    stdout=cls.rviz_log, stderr=subprocess.STDOUT)
        cls.env = env
        subscribers = [rospy.Subscriber("/table_segmentation/object", PointCloud2, cls.on_object, queue_size=2),
                       rospy.Subscriber("/grasp_planner/grasps", GraspArray, cls.on_grasps, queue_size=2)]
        cls.wait_for_rviz_subscriptions()
        bag_start.resume_when_listening(subscribers, "/bag_player/pause_playback", timeout_s=TIMEOUT_S)
        results = os.path.join(os.environ.get("ROS_HOME", os.path.expanduser("~/.ros")), "test_results", "fast_grasp")
        os.makedirs(results, exist_ok=True)
        cls.screenshot = os.path.join(results, "rviz_view.png")

    @classmethod
    def tearDownClass(cls):
        for process in (cls.rviz, cls.xvfb):
            process.terminate()
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
        cls.rviz_log.close()

    @classmethod
    def wait_for_rviz_subscriptions(cls):
        """rviz must listen before the bag plays: neither the clouds nor the markers are latched."""
        needed = ("/table_segmentation/object", "/grasp_planner/markers")
        deadline = time.monotonic() + TIMEOUT_S
        while time.monotonic() < deadline:
            _, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
            listening = {topic for topic, nodes in subscribers if "/rviz_view_test_rviz" in nodes}
            if all(t in listening for t in needed):
                return
            if cls.rviz.poll() is not None:
                raise RuntimeError("rviz exited with %s (log %s)" % (cls.rviz.returncode, cls.rviz_log.name))
            time.sleep(0.2)
        raise RuntimeError("rviz did not subscribe to %s within %.0f s" % (needed, TIMEOUT_S))

    @classmethod
    def on_object(cls, msg):
        with cls.lock:
            cls.object_cloud = msg

    @classmethod
    def on_grasps(cls, msg):
        if msg.grasps:
            with cls.lock:
                cls.grasps = msg

    def wait_for_data(self):
        deadline = time.monotonic() + TIMEOUT_S
        while time.monotonic() < deadline:
            with self.lock:
                if self.object_cloud is not None and self.grasps is not None:
                    return self.object_cloud, self.grasps
            time.sleep(0.1)
        self.fail("no object cloud and grasps within %.0f s" % TIMEOUT_S)

    def take_screenshot(self):
        subprocess.run(["import", "-display", self.display, "-window", "root", self.screenshot], check=True,
                       env=self.env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=30)
        ppm = subprocess.run(["convert", self.screenshot, "-depth", "8", "ppm:-"], check=True,
                             stdout=subprocess.PIPE, timeout=30).stdout
        # binary PPM: "P6\n<w> <h>\n255\n" then RGB bytes
        header, rest = ppm.split(b"\n", 3)[:3], ppm.split(b"\n", 3)[3]
        width, height = map(int, header[1].split())
        return np.frombuffer(rest, dtype=np.uint8)[:width * height * 3].reshape(height, width, 3)

    def render_box(self, image):
        is_background = np.all(np.abs(image.astype(int) - self.background) <= 2, axis=2)
        rows = np.where(is_background.sum(axis=1) > 100)[0]
        cols = np.where(is_background.sum(axis=0) > 100)[0]
        self.assertTrue(len(rows) and len(cols), "no rviz background (%s) on screen: rviz not drawing" %
                        (self.background,))
        return int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1

    def region(self, image, pixel, half=12):
        col, row = int(round(pixel[0])), int(round(pixel[1]))
        return image[max(0, row - half):row + half + 1, max(0, col - half):col + half + 1].astype(int)

    def check(self, image, object_centroid, grasp_position, link_positions):
        """Which expectations fail on this screenshot (empty: all hold)."""
        box = self.render_box(image)
        failures = []
        background = np.array(self.background)
        red = self.region(image, project(object_centroid, box)[0])
        red_pixels = np.sum((red[..., 0] > 150) & (red[..., 1] < 110) & (red[..., 2] < 110))
        if red_pixels < 5:
            failures.append("object: %d red pixels around its centroid's projection %s" %
                            (red_pixels, project(object_centroid, box)[0]))
        blue = self.region(image, project(grasp_position, box)[0], half=20)
        blue_pixels = np.sum((blue[..., 2] > blue[..., 0] + 40) & (blue[..., 2] > blue[..., 1] + 20) &
                             (np.abs(blue - background).sum(axis=2) > 30))
        if blue_pixels < 5:
            failures.append("grasp: %d gripper-blue pixels around the grasp's projection %s" %
                            (blue_pixels, project(grasp_position, box)[0]))
        for link, position in link_positions.items():
            pixel = project(position, box)[0]
            patch = self.region(image, pixel, half=6)
            drawn = np.sum(np.abs(patch - background).sum(axis=2) > 30)
            if drawn < 10:
                failures.append("robot: %s at %s has %d drawn pixels" % (link, pixel, drawn))
        for point in EMPTY_POINTS:
            empty = self.region(image, project(point, box)[0], half=6)
            if np.sum(np.abs(empty - background).sum(axis=2) > 30) > 0:
                failures.append("empty space around %s is drawn on: the checks would see anything" % (point,))
        return failures

    def test_object_grasp_and_robot_drawn(self):
        cloud, grasps = self.wait_for_data()
        self.assertEqual(cloud.header.frame_id, "base_link")
        points = np.array(list(point_cloud2.read_points(cloud, field_names=("x", "y", "z"), skip_nans=True)))
        centroid = points.mean(axis=0)
        best = grasps.grasps[0]
        self.assertEqual(grasps.header.frame_id, "base_link")
        position = [best.pose.position.x, best.pose.position.y, best.pose.position.z]
        links = {}
        for link in ROBOT_LINKS:
            t = self.tf_buffer.lookup_transform("base_link", link, rospy.Time(0), rospy.Duration(10.0))
            links[link] = [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]
        deadline = time.monotonic() + 60.0
        failures = ["no screenshot"]
        while time.monotonic() < deadline:
            image = self.take_screenshot()
            failures = self.check(image, centroid, position, links)
            if not failures:
                break
            time.sleep(1.0)
        rospy.loginfo("rviz screenshot %s: object centroid %s, grasp %s, links %s", self.screenshot, centroid,
                      position, links)
        self.assertFalse(failures, "screenshot %s: %s" % (self.screenshot, failures))


if __name__ == "__main__":
    rostest.rosrun("fast_grasp", "rviz_view", RvizViewTest)
