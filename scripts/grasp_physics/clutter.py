"""Several objects on the table in MuJoCo (issue 11 part 1): seeded clutter scenes, *packed*
(standing upright side by side, touching) or *piled* (dropped from a few cm above the
growing pile in random orientations and settled), and the grasp trial of trial.py run with
every remaining object present.

A scene is a list of objects (objects.EvalObject) and their poses (pos, quat wxyz of the body
frame, whose origin is the visual mesh's base centre as in trial.py). The MuJoCo model is
rebuilt for each subset of objects (an object removed after a successful grasp is gone from
the model, not parked somewhere it could still be touched)."""
import math

import mujoco
import numpy as np

from . import objects as objects_lib
from .trial import StillCounter, TrialParams, _f, execute_grasp, object_geoms, random_quat, rotated, world_xml

# where the clutter is built: in front of the robot like the single-object evaluator's objects
CLUTTER_CENTRE_XY_M = (0.5, 0.0)
HAND_ROLES = ("palm", "finger_a", "finger_b")
# objects farther than this from the clutter centre after settling are off the work area
# (a packed row of five objects reaches 0.25 m; the camera at 0.55 m sees about +-0.3 m)
WORKSPACE_RADIUS_M = 0.3


def fits_gripper(obj, gripper, margin_m=0.005):
    """Standing in its upright (config) orientation, the object is narrower than the opening."""
    return objects_lib.min_horizontal_width(obj.visual.vertices) < gripper["max_opening_m"] - margin_m


def clutter_xml(objs, gripper, params):
    assets, bodies = [], []
    for k, obj in enumerate(objs):
        a, geoms = object_geoms(obj, params.friction, "obj_%d_" % k, "obj_mesh_%d_" % k)
        assets += a
        bodies.append('<body name="object_%d" pos="%s">\n      <freejoint name="object_%d_free"/>\n'
                      '      %s\n    </body>'
                      % (k, _f(0.5, 0.3 * k, 0.5), k, "\n      ".join(geoms)))
    return world_xml("clutter_trial", params, gripper, assets, bodies)


