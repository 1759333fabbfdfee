"""One object on a table in MuJoCo: settle it into a seeded rest pose, then execute a grasp
(pre-grasp 5 cm back along the approach, approach, close under the force limit, lift 15 cm,
shake +-30 deg about two horizontal axes, hold) and say whether it held.

Success: at the end the object is more than `lifted_m` above its rest height and touches both
fingers. Unexpected contact: the hand touches the object before the fingers start closing, or
the table at any time."""
import math

import mujoco
import numpy as np

from . import gripper as gripper_mjcf

TABLE_CENTRE_XY_M = (0.55, 0.0)
TABLE_HALF_SIZE_M = (0.6, 0.4, 0.02)


class StillCounter:
    """Counts the steps since the last one with a speed over params.settle_speed: the bodies are
    at rest once that has lasted params.settle_still_s."""

    def __init__(self, params, timestep_s):
        self.needed = max(1, int(round(params.settle_still_s / timestep_s)))
        self.speed = params.settle_speed
        self.still = 0

    def at_rest(self, max_speed):
        self.still = self.still + 1 if max_speed < self.speed else 0
        return self.still >= self.needed


class TrialParams:
    def __init__(self, **overrides):
        self.friction = 0.8
        self.timestep_s = 0.001
        self.pregrasp_back_m = 0.05
        self.pregrasp_hold_s = 0.1
        self.approach_s = 0.5
        self.close_s = 0.8
        self.lift_m = 0.15
        self.lift_s = 1.0
        self.shake_deg = 30.0
        self.shake_s = 2.0
        self.hold_s = 2.0
        self.lifted_m = 0.10
        # a settle (one object, or a clutter table's drops and the rest after a pick): at most this
        # long (a pebble dropped tilted rocks for up to ~8 s in MuJoCo, which has no rolling
        # resistance here, also in a pile; a ball rolling off the table never stops, and a pile
        # whose contacts chatter at ~1 mm/s stops here too, having moved < 1 mm)
        self.settle_s = 10.0
        # at rest = every speed under settle_speed for settle_still_s on end: one slow step is a
        # rocking body's turning point (a pebble 20-40 deg from flat, a mug about to tip over)
        self.settle_speed = 2e-3
        self.settle_still_s = 0.3
        for k, v in overrides.items():
            if not hasattr(self, k):
                raise KeyError("unknown trial parameter %s" % k)
            setattr(self, k, v)


def rotated(vertices, quat_wxyz):
    """vertices (N x 3) turned by the unit quaternion (w, x, y, z): the object frame's points
    in a pose's orientation."""
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(quat_wxyz, float))
    return vertices @ rot.reshape(3, 3).T


def _f(*values):
    return " ".join("%.6g" % v for v in values)


def object_geoms(obj, friction, geom_prefix="obj_", mesh_prefix="obj_mesh_"):
    """(mesh assets, geoms) of obj's collision model, geoms named <geom_prefix><i> (the trial
    tells objects from the hand by the prefix obj_; the clutter scene names each object's
    geoms obj_<k>_<i>)."""
    assets, geoms = [], []
    fr = _f(friction, 0.005, 0.0001)
    for i, item in enumerate(obj.collision):
        kind = item[0]
        common = 'name="%s%d" friction="%s" condim="4" density="1000" rgba="0.8 0.3 0.2 1"' % (geom_prefix, i, fr)
        if kind == "mesh":
            assets.append('<mesh name="%s%d" file="%s"/>' % (mesh_prefix, i, item[1]))
            geoms.append('<geom type="mesh" mesh="%s%d" %s/>' % (mesh_prefix, i, common))
        elif kind == "box_yaw":
            geoms.append('<geom type="box" size="%s" pos="%s" euler="0 0 %s" %s/>'
                         % (_f(*item[1]), _f(*item[2]), _f(item[3]), common))
        else:
            geoms.append('<geom type="%s" size="%s" pos="%s" %s/>' % (kind, _f(*item[1]), _f(*item[2]), common))
    return assets, geoms


