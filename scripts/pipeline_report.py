#!/usr/bin/python3
"""Prints, per camera frame of the replayed bag, what the pipeline found: the table plane,
the target object (points, centroid, extent), the chosen grasp (or, from the principal-axis
planner, the next camera pose it suggests when it found none) and, when the arm planner
runs, the trajectory. Exits once every frame of the bag is reported, or after ~timeout_s.

Parameters (private): bag (path, to count its frames), timeout_s, cloud_topic, report_file
(write the report there instead of stdout: scripts/demo.sh shows only it and the warnings),
expect_grasps (bool), expect_trajectory (bool), stop_after_grasp (bool: a live camera, e.g.
scene_camera following the next view, has no frame count; stop at the first frame with a grasp
reported in full), clear_table (bool: scene_camera clears a cluttered table; print each of its
picks, stop when it says the table is cleared or when no pick came for ~pick_timeout_s, 30 s;
exit 1 only if there was no pick at all).
"""
import math
import os
import sys
import threading

import rosbag
import rospy
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from fast_grasp.msg import GraspArray, SegmentedScene

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bag_start  # noqa: E402


def count_frames(bag_path, topic):
    with rosbag.Bag(bag_path) as bag:
        info = bag.get_type_and_topic_info().topics
        return info[topic].message_count if topic in info else 0