class ClutterScene:
    """The compiled model of objs (each with its mass set to obj.mass_kg) and the hand."""

    def __init__(self, objs, gripper, params=None):
        self.objs, self.gripper = list(objs), gripper
        self.params = params or TrialParams()
        m = self.model = mujoco.MjModel.from_xml_string(clutter_xml(self.objs, gripper, self.params))
        self.bodies, self.qadr, self.vadr = [], [], []
        for k, obj in enumerate(self.objs):
            body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object_%d" % k)
            scale = obj.mass_kg / m.body_mass[body]
            m.body_mass[body] *= scale
            m.body_inertia[body] *= scale
            jnt = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "object_%d_free" % k)
            self.bodies.append(body)
            self.qadr.append(m.jnt_qposadr[jnt])
            self.vadr.append(m.jnt_dofadr[jnt])
        mujoco.mj_setConst(m, mujoco.MjData(m))
        self.mocap = m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hand_target")]
        hand_jnt = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "hand_free")
        self.hand_qadr = m.jnt_qposadr[hand_jnt]
        # who each geom belongs to: "object<k>", table, floor, palm, finger_a, finger_b
        body_to_object = {b: k for k, b in enumerate(self.bodies)}
        self.geom_role = []
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            role = "other"
            if m.geom_bodyid[g] in body_to_object:
                role = "object%d" % body_to_object[m.geom_bodyid[g]]
            for prefix in ("table", "floor") + HAND_ROLES:
                if name.startswith(prefix):
                    role = prefix
            self.geom_role.append(role)
        self.data = mujoco.MjData(m)

    # ---- state -----------------------------------------------------------------------------
    def set_poses(self, poses):
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        for k, (pos, quat) in enumerate(poses):
            d.qpos[self.qadr[k]:self.qadr[k] + 3] = pos
            d.qpos[self.qadr[k] + 3:self.qadr[k] + 7] = quat
        d.qpos[self.hand_qadr:self.hand_qadr + 7] = [0.5, 0.0, 2.0, 1, 0, 0, 0]
        d.mocap_pos[self.mocap] = [0.5, 0.0, 2.0]
        d.mocap_quat[self.mocap] = [1, 0, 0, 0]
        d.ctrl[:] = 0.0
        mujoco.mj_forward(m, d)

    def poses(self):
        d = self.data
        return [(d.qpos[a:a + 3].copy(), d.qpos[a + 3:a + 7].copy()) for a in self.qadr]

    def world_vertices(self, k, pose=None):
        pos, quat = pose if pose is not None else self.poses()[k]
        return rotated(self.objs[k].visual.vertices, quat) + pos

    def max_speed(self, objects=None):
        """The largest speed component of `objects` (indices; default all)."""
        d = self.data
        adr = self.vadr if objects is None else [self.vadr[k] for k in objects]
        return max([np.abs(d.qvel[a:a + 6]).max() for a in adr] or [0.0])

    def settle(self, max_s=None, min_s=0.2, moving=None, held_poses=None):
        """Steps until the objects `moving` (default all) are at rest (StillCounter: every speed
        under settle_speed for settle_still_s on end) or max_s (default settle_s) has passed; the
        others stay frozen at their held_poses. Returns the poses."""
        m, d = self.model, self.data
        frozen = [] if moving is None else [k for k in range(len(self.objs)) if k not in moving]
        steps = int((max_s or self.params.settle_s) / m.opt.timestep)
        still = StillCounter(self.params, m.opt.timestep)
        for i in range(steps):
            for k in frozen:
                a, v = self.qadr[k], self.vadr[k]
                d.qpos[a:a + 3], d.qpos[a + 3:a + 7] = held_poses[k]
                d.qvel[v:v + 6] = 0.0
            mujoco.mj_step(m, d)
            if still.at_rest(self.max_speed(moving)) and i * m.opt.timestep > min_s:
                break
        return self.poses()

    # ---- contacts --------------------------------------------------------------------------
    def contact_pairs(self):
        pairs = set()
        d = self.data
        for i in range(d.ncon):
            a, b = self.geom_role[d.contact[i].geom1], self.geom_role[d.contact[i].geom2]
            pairs.add((a, b) if a < b else (b, a))
        return pairs

    def objects_in_both_fingers(self):
        pairs = self.contact_pairs()
        out = []
        for k in range(len(self.objs)):
            role = "object%d" % k
            touches = {r for p in pairs if role in p for r in p}
            if {"finger_a", "finger_b"} <= {r.split("_proximal")[0].split("_distal")[0] for r in touches}:
                out.append(k)
        return out

    # ---- grasp -----------------------------------------------------------------------------
    def execute(self, poses, grasp_rotation, grasp_position):
        """trial.execute_grasp with every object of the scene present. Success: an object rose
        more than lifted_m and is in both fingers at the end (`grasped` is its index, -1 when
        none). Unexpected contact: the hand touches the table, or any object before closing;
        `touched_first` is the index of the first object the hand touched before closing (-1:
        none), which tells a hand that ran into the object it was sent for (its hidden side)
        from one that hit a neighbour."""
        d, p = self.data, self.params
        self.set_poses(poses)
        rest_z = [float(d.xipos[b][2]) for b in self.bodies]
        closed_on = []
        touched_first = []

        def closed_on_object():
            closed_on[:] = self.objects_in_both_fingers()
            return bool(closed_on)

        def lifted_in_hand():
            return [k for k in self.objects_in_both_fingers()
                    if d.xipos[self.bodies[k]][2] - rest_z[k] > p.lifted_m]

        def hand_touches(pairs, prefix):
            touching = [pr for pr in pairs
                        if any(r.startswith(prefix) for r in pr) and any(r.startswith(h) for h in HAND_ROLES for r in pr)]
            # execute_grasp asks about objects only before closing (pregrasp and approach)
            if prefix == "object" and touching and not touched_first:
                touched_first.append(min(int(r[len("object"):]) for pr in touching for r in pr
                                         if r.startswith("object")))
            return bool(touching)

        outcome = execute_grasp(self, grasp_rotation, grasp_position, closed_on_object,
                                lambda: bool(lifted_in_hand()), hand_touches)
        lifted = lifted_in_hand()
        outcome["closed_on"] = closed_on[0] if closed_on else -1
        outcome["touched_first"] = touched_first[0] if touched_first else -1
        outcome["grasped"] = lifted[0] if lifted and outcome["success"] else -1
        outcome["lifted_together"] = len(lifted)
        return outcome


# ---- scene generation --------------------------------------------------------------------------
def _footprint(vertices_xy, spacing_m=0.002):
    """Boundary of the convex hull of the points (x, y), sampled every spacing_m."""
    from scipy.spatial import ConvexHull
    hull = vertices_xy[ConvexHull(vertices_xy).vertices]
    points = []
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / spacing_m)))
        points.append(a + np.outer(np.arange(n) / n, b - a))
    return np.concatenate(points)


class _Obstacle:
    """Placed footprints: distance and overlap tests for a footprint moved over them."""

    def __init__(self, points):
        from scipy.spatial import Delaunay, cKDTree
        self.points, self.tree, self.hull = points, cKDTree(points), Delaunay(points)

    def clear_of(self, local, local_hull, offset, gap_m):
        """The footprint `local` moved by offset is at least gap_m from the placed ones and
        neither contains the other."""
        moved = local + offset
        if self.tree.query(moved)[0].min() < gap_m:
            return False
        if (self.hull.find_simplex(moved) >= 0).any():
            return False
        return not (local_hull.find_simplex(self.points - offset) >= 0).any()


