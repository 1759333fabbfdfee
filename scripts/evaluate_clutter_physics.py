#!/usr/bin/env python3
"""Clearing a cluttered table: the clutter-removal protocol of VGN/GIGA in MuJoCo (issue 11 part 4).

Per table: 3-6 objects of the training half of config/evaluation/objects.yaml (`--split
heldout` or `heldout_extra`: of a held-out half, for reporting only; never tune on it) that fit the gripper
standing upright, *packed* (upright, side by side, touching) or *piled* (dropped
onto each other and settled), seeded (scripts/grasp_physics/clutter.py). Then, until the table
is empty, no grasp is found or two grasps in a row fail: render the remaining objects with the
package's Xtion renderer from an eye-in-hand camera like the single-object evaluator's
(0.55-0.75 m, 30-60 deg down, seeded azimuth, looking at the remaining objects' centre); plan
with `grasp_offline --scene`; execute the top grasp in MuJoCo with every remaining object
present (approach, close, lift 15 cm, shake, hold: scripts/grasp_physics/trial.py); a grasp
succeeds when an object is lifted and held at the end, and that object is removed; the rest
settle (objects that rolled out of the work area are dropped, not counted as cleared) and the
loop renders again.

Without flags this measures the baseline: the pipeline keeps ONE target cluster
(config/perception.yaml target_cluster: center_of_view) and plans for it, and touching objects
come out as one cluster. The pipeline that clears tables (demo.launch split_touching_objects:=true
all_objects:=true; issue 11 parts 2-3) is `--split-touching-objects --all-objects`, as below (the
issue's numbers: docs/clutter.md).

    source scripts/env.sh; set +u; source "${FAST_GRASP_WS}/devel/setup.bash"; set -u
    FAST_GRASP_YCB_DIR="$(bash scripts/fetch_ycb.sh)" .ws/venv/bin/python scripts/evaluate_clutter_physics.py \
        --planners fused --gripper robotiq_2f85 --split-touching-objects --all-objects \
        --tables 50 --arrangements packed,piled --out-dir bench_out/clutter

Success % = successful grasps / attempts; cleared % = objects removed by a grasp / objects
placed. Every attempt goes to <out-dir>/attempts.csv, one row per table to tables.csv, the
summary to summary.txt; its last lines, per planner:
`<planner> <gripper> clutter-packed: success P % cleared R %` and the same for clutter-piled.
Same seed, same numbers.
"""
import argparse
import csv
import multiprocessing
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import evaluate_grasps_physics as single  # noqa: E402  (camera, planning and report helpers)

FIELDS = ["planner", "gripper", "arrangement", "table", "attempt", "objects_placed", "objects_left", "views",
          "status", "message", "planning_ms", "target_cluster_objects", "target_cluster_names", "success", "grasped_object",
          "closed_on", "touched_first", "failure_phase", "unexpected_contact",
          "contact_phase", "table_contact", "lifted_together", "unstable", "rolled_away", "grasp_x", "grasp_y",
          "grasp_z", "approach_x", "approach_y", "approach_z", "width_m", "score", "source"]
TABLE_FIELDS = ["planner", "gripper", "arrangement", "table", "seed", "objects", "objects_placed", "attempts",
                "successes", "cleared", "rolled_away", "end"]
BASELINE_NOTE = ("baseline: the pipeline plans for ONE target cluster (perception target_cluster, "
                 "center_of_view); touching objects are one cluster; no per-object planning (--all-objects)")
