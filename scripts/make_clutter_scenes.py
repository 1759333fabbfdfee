#!/usr/bin/env python3
"""Writes a clutter scene for render_bag (issue 11 part 1): config/scenes/clutter_<name>.yaml.

The table is the clutter evaluator's (scripts/grasp_physics/clutter.py make_table): N objects
drawn (seeded) from the TRAINING half of config/evaluation/objects.yaml that fit the gripper
standing upright, *packed* (upright, side by side, touching) or *piled* (dropped onto each other),
settled in MuJoCo. No baked meshes: each object references its YCB scan (`ycb:NAME`) or its
parametric shape, and its settled 6-DoF pose is the part's `offset_m` + `rpy_rad` in an object
frame at the body's x, y on the (level) table with zero yaw. The part is centred on its base
(`centre_on_base`, the loader's default: bounding-box centre in x, y, lowest point at z = 0, as
objects.py centres the evaluator's meshes), so the part frame is MuJoCo's body frame and
`offset_m` is the body position. The camera is the evaluator's eye-in-hand view of the objects'
centre (0.55-0.75 m, 30-60 deg down, seeded azimuth); the object nearest the looked-at point is
the target. Render it with `scripts/make_bags.sh clutter_<name>`.

    FAST_GRASP_YCB_DIR="$(bash scripts/fetch_ycb.sh)" .ws/venv/bin/python scripts/make_clutter_scenes.py \\
        --arrangement packed --seed 7 --objects 4             # -> config/scenes/clutter_packed_7.yaml

Same arguments, same file.
"""
import argparse
import math
import os
import sys

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import evaluate_clutter_physics as evaluator  # noqa: E402  (candidates, colours)
import evaluate_grasps_physics as single  # noqa: E402  (camera, venv re-exec)

TABLE = "table: {size_m: [1.2, 0.8, 0.04], centre_xy_m: [%.4f, %.4f], top_z_m: 0.0, roll_rad: 0.0, pitch_rad: 0.0, " \
        "rgb: [150, 110, 75]}\n"


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("--arrangement", required=True, choices=["packed", "piled"])
    p.add_argument("--seed", type=int, required=True, help="objects, poses, camera and the renderer's noise")
    p.add_argument("--objects", type=int, default=4, help="objects drawn (a pile may keep fewer)")
    p.add_argument("--name", default="", help="scene name after clutter_ (default: <arrangement>_<seed>)")
    p.add_argument("--gripper", default="robotiq_2f85", help="objects must fit its opening standing upright")
    p.add_argument("--kinds", default="ycb,parametric", help="ycb, parametric or both")
    p.add_argument("--objects-config", default=os.path.join(ROOT, "config/evaluation/objects.yaml"))
    p.add_argument("--ycb-dir", default=os.environ.get("FAST_GRASP_YCB_DIR", ""))
    p.add_argument("--cache-dir", default=os.path.join(os.environ.get("FAST_GRASP_WS", os.path.join(ROOT, ".ws")),
                                                         "physics_cache"))
    p.add_argument("--out-dir", default=os.path.join(ROOT, "config/scenes"))
    p.add_argument("--friction", type=float, default=0.8)
    p.add_argument("--verify", default="", metavar="TRUTH",
                   help="instead of writing the scene: check that render_bag's truth of it (objects: "
                        "surface_points_5mm, height_m) matches the settled MuJoCo poses; exit 1 if not")
    return p.parse_args(argv)


def parametric_part(spec):
    """The scene format's part of an objects.yaml parametric shape (same geometry as
    objects._parametric builds for MuJoCo and the evaluator's renders)."""
    shape = spec["shape"]
    if shape == "sphere":
        return {"shape": "sphere", "radius_m": spec["radius_m"]}
    if shape == "ellipsoid":  # a unit sphere scaled per axis: it still stands on z = 0
        return {"shape": "sphere", "radius_m": 1.0, "scale_xyz": list(spec["radii_m"])}
    if shape == "box":
        return {"shape": "box", "size_m": list(spec["size_m"])}
    if shape == "cylinder":
        return {"shape": "cylinder", "radius_m": spec["radius_m"], "height_m": spec["height_m"]}
    if shape == "vessel":  # objects._revolution's (r, z) profile as the scene format's (z, r)
        r, h, w = spec["radius_m"], spec["height_m"], spec["wall_m"]
        return {"shape": "revolution", "profile_z_r_m": [[0, 0], [0, r], [h, r], [h, r - w], [w, r - w], [w, 0]]}
    if shape == "bottle":
        r, h, rn = spec["radius_m"], spec["height_m"], spec["neck_radius_m"]
        return {"shape": "revolution",
                "profile_z_r_m": [[0, 0], [0, r], [0.62 * h, r], [0.8 * h, rn], [h, rn], [h, 0]]}
    raise ValueError("%s: unknown shape %s" % (spec["name"], shape))