class Report:
    def __init__(self):
        self.lock = threading.Lock()
        self.frames = {}  # stamp -> dict of parts
        self.order = []
        self.expect_grasps = rospy.get_param("~expect_grasps", True)
        self.expect_trajectory = rospy.get_param("~expect_trajectory", False)
        self.pending_summaries = []  # arm summaries that came before their trajectory

    def frame(self, stamp):
        key = stamp.to_nsec()
        if key not in self.frames:
            self.frames[key] = {}
            self.order.append(key)
        return self.frames[key]

    def complete(self, parts):
        needed = ["scene"]
        if parts.get("scene") is not None and parts["scene"].ok:
            if self.expect_grasps:
                needed.append("grasps")
                grasps = parts.get("grasps")
                if self.expect_trajectory and grasps is not None and grasps.grasps:
                    needed.append("trajectory")
        if "trajectory" in needed and "trajectory" in parts and parts["trajectory"][1] is None:
            return False  # the plan's summary has not arrived yet
        return all(n in parts for n in needed)

    def on_scene(self, msg):
        with self.lock:
            self.frame(msg.header.stamp)["scene"] = msg
            self.flush()

    def on_grasps(self, msg):
        with self.lock:
            self.frame(msg.header.stamp)["grasps"] = msg
            self.flush()

    def on_next_view(self, msg):
        with self.lock:
            parts = self.frame(msg.header.stamp)
            parts["next_view"] = msg
            if parts.get("printed"):  # published after the grasps it belongs to
                print("frame t=%.3f s\n%s" % (msg.header.stamp.to_sec(), self.describe_next_view(msg)), flush=True)
            else:
                self.flush()

    @staticmethod
    def describe_next_view(msg):
        p, q = msg.pose.position, msg.pose.orientation
        # Optical z (the line of sight) of the suggested camera: third column of its rotation.
        sight = (2 * (q.x * q.z + q.w * q.y), 2 * (q.y * q.z - q.w * q.x), 1 - 2 * (q.x * q.x + q.y * q.y))
        return ("  next view (Ch3.2.3): camera at (%.3f, %.3f, %.3f) m looking along (%.2f, %.2f, %.2f) "
                "in %s" % (p.x, p.y, p.z, sight[0], sight[1], sight[2], msg.header.frame_id))

    def on_trajectory(self, msg):
        with self.lock:
            # The trajectory carries the stamp of the grasps it was planned for; its summary
            # comes next on the arm planner's status.
            parts = self.frame(msg.header.stamp)
            # Topics are not ordered with each other: the summary may already be here.
            parts["trajectory"] = (msg, self.pending_summaries.pop(0) if self.pending_summaries else None)
            self.flush()

    def on_arm_status(self, msg):
        with self.lock:
            # Statuses come in planning order: a success completes the oldest trajectory still
            # without its summary; a failure answers the oldest frame still waiting for a plan.
            if msg.data.startswith("OK") and not any(
                    "trajectory" in p and p["trajectory"][1] is None for p in self.frames.values()):
                self.pending_summaries.append(msg.data)  # its trajectory has not arrived yet
                return
            for key in self.order:
                parts = self.frames[key]
                if msg.data.startswith("OK"):
                    if "trajectory" in parts and parts["trajectory"][1] is None:
                        parts["trajectory"] = (parts["trajectory"][0], msg.data)
                        break
                else:
                    grasps = parts.get("grasps")
                    if grasps is not None and grasps.grasps and "trajectory" not in parts:
                        parts["trajectory"] = (None, msg.data)
                        break
            self.flush()

    def flush(self):
        for key in self.order:
            parts = self.frames[key]
            if parts.get("printed") or not self.complete(parts):
                continue
            parts["printed"] = True
            print(self.describe(key, parts), flush=True)

    def printed(self):
        return sum(1 for p in self.frames.values() if p.get("printed"))

    def printed_grasp(self):
        return any(p.get("printed") and p.get("grasps") is not None and p["grasps"].grasps
                   for p in self.frames.values())

    @staticmethod
    def describe(key, parts):
        lines = ["frame t=%.3f s" % (key * 1e-9)]
        scene = parts.get("scene")
        if scene is not None:
            if scene.ok:
                a, b, c, d = scene.table_plane
                e = scene.object_extent
                p = scene.object_centroid
                lines.append("  table plane: %.4f x %+.4f y %+.4f z %+.4f = 0 (%d points)"
                             % (a, b, c, d, scene.table_points))
                lines.append("  object: %d points, centroid (%.3f, %.3f, %.3f) m, extent %.3f x %.3f x %.3f m"
                             % (scene.object_points, p.x, p.y, p.z, e.x, e.y, e.z))
            else:
                lines.append("  segmentation failed: %s" % scene.status)
        grasps = parts.get("grasps")
        if grasps is not None:
            if grasps.grasps:
                g = grasps.grasps[0]
                q = g.pose.orientation
                objects = sorted({x.object_id for x in grasps.grasps})
                # all_objects: the first grasp is of the object picked first, not always the target.
                source = g.algorithm if len(objects) < 2 else "%s, object %d of %d with grasps" % (
                    g.algorithm, g.object_id, len(objects))
                lines.append("  grasp (%s, best of %d, %.2f ms): position (%.3f, %.3f, %.3f) m, "
                             "orientation xyzw (%.3f, %.3f, %.3f, %.3f), width %.3f m, score %.3f"
                             % (source, len(grasps.grasps), grasps.compute_time_s * 1e3,
                                g.pose.position.x, g.pose.position.y, g.pose.position.z,
                                q.x, q.y, q.z, q.w, g.width_m, g.score))
                metrics = [(name, getattr(g, name)) for name in
                           ("force_balance_rad", "xoz_offset_m", "variance_m", "torque_offset_m", "gravity_offset_m")]
                known = ["%s %.4f" % (n, v) for n, v in metrics if not math.isnan(v)]
                if known:  # the fused planner's own candidates carry no thesis metric
                    lines.append("    metrics: " + ", ".join(known))
            else:
                lines.append("  no grasp: %s" % grasps.status)
                if "next_view" in parts:
                    lines.append(Report.describe_next_view(parts["next_view"]))
        if "trajectory" in parts:
            traj, status = parts["trajectory"]
            if traj is None:
                lines.append("  no trajectory: %s" % status)
            else:
                duration = traj.points[-1].time_from_start.to_sec() if traj.points else 0.0
                lines.append("  trajectory: %d waypoints, %.2f s; %s" % (len(traj.points), duration, status))
        return "\n".join(lines)