ALL_OBJECTS_NOTE = ("--all-objects: every cluster planned, grasps clear of the other clusters and their unseen parts, "
                    "the object picked by table_grasps/object_choice")


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("--planners", default="fused", help="comma list of grasp_offline algorithms")
    p.add_argument("--gripper", default="robotiq_2f85", help="config/grippers/NAME.yaml or a YAML file")
    p.add_argument("--tables", type=int, default=4, help="tables per arrangement")
    p.add_argument("--objects-per-table", default="3,6", help="MIN,MAX objects placed per table")
    p.add_argument("--arrangements", default="packed,piled", help="packed, piled or both")
    p.add_argument("--objects-config", default=os.path.join(ROOT, "config/evaluation/objects.yaml"))
    p.add_argument("--objects", default="", help="comma list of object names to draw from (default: the --split half)")
    p.add_argument("--split", default="train", choices=single.SPLIT_CHOICES,
                   help="which half of the objects config the tables are drawn from (heldout and heldout_extra: "
                        "report, never tune)")
    p.add_argument("--kinds", default="ycb,parametric",
                   help="ycb, parametric or both (ycb is skipped when no YCB folder is given)")
    p.add_argument("--friction", type=float, default=0.8)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--params", default="", help="planner parameters YAML for grasp_offline")
    p.add_argument("--split-touching-objects", action="store_true",
                   help="passed to grasp_offline: cut clusters at concave creases (perception split_concave_creases)")
    p.add_argument("--all-objects", action="store_true",
                   help="passed to grasp_offline: plan for every cluster, grasps kept clear of the other objects and "
                        "their unseen parts, the object picked by table_grasps/object_choice (issue 11 part 3)")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--only-tables", default="",
                   help="comma list of table indices to run (the same tables as in a full run: a table's "
                        "objects and poses depend only on --seed, the arrangement and its index)")
    p.add_argument("--keep-scenes", default="",
                   help="keep every attempt's renderer scene (scene.yaml, meshes) and target cluster under "
                        "this folder, one sub-folder per table and attempt, to replay with grasp_offline --scene")
    p.add_argument("--out-dir", default=os.path.join(ROOT, "bench_out/clutter"))
    p.add_argument("--cache-dir", default=os.path.join(os.environ.get("FAST_GRASP_WS", os.path.join(ROOT, ".ws")),
                                                         "physics_cache"))
    p.add_argument("--ycb-dir", default=single.default_ycb_dir(),
                   help="folder of the YCB STL meshes (default: $FAST_GRASP_YCB_DIR, else the workspace cache)")
    p.add_argument("--grasp-offline", default="", help="path of grasp_offline (default: from the catkin devel space)")
    p.add_argument("--pool", type=int, default=1,
                   help="also simulate the grasps ranked 2..N of every attempt, each from the same table state, "
                        "into pool.csv with their features (training data for scripts/fit_fused_model.py); the "
                        "clearance itself goes on with the top grasp as always")
    p.add_argument("--follow-next-view", type=int, default=0,
                   help="passed to grasp_offline: when no object has a grasp, render again from the planner's "
                        "next view (the camera turned about the table, table_grasps/next_view_turn_rad) up to N "
                        "times before the table ends on 'no grasp' (0: the VGN/GIGA protocol's one view)")
    args = p.parse_args(argv)
    if args.follow_next_view < 0:
        p.error("--follow-next-view N with N >= 0")
    if args.pool < 1:
        p.error("--pool N with N >= 1")
    lo, _, hi = args.objects_per_table.partition(",")
    args.min_objects, args.max_objects = int(lo), int(hi or lo)
    if not 1 <= args.min_objects <= args.max_objects:
        p.error("--objects-per-table MIN,MAX with 1 <= MIN <= MAX")
    args.arrangement_list = [a for a in args.arrangements.split(",") if a]
    try:
        args.only_table_list = [int(x) for x in args.only_tables.split(",") if x]
    except ValueError:
        p.error("--only-tables: comma list of table indices")
    if not args.arrangement_list or set(args.arrangement_list) - {"packed", "piled"}:
        p.error("--arrangements: packed, piled or packed,piled")
    args.planner_list = [x for x in args.planners.split(",") if x]
    # evaluate_grasps_physics.plan reads args.follow_next_view too (--max-grasps is args.pool)
    return args


def load_candidates(args, gripper):
    """The --split half's objects that fit the gripper standing upright, in config order."""
    from grasp_physics import clutter, objects
    kinds = tuple(k for k in args.kinds.split(",") if k and (k != "ycb" or args.ycb_dir))
    if "ycb" in args.kinds.split(",") and not args.ycb_dir:
        print("no YCB folder (run scripts/fetch_ycb.sh or pass --ycb-dir): the tables hold parametric "
              "objects only", file=sys.stderr)
    names = [n for n in args.objects.split(",") if n]
    objs = objects.load_objects(args.objects_config, args.ycb_dir, args.cache_dir, "all" if names else args.split,
                                names, kinds)
    return [o for o in objs if clutter.fits_gripper(o, gripper)]


