"""Forward kinematics straight from a URDF's joint origins and axes (numpy only), so the
tests check the C++ KDL chain against an independent reading of the same robot file."""
import xml.etree.ElementTree as ET

import numpy as np


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def axis_angle(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def homogeneous(rotation, translation):
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


class UrdfChain:
    def __init__(self, urdf_path, base="base_link", tip="grasp_frame"):
        root = ET.parse(urdf_path).getroot()
        by_child = {}
        for joint in root.findall("joint"):
            by_child[joint.find("child").get("link")] = joint
        chain = []
        link = tip
        while link != base:
            if link not in by_child:
                raise ValueError("no joint chain from %s to %s" % (base, tip))
            joint = by_child[link]
            chain.append(joint)
            link = joint.find("parent").get("link")
        self.joints = []
        for joint in reversed(chain):
            origin = joint.find("origin")
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            axis_el = joint.find("axis")
            axis = [float(v) for v in (axis_el.get("xyz") if axis_el is not None else "1 0 0").split()]
            limit = joint.find("limit")
            # A continuous joint's <limit> has no position bounds: it turns without end.
            bound = "inf" if joint.get("type") == "continuous" else None
            self.joints.append({
                "name": joint.get("name"), "type": joint.get("type"),
                "origin": homogeneous(rpy_matrix(*rpy), xyz), "axis": axis,
                "lower": float(limit.get("lower", "-" + bound if bound else None)) if limit is not None else None,
                "upper": float(limit.get("upper", bound)) if limit is not None else None,
                "velocity": float(limit.get("velocity")) if limit is not None else None})
        self.moving = [j for j in self.joints if j["type"] in ("revolute", "continuous", "prismatic")]
        self.names = [j["name"] for j in self.moving]

    def fk(self, q):
        """4x4 pose of the tip in the base frame for the moving joints' values q."""
        t = np.eye(4)
        i = 0
        for joint in self.joints:
            t = t @ joint["origin"]
            if joint["type"] in ("revolute", "continuous"):
                t = t @ homogeneous(axis_angle(joint["axis"], q[i]), [0, 0, 0])
                i += 1
            elif joint["type"] == "prismatic":
                t = t @ homogeneous(np.eye(3), np.asarray(joint["axis"]) * q[i])
                i += 1
        return t
