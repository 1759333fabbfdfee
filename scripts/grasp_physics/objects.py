"""The evaluator's objects: a visual mesh (what the renderer draws), a collision model (what
MuJoCo touches) and a mass, for YCB scans and parametric household shapes.

Collision: primitives stay MuJoCo primitives (exact spheres, boxes, cylinders, ellipsoids);
meshes are split into convex parts by CoACD (MuJoCo collides a mesh as its convex hull, which
would fill a cup or a mug's handle), cached under <cache>/coacd/."""
import hashlib
import os

import numpy as np
import trimesh
import yaml

DENSITY_KG_M3 = 500.0

YCB_CLASSES = (("cups", "cup"), ("mug", "cup"), ("bottle", "bottle"), ("cleanser", "bottle"),
               ("box", "box"), ("lego", "block"), ("blocks", "block"), ("dice", "block"),
               ("marbles", "sphere"), ("airplane", "toy"), ("peg_test", "toy"), ("_can", "can"),
               ("ball", "sphere"), ("bowl", "cup"), ("pitcher", "cup"), ("brick", "box"), ("block", "block"),
               ("rubiks", "block"))

# The halves of config/evaluation/objects.yaml: train (tune and fit on it), heldout (report it,
# never tune on it) and heldout_extra (a second held-out set of the YCB scans in neither half).
# evaluate_grasps_physics.SPLIT_CHOICES repeats the names for argparse (read before trimesh loads).
SPLITS = ("train", "heldout", "heldout_extra")


class EvalObject:
    """name, cls, split, visual (trimesh, z up, base on z = 0, centred in x y), mass_kg, and
    collision: list of ('sphere'|'box'|'cylinder'|'ellipsoid', size, pos) or ('mesh', path, None)."""

    def __init__(self, name, cls, split, visual, mass_kg, collision):
        self.name, self.cls, self.split = name, cls, split
        self.visual, self.mass_kg, self.collision = visual, mass_kg, collision

    def __repr__(self):
        return "EvalObject(%s, %s, %.3f kg)" % (self.name, self.cls, self.mass_kg)


def _centre_on_base(mesh):
    lo, hi = mesh.bounds
    mesh.apply_translation([-(lo[0] + hi[0]) / 2.0, -(lo[1] + hi[1]) / 2.0, -lo[2]])
    return mesh


def _revolution(profile):
    """Closed solid of revolution about z from a (r, z) polyline that starts and ends on the axis."""
    return trimesh.creation.revolve(np.asarray(profile, dtype=float), sections=48)


def _convex_parts(mesh, cache_dir, key):
    """CoACD convex decomposition, cached as STL files; returns their paths."""
    folder = os.path.join(cache_dir, "coacd", key)
    done = os.path.join(folder, "done")
    if not os.path.exists(done):
        import coacd  # imported here: primitives-only runs (the test suite) do not need it
        coacd.set_log_level("error")
        os.makedirs(folder, exist_ok=True)
        parts = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=0.08, max_convex_hull=16,
                                preprocess_resolution=30, resolution=1000, mcts_iterations=60,
                                mcts_max_depth=2, mcts_nodes=10, seed=1)
        for i, (v, f) in enumerate(parts):
            trimesh.Trimesh(v, f).export(os.path.join(folder, "part_%02d.stl" % i))
        with open(done, "w") as f:
            f.write("%d\n" % len(parts))
    return sorted(os.path.join(folder, p) for p in os.listdir(folder) if p.endswith(".stl"))