def table_seed(args, arrangement, index):
    return args.seed * 100000 + (1 if arrangement == "packed" else 2) * 1000 + index


# ---- render scene of the remaining objects -----------------------------------------------------
COLOURS = [(200, 60, 40), (60, 160, 70), (50, 90, 200), (220, 180, 40), (150, 60, 170), (40, 170, 170)]


def write_clutter_scene(folder, scene, poses, names, eye, target, seed):
    """Renderer scene (docs/renderer.md) of the remaining objects: each settled object's visual
    mesh turned to its pose and baked into its own STL (the scene format has yaw only), named
    with centre_on_base: false at its x, y. The object nearest the looked-at point is marked
    target (the truth file's object; the pipeline chooses its own target cluster)."""
    nearest = int(np.argmin([np.linalg.norm(p[0][:2] - np.asarray(target[:2])) for p in poses]))
    with open(os.path.join(folder, "scene.yaml"), "w") as f:
        f.write("name: clutter\nseed: %d\nframes: 1\ncompression: none\n" % seed)
        f.write("table: {size_m: [1.2, 0.8, 0.04], centre_xy_m: [%.4f, %.4f], top_z_m: 0.0, rgb: [150, 110, 75]}\n"
                % single.trial_lib.TABLE_CENTRE_XY_M)
        f.write("objects:\n")
        for k, (pos, quat) in enumerate(poses):
            mesh = scene.objs[k].visual.copy()
            mesh.vertices = single.trial_lib.rotated(mesh.vertices, quat) + np.array([0.0, 0.0, pos[2]])
            mesh_name = "object_%d.stl" % k
            mesh.export(os.path.join(folder, mesh_name))
            f.write("  - name: %s\n    target: %s\n    xy_m: [%.6f, %.6f]\n    parts:\n"
                    "      - {mesh: %s, centre_on_base: false, rgb: [%d, %d, %d]}\n"
                    % (names[k], "true" if k == nearest else "false", pos[0], pos[1], mesh_name,
                       *COLOURS[k % len(COLOURS)]))
        f.write("cameras:\n  - {prefix: camera, eye_m: [%.5f, %.5f, %.5f], target_m: [%.5f, %.5f, %.5f]}\n"
                % (tuple(eye) + tuple(target)))
    return os.path.join(folder, "scene.yaml")


def objects_in_cluster(cluster_pcd, scene, poses, names, near_m=0.006, share=0.05):
    """Which objects the pipeline's target cluster covers: those owning at least `share` of its
    points (a point belongs to the object whose surface is nearest, within near_m). One name is
    the right cluster; several are the merged blob of issue 11."""
    if not os.path.exists(cluster_pcd):
        return []
    import trimesh
    from scipy.spatial import cKDTree
    xyz = single.read_pcd_xyz(cluster_pcd)
    xyz = xyz[np.isfinite(xyz).all(axis=1)]
    if len(xyz) == 0:
        return []
    distances = []
    for k, pose in enumerate(poses):
        mesh = scene.objs[k].visual.copy()
        mesh.vertices = single.trial_lib.rotated(mesh.vertices, pose[1]) + pose[0]
        surface = trimesh.sample.sample_surface(mesh, 4000, seed=k)[0]  # seeded: same seed, same report
        distances.append(cKDTree(surface).query(xyz)[0])
    distances = np.stack(distances, axis=1)
    owner = np.where(distances.min(axis=1) < near_m, distances.argmin(axis=1), -1)
    return [names[k] for k in range(len(poses)) if (owner == k).mean() >= share]