def parametric_specs(config_path):
    with open(config_path) as f:
        config = yaml.safe_load(f)
    return {s["name"]: s for half in config.get("parametric", {}).values() for s in half}


def rpy_from_quat_wxyz(quat):
    """roll, pitch, yaw with R = Rz(yaw) Ry(pitch) Rx(roll), the loader's rpy_rad order."""
    from scipy.spatial.transform import Rotation
    w, x, y, z = quat
    return Rotation.from_quat([x, y, z, w]).as_euler("xyz")


def flow(value):
    """A YAML flow value: numbers with up to 6 decimals (1 um, 1 urad), lists in brackets."""
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(flow(v) for v in value) + "]"
    if isinstance(value, (float, np.floating)):
        text = "%.6f" % value
        text = text.rstrip("0").rstrip(".") if "." in text else text
        return "0.0" if text in ("-0", "0") else text
    return str(value)


def build_table(args):
    """(objects, poses, eye, look_at) of the seeded table: the evaluator's draw and settling."""
    from grasp_physics import clutter
    gripper = single.gripper_lib.load_gripper(single.gripper_path(args.gripper))
    params = single.trial_lib.TrialParams(friction=args.friction)
    candidates = evaluator.load_candidates(argparse.Namespace(
        kinds=args.kinds, ycb_dir=args.ycb_dir, objects="", objects_config=args.objects_config,
        cache_dir=args.cache_dir, split="train"), gripper)
    assert all(o.split == "train" for o in candidates), "clutter scenes use the training half only"
    rng = np.random.default_rng(args.seed)
    chosen = [candidates[i] for i in rng.choice(len(candidates), size=min(args.objects, len(candidates)),
                                                replace=False)]
    scene, poses = clutter.make_table(args.arrangement, chosen, gripper, rng, params)
    objs = list(scene.objs)
    tops = [scene.world_vertices(k, poses[k])[:, 2].max() for k in range(len(objs))]
    centre = np.array([np.mean([p[0][0] for p in poses]), np.mean([p[0][1] for p in poses]), 0.5 * max(tops)])
    eye, look_at = single.camera_for(centre, rng)
    return objs, poses, eye, look_at, [o.name for o in chosen]