def world_xml(model_name, params, gripper, assets, bodies):
    """The MuJoCo world of every trial: stiff contacts, the floor, the table, `bodies` (MJCF body
    strings of the objects) and the hand built from the gripper YAML."""
    hand, equality, actuators, tendons, excludes = gripper_mjcf.hand_mjcf(gripper, params.friction)
    return """<mujoco model="%s">
  <compiler angle="radian" inertiafromgeom="true" boundmass="0.001" boundinertia="1e-7"/>
  <option timestep="%s" gravity="0 0 -9.81" cone="elliptic" impratio="10" integrator="implicit"/>
  <default>
    <!-- stiff contacts: with MuJoCo's default solref (20 ms) a 40 N squeeze sinks a finger 1 cm
         into the object and the penetration itself wedges objects out of the hand -->
    <geom solref="0.003 1" solimp="0.95 0.99 0.0005"/>
  </default>
  <asset>%s</asset>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.1" pos="0 0 -0.75"/>
    <geom name="table" type="box" size="%s" pos="%s" friction="%s" condim="6" rgba="0.6 0.45 0.3 1"/>
    %s
    %s
  </worldbody>
  <contact>%s</contact>
  <tendon>%s</tendon>
  <equality>%s</equality>
  <actuator>%s</actuator>
</mujoco>""" % (model_name, _f(params.timestep_s), "\n".join(assets), _f(*TABLE_HALF_SIZE_M),
                _f(TABLE_CENTRE_XY_M[0], TABLE_CENTRE_XY_M[1], -TABLE_HALF_SIZE_M[2]),
                _f(params.friction, 0.005, 0.0005), "\n    ".join(bodies), hand, excludes, tendons,
                equality, actuators)


def scene_xml(obj, gripper, params):
    assets, geoms = object_geoms(obj, params.friction)
    body = ('<body name="object" pos="0.5 0 0.2">\n      <freejoint name="object_free"/>\n      %s\n    </body>'
            % "\n      ".join(geoms))
    return world_xml("grasp_trial", params, gripper, assets, [body])


