#!/usr/bin/python3
"""Soak the running pipeline (launch/soak.launch) with the bundled bag frames.

usage: soak.py [--minutes M] [--rate HZ] [--help]

Publishes the camera frames of bags/*.bag (not the two-camera one) round-robin at HZ on
/camera/depth_registered/points, each with a fresh stamp and the bag's camera transform on
/tf at that stamp, for M minutes. Meanwhile it listens to every stage's output and ~status and
samples the resident memory (VmRSS) of the nodelet managers. At the end it prints per stage
(preprocess, table segmentation, normals, each grasp planner, arm planner):

  in          frames offered to the stage (its input topic, by stamp)
  processed   ~status lines (one per frame the stage's callback handled)
  out         frames published on the stage's output
  superseded  in - processed: a newer frame arrived while the stage was busy (input queue 1-2:
              the latest frame wins by design; these never reach the callback, so no status)
  dropped     processed frames with no output, by the reason on ~status
  unmatched   outputs whose stamp is not one of the stage's input stamps
  unexplained processed - out - dropped (0 when every frame is accounted for)

and the memory over time, then the targets: 10 minutes, < 5 % growth after warm-up, every output
stamped with an input stamp, no unexplained drop. scripts/soak.sh starts master and pipeline.
The module is also the driver of the soak and fault rostests (test/pipeline_faults.py).
"""
import argparse
import collections
import glob
import os
import re
import statistics
import struct
import sys
import threading
import time
import xmlrpc.client

import rosbag
import rosgraph
import rospy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

BAG_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bags")
CLOUD_TOPIC = "/camera/depth_registered/points"
PLANNERS = ("grasp_planner", "cshape_planner", "principal_axis_planner", "boundary_planner", "concavity_planner")
MANAGERS = ("/fast_grasp_manager", "/fast_grasp_planning_manager")


class RawCloud(PointCloud2):
    """A PointCloud2 kept serialised: publishing writes its bytes unchanged (a 640x480 frame is
    9.8 MB; re-serialising it in Python 30 times a second would be the bottleneck)."""
    __slots__ = ("raw",)
    _has_header = False  # rospy must not touch .header (the stamp is in the bytes)

    def __init__(self, raw):  # pylint: disable=super-init-not-called
        self.raw = raw

    def serialize(self, buff):
        buff.write(self.raw)


def header_stamp_us(raw):
    """Stamp of a serialised message that starts with a std_msgs/Header, in microseconds: the
    unit of a pcl::PointCloud's stamp, so the clouds' stamps compare with the camera's."""
    secs, nsecs = struct.unpack_from("<II", raw, 4)
    return secs * 1000000 + nsecs // 1000


def grasp_count(raw):
    """Number of grasps in a serialised fast_grasp/GraspArray (header, then Grasp[])."""
    frame_len = struct.unpack_from("<I", raw, 12)[0]
    return struct.unpack_from("<I", raw, 16 + frame_len)[0]


class Frame:
    """One camera frame of a bag: the serialised cloud and the camera's transforms."""

    def __init__(self, bag, raw, transforms):
        self.bag = bag
        self.raw = raw
        self.transforms = transforms

    def cloud(self):
        msg = PointCloud2()
        msg.deserialize(bytes(self.raw))
        return msg


def load_frames(pattern=os.path.join(BAG_DIR, "*.bag")):
    # clutter_* bags stay in: the soak checks frame accounting and memory, not any object's
    # truth, and several objects per frame is input the pipeline must take
    frames = []
    for path in sorted(glob.glob(pattern)):
        if os.path.basename(path).startswith("two_camera"):
            continue
        with rosbag.Bag(path) as bag:
            transforms = []
            clouds = []
            for topic, msg, _ in bag.read_messages(topics=["/tf_static", CLOUD_TOPIC], raw=True):
                if topic == "/tf_static":
                    tf = TFMessage()
                    tf.deserialize(msg[1])
                    transforms.extend(tf.transforms)
                else:
                    clouds.append(bytes(msg[1]))
        frames.extend(Frame(os.path.basename(path), raw, transforms) for raw in clouds)
    if not frames:
        raise RuntimeError("no frames in %s" % pattern)
    return frames


def stamped_cloud(raw, stamp):
    """A copy of serialised cloud bytes with the header stamp replaced."""
    data = bytearray(raw)
    struct.pack_into("<II", data, 4, stamp.secs, stamp.nsecs)
    return RawCloud(data)


