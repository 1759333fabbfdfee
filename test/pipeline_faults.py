#!/usr/bin/python3
"""rostest node for pipeline_faults.test (launch/soak.launch without its soak node): a short
soak of the bundled frames, then faults injected into the running pipeline, each of which must
give a clear status and leave the pipeline working again without a restart:

- a 20 s soak at 30 Hz: every output carries one of its stage's input stamps, every processed
  frame is accounted for (output, or a drop with its ~status reason), memory not running away;
- a camera that switches resolution (640x480 -> 320x240 -> 1280x960 -> 640x480, the bag frames
  re-sampled): every resolution goes through to grasps;
- tf that stops arriving: cloud_preprocess says "no transform", and the frames after tf returns
  go through to grasps;
- the planning manager killed (SIGKILL, as a crash in a planner would): its /diagnostics go
  silent while perception keeps reporting, roslaunch respawns it, the bonded loaders reload
  the planners, and the frames after that get grasps and an arm trajectory again;
- the grasp planner's loader killed: the nodelet is unloaded (bond) and loaded again.

The 20 M-point cloud (down-sampled, not rejected) is in perception_bad_input.py."""
import io
import os
import signal
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from nodelet.srv import NodeletList

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
import soak  # noqa: E402

RATE_HZ = 30.0
SOAK_S = 20.0
RECOVERY_TIMEOUT_S = 90.0
BOND_SETTLED_S = 6.0  # a loader's bond has exchanged several heartbeats (1 s period) by then


def process_age_s(pid):
    """Seconds since the process started (from /proc), 0 when it is gone."""
    try:
        with open("/proc/%d/stat" % pid) as stat:
            start_ticks = int(stat.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as uptime:
            return float(uptime.read().split()[0]) - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return 0.0


def resampled(frame, factor):
    """The frame's cloud as a camera of another resolution sees it: every `factor`-th pixel
    (factor < 1: each pixel repeated 1/factor times in both directions)."""
    msg = frame.cloud()
    pixels = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.width, msg.point_step)
    if factor >= 1:
        pixels = pixels[::factor, ::factor]
    else:
        repeat = int(round(1 / factor))
        pixels = np.repeat(np.repeat(pixels, repeat, axis=0), repeat, axis=1)
    msg.height, msg.width = pixels.shape[0], pixels.shape[1]
    msg.row_step = msg.width * msg.point_step
    msg.data = np.ascontiguousarray(pixels).tobytes()
    buff = io.BytesIO()
    msg.serialize(buff)
    return buff.getvalue(), frame.transforms


class PipelineFaultsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("pipeline_faults_test")
        cls.frames = soak.load_frames()
        cls.player = soak.FramePlayer(cls.frames)
        cls.stages = soak.pipeline_stages()
        cls.monitor = soak.PipelineMonitor(cls.stages, cls.player)
        cls.stage = {s.name: s for s in cls.stages}
        cls.lock = threading.Lock()
        cls.diagnostics = []  # (monotonic time, status name, its "messages processed" or None)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.on_diagnostics, queue_size=None)
        cls.monitor.wait_connected(timeout_s=120.0)

    @classmethod
    def on_diagnostics(cls, msg):
        now = time.monotonic()
        with cls.lock:
            cls.diagnostics.extend((now, status.name, cls.messages_processed(status)) for status in msg.status)

    @staticmethod
    def messages_processed(status):
        for value in status.values:
            if value.key == "messages processed":
                try:
                    return int(value.value)
                except ValueError:
                    return None
        return None

    def planner_diagnostics(self, planner, since):
        """(time, messages processed) of the planner's /diagnostics received after `since`."""
        with self.lock:
            return [(t, processed) for t, name, processed in self.diagnostics
                    if planner in name and t > since and processed is not None]

    # -- helpers ---------------------------------------------------------------------------
    def play_until(self, condition, what, timeout_s=RECOVERY_TIMEOUT_S, rate_hz=RATE_HZ):
        """Plays frames until condition() holds; fails naming `what`, the latest statuses and
        the stages that published nothing since the first frame played here."""
        first = self.player.publish_one()
        deadline = time.monotonic() + timeout_s
        period = 1.0 / rate_hz
        while time.monotonic() < deadline:
            self.player.publish_one()
            time.sleep(period)
            with self.monitor.lock:
                if condition():
                    return
        with self.monitor.lock:
            silent = [s.name for s in self.stages if not self.outputs_since(s.name, first)]
        self.fail("%s not within %.0f s; no output since from %s; loaded planners %s; latest statuses: %s"
                  % (what, timeout_s, silent, self.loaded_planners(), self.latest_statuses()))

    def latest_statuses(self):
        with self.monitor.lock:
            return {s.name: (s.statuses[-1][1][:160] if s.statuses else None) for s in self.stages}

    def outputs_since(self, stage, first_stamp):
        return [s for s in self.stage[stage].outputs if s >= first_stamp]

    def all_planners_answered_since(self, first_stamp):
        return all(self.outputs_since(name, first_stamp) for name in soak.PLANNERS)

    # -- tests -----------------------------------------------------------------------------
    def test_00_short_soak(self):
        sampler = soak.MemorySampler(period_s=1.0)
        sampler.start()
        elapsed = self.player.play(SOAK_S, RATE_HZ)
        self.monitor.wait_quiet(quiet_s=3.0, timeout_s=60.0)
        sampler.stop()
        rows = self.monitor.counts()
        rospy.loginfo("short soak:\n%s", soak.format_report(rows, sampler, elapsed / 60.0, RATE_HZ,
                                                             len(self.player.sent) / elapsed, 5.0, "-", "-"))
        for row in rows:
            self.assertEqual(row["unmatched"], 0, "%s published stamps that are no input's: %s" % (row["stage"], row))
            self.assertEqual(row["unexplained"], 0, "%s: frames processed but neither out nor dropped: %s"
                             % (row["stage"], row))
            self.assertGreaterEqual(row["superseded"], 0, "%s: more statuses than inputs: %s" % (row["stage"], row))
            self.assertGreater(row["out"], 0, "%s produced nothing in %.0f s: %s" % (row["stage"], SOAK_S, row))
        # Memory: not a timing target, a bound against a leak of a frame a frame (9.8 MB each,
        # 600 frames here): after 5 s the managers may grow, but not by frames' worth.
        for name, samples in sampler.samples.items():
            self.assertTrue(samples, "no VmRSS samples of %s" % name)
            settled = [rss for t, _, rss in samples if t >= 5.0]
            self.assertTrue(settled, name)
            self.assertLess(max(settled) - settled[0], 200 * 1024,
                            "%s grew from %d to %d kB during the soak" % (name, settled[0], max(settled)))

    def test_00b_perception_manager_runs_with_two_malloc_arenas(self):
        # launch/perception.launch's malloc_arena_max: with glibc's 8 arenas per core the manager
        # keeps freed camera frames in each arena and its RSS climbs in 9.4 MiB steps under load
        # (docs/tests.md, Soak, session 18); with 2 it stays flat.
        pid = soak.manager_pid("/fast_grasp_manager")
        self.assertTrue(pid, "the perception manager is not registered")
        with open("/proc/%d/environ" % pid, "rb") as environ:
            variables = environ.read().split(b"\0")
        self.assertIn(b"MALLOC_ARENA_MAX=2", variables)

    def test_01_camera_switches_resolution(self):
        frames = self.frames[:4]
        phases = [("320x240", [resampled(f, 2) for f in frames]), ("1280x960", [resampled(f, 0.5) for f in frames]),
                  ("640x480", [(f.raw, f.transforms) for f in frames])]
        try:
            for name, clouds in phases:
                self.player.frame_source = lambda i, clouds=clouds: clouds[i % len(clouds)]
                first = self.player.publish_one()
                # 1280x960 frames are 39 MB: a slower rate keeps the Python side from lagging.
                self.play_until(lambda: self.outputs_since("normals", first) and self.outputs_since("grasp_planner", first),
                                "object normals and grasps from %s frames" % name, rate_hz=5.0)
                with self.monitor.lock:
                    preprocess = self.stage["preprocess"].statuses[-1][1]
                self.assertFalse(preprocess.startswith("ERROR"), "%s: %s" % (name, preprocess))
                rospy.loginfo("%s: preprocess said %s", name, preprocess[:120])
        finally:
            self.player.frame_source = None

    def test_02_tf_stops_and_returns(self):
        with self.monitor.lock:
            errors_before = sum(1 for level, _ in self.stage["preprocess"].statuses if level == "ERROR")
        self.player.tf_enabled = False
        try:
            self.play_until(lambda: any(level == "ERROR" and "no transform" in text
                                        for level, text in self.stage["preprocess"].statuses[errors_before:]),
                            "preprocess status 'no transform' while tf is missing", timeout_s=30.0, rate_hz=10.0)
        finally:
            self.player.tf_enabled = True
        with self.monitor.lock:
            said = [text for level, text in self.stage["preprocess"].statuses[errors_before:] if level == "ERROR"][-1]
        rospy.loginfo("tf stopped: preprocess said %s", said[:200])
        first = self.player.publish_one()
        returned = time.monotonic()
        self.play_until(lambda: self.outputs_since("preprocess", first), "a preprocessed cloud after tf returned")
        preprocessed = time.monotonic()
        self.play_until(lambda: self.all_planners_answered_since(first), "grasps from every planner after tf returned")
        rospy.loginfo("tf returned: a preprocessed cloud %.1f s later, grasps from every planner %.1f s later",
                      preprocessed - returned, time.monotonic() - returned)

    def test_04_planner_loader_killed(self):
        # The grasp planner's `nodelet load` process dies: the manager unloads the nodelet when
        # the bond times out, the respawned loader loads it again (until then its load attempts
        # fail: the name is taken); the other planners never stop. The unload and the reload can
        # be a tenth of a second apart (a respawned loader is waiting), too short to see in the
        # manager's list: a new nodelet instance also shows as its "messages processed" count
        # starting again from zero in /diagnostics.
        loader = "/grasp_planner"
        pid = soak.manager_pid(loader)
        self.assertIsNotNone(pid, "no pid for %s" % loader)
        self.assertIn(loader, self.loaded_planners())
        # Debian's bondcpp (1.8.6) never breaks a bond whose sister died after its first status
        # message and before its second: the connect timer is stopped and the heartbeat timer
        # not yet started (fixed upstream in ros/bond_core#93). test_03 has just reloaded every
        # planner; a loader killed within its first heartbeats would leave the nodelet loaded for
        # good (seen in CI: killed 2 s after its load). Kill it once its bond has run a while.
        self.play_until(lambda: process_age_s(pid) >= BOND_SETTLED_S,
                        "%s up for %.0f s" % (loader, BOND_SETTLED_S), rate_hz=10.0)
        before = time.monotonic()
        self.play_until(lambda: self.planner_diagnostics("grasp_planner", before),
                        "diagnostics from the grasp planner before the kill", rate_hz=10.0)
        processed_before = self.planner_diagnostics("grasp_planner", before)[-1][1]
        os.kill(pid, signal.SIGKILL)
        killed_at = time.monotonic()
        with self.monitor.lock:
            others_before = len(self.stage["cshape_planner"].statuses)

        def new_instance():
            return any(processed < processed_before
                       for _, processed in self.planner_diagnostics("grasp_planner", killed_at))

        self.play_until(lambda: loader not in self.loaded_planners() or new_instance(),
                        "%s unloaded by its manager" % loader, rate_hz=10.0)
        unloaded_at = time.monotonic()
        self.play_until(lambda: loader in self.loaded_planners(), "%s loaded again" % loader, rate_hz=10.0)
        reloaded_at = time.monotonic()
        first_after = self.player.publish_one()
        self.play_until(lambda: self.outputs_since("grasp_planner", first_after) and
                        self.outputs_since("arm_planner", first_after),
                        "grasps and a trajectory after the grasp planner was reloaded")
        self.play_until(new_instance, "diagnostics of a new grasp planner instance (its count restarted)",
                        rate_hz=10.0)
        with self.monitor.lock:
            self.assertGreater(len(self.stage["cshape_planner"].statuses), others_before)
        rospy.loginfo("grasp planner loader killed: unloaded (seen) after %.1f s, loaded again (seen) after %.1f s, "
                      "grasps and a trajectory after %.1f s", unloaded_at - killed_at, reloaded_at - killed_at,
                      time.monotonic() - killed_at)

    @staticmethod
    def loaded_planners():
        """Nodelets loaded in the planning manager (its ~list service); [] while it is down."""
        try:
            return rospy.ServiceProxy("/fast_grasp_planning_manager/list", NodeletList)().nodelets
        except (rospy.ServiceException, rospy.ROSException):
            return []

    def test_03_planning_manager_killed(self):
        manager = "/fast_grasp_planning_manager"
        pid = soak.manager_pid(manager)
        self.assertIsNotNone(pid, "no pid for %s" % manager)
        # Every loader's bond to this manager has formed (they loaded minutes ago). A loader that
        # loaded its nodelet a second before the manager died, before the first heartbeats, was
        # seen to stay orphaned: it never reloaded (NOTES.md). So this fault comes before the
        # loader one, not right after a reload.
        self.assertEqual(sorted(self.loaded_planners()), sorted("/" + n for n in soak.PLANNERS + ("arm_planner",)))
        first = self.player.publish_one()
        self.play_until(lambda: self.outputs_since("arm_planner", first), "a trajectory before the kill")
        os.kill(pid, signal.SIGKILL)
        killed_at = time.monotonic()
        rospy.loginfo("killed %s (pid %d)", manager, pid)
        # The dead planners' /diagnostics stop (a diagnostic aggregator shows them stale) while
        # perception keeps reporting frames.
        with self.monitor.lock:
            perception_before = len(self.stage["preprocess"].statuses)
        perception_pid = soak.manager_pid("/fast_grasp_manager")
        self.play_until(lambda: soak.manager_pid(manager) not in (None, pid), "a respawned %s" % manager,
                        rate_hz=10.0)

        def perception_reported():  # play_until holds the monitor's lock
            return len(self.stage["preprocess"].statuses) > perception_before
        # Perception runs in its own manager and keeps reporting frames. A frame can take longer
        # than the respawn (seen under ThreadSanitizer), so wait for one instead of requiring it
        # by the time the planning manager is back.
        self.play_until(perception_reported, "perception reporting frames after the planners were killed")
        self.assertEqual(soak.manager_pid("/fast_grasp_manager"), perception_pid,
                         "the perception manager went down with the planning manager")
        rospy.loginfo("%s respawned %.1f s after the kill", manager, time.monotonic() - killed_at)
        first_after = self.player.publish_one()
        self.play_until(lambda: self.all_planners_answered_since(first_after) and
                        self.outputs_since("arm_planner", first_after),
                        "grasps from every planner and a trajectory after the respawn")
        # The respawned planners' diagnostics come on a 1 s timer: wait for the first one.
        self.play_until(lambda: self.planner_diagnostics("grasp_planner", killed_at),
                        "diagnostics from the reloaded grasp planner", rate_hz=10.0)
        silent_until = min(t for t, _ in self.planner_diagnostics("grasp_planner", killed_at))
        rospy.loginfo("planner diagnostics silent for %.1f s after the kill; every planner and the arm back %.1f s "
                      "after it", silent_until - killed_at, time.monotonic() - killed_at)
        self.assertGreater(silent_until - killed_at, 1.0, "the planner's diagnostics never went silent")


if __name__ == "__main__":
    rostest.rosrun("fast_grasp", "pipeline_faults", PipelineFaultsTest)