# ---- one table: clear it -----------------------------------------------------------------------
def clear_table(job):
    args, planner, arrangement, index, candidates = job
    single.import_physics()
    from grasp_physics import clutter
    gripper = single.gripper_lib.load_gripper(single.gripper_path(args.gripper))
    params = single.trial_lib.TrialParams(friction=args.friction)
    seed = table_seed(args, arrangement, index)
    rng = np.random.default_rng(seed)
    count = int(rng.integers(args.min_objects, args.max_objects + 1))
    chosen = [candidates[i] for i in rng.choice(len(candidates), size=min(count, len(candidates)), replace=False)]
    scene, poses = clutter.make_table(arrangement, chosen, gripper, rng, params)
    objs = list(scene.objs)
    placed = len(objs)
    grasp_offline = single.find_grasp_offline(args.grasp_offline)
    base = {"planner": planner, "gripper": gripper["name"], "arrangement": arrangement, "table": index,
            "objects_placed": placed}
    rows, pool_rows, successes, cleared, rolled_away, failures_in_row, end = [], [], 0, 0, 0, 0, ""
    attempt = 0
    with tempfile.TemporaryDirectory(prefix="fg_clutter_") as folder:
        while True:
            if not objs:
                end = "empty"
                break
            if failures_in_row >= 2:
                end = "two failures in a row"
                break
            attempt += 1
            names = [o.name for o in objs]
            tops = [scene.world_vertices(k, poses[k])[:, 2].max() for k in range(len(objs))]
            centre = np.array([np.mean([p[0][0] for p in poses]), np.mean([p[0][1] for p in poses]),
                               0.5 * max(tops)])
            eye, target = single.camera_for(centre, rng)
            attempt_folder = folder
            if args.keep_scenes:
                attempt_folder = os.path.join(args.keep_scenes, "%s_%s_table%d_attempt%d"
                                              % (planner, arrangement, index, attempt))
                os.makedirs(attempt_folder, exist_ok=True)
            scene_yaml = write_clutter_scene(attempt_folder, scene, poses, names, eye, target,
                                             seed % 100000 + attempt)
            cluster_pcd = os.path.join(attempt_folder, "cluster_%d.pcd" % attempt)
            report = single.plan(grasp_offline, scene_yaml, planner, single.gripper_path(args.gripper), args,
                                 cluster_pcd)
            grasps = single.grasps_from_report(report)
            in_cluster = objects_in_cluster(cluster_pcd, scene, poses, names)
            row = dict(base, attempt=attempt, objects_left=len(objs), views=max(1, len(report.get("views") or [])),
                       status=report.get("status", "?"),
                       message=report.get("message", "")[:200],
                       planning_ms=1000 * (report.get("compute_time_s") or 0.0),
                       target_cluster_objects=len(in_cluster), target_cluster_names=" ".join(in_cluster))
            if not grasps:
                rows.append(row)
                attempt -= 1  # a planning call without a grasp is not a grasp attempt
                end = "no grasp"
                break
            grasp = grasps[0]
            outcome = scene.execute(poses, grasp["rotation"], grasp["position"])
            r = grasp["rotation"]
            row.update(success=outcome["success"], failure_phase=outcome["failure_phase"],
                       unexpected_contact=outcome["unexpected_contact"], contact_phase=outcome["contact_phase"],
                       table_contact=outcome["table_contact"], lifted_together=outcome["lifted_together"],
                       unstable=outcome["unstable"],
                       grasped_object=names[outcome["grasped"]] if outcome["grasped"] >= 0 else "",
                       closed_on=names[outcome["closed_on"]] if outcome["closed_on"] >= 0 else "",
                       touched_first=names[outcome["touched_first"]] if outcome["touched_first"] >= 0 else "",
                       grasp_x=grasp["position"][0], grasp_y=grasp["position"][1], grasp_z=grasp["position"][2],
                       approach_x=r[0, 0], approach_y=r[1, 0], approach_z=r[2, 0], width_m=grasp["width_m"],
                       score=grasp["score"], source=grasp.get("source", ""))
            # what is left after the trial: the grasped object leaves with the hand; the others
            # (and an object a failed grasp dropped) settle without the hand
            after = scene.poses()
            for rank, candidate in enumerate(grasps[:args.pool], start=1):
                tried = outcome if rank == 1 else scene.execute(poses, candidate["rotation"], candidate["position"])
                pool_rows.append(pool_row(base, attempt, rank, candidate, tried, names))
            keep = [k for k in range(len(objs)) if k != outcome["grasped"]]
            if outcome["success"]:
                successes += 1
                cleared += 1
                failures_in_row = 0
            else:
                failures_in_row += 1
            objs = [objs[k] for k in keep]
            poses = [after[k] for k in keep]
            scene = clutter.ClutterScene(objs, gripper, params)
            scene.set_poses(poses)
            poses = scene.settle()
            stay = clutter.on_table(scene, poses)
            row["rolled_away"] = len(objs) - len(stay)
            rolled_away += len(objs) - len(stay)
            if len(stay) < len(objs):
                objs = [objs[k] for k in stay]
                poses = [poses[k] for k in stay]
                scene = clutter.ClutterScene(objs, gripper, params)
                scene.set_poses(poses)
            rows.append(row)
    table = dict(base, seed=seed, objects=" ".join(o.name for o in chosen), attempts=attempt, successes=successes,
                 cleared=cleared,
                 rolled_away=rolled_away, end=end)
    return rows, table, pool_rows