def scene_text(args, name, objs, poses, eye, look_at, chosen_names):
    specs = parametric_specs(args.objects_config)
    nearest = int(np.argmin([np.linalg.norm(p[0][:2] - np.asarray(look_at[:2])) for p in poses]))
    command = "FAST_GRASP_YCB_DIR=\"$(bash scripts/fetch_ycb.sh)\" .ws/venv/bin/python scripts/make_clutter_scenes.py " \
              "--arrangement %s --seed %d --objects %d%s%s" % (
                  args.arrangement, args.seed, args.objects, " --name " + args.name if args.name else "",
                  " --kinds " + args.kinds if args.kinds != "ycb,parametric" else "")
    lines = [
        "# Scene for bags/%s.bag, rendered by render_bag (scripts/make_bags.sh; format: docs/renderer.md)." % name,
        "# Written by: %s" % command,
        "# Issue 11 clutter: %d training objects (%s) %s, settled in MuJoCo (scripts/grasp_physics/clutter.py);"
        % (len(objs), ", ".join(o.name for o in objs), "packed side by side" if args.arrangement == "packed"
           else "dropped onto each other"),
        "# each part's offset_m + rpy_rad is its settled body pose (mesh centred on its base), in a zero-yaw frame at",
        "# xy_m on the level table. Target: the object nearest the camera's looked-at point.",
    ]
    if len(objs) < len(chosen_names):
        lines.append("# Left out (rolled off the pile): %s" % ", ".join(n for n in chosen_names
                                                                      if n not in [o.name for o in objs]))
    lines += ["name: %s" % name, "seed: %d" % args.seed, "frames: 2", "compression: bz2",
              TABLE.rstrip("\n") % single.trial_lib.TABLE_CENTRE_XY_M, "floor_drop_m: 0.75", "objects:"]
    for k, (obj, (pos, quat)) in enumerate(zip(objs, poses)):
        if obj.name in specs:
            part = parametric_part(specs[obj.name])
        else:
            part = {"mesh": "ycb:" + obj.name, "centre_on_base": True}
        part["offset_m"] = [0.0, 0.0, float(pos[2])]
        part["rpy_rad"] = [float(a) for a in rpy_from_quat_wxyz(quat)]
        part["rgb"] = list(evaluator.COLOURS[k % len(evaluator.COLOURS)])
        lines += ["  - name: %s" % obj.name,
                  "    target: %s" % ("true" if k == nearest else "false"),
                  "    xy_m: %s" % flow([float(pos[0]), float(pos[1])]),
                  "    yaw_rad: 0.0",
                  "    parts:",
                  "      - " + "\n        ".join("%s: %s" % (key, flow(value)) for key, value in part.items())]
    distance = np.linalg.norm(np.asarray(eye) - np.asarray(look_at))
    down = math.degrees(math.asin((eye[2] - look_at[2]) / distance))
    azimuth = math.degrees(math.atan2(look_at[1] - eye[1], look_at[0] - eye[0]))
    lines += ["cameras:", "  - prefix: camera",
              "    # eye in hand: %.2f m from the objects' centre, %.0f deg down, %.0f deg azimuth" % (
                  distance, down, azimuth),
              "    eye_m: %s" % flow([round(float(v), 4) for v in eye]),
              "    target_m: %s" % flow([round(float(v), 4) for v in look_at])]
    return "\n".join(lines) + "\n"


def verify(truth_path, objs, poses, tolerance_m=0.003):
    """render_bag's per-object truth of the scene against the settled poses: every surface point
    within tolerance_m of the posed mesh (5 mm voxel centroids sit up to ~2.5 mm off a curved
    surface; a wrong rotation or offset puts them centimetres off), the mesh's bounds and top
    within tolerance_m of the points'. Returns the number of objects that fail."""
    import trimesh
    from scipy.spatial import cKDTree
    with open(truth_path) as f:
        truth = yaml.load(f, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    failures = 0
    for k, (obj, (pos, quat), entry) in enumerate(zip(objs, poses, truth["objects"])):
        mesh = obj.visual.copy()
        mesh.vertices = single.trial_lib.rotated(mesh.vertices, quat) + pos
        dense = trimesh.sample.sample_surface_even(mesh, 200000, seed=k)[0]
        points = np.asarray(entry["surface_points_5mm"], float)
        distance = cKDTree(dense).query(points)[0]
        bounds = np.abs(np.concatenate([points.min(axis=0) - mesh.bounds[0], points.max(axis=0) - mesh.bounds[1]]))
        top = abs(entry["height_m"] - mesh.bounds[1][2])
        ok = entry["name"] == obj.name and distance.max() < tolerance_m and bounds.max() < tolerance_m and \
            top < 1e-4
        failures += not ok
        print("%-4s %-22s surface points to mesh: median %.2f mm, max %.2f mm; bounds %.2f mm; top %.3f mm"
              % ("ok" if ok else "FAIL", entry["name"], 1e3 * np.median(distance), 1e3 * distance.max(),
                 1e3 * bounds.max(), 1e3 * top))
    return failures


def main(argv):
    args = parse_args(argv)
    if "ycb" in args.kinds.split(",") and not args.ycb_dir:
        # without it the evaluator's candidates silently lose the YCB objects: another table
        sys.exit("make_clutter_scenes: --kinds has ycb: set FAST_GRASP_YCB_DIR or --ycb-dir (scripts/fetch_ycb.sh)")
    single.import_physics()
    name = "clutter_" + (args.name or "%s_%d" % (args.arrangement, args.seed))
    objs, poses, eye, look_at, chosen_names = build_table(args)
    if args.verify:
        return 1 if verify(args.verify, objs, poses) else 0
    text = scene_text(args, name, objs, poses, eye, look_at, chosen_names)
    path = os.path.join(args.out_dir, name + ".yaml")
    with open(path, "w") as f:
        f.write(text)
    print("%s: %d of %d objects (%s), camera %s" % (path, len(objs), len(chosen_names),
                                                   " ".join(o.name for o in objs), flow(list(eye))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