class Scene:
    """The compiled model with the object's mass set to obj.mass_kg (inertia scaled alike)."""

    def __init__(self, obj, gripper, params=None):
        self.obj, self.gripper = obj, gripper
        self.params = params or TrialParams()
        self.model = mujoco.MjModel.from_xml_string(scene_xml(obj, gripper, self.params))
        m = self.model
        self.object_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
        scale = obj.mass_kg / m.body_mass[self.object_body]
        m.body_mass[self.object_body] *= scale
        m.body_inertia[self.object_body] *= scale
        mujoco.mj_setConst(m, mujoco.MjData(m))  # derived quantities (invweight0, ...) follow the mass
        self.hand_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hand")
        self.mocap = m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hand_target")]
        self.table_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "table")
        obj_jnt = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "object_free")
        hand_jnt = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "hand_free")
        self.obj_qadr, self.obj_vadr = m.jnt_qposadr[obj_jnt], m.jnt_dofadr[obj_jnt]
        self.hand_qadr, self.hand_vadr = m.jnt_qposadr[hand_jnt], m.jnt_dofadr[hand_jnt]
        # what each geom belongs to: object, table, palm, finger_a, finger_b
        self.geom_role = []
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            role = "other"
            for prefix in ("obj_", "table", "floor", "palm", "finger_a", "finger_b"):
                if name.startswith(prefix):
                    role = prefix.rstrip("_").replace("obj", "object")
            self.geom_role.append(role)
        self.data = mujoco.MjData(m)

    # ---- contacts --------------------------------------------------------------------------
    def contact_pairs(self):
        pairs = set()
        d = self.data
        for i in range(d.ncon):
            c = d.contact[i]
            a, b = self.geom_role[c.geom1], self.geom_role[c.geom2]
            pairs.add((a, b) if a < b else (b, a))
        return pairs

    @staticmethod
    def hand_touches(pairs, other):
        return any(other in p and ({"palm", "finger_a", "finger_b"} & set(p)) for p in pairs)

    # ---- settle ----------------------------------------------------------------------------
    def settle(self, quat_wxyz, xy=(0.5, 0.0)):
        """Drops the object (orientation quat) from just above the table; returns (pos, quat)
        of its rest pose."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        lowest = rotated(self.obj.visual.vertices, quat_wxyz)[:, 2].min()
        d.qpos[self.obj_qadr:self.obj_qadr + 3] = [xy[0], xy[1], -lowest + 0.003]
        d.qpos[self.obj_qadr + 3:self.obj_qadr + 7] = quat_wxyz
        self._park_hand()
        still = StillCounter(self.params, m.opt.timestep)
        for _ in range(int(self.params.settle_s / m.opt.timestep)):
            mujoco.mj_step(m, d)
            if still.at_rest(np.abs(d.qvel[self.obj_vadr:self.obj_vadr + 6]).max()):
                break
        return d.qpos[self.obj_qadr:self.obj_qadr + 3].copy(), d.qpos[self.obj_qadr + 3:self.obj_qadr + 7].copy()

    def _park_hand(self):
        d = self.data
        d.qpos[self.hand_qadr:self.hand_qadr + 7] = [0.5, 0.0, 2.0, 1, 0, 0, 0]
        d.mocap_pos[self.mocap] = [0.5, 0.0, 2.0]
        d.mocap_quat[self.mocap] = [1, 0, 0, 0]

    # ---- grasp -----------------------------------------------------------------------------
    def execute(self, rest_pos, rest_quat, grasp_rotation, grasp_position):
        """Runs the grasp (3x3 rotation with columns approach, closing, axis; position of the
        closing region's centre) from the rest pose. Returns a dict of the outcome."""
        m, d, p = self.model, self.data, self.params
        mujoco.mj_resetData(m, d)
        d.qpos[self.obj_qadr:self.obj_qadr + 3] = rest_pos
        d.qpos[self.obj_qadr + 3:self.obj_qadr + 7] = rest_quat
        d.ctrl[:] = 0.0
        mujoco.mj_forward(m, d)
        rest_z = float(d.xipos[self.object_body][2])  # centre of mass: the body origin turns with it

        def held():
            pairs = self.contact_pairs()
            return ("finger_a", "object") in pairs and ("finger_b", "object") in pairs

        def held_and_lifted():
            return held() and d.xipos[self.object_body][2] - rest_z > p.lifted_m

        outcome = execute_grasp(self, grasp_rotation, grasp_position, held, held_and_lifted, self.hand_touches)
        outcome["object_rise_m"] = float(d.xipos[self.object_body][2] - rest_z)
        return outcome


def execute_grasp(scene, grasp_rotation, grasp_position, closed_on_object, held_and_lifted, hand_touches):
    """The grasp every trial runs, one object or a cluttered table: the hand (coupled to its
    mocap target) starts 5 cm back along the approach, approaches, closes under its force limit,
    lifts 15 cm, shakes about two horizontal axes and holds. `closed_on_object()` says whether the
    closed fingers hold something, `held_and_lifted()` whether it is held and up after each later
    phase, `hand_touches(pairs, what)` whether a contact pair joins the hand and `what` ("table",
    "object"). `scene` provides model, data, params, gripper, mocap, hand_qadr, contact_pairs().
    Returns the outcome: success, failure_phase, unexpected_contact and contact_phase (the hand on
    the table at any time, or on an object before closing), table_contact, unstable."""
    m, d, p = scene.model, scene.data, scene.params
    rot = np.asarray(grasp_rotation, float)
    target = np.asarray(grasp_position, float)
    approach = rot[:, 0] / np.linalg.norm(rot[:, 0])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.reshape(-1))
    start = target - p.pregrasp_back_m * approach
    d.qpos[scene.hand_qadr:scene.hand_qadr + 3] = start
    d.qpos[scene.hand_qadr + 3:scene.hand_qadr + 7] = quat
    d.mocap_pos[scene.mocap] = start
    d.mocap_quat[scene.mocap] = quat
    mujoco.mj_forward(m, d)
    closed = gripper_mjcf.closed_control(scene.gripper)
    outcome = {"unexpected_contact": False, "contact_phase": "", "failure_phase": "",
               "success": False, "table_contact": False}

    def run(seconds, phase, update):
        n = max(1, int(round(seconds / m.opt.timestep)))
        for i in range(n):
            update((i + 1) / n)
            mujoco.mj_step(m, d)
            pairs = scene.contact_pairs()
            if hand_touches(pairs, "table"):
                outcome["table_contact"] = True
                if not outcome["unexpected_contact"]:
                    outcome["unexpected_contact"], outcome["contact_phase"] = True, phase
            if phase in ("pregrasp", "approach") and hand_touches(pairs, "object") \
                    and not outcome["unexpected_contact"]:
                outcome["unexpected_contact"], outcome["contact_phase"] = True, phase

    run(p.pregrasp_hold_s, "pregrasp", lambda s: None)
    run(p.approach_s, "approach", lambda s: d.mocap_pos.__setitem__(
        scene.mocap, start + _smooth(s) * p.pregrasp_back_m * approach))
    run(p.close_s, "close", lambda s: d.ctrl.__setitem__(slice(None), np.asarray(closed) * min(1.0, 2.0 * s)))
    if not closed_on_object():
        outcome["failure_phase"] = "close"
    lift_start = d.mocap_pos[scene.mocap].copy()
    run(p.lift_s, "lift", lambda s: d.mocap_pos.__setitem__(
        scene.mocap, lift_start + np.array([0, 0, p.lift_m * _smooth(s)])))
    if not outcome["failure_phase"] and not held_and_lifted():
        outcome["failure_phase"] = "lift"
    base_quat = d.mocap_quat[scene.mocap].copy()
    amplitude = math.radians(p.shake_deg)

    def shake(s):
        axis = np.array([1.0, 0, 0]) if s < 0.5 else np.array([0, 1.0, 0])
        angle = amplitude * math.sin(2.0 * math.pi * (2.0 * s % 1.0))
        q = np.zeros(4)
        mujoco.mju_axisAngle2Quat(q, axis, angle)
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, q, base_quat)
        d.mocap_quat[scene.mocap] = out

    run(p.shake_s, "shake", shake)
    if not outcome["failure_phase"] and not held_and_lifted():
        outcome["failure_phase"] = "shake"
    run(p.hold_s, "hold", lambda s: None)
    if not outcome["failure_phase"] and not held_and_lifted():
        outcome["failure_phase"] = "hold"
    outcome["success"] = not outcome["failure_phase"]
    # MuJoCo resets a diverging simulation and warns; such a trial says nothing about the grasp
    outcome["unstable"] = int(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number) > 0
    if outcome["unstable"]:
        outcome["success"], outcome["failure_phase"] = False, "unstable"
    return outcome

def _smooth(s):
    """Minimum-jerk-like 0..1 ramp."""
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


def random_quat(rng):
    """Uniform random rotation (w, x, y, z)."""
    u1, u2, u3 = rng.random(3)
    q = np.array([math.sqrt(1 - u1) * math.sin(2 * math.pi * u2), math.sqrt(1 - u1) * math.cos(2 * math.pi * u2),
                  math.sqrt(u1) * math.sin(2 * math.pi * u3), math.sqrt(u1) * math.cos(2 * math.pi * u3)])
    return np.array([q[3], q[0], q[1], q[2]])