POOL_FIELDS = ["planner", "gripper", "arrangement", "table", "attempt", "rank", "object", "pose", "view", "status",
               "success", "unexpected_contact", "unstable", "failure_phase", "grasped_object", "closed_on", "score",
               "source", "width_m"]


def pool_row(base, attempt, rank, grasp, outcome, names):
    """One simulated candidate in the columns scripts/fit_fused_model.py reads: a scene (its
    object/pose/view key) is one attempt of one table; `object` names the table, so leave-one-
    object-out leaves a whole table out."""
    row = dict(base, attempt=attempt, rank=rank, object="%s-%d" % (base["arrangement"], base["table"]),
               pose=attempt, view=0, status="ok", success=outcome["success"],
               unexpected_contact=outcome["unexpected_contact"], unstable=outcome["unstable"],
               failure_phase=outcome["failure_phase"],
               grasped_object=names[outcome["grasped"]] if outcome["grasped"] >= 0 else "",
               closed_on=names[outcome["closed_on"]] if outcome["closed_on"] >= 0 else "",
               score=grasp["score"], source=grasp.get("source", ""), width_m=grasp["width_m"])
    row.update({"f_" + k: v for k, v in grasp.get("features", {}).items()})
    return row


# ---- report ------------------------------------------------------------------------------------
def interval_over_tables(tables, numerator, denominator, resamples=2000, seed=0):
    """95 % interval (lo, hi, in %) of sum(numerator) / sum(denominator), the tables resampled with
    replacement (percentile bootstrap, seeded: same tables, same interval). By table, not by
    attempt: the attempts of one table hang together (one merged cluster, one unreachable object
    can end a whole table), so a per-attempt binomial interval would claim more than 50 tables
    show."""
    num = np.array([x[numerator] for x in tables], dtype=float)
    den = np.array([x[denominator] for x in tables], dtype=float)
    if len(tables) == 0 or den.sum() <= 0:
        return float("nan"), float("nan")
    picks = np.random.default_rng(seed).integers(0, len(tables), size=(resamples, len(tables)))
    totals = den[picks].sum(axis=1)
    rates = 100.0 * num[picks].sum(axis=1) / np.where(totals > 0, totals, 1.0)
    return float(np.percentile(rates, 2.5)), float(np.percentile(rates, 97.5))


