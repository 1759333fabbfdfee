"""A MuJoCo hand built from a gripper YAML (config/grippers/*.yaml), so a new gripper YAML is
evaluated without code.

Frame: the grasp frame of include/fast_grasp/core/grasp_types.h -- origin at the centre of the
closing region, X = approach, Y = closing direction, Z = X x Y. The fingers span
finger_depth_m along X centred on the origin and the palm stands behind them (X <
-finger_depth/2), exactly the boxes of grasping/gripper_volume.h.

Two finger kinematics (YAML key `physics_fingers`, default from `underactuated`):
- `parallel`: each finger a box on a prismatic joint along Y (Robotiq 2F-85 in its parallel
  pinch, PR2).
- `two_phalanx`: each finger a proximal and a distal phalanx on hinges about Z, driven by one
  tendon with a spring that keeps the distal phalanx straight until the proximal one is blocked
  (the Lacquey Fetch's under-actuation: the finger wraps the object).

The hand is not teleported: a free body welded to a mocap target through a soft weld, so a
contact pushes it back (the compliant coupling of a position-controlled arm). Each finger's
actuator is force-limited (max_finger_force_n)."""
import yaml


def load_gripper(path):
    with open(path) as f:
        g = yaml.safe_load(f)
    g.setdefault("palm_width_m", 2.0 * g["finger_width_m"])
    g.setdefault("physics_fingers", "two_phalanx" if g.get("name") == "lacquey_fetch" else "parallel")
    g.setdefault("max_finger_force_n", 40.0)
    if g["physics_fingers"] not in ("parallel", "two_phalanx"):
        raise ValueError("%s: physics_fingers must be parallel or two_phalanx" % path)
    return g


def _f(*values):
    return " ".join("%.6g" % v for v in values)


