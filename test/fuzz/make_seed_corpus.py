#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpora (test/fuzz/corpus/<corpus>/seed_*) from the bundled bags,
their ground truth and the config files, in the layouts the targets decode (see each
test/fuzz/fuzz_*.cpp). Deterministic; regression inputs (crash_*, slow_*) in the same folders are
kept. Run it again after changing a layout: /usr/bin/python3 test/fuzz/make_seed_corpus.py
"""
import argparse
import glob
import math
import os
import shutil
import struct
import sys

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.normpath(os.path.join(HERE, "..", ".."))
CORPUS = os.path.join(HERE, "corpus")
# Scenes whose object views seed the planners: a box, handles, long and flat objects, a thin
# glass, and the two-camera scene (two sensor origins).
VIEW_SCENES = ["cracker_box", "mug", "hammer", "beer_bottle", "pan", "wine_glass", "power_drill",
               "two_camera_spray_bottle"]
CLOUD_SCENES = ["milk_carton", "mug", "racket"]


def clear_seeds(corpus):
    folder = os.path.join(CORPUS, corpus)
    os.makedirs(folder, exist_ok=True)
    for path in glob.glob(os.path.join(folder, "seed_*")):
        os.remove(path)
    return folder


def write(folder, name, data):
    with open(os.path.join(folder, "seed_" + name), "wb") as out:
        out.write(data)


def truth(scene):
    with open(os.path.join(SOURCE, "bags", scene + ".truth.yaml")) as f:
        return yaml.safe_load(f)


def estimated_normals(points, origin, k=8):
    """Unit normals by PCA of the k nearest points, turned toward the camera."""
    normals = np.zeros_like(points)
    for i, p in enumerate(points):
        d = np.linalg.norm(points - p, axis=1)
        neighbours = points[np.argsort(d)[:k]]
        w, v = np.linalg.eigh(np.cov((neighbours - neighbours.mean(axis=0)).T))
        n = v[:, 0]
        if np.dot(origin - p, n) < 0:
            n = -n
        normals[i] = n
    return normals


def object_views():
    """fuzz_object_view.h: flags, origins, table plane, points as int16 0.1 mm + int8 normals."""
    folder = clear_seeds("object_view")
    for scene in VIEW_SCENES:
        t = truth(scene)
        points = np.array(t["visible_points_1cm"], dtype=float)
        origins = [t["camera_pose"]["position"]]
        if "head_camera_pose" in t:  # two-camera scene (Ch3.5)
            origins.append(t["head_camera_pose"]["position"])
        normals = estimated_normals(points, np.array(origins[0]))
        flags = 0x01 | (len(origins) << 4)  # table plane, quantised points
        data = struct.pack("<B", flags)
        for o in origins:
            data += struct.pack("<3f", *o)
        data += struct.pack("<4f", *t["table_plane"])
        for p, n in zip(points, normals):
            q = [int(round(c * 1e4)) for c in p]
            if any(abs(c) > 32767 for c in q):
                continue
            data += struct.pack("<3h3b", *q, *[int(round(c * 127)) for c in n])
        write(folder, scene, data)
    # A raw-float view with NaN, inf and denormal coordinates and a custom (Robotiq 2F-85) gripper.
    data = struct.pack("<B", 0x02 | 0x04 | 0x08 | (1 << 4))
    data += struct.pack("<3f", 0.0, 0.0, 0.6) + struct.pack("<3f", 0.0, 0.0, -1.0)
    data += struct.pack("<12fB", 0.085, 0.0, 0.022, 0.01, 0.04, 0.06, 0.03, 0.0, 0.045, 0.06, 0.02, 0.0, 0)
    rng = np.random.default_rng(1)
    for i in range(60):
        p = [0.5 + 0.02 * rng.standard_normal(), 0.02 * rng.standard_normal(), 0.05 + 0.03 * rng.random()]
        if i == 10:
            p[0] = float("nan")
        if i == 20:
            p[1] = float("inf")
        if i == 30:
            p[2] = 1e-40
        data += struct.pack("<6f", *p, 0.0, 0.0, 1.0)
    write(folder, "raw_floats", data)


def bag_clouds(scene, frames=1):
    import rosbag  # Debian's python3-rosbag
    t = truth(scene)
    with rosbag.Bag(os.path.join(SOURCE, "bags", scene + ".bag")) as bag:
        for _, msg, _ in bag.read_messages(topics=[t["topic"]]):
            yield t, msg
            frames -= 1
            if frames == 0:
                return


def pixel_grid(msg, step):
    """(rows, cols, xyz) of every step-th pixel of an organised PointCloud2 (float32 x, y, z)."""
    offsets = {f.name: f.offset for f in msg.fields}
    raw = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.row_step)
    rows = range(0, msg.height, step)
    cols = range(0, msg.width, step)
    xyz = np.zeros((len(rows), len(cols), 3), dtype=np.float32)
    for a, axis in enumerate("xyz"):
        o = offsets[axis]
        for i, r in enumerate(rows):
            for j, c in enumerate(cols):
                xyz[i, j, a] = np.frombuffer(raw[r, c * msg.point_step + o:c * msg.point_step + o + 4].tobytes(),
                                             dtype=np.float32)[0]
    return xyz


def cloud_preprocess():
    """fuzz_cloud_preprocess.cpp: header, params, camera pose, then the PointCloud2 data."""
    folder = clear_seeds("cloud_preprocess")
    for scene in CLOUD_SCENES:
        for t, msg in bag_clouds(scene):
            xyz = pixel_grid(msg, 32)  # 20 x 15 pixels of the 640 x 480 frame
            h, w, _ = xyz.shape
            pose = t["camera_pose"]
            qx, qy, qz, qw = pose["orientation_xyzw"]
            for point_step, name in ((16, "packed"), (32, "rgb_padded")):
                header = struct.pack("<HHHIHHH", w, h, point_step, w * point_step, 0, 4, 8)
                header += struct.pack("<BffffI", 1, 0.005, 0.85, -10.0, 10.0, 2000000)
                header += struct.pack("<7f", *pose["position"], qw, qx, qy, qz)
                body = b""
                for row in xyz:
                    for p in row:
                        body += struct.pack("<3f", *p) + b"\0" * (point_step - 12)
                write(folder, "%s_%s" % (scene, name), header + body)
    # Unorganised, with NaN, inf and denormal coordinates.
    header = struct.pack("<HHHIHHH", 8, 1, 12, 96, 0, 4, 8) + struct.pack("<BffffI", 2, 0.0, 2.0, -1.0, 1.0, 100)
    header += struct.pack("<7f", 0, 0, 0.6, 1, 0, 0, 0)
    body = b"".join(struct.pack("<3f", *p) for p in [
        (0.1, 0.0, 0.5), (float("nan"),) * 3, (float("inf"), 0, 0), (1e-42, 1e-42, 1e-42),
        (0.2, 0.1, 0.4), (0, 0, 0), (-0.1, 0.05, 0.55), (0.3, -0.2, float("-inf"))])
    write(folder, "special_values", header + body)


def lzf_literals(data):
    """LZF stream of literal runs only (control byte n < 32: n + 1 literal bytes): valid input
    for PCL's lzfDecompress without an LZF compressor."""
    out = b""
    for i in range(0, len(data), 32):
        chunk = data[i:i + 32]
        out += bytes([len(chunk) - 1]) + chunk
    return out