def _parametric(spec, cache_dir):
    shape = spec["shape"]
    if shape == "sphere":
        r = spec["radius_m"]
        visual = trimesh.creation.icosphere(subdivisions=3, radius=r)
        collision = [("sphere", [r], [0, 0, r])]
    elif shape == "ellipsoid":
        radii = spec["radii_m"]
        visual = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        visual.apply_scale(radii)
        collision = [("ellipsoid", list(radii), [0, 0, radii[2]])]
    elif shape == "box":
        size = spec["size_m"]
        visual = trimesh.creation.box(extents=size)
        collision = [("box", [s / 2.0 for s in size], [0, 0, size[2] / 2.0])]
    elif shape == "cylinder":
        r, h = spec["radius_m"], spec["height_m"]
        visual = trimesh.creation.cylinder(radius=r, height=h, sections=48)
        collision = [("cylinder", [r, h / 2.0], [0, 0, h / 2.0])]
    elif shape == "vessel":
        r, h, w = spec["radius_m"], spec["height_m"], spec["wall_m"]
        visual = _revolution([[0, 0], [r, 0], [r, h], [r - w, h], [r - w, w], [0, w]])
        collision = [("cylinder", [r, w / 2.0], [0, 0, w / 2.0])]
        # the wall as 16 boxes around the axis: a cup the fingers can close on from inside the rim
        n = 16
        seg = 2.0 * r * np.tan(np.pi / n) * 1.02
        for i in range(n):
            a = 2.0 * np.pi * i / n
            collision.append(("box_yaw", [w / 2.0, seg / 2.0, (h - w) / 2.0],
                              [(r - w / 2.0) * np.cos(a), (r - w / 2.0) * np.sin(a), w + (h - w) / 2.0], a))
    elif shape == "bottle":
        r, h, rn = spec["radius_m"], spec["height_m"], spec["neck_radius_m"]
        shoulder, neck = 0.62 * h, 0.8 * h
        visual = _revolution([[0, 0], [r, 0], [r, shoulder], [rn, neck], [rn, h], [0, h]])
        collision = [("cylinder", [r, shoulder / 2.0], [0, 0, shoulder / 2.0]),
                     ("cylinder", [(r + rn) / 2.0, (neck - shoulder) / 2.0], [0, 0, (shoulder + neck) / 2.0]),
                     ("cylinder", [rn, (h - neck) / 2.0], [0, 0, (neck + h) / 2.0])]
    else:
        raise ValueError("%s: unknown shape %s" % (spec["name"], shape))
    _centre_on_base(visual)
    return visual, collision


def load_objects(config_path, ycb_dir, cache_dir, split="all", names=None, kinds=("ycb", "parametric")):
    """EvalObjects of config/evaluation/objects.yaml: split train | heldout | heldout_extra | all;
    names filters."""
    with open(config_path) as f:
        config = yaml.safe_load(f)
    objects = []
    for kind in kinds:
        for half in SPLITS:
            if split not in ("all", half):
                continue
            for spec in config.get(kind, {}).get(half, []):
                name = spec["name"]
                if names and name not in names:
                    continue
                if kind == "ycb":
                    if not ycb_dir:
                        raise RuntimeError("YCB objects need the YCB folder (scripts/fetch_ycb.sh)")
                    path = os.path.join(ycb_dir, name + ".stl")
                    visual = _centre_on_base(trimesh.load(path, force="mesh"))
                    key = hashlib.sha1(open(path, "rb").read()).hexdigest()[:12] + "_" + name
                    collision = [("mesh", p, None) for p in _convex_parts(visual, cache_dir, key)]
                    cls = next((c for k, c in YCB_CLASSES if k in name), "tool")
                else:
                    visual, collision = _parametric(spec, cache_dir)
                    cls = spec.get("class", spec["shape"])
                volume = visual.volume if visual.is_watertight else \
                    sum(trimesh.load(p).volume for kind_, p, _ in collision if kind_ == "mesh")
                mass = spec.get("mass_kg") or DENSITY_KG_M3 * abs(volume)
                objects.append(EvalObject(name, cls, half, visual, float(mass), collision))
    return objects


def min_horizontal_width(vertices, directions=36):
    """Smallest extent of the points over horizontal directions: what a gripper closing
    horizontally must open to."""
    a = np.linspace(0.0, np.pi, directions, endpoint=False)
    d = np.stack([np.cos(a), np.sin(a)], axis=1)
    proj = vertices[:, :2] @ d.T
    return float((proj.max(axis=0) - proj.min(axis=0)).min())