class FramePlayer:
    """Publishes frames round-robin with fresh stamps; the camera tf goes out on /tf at each
    frame's stamp. `tf_enabled` and `frame_source` let a test cut tf or swap the frames."""

    def __init__(self, frames):
        self.frames = frames
        self.cloud_pub = rospy.Publisher(CLOUD_TOPIC, PointCloud2, queue_size=2)
        self.tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=20)
        self.tf_enabled = True
        self.frame_source = None  # callable(index) -> (raw bytes, transforms); None: self.frames
        self.sent = []  # stamps in µs
        self.lock = threading.Lock()
        self.index = 0

    def publish_one(self):
        if self.frame_source:
            raw, transforms = self.frame_source(self.index)
        else:
            frame = self.frames[self.index % len(self.frames)]
            raw, transforms = frame.raw, frame.transforms
        self.index += 1
        stamp = rospy.Time.now()
        if self.tf_enabled:
            for t in transforms:
                t.header.stamp = stamp
            self.tf_pub.publish(TFMessage(transforms=transforms))
        self.cloud_pub.publish(stamped_cloud(raw, stamp))
        with self.lock:
            self.sent.append(stamp.to_nsec() // 1000)
        return stamp.to_nsec() // 1000

    def play(self, duration_s, rate_hz, stop=lambda: False):
        period = 1.0 / rate_hz
        start = time.monotonic()
        next_time = start
        while not rospy.is_shutdown() and not stop():
            now = time.monotonic()
            if now - start >= duration_s:
                break
            if now < next_time:
                time.sleep(next_time - now)
            self.publish_one()
            # Behind schedule (a slow publish): skip the missed slots instead of bursting.
            next_time = max(next_time + period, time.monotonic() - period)
        return time.monotonic() - start


class Stage:
    """Counts of one pipeline stage. `output_levels`: the status levels that come with an
    output (preprocess and normals publish on a WARN note, table segmentation does not)."""

    def __init__(self, name, status_topic, input_topic, output_topic, output_levels, counts_output=None):
        self.name = name
        self.status_topic = status_topic
        self.input_topic = input_topic
        self.output_topic = output_topic
        self.output_levels = output_levels
        self.counts_output = counts_output or (lambda raw: True)
        self.statuses = []  # (level, text)
        self.outputs = []  # stamps of the outputs that count as "out"
        self.answers = []  # stamps of every message on the output topic


def status_level(text):
    for level in ("OK", "WARN", "ERROR"):
        if text.startswith(level + ": "):
            return level
    return "?"


def reason_of(text):
    """The status text without its level and numbers, up to the first ':', ';' or '(': the
    reason a drop is counted under."""
    body = text.split(": ", 1)[1] if ": " in text else text
    body = re.split(r"[:;(]", body, 1)[0]
    body = re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "N", body).strip()
    return (status_level(text) + " " + body)[:70]


def pipeline_stages():
    stages = [
        Stage("preprocess", "/cloud_preprocess/status", CLOUD_TOPIC, "/cloud_preprocess/output", ("OK", "WARN")),
        Stage("table_segmentation", "/table_segmentation/status", "/cloud_preprocess/output",
              "/table_segmentation/object", ("OK",)),
        Stage("normals", "/normal_estimation/status", "/table_segmentation/object", "/normal_estimation/output",
              ("OK", "WARN")),
    ]
    for planner in PLANNERS:
        # A planner answers every frame on ~grasps (empty with the failure); "out" = with grasps.
        stages.append(Stage(planner, "/%s/status" % planner, "/normal_estimation/output", "/%s/grasps" % planner,
                            ("OK",), counts_output=lambda raw: grasp_count(raw) > 0))
    stages.append(Stage("arm_planner", "/arm_planner/status", "/grasp_planner/grasps", "/arm_planner/trajectory",
                        ("OK",)))
    return stages