def main():
    rospy.init_node("pipeline_report")
    report_file = rospy.get_param("~report_file", "")
    if report_file:
        sys.stdout = open(report_file, "w", buffering=1)
    bag = rospy.get_param("~bag", "")
    cloud_topic = rospy.get_param("~cloud_topic", "/camera/depth_registered/points")
    timeout_s = rospy.get_param("~timeout_s", 60.0)
    expected = count_frames(bag, cloud_topic) if bag else 0
    stop_after_grasp = rospy.get_param("~stop_after_grasp", False)
    expect_trajectory = rospy.get_param("~expect_trajectory", False)
    report = Report()
    clear_table = rospy.get_param("~clear_table", False)
    pick_timeout_s = rospy.get_param("~pick_timeout_s", 30.0)
    picks = []  # scene_camera's pick lines, in order
    cleared = threading.Event()

    def on_camera_status(msg):
        text = msg.data[4:] if msg.data.startswith("OK: ") else msg.data
        if text.startswith("pick "):
            picks.append(text)
            print("scene_camera: " + text, flush=True)
        elif text.startswith("table cleared"):
            print("scene_camera: " + text, flush=True)
            cleared.set()

    if clear_table:
        rospy.Subscriber("/scene_camera/status", String, on_camera_status, queue_size=20)
    subscribers = [
        rospy.Subscriber("/table_segmentation/segmented_scene", SegmentedScene, report.on_scene, queue_size=10),
        rospy.Subscriber("/grasp_planner/grasps", GraspArray, report.on_grasps, queue_size=10)]
    if expect_trajectory:
        subscribers += [
            rospy.Subscriber("/arm_planner/status", String, report.on_arm_status, queue_size=10),
            rospy.Subscriber("/arm_planner/trajectory", JointTrajectory, report.on_trajectory, queue_size=10)]
    # Advertised only by the principal-axis planner: not waited for.
    rospy.Subscriber("/grasp_planner/next_view", PoseStamped, report.on_next_view, queue_size=10)
    print("pipeline_report: waiting for %d frame(s) of %s" % (expected, bag or "the live camera"), flush=True)
    # demo.launch plays the bag paused (~pause_service): every frame is reported, however long
    # this machine takes to start the pipeline.
    pause_service = rospy.get_param("~pause_service", "")
    if pause_service:
        bag_start.resume_when_listening(subscribers, pause_service, rospy.get_param("~bag_topics", None))
    # Wall-clock timeout: sim time stops when the bag ends.
    import time
    deadline = time.monotonic() + timeout_s
    if clear_table:
        last_pick, seen = time.monotonic(), 0
        while not rospy.is_shutdown() and not cleared.is_set():
            if len(picks) != seen:
                last_pick, seen = time.monotonic(), len(picks)
            if time.monotonic() - last_pick > pick_timeout_s:
                print("pipeline_report: stopped after %d pick(s): no pick for %.0f s" % (len(picks), pick_timeout_s),
                      flush=True)
                sys.exit(0 if picks else 1)
            time.sleep(0.05)
        time.sleep(0.5)  # the last round's frame reports
        print("pipeline_report: table cleared in %d pick(s)" % len(picks), flush=True)
        return
    while not rospy.is_shutdown() and time.monotonic() < deadline:
        if expected and report.printed() >= expected:
            print("pipeline_report: all %d frame(s) reported" % expected, flush=True)
            return
        if stop_after_grasp and report.printed_grasp():
            print("pipeline_report: a grasp after %d frame(s)" % report.printed(), flush=True)
            return
        time.sleep(0.05)
    with report.lock:
        missing = [k for k in report.order if not report.frames[k].get("printed")]
        for key in missing:
            print(Report.describe(key, report.frames[key]) + "\n  (incomplete)", flush=True)
    print("pipeline_report: timed out after %.0f s with %d of %d frame(s) reported"
          % (timeout_s, report.printed(), expected), flush=True)
    sys.exit(1)


if __name__ == "__main__":
    main()