def packed_poses(objs, rng, gap_m=0.0005, centre_xy=CLUTTER_CENTRE_XY_M):
    """Upright, seeded yaw, side by side: each object after the first comes in from a seeded
    direction toward the group's centre and stops gap_m short of touching a placed one (the
    settle that follows lets them lean on each other where they do)."""
    from scipy.spatial import Delaunay
    poses, footprints = [], []
    for obj in objs:
        yaw = rng.uniform(-math.pi, math.pi)
        quat = np.array([math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)])
        local = _footprint(rotated(obj.visual.vertices, quat)[:, :2])
        if not poses:
            xy = np.asarray(centre_xy, float)
        else:
            placed = _Obstacle(np.concatenate(footprints))
            local_hull = Delaunay(local)
            group_centre = placed.points.mean(axis=0)
            direction = rng.uniform(-math.pi, math.pi)
            unit = np.array([math.cos(direction), math.sin(direction)])
            # start clear of everything, step inward (5 mm, then 0.5 mm) while still clear
            distance = np.linalg.norm(placed.points - group_centre, axis=1).max() + \
                np.linalg.norm(local, axis=1).max() + 0.01
            for step in (0.005, 0.0005):
                while distance - step > 0 and \
                        placed.clear_of(local, local_hull, group_centre + (distance - step) * unit, gap_m):
                    distance -= step
            xy = group_centre + distance * unit
        lowest = rotated(obj.visual.vertices, quat)[:, 2].min()
        poses.append((np.array([xy[0], xy[1], -lowest + 0.001]), quat))
        footprints.append(local + xy)
    return poses


def make_packed(objs, gripper, rng, params=None):
    scene = ClutterScene(objs, gripper, params)
    scene.set_poses(packed_poses(objs, rng))
    return scene, scene.settle()


def make_piled(objs, gripper, rng, params=None, drop_height_m=0.03, radius_m=0.04,
               centre_xy=CLUTTER_CENTRE_XY_M, tries=4):
    """Drops the objects one by one in seeded orientations at a seeded point within radius_m of
    the centre, each with its lowest point drop_height_m above the pile's highest point, and
    lets each come to rest before the next. A drop after which an object has rolled out of the
    work area (a sphere off the pile, a bottle rolling away) is undone and tried again with the
    next seeded pose, up to `tries` times; an object that never stays is left out (it waits
    off the table, and make_table drops it)."""
    scene = ClutterScene(objs, gripper, params)
    # objects not yet dropped wait far off the table, apart, frozen
    poses = [(np.array([-1.0 - 0.5 * k, 2.0, 1.0]), np.array([1.0, 0, 0, 0])) for k in range(len(objs))]
    dropped = []
    for k, obj in enumerate(objs):
        before = list(poses)
        for _ in range(tries):
            quat = random_quat(rng)
            r, a = radius_m * math.sqrt(rng.random()), rng.uniform(-math.pi, math.pi)
            xy = np.asarray(centre_xy) + r * np.array([math.cos(a), math.sin(a)])
            top = max([scene.world_vertices(j, before[j])[:, 2].max() for j in dropped] or [0.0])
            lowest = rotated(obj.visual.vertices, quat)[:, 2].min()
            poses = list(before)
            poses[k] = (np.array([xy[0], xy[1], top + drop_height_m - lowest]), quat)
            scene.set_poses(poses)
            poses = scene.settle(min_s=0.3, moving=dropped + [k], held_poses=poses)
            if len(on_table(scene, [poses[j] for j in dropped + [k]], sub=[*dropped, k])) == len(dropped) + 1:
                dropped.append(k)
                break
        else:
            poses = before
    scene.set_poses(poses)
    return scene, poses


def on_table(scene, poses, workspace_radius_m=None, centre_xy=CLUTTER_CENTRE_XY_M, sub=None):
    """Indices (into poses) of the objects still in the work area: above the table top and
    within workspace_radius_m of the clutter's centre (VGN's protocol also drops what rolled
    away). sub: the scene's object index of each pose (default 0, 1, ...)."""
    radius = WORKSPACE_RADIUS_M if workspace_radius_m is None else workspace_radius_m
    keep = []
    for i, pose in enumerate(poses):
        v = scene.world_vertices(sub[i] if sub else i, pose)
        if v[:, 2].min() > -0.01 and np.linalg.norm(pose[0][:2] - np.asarray(centre_xy)) < radius:
            keep.append(i)
    return keep


def make_table(arrangement, objs, gripper, rng, params=None):
    """(scene, poses) of a packed or piled table of objs; objects that rolled out of the
    workspace while it settled are left out (scene.objs says which stayed)."""
    if arrangement == "packed":
        scene, poses = make_packed(objs, gripper, rng, params)
    elif arrangement == "piled":
        scene, poses = make_piled(objs, gripper, rng, params)
    else:
        raise ValueError("arrangement must be packed or piled, not %s" % arrangement)
    keep = on_table(scene, poses)
    if len(keep) < len(objs):
        scene = ClutterScene([objs[k] for k in keep], gripper, params)
        poses = [poses[k] for k in keep]
        scene.set_poses(poses)
    return scene, poses