def pcd_input():
    """fuzz_pcd_input.cpp: PCD files of object points in ascii, binary and binary_compressed."""
    folder = clear_seeds("pcd_input")
    for scene in ("milk_carton", "mug"):
        points = np.array(truth(scene)["visible_points_1cm"], dtype=np.float32)[::3]
        n = len(points)
        header = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\n"
                  "TYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\n" % (n, n))
        ascii_body = "".join("%g %g %g\n" % tuple(p) for p in points)
        write(folder, scene + "_ascii.pcd", (header + "DATA ascii\n" + ascii_body).encode())
        write(folder, scene + "_binary.pcd", (header + "DATA binary\n").encode() + points.tobytes())
        soa = points.T.copy().tobytes()  # binary_compressed stores each field's column in turn
        compressed = lzf_literals(soa)
        write(folder, scene + "_compressed.pcd", (header + "DATA binary_compressed\n").encode() +
              struct.pack("<II", len(compressed), len(soa)) + compressed)
    # x y z plus rgb and a NaN row, organised 2 x 2.
    write(folder, "organised_rgb.pcd", (
        "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 2\n"
        "POINTS 4\nDATA ascii\n0.5 0 0.05 255\nnan nan nan 0\n0.51 0.01 0.06 65280\n0.52 0 0.07 0\n").encode())