def summarise(tables, rows, planners, arrangements, gripper_name, follow_next_view=0):
    lines, table_md = [], []
    # the protocol plans from one view a call; following the table's next view is labelled apart
    views = "-within-%d-views" % (1 + follow_next_view) if follow_next_view else ""
    for planner in planners:
        for arrangement in arrangements:
            t = [x for x in tables if x["planner"] == planner and x["arrangement"] == arrangement]
            if not t:
                continue
            attempts = sum(x["attempts"] for x in t)
            successes = sum(x["successes"] for x in t)
            placed = sum(x["objects_placed"] for x in t)
            cleared = sum(x["cleared"] for x in t)
            success_pct = 100.0 * successes / attempts if attempts else 0.0
            cleared_pct = 100.0 * cleared / placed if placed else 0.0
            calls = [r for r in rows if r["planner"] == planner and r["arrangement"] == arrangement]
            single_object = sum(1 for r in calls if r.get("target_cluster_objects") == 1)
            merged = sum(1 for r in calls if (r.get("target_cluster_objects") or 0) > 1)
            ends = {}
            for x in t:
                ends[x["end"]] = ends.get(x["end"], 0) + 1
            success_lo, success_hi = interval_over_tables(t, "successes", "attempts")
            cleared_lo, cleared_hi = interval_over_tables(t, "cleared", "objects_placed")
            table_md.append("| %s | %s | %d | %d | %d | %d | %d | %.1f (%.0f-%.0f) | %.1f (%.0f-%.0f) | %d / %d / %d | %s |" % (
                planner, arrangement, len(t), placed, attempts, successes, cleared, success_pct, success_lo, success_hi,
                cleared_pct, cleared_lo, cleared_hi,
                single_object, merged, len(calls),
                ", ".join("%s %d" % kv for kv in sorted(ends.items()))))
            lines.append("%s %s clutter-%s%s: success %.0f %% cleared %.0f %%"
                         % (planner, gripper_name, arrangement, views, success_pct, cleared_pct))
    return table_md, lines


def main(argv):
    args = parse_args(argv)
    single.import_physics()
    gripper = single.gripper_lib.load_gripper(single.gripper_path(args.gripper))
    candidates = load_candidates(args, gripper)
    if not candidates:
        sys.exit("no objects that fit %s" % gripper["name"])
    jobs = [(args, planner, arrangement, index, candidates)
            for planner in args.planner_list for arrangement in args.arrangement_list for index in range(args.tables)
            if not args.only_table_list or index in args.only_table_list]
    os.makedirs(args.out_dir, exist_ok=True)
    t0 = time.time()
    if args.jobs > 1:
        with multiprocessing.Pool(args.jobs) as pool:
            results = pool.map(clear_table, jobs, chunksize=1)
    else:
        results = [clear_table(j) for j in jobs]
    rows = [r for rs, _, _ in results for r in rs]
    tables = [t for _, t, _ in results]
    pool_rows = [r for _, _, ps in results for r in ps]
    if args.pool > 1:
        features = sorted({k for r in pool_rows for k in r if k.startswith("f_")})
        with open(os.path.join(args.out_dir, "pool.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=POOL_FIELDS + features, extrasaction="ignore")
            w.writeheader()
            w.writerows(pool_rows)
    with open(os.path.join(args.out_dir, "attempts.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(args.out_dir, "tables.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=TABLE_FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(tables)
    table_md, lines = summarise(tables, rows, args.planner_list, args.arrangement_list, gripper["name"],
                                args.follow_next_view)
    header = ("# clutter clearance: %s, friction %.2f, %d tables per arrangement, %d-%d objects per table from %d "
              "%s objects that fit, seed %d%s, %.0f s"
              % (single.gripper_lib.finger_reach_note(gripper), args.friction, args.tables, args.min_objects,
                 args.max_objects, len(candidates), "training" if args.split == "train" else "HELD-OUT", args.seed,
                 (", split touching objects" if args.split_touching_objects else "") +
                 (", up to %d more views when no object has a grasp" % args.follow_next_view
                  if args.follow_next_view else ""), time.time() - t0))
    out = [header,
           "# " + (ALL_OBJECTS_NOTE if args.all_objects else BASELINE_NOTE) +
           ("; touching objects cut apart at concave creases" if args.split_touching_objects
            else "; touching objects are one cluster"),
           "| planner | arrangement | tables | objects placed | attempts | successes | cleared | success % (95 % "
           "interval over tables) | cleared % (95 % interval) | target cluster one object / several / planning calls "
           "| tables ended by |",
           "|---|---|---|---|---|---|---|---|---|---|---|"] + table_md
    with open(os.path.join(args.out_dir, "summary.txt"), "w") as f:
        f.write("\n".join(out + lines) + "\n")
    print("\n".join(out))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
