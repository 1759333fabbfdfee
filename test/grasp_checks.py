"""Independent geometric checks of a grasp against the object it was planned for.

Pure numpy, no ROS: the rostest node and offline tools share it. Conventions follow
DESIGN.md: the grasp frame has its origin at the centre of the closing region, X = approach,
Y = closing direction, Z = X x Y; the fingers straddle the origin along X.
"""
import numpy as np


def cloud_to_xyz(msg, finite_only=True):
    """(N, 3) float array from a sensor_msgs/PointCloud2 with float32 x, y, z fields, read with
    numpy (point_cloud2.read_points takes ~0.1 s per 10 k points in Python: a test reading big
    clouds that way lags the small messages it pairs them with)."""
    offsets = {f.name: f.offset for f in msg.fields}
    n = msg.width * msg.height
    raw = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(n, msg.point_step)
    xyz = np.empty((n, 3), dtype=np.float64)
    for i, name in enumerate("xyz"):
        xyz[:, i] = raw[:, offsets[name]:offsets[name] + 4].copy().view(np.float32).ravel()
    return xyz[np.isfinite(xyz).all(axis=1)] if finite_only else xyz


def quaternion_matrix(x, y, z, w):
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def to_grasp_frame(points, position, rotation):
    """Object points (N x 3, base frame) in grasp coordinates."""
    return (points - position) @ rotation


def in_box(local, lo, hi):
    return np.all((local >= lo) & (local <= hi), axis=1)


def closing_region_count(local, width_m, gripper, margin_m=0.005):
    """Object points between the fingertips: what the fingers will squeeze."""
    half = np.array([gripper["finger_depth_m"] / 2, width_m / 2 + margin_m, gripper["finger_width_m"] / 2])
    return int(np.count_nonzero(in_box(local, -half, half)))


def gripper_boxes(gripper, opening_m):
    """(lo, hi) boxes of both fingers at `opening_m` and the palm, grasp coordinates."""
    d = gripper["finger_depth_m"]
    t = gripper["finger_thickness_m"]
    w = gripper["finger_width_m"]
    palm = gripper.get("palm_thickness_m", 0.03)
    palm_half_width = gripper.get("palm_width_m", 0.0) / 2 or w
    y0 = opening_m / 2
    return [
        (np.array([-d / 2, y0, -w / 2]), np.array([d / 2, y0 + t, w / 2])),
        (np.array([-d / 2, -y0 - t, -w / 2]), np.array([d / 2, -y0, w / 2])),
        (np.array([-d / 2 - palm, -y0 - t, -palm_half_width]), np.array([-d / 2, y0 + t, palm_half_width])),
    ]


def points_in_gripper(local, gripper, opening_m):
    """Object points inside the open gripper's fingers or palm."""
    inside = np.zeros(len(local), dtype=bool)
    for lo, hi in gripper_boxes(gripper, opening_m):
        inside |= in_box(local, lo, hi)
    return int(np.count_nonzero(inside))


def box_samples(lo, hi, step_m=0.004):
    axes = [np.arange(lo[i], hi[i] + 1e-9, step_m) if hi[i] - lo[i] > step_m else np.array([(lo[i] + hi[i]) / 2])
            for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return grid


class CameraOcclusion:
    """Space hidden behind the seen object surface, as one camera saw it.

    A point is in the unseen part when it projects inside the object's image silhouette and
    lies farther from the camera than the object surface seen along that ray. Built from the
    object cloud itself, independently of the planners' own unseen-part construction.
    """

    def __init__(self, object_points_base, camera_position, camera_rotation, fx=570.3422, cx=319.5, cy=239.5,
                 bin_px=4):
        self.position = np.asarray(camera_position, dtype=float)
        self.rotation = np.asarray(camera_rotation, dtype=float)  # optical frame axes in base
        self.fx, self.cx, self.cy, self.bin = fx, cx, cy, bin_px
        u, v, z = self.project(object_points_base)
        self.depth = {}
        for key, depth in zip(zip(u, v), z):
            if depth < self.depth.get(key, np.inf):
                self.depth[key] = depth

    def project(self, points_base):
        cam = (np.asarray(points_base) - self.position) @ self.rotation
        z = cam[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.floor((self.fx * cam[:, 0] / z + self.cx) / self.bin).astype(int)
            v = np.floor((self.fx * cam[:, 1] / z + self.cy) / self.bin).astype(int)
        return u, v, z

    def hidden(self, points_base, margin_m=0.01):
        """Boolean mask of points behind the seen surface (beyond margin_m)."""
        u, v, z = self.project(points_base)
        mask = np.zeros(len(z), dtype=bool)
        for i, key in enumerate(zip(u, v)):
            surface = self.depth.get(key)
            if surface is not None and z[i] > surface + margin_m:
                mask[i] = True
        return mask


def gripper_in_unseen(position, rotation, gripper, opening_m, occlusions, margin_m=0.01):
    """Samples of the open gripper volume lying in the unseen part of every camera.

    With two cameras a point is unseen only if no camera saw through it, i.e. hidden in all.
    """
    samples = np.vstack([box_samples(lo, hi) for lo, hi in gripper_boxes(gripper, opening_m)])
    base = samples @ rotation.T + position
    hidden = np.ones(len(base), dtype=bool)
    for occlusion in occlusions:
        hidden &= occlusion.hidden(base, margin_m)
    return int(np.count_nonzero(hidden)), len(base)