class PipelineMonitor:
    """Listens to every stage's input, output and ~status (stamps parsed from the raw bytes:
    no cloud is deserialised)."""

    def __init__(self, stages, player):
        self.stages = stages
        self.player = player
        self.lock = threading.Lock()
        self.topic_stamps = collections.defaultdict(list)
        self.last_status_time = time.monotonic()
        self.subscribers = []
        topics = {s.output_topic for s in stages} | {s.input_topic for s in stages if s.input_topic != CLOUD_TOPIC}
        for topic in sorted(topics):
            self.subscribers.append(rospy.Subscriber(topic, rospy.AnyMsg, self.on_message, callback_args=topic,
                                                     queue_size=None, buff_size=1 << 24))
        for stage in stages:
            self.subscribers.append(rospy.Subscriber(stage.status_topic, String, self.on_status, callback_args=stage,
                                                     queue_size=None))

    def on_message(self, msg, topic):
        stamp = header_stamp_us(msg._buff)
        with self.lock:
            self.topic_stamps[topic].append(stamp)
            for stage in self.stages:
                if stage.output_topic == topic:
                    stage.answers.append(stamp)
                    if stage.counts_output(msg._buff):
                        stage.outputs.append(stamp)

    def on_status(self, msg, stage):
        with self.lock:
            stage.statuses.append((status_level(msg.data), msg.data))
            self.last_status_time = time.monotonic()

    def wait_connected(self, timeout_s=60.0):
        """Until the pipeline listens to the camera and every topic watched here has a
        publisher (the lazy nodelets subscribe once their outputs have listeners)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            missing = [s.resolved_name for s in self.subscribers if s.get_num_connections() == 0]
            if self.player.cloud_pub.get_num_connections() == 0:
                missing.append(CLOUD_TOPIC + " (no subscriber)")
            if not missing:
                time.sleep(1.0)  # last handshakes, tf listeners
                return
            time.sleep(0.2)
        raise RuntimeError("pipeline not connected after %.0f s: %s" % (timeout_s, missing))

    def wait_quiet(self, quiet_s=5.0, timeout_s=120.0):
        """Until no stage has reported for quiet_s (the last frames drained)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                idle = time.monotonic() - self.last_status_time
            if idle >= quiet_s:
                return
            time.sleep(0.2)

    def counts(self):
        """One row per stage (a dict), see the module doc."""
        rows = []
        with self.lock:
            sent = set(self.player.sent)
            for stage in self.stages:
                inputs = sent if stage.input_topic == CLOUD_TOPIC else set(self.topic_stamps[stage.input_topic])
                statuses = list(stage.statuses)
                processed = len(statuses)
                dropped = collections.Counter(reason_of(text) for level, text in statuses
                                              if level not in stage.output_levels)
                notes = collections.Counter(reason_of(text) for level, text in statuses
                                            if level != "OK" and level in stage.output_levels)
                out = len(stage.outputs)
                rows.append(dict(stage=stage.name, inputs=len(inputs), processed=processed, out=out,
                                 superseded=len(inputs) - processed, dropped=dropped, notes=notes,
                                 unmatched=sum(1 for s in stage.answers if s not in inputs),
                                 unexplained=processed - out - sum(dropped.values())))
        return rows


def manager_pid(name):
    """PID of a running node, from its XML-RPC getPid (None if it is not registered)."""
    try:
        uri = rosgraph.Master(rospy.get_name()).lookupNode(name)
        return xmlrpc.client.ServerProxy(uri).getPid(rospy.get_name())[2]
    except Exception:  # not (yet) registered, or just died
        return None


def vm_rss_kb(pid):
    try:
        with open("/proc/%d/status" % pid) as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


class MemorySampler(threading.Thread):
    """VmRSS of the managers every period_s: samples[name] = [(t_s, pid, kB)]."""

    def __init__(self, managers=MANAGERS, period_s=2.0):
        super().__init__(daemon=True)
        self.managers = managers
        self.period_s = period_s
        self.samples = {name: [] for name in managers}
        self.start_time = time.monotonic()
        self.stopped = threading.Event()

    def run(self):
        while not self.stopped.is_set():
            for name in self.managers:
                pid = manager_pid(name)
                rss = vm_rss_kb(pid) if pid else None
                if rss:
                    self.samples[name].append((time.monotonic() - self.start_time, pid, rss))
            self.stopped.wait(self.period_s)

    def stop(self):
        self.stopped.set()
        self.join(5.0)

    def growth(self, name, warm_up_s):
        """(RSS just after warm-up, RSS at the end, growth in %) over one pid's samples: the
        medians of two windows of the same length (the warm-up's, at most 60 s), one right after
        the warm-up and one at the end. Same-length windows because the RSS of a manager that
        hands whole camera frames between threads swings by a few frames (9.4 MiB each) from one
        2 s sample to the next: a short window against a long one compares noise."""
        samples = self.samples[name]
        if not samples:
            return None
        pid = samples[-1][1]
        mine = [(t, rss) for t, p, rss in samples if p == pid]
        end_t = mine[-1][0]
        window_s = max(2.0, min(60.0, warm_up_s))
        after = [rss for t, rss in mine if warm_up_s <= t < warm_up_s + window_s]
        tail = [rss for t, rss in mine if t >= end_t - window_s]
        if not after or not tail:
            return None
        base = statistics.median(after)
        last = statistics.median(tail)
        return base, last, 100.0 * (last - base) / base