def hand_mjcf(g, friction, weld_timeconst_s=0.02):
    """(worldbody XML, equality XML, actuator XML, tendon XML, contact-exclude XML) of the hand.

    Bodies: hand_target (mocap), hand (free, palm), finger_a (+Y side), finger_b (-Y side).
    Geoms are named palm, finger_a*, finger_b* so the trial can tell who touched what."""
    fd, ft, fw = g["finger_depth_m"], g["finger_thickness_m"], g["finger_width_m"]
    opening = g["max_opening_m"]
    palm_t, palm_w = g["palm_thickness_m"], g["palm_width_m"]
    force = float(g["max_finger_force_n"])
    half_y = opening / 2.0 + ft
    fr = _f(friction, 0.005, 0.0001)
    palm_x = -fd / 2.0 - palm_t / 2.0
    body = ['<body name="hand_target" mocap="true" pos="0 0 2"/>',
            '<body name="hand" pos="0 0 2" gravcomp="1">',
            '  <freejoint name="hand_free"/>',
            '  <geom name="palm" type="box" size="%s" pos="%s" mass="0.4" friction="%s" condim="4" rgba="0.3 0.3 0.35 1"/>'
            % (_f(palm_t / 2.0, half_y, palm_w / 2.0), _f(palm_x, 0, 0), fr)]
    actuators, tendons = [], []
    if g["physics_fingers"] == "parallel":
        travel = max(opening - g.get("min_opening_m", 0.0), 0.0) / 2.0
        for name, side in (("finger_a", 1.0), ("finger_b", -1.0)):
            y = side * (opening / 2.0 + ft / 2.0)
            body += ['  <body name="%s" pos="%s" gravcomp="1">' % (name, _f(0, y, 0)),
                     '    <joint name="%s_slide" type="slide" axis="%s" range="0 %s" damping="20" armature="0.05"/>'
                     % (name, _f(0, -side, 0), _f(travel + 0.002)),
                     '    <geom name="%s" type="box" size="%s" mass="0.05" friction="%s" condim="4" rgba="0.2 0.2 0.2 1"/>'
                     % (name, _f(fd / 2.0, ft / 2.0, fw / 2.0), fr),
                     '  </body>']
            # kp large enough that the force limit, not the gain, sets the squeeze
            actuators.append('<position name="%s_close" joint="%s_slide" kp="%s" ctrlrange="0 %s" forcerange="%s"/>'
                             % (name, name, _f(4.0 * force / max(travel, 1e-3)), _f(travel + 0.002), _f(-force, force)))
    else:
        link = fd / 2.0
        # Tendon torque: max_finger_force_n at a contact halfway along the finger. The distal
        # spring is preloaded against its straight stop with half of it, so the finger moves
        # as one piece until the proximal phalanx is blocked and then curls around the object.
        torque = force * fd / 2.0
        for name, side in (("finger_a", 1.0), ("finger_b", -1.0)):
            y = side * (opening / 2.0 + ft / 2.0)
            axis = _f(0, 0, -side)  # positive angle turns the finger toward the closing line
            body += ['  <body name="%s" pos="%s" gravcomp="1">' % (name, _f(-fd / 2.0, y, 0)),
                     '    <joint name="%s_proximal" type="hinge" axis="%s" range="-0.05 1.6" damping="0.3" armature="0.002"/>'
                     % (name, axis),
                     '    <geom name="%s_proximal" type="box" size="%s" pos="%s" mass="0.04" friction="%s" condim="4" rgba="0.2 0.2 0.2 1"/>'
                     % (name, _f(link / 2.0, ft / 2.0, fw / 2.0), _f(link / 2.0, 0, 0), fr),
                     '    <body name="%s_distal" pos="%s" gravcomp="1">' % (name, _f(link, 0, 0)),
                     '      <joint name="%s_distal" type="hinge" axis="%s" range="0 1.6" damping="0.05" stiffness="%s" springref="-1.5" armature="0.002"/>'
                     % (name, axis, _f(0.5 * torque / 1.5)),
                     '      <geom name="%s_distal" type="box" size="%s" pos="%s" mass="0.03" friction="%s" condim="4" rgba="0.25 0.25 0.25 1"/>'
                     % (name, _f(link / 2.0, ft / 2.0, fw / 2.0), _f(link / 2.0, 0, 0), fr),
                     '    </body>',
                     '  </body>']
            tendons.append('<fixed name="%s_tendon"><joint joint="%s_proximal" coef="1"/><joint joint="%s_distal" coef="1"/></fixed>'
                           % (name, name, name))
            actuators.append('<position name="%s_close" tendon="%s_tendon" kp="%s" ctrlrange="0 3.2" forcerange="%s"/>'
                             % (name, name, _f(4.0 * torque), _f(-torque, torque)))
    body.append('</body>')
    equality = ['<weld name="hand_coupling" body1="hand_target" body2="hand" solref="%s 1"/>' % _f(weld_timeconst_s)]
    excludes = ['<exclude body1="hand" body2="finger_a"/>', '<exclude body1="hand" body2="finger_b"/>']
    if g["physics_fingers"] == "two_phalanx":
        excludes += ['<exclude body1="finger_a" body2="finger_a_distal"/>',
                     '<exclude body1="finger_b" body2="finger_b_distal"/>']
    return "\n".join(body), "\n".join(equality), "\n".join(actuators), "\n".join(tendons), "\n".join(excludes)


def closed_control(g):
    """Actuator targets that close the fingers fully (contacts and force limits stop them)."""
    if g["physics_fingers"] == "parallel":
        travel = max(g["max_opening_m"] - g.get("min_opening_m", 0.0), 0.0) / 2.0
        return [travel + 0.002, travel + 0.002]
    return [3.2, 3.2]


def finger_reach_note(g):
    """One line for the report: what the model is."""
    return "%s: %s fingers, opening %.0f mm, %.0f N per finger" % (
        g.get("name", "?"), g["physics_fingers"], 1000 * g["max_opening_m"], g["max_finger_force_n"])