def mesh_loader():
    """fuzz_mesh_loader.cpp: format byte (0 stl, 1 obj, 2 ply) + a unit box file."""
    folder = clear_seeds("mesh_loader")
    v = [(x, y, z) for x in (0, 0.05) for y in (0, 0.05) for z in (0, 0.1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    obj = "".join("v %g %g %g\n" % p for p in v) + "".join("f %d %d %d %d\n" % tuple(i + 1 for i in q) for q in quads)
    write(folder, "box.obj", b"\x01" + obj.encode())
    ply = ("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 6\nproperty list uchar int vertex_indices\nend_header\n" +
           "".join("%g %g %g\n" % p for p in v) + "".join("4 %d %d %d %d\n" % q for q in quads))
    write(folder, "box.ply", b"\x02" + ply.encode())
    stl = "solid box\n"
    for t in tris:
        stl += " facet normal 0 0 0\n  outer loop\n" + "".join("   vertex %g %g %g\n" % v[i] for i in t)
        stl += "  endloop\n endfacet\n"
    write(folder, "box_ascii.stl", b"\x00" + (stl + "endsolid box\n").encode())
    binary = b"\0" * 80 + struct.pack("<I", len(tris))
    for t in tris:
        binary += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v[i]) for i in t) + b"\0\0"
    write(folder, "box_binary.stl", b"\x00" + binary)


def yaml_configs():
    for corpus, pattern in (("grasp_planner_params", "config/grasp_planners.yaml"),
                            ("gripper_model", "config/grippers/*.yaml"),
                            ("robot_config", "config/robots/*.yaml")):
        folder = clear_seeds(corpus)
        for path in sorted(glob.glob(os.path.join(SOURCE, pattern))):
            if "home_pose" in path:
                continue
            shutil.copyfile(path, os.path.join(folder, "seed_" + os.path.basename(path)))


def arm_ik():
    """fuzz_arm_ik.cpp: robot/flags, target, seed, tolerances, solutions, iterations, seed, timeout."""
    folder = clear_seeds("arm_ik")
    down = (0.0, 1.0, 0.0, 0.0)  # w x y z: approach (x) pointing down
    cases = [("ur5_front", 0, (0.45, 0.1, 0.25) + down, [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]),
             ("ur5_far", 0, (2.0, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0), [0.0] * 6),
             ("lwr4_front", 1, (0.5, 0.0, 0.3) + down, [0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0])]
    for name, robot, target, seed in cases:
        data = struct.pack("<B", robot) + struct.pack("<7d", *target) + struct.pack("<%dd" % len(seed), *seed)
        data += struct.pack("<ddBBIB", 1e-5, 1e-5, 2, 60, 42, 50)
        write(folder, name, data)
    # Own joint limits and a raw matrix target.
    data = struct.pack("<B", 0x02 | 0x04) + struct.pack("<16d", 1, 0, 0, 0.4, 0, 1, 0, 0, 0, 0, 1, 0.3, 0, 0, 0, 1)
    data += struct.pack("<6d", *[0.1] * 6) + struct.pack("<6d", *[-1.0] * 6) + struct.pack("<6d", *[1.0] * 6)
    data += struct.pack("<ddBBIB", 1e-4, 1e-4, 1, 30, 7, 20)
    write(folder, "ur5_limits_matrix", data)


def trajectory_timing():
    """fuzz_trajectory_timing.cpp: flags, joints, limit joints, limits, step, corner, waypoints."""
    folder = clear_seeds("trajectory_timing")
    pi = math.pi
    limits = struct.pack("<6d", *[pi] * 6) + struct.pack("<6d", *[2.0] * 6) + struct.pack("<dd", 0.02, 0.1)
    path = [[0, -1570, 1570, -1570, -1570, 0], [300, -1400, 1500, -1600, -1570, 200],
            [600, -1200, 1300, -1700, -1500, 400], [600, -1200, 1300, -1700, -1500, 400], [-500, -800, 900, -1000, -1570, 0]]
    data = struct.pack("<BBB", 0, 5, 6) + limits + b"".join(struct.pack("<6h", *q) for q in path)
    write(folder, "ur5_quantised", data)
    raw = [[0.0] * 6, [0.5, 0.2, -0.3, 0.1, 0.0, 0.0], [0.5 + 1e-12, 0.2, -0.3, 0.1, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0, 1.0, 1.0]]
    data = struct.pack("<BBB", 1, 5, 6) + limits + b"".join(struct.pack("<6d", *q) for q in raw)
    write(folder, "ur5_raw", data)
    data = struct.pack("<BBB", 0, 0, 1) + struct.pack("<dddd", 1.0, 1.0, 0.01, 0.1) + struct.pack("<3h", 0, 1000, -1000)
    write(folder, "one_joint_reverse", data)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.parse_args()
    object_views()
    cloud_preprocess()
    pcd_input()
    mesh_loader()
    yaml_configs()
    arm_ik()
    trajectory_timing()
    total = sum(os.path.getsize(p) for p in glob.glob(os.path.join(CORPUS, "*", "*")))
    print("corpus: %d files, %d KB" % (len(glob.glob(os.path.join(CORPUS, "*", "*"))), total // 1024))
    return 0


if __name__ == "__main__":
    sys.exit(main())