def format_report(rows, sampler, minutes, rate_hz, achieved_hz, warm_up_s, load_before, load_after,
                  target_minutes=10.0, max_growth_pct=5.0):
    lines = []
    lines.append("soak: %.1f min at %g Hz requested, %.1f Hz published; load average before %s, after %s"
                 % (minutes, rate_hz, achieved_hz, load_before, load_after))
    header = "%-24s %7s %9s %7s %10s %9s %11s  %s" % ("stage", "in", "processed", "out", "superseded", "unmatched",
                                                     "unexplained", "dropped (reason: count); notes")
    lines.append(header)
    lines.append("-" * len(header))
    for row in rows:
        dropped = ", ".join("%s: %d" % kv for kv in row["dropped"].most_common()) or "-"
        notes = ", ".join("%s: %d" % kv for kv in row["notes"].most_common())
        lines.append("%-24s %7d %9d %7d %10d %9d %11d  %s%s" % (
            row["stage"], row["inputs"], row["processed"], row["out"], row["superseded"], row["unmatched"],
            row["unexplained"], dropped, ("; notes " + notes) if notes else ""))
    lines.append("superseded: never reached the callback, a newer frame was queued first (input queues 1-2, the "
                 "latest frame wins); dropped: processed without output, by ~status reason")
    lines.append("")
    lines.append("resident memory (VmRSS, MB) over time, warm-up %.0f s:" % warm_up_s)
    growths = {}
    for name, samples in sampler.samples.items():
        if not samples:
            lines.append("  %s: no samples" % name)
            continue
        pids = sorted({p for _, p, _ in samples})
        step = max(1, len(samples) // 10)
        series = " ".join("%.0fs:%.1f" % (t, rss / 1024.0) for t, _, rss in samples[::step] + [samples[-1]])
        lines.append("  %s (pid%s %s): %s" % (name, "s" if len(pids) > 1 else "", ",".join(map(str, pids)), series))
        growths[name] = sampler.growth(name, warm_up_s)
    lines.append("")
    unmatched = sum(r["unmatched"] for r in rows)
    unexplained = sum(abs(r["unexplained"]) for r in rows) + sum(max(0, -r["superseded"]) for r in rows)
    mem_ok = all(g is not None and g[2] < max_growth_pct for g in growths.values()) and bool(growths)
    mem_text = ", ".join("%s %.1f -> %.1f MB (%+.2f %%)" % (n, g[0] / 1024.0, g[1] / 1024.0, g[2]) if g else
                         "%s: too few samples" % n for n, g in growths.items())
    lines.append("target: soak >= %g min: %.1f min -> %s" % (target_minutes, minutes,
                                                             "PASS" if minutes >= target_minutes else "SHORT"))
    lines.append("target: memory growth after warm-up < %g %%: %s -> %s" % (max_growth_pct, mem_text,
                                                                          "PASS" if mem_ok else "FAIL"))
    lines.append("target: every output stamped with an input stamp: %d unmatched -> %s"
                 % (unmatched, "PASS" if unmatched == 0 else "FAIL"))
    lines.append("target: no unexplained drop: %d -> %s" % (unexplained, "PASS" if unexplained == 0 else "FAIL"))
    return "\n".join(lines)


def load_average():
    return "%.2f %.2f %.2f" % os.getloadavg()


def soak(minutes, rate_hz):
    frames = load_frames()
    player = FramePlayer(frames)
    stages = pipeline_stages()
    monitor = PipelineMonitor(stages, player)
    rospy.loginfo("soak: %d frames from %s; waiting for the pipeline", len(frames), BAG_DIR)
    monitor.wait_connected()
    sampler = MemorySampler()
    sampler.start()
    load_before = load_average()
    rospy.loginfo("soak: publishing at %g Hz for %.1f min", rate_hz, minutes)
    elapsed = player.play(minutes * 60.0, rate_hz)
    monitor.wait_quiet()
    sampler.stop()
    load_after = load_average()
    warm_up_s = min(60.0, 0.25 * elapsed)
    return format_report(monitor.counts(), sampler, elapsed / 60.0, rate_hz, len(player.sent) / elapsed, warm_up_s,
                         load_before, load_after), sampler


def write_memory_csv(path, sampler):
    """Every VmRSS sample (one per manager every 2 s): the report prints one a minute."""
    with open(path, "w") as out:
        out.write("manager,t_s,pid,vm_rss_kb\n")
        for name, samples in sampler.samples.items():
            for t, pid, kb in samples:
                out.write("%s,%.1f,%d,%d\n" % (name, t, pid, kb))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     usage="soak.py [--minutes M] [--rate HZ] [--report FILE]")
    parser.add_argument("--minutes", type=float, default=1.0)
    parser.add_argument("--rate", type=float, default=30.0, help="frames per second (default 30)")
    parser.add_argument("--report", default="", help="also write the report to this file, and every memory "
                        "sample to <report without extension>_memory.csv")
    args = parser.parse_args(rospy.myargv(argv)[1:])
    rospy.init_node("soak", disable_signals=False)
    report, sampler = soak(args.minutes, args.rate)
    print(report, flush=True)
    if args.report:
        with open(args.report, "w") as out:
            out.write(report + "\n")
        write_memory_csv(os.path.splitext(args.report)[0] + "_memory.csv", sampler)


if __name__ == "__main__":
    main(sys.argv)
