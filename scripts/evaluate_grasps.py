#!/usr/bin/env python3
"""Offline grasp evaluation over the bundled bags: the pipeline rostest's checks, without ROS.

For each bag and planner this runs `grasp_offline` (same perception and planner as the
nodelets), loads the object cloud it saved and applies the independent checks of
test/grasp_checks.py to the best grasp: points between the fingers, object points inside the
open gripper, gripper samples in the unseen part, approach from the seen side. One line per
bag and planner; exit 1 if any check failed.

    source scripts/env.sh; set +u; source "${FAST_GRASP_WS}/devel/setup.bash"
    /usr/bin/python3 scripts/evaluate_grasps.py [--planners cshape,principal_axis] [bags/mug.bag ...]
"""
import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "test"))
import grasp_checks  # noqa: E402


def read_pcd_xyz(path):
    """x, y, z of a binary or ascii PCD (the fields grasp_offline writes)."""
    with open(path, "rb") as f:
        header = {}
        while True:
            line = f.readline().decode("ascii").strip()
            if not line or line.startswith("#"):
                continue
            key, _, value = line.partition(" ")
            header[key] = value.split()
            if key == "DATA":
                break
        fields = header["FIELDS"]
        sizes = [int(s) for s in header["SIZE"]]
        types = header["TYPE"]
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
        points = int(header["POINTS"][0])
        kinds = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "u1", ("U", 2): "<u2", ("U", 4): "<u4",
                 ("I", 1): "i1", ("I", 2): "<i2", ("I", 4): "<i4"}
        dtype = np.dtype([("%s_%d" % (n, i), kinds[(t, s)], (c,)) for i, (n, s, t, c)
                          in enumerate(zip(fields, sizes, types, counts))])
        if header["DATA"][0] == "binary":
            data = np.frombuffer(f.read(dtype.itemsize * points), dtype=dtype, count=points)
            column = {n: data["%s_%d" % (n, i)][:, 0] for i, n in enumerate(fields)}
        else:
            table = np.loadtxt(f, ndmin=2)
            column = {n: table[:, i] for i, n in enumerate(fields)}
    xyz = np.stack([column["x"], column["y"], column["z"]], axis=1).astype(float)
    return xyz[np.all(np.isfinite(xyz), axis=1)]


def camera_from_truth(pose):
    return np.array(pose["position"], dtype=float), grasp_checks.quaternion_matrix(*pose["orientation_xyzw"])


def evaluate(bag, planner, gripper, gripper_name, params, workdir):
    truth_path = bag[:-len(".bag")] + ".truth.yaml"
    with open(truth_path) as f:
        truth = yaml.safe_load(f)
    object_pcd = os.path.join(workdir, "object.pcd")
    run = subprocess.run(["rosrun", "fast_grasp", "grasp_offline", "--bag", bag, "--algorithm", planner,
                          "--format", "json", "--params", params, "--gripper", gripper_name,
                          "--save-object", object_pcd], capture_output=True, text=True)
    report = json.loads(run.stdout) if run.stdout.strip() else {"status": "crash", "message": run.stderr}
    if report["status"] != "ok":
        return False, "%s: %s" % (report["status"], report.get("message", "")[:160])
    points = read_pcd_xyz(object_pcd)
    grasp = report["grasps"][0]
    position = np.array(grasp["position"])
    rotation = grasp_checks.quaternion_matrix(*grasp["quaternion_xyzw"])
    local = grasp_checks.to_grasp_frame(points, position, rotation)
    opening = gripper["max_opening_m"]
    between = grasp_checks.closing_region_count(local, grasp["width_m"], gripper)
    colliding = grasp_checks.points_in_gripper(local, gripper, opening)
    cams = [truth["camera_pose"]] + ([truth["head_camera_pose"]] if "head_camera_pose" in truth else [])
    occlusions = [grasp_checks.CameraOcclusion(points, *camera_from_truth(c)) for c in cams]
    hidden, total = grasp_checks.gripper_in_unseen(position, rotation, gripper, opening, occlusions)
    seen_side = any(float(rotation[:, 0] @ (position - camera_from_truth(c)[0])) > 0.0 for c in cams)
    ok = between >= 5 and colliding <= 2 and hidden <= max(3, total // 100) and seen_side and \
        0.0 < grasp["width_m"] <= opening + 1e-6
    approach = rotation[:, 0]
    return ok, ("width %.3f between %d in_gripper %d unseen %d/%d seen_side %s approach [%.2f %.2f %.2f] %.1f ms"
                % (grasp["width_m"], between, colliding, hidden, total, seen_side, approach[0], approach[1],
                   approach[2], 1e3 * report["compute_time_s"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bags", nargs="*", help="default: every bags/*.bag")
    parser.add_argument("--planners", default="principal_axis,cshape")
    parser.add_argument("--gripper", default="lacquey_fetch")
    parser.add_argument("--time-budget-s", type=float, default=30.0,
                        help="C-shape time budget (the shipped 0.1 s depends on machine load)")
    args = parser.parse_args()
    bags = args.bags or sorted(glob.glob(os.path.join(ROOT, "bags", "*.bag")))
    with open(os.path.join(ROOT, "config", "grippers", args.gripper + ".yaml")) as f:
        gripper = yaml.safe_load(f)
    with open(os.path.join(ROOT, "config", "grasp_planners.yaml")) as f:
        params = yaml.safe_load(f)
    params["cshape"]["time_budget_s"] = args.time_budget_s
    failed = 0
    with tempfile.TemporaryDirectory() as workdir:
        params_path = os.path.join(workdir, "params.yaml")
        with open(params_path, "w") as f:
            yaml.safe_dump(params, f)
        for bag in bags:
            for planner in args.planners.split(","):
                ok, line = evaluate(bag, planner, gripper, args.gripper, params_path, workdir)
                failed += not ok
                print("%-4s %-26s %-15s %s" % ("ok" if ok else "FAIL", os.path.basename(bag), planner, line),
                      flush=True)
    print("%d failed" % failed)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
