"""Hand-made PointCloud2 messages for the perception rostests (fields x y z rgb, float32).

Scenes are written in base_link coordinates and converted into the camera's optical frame,
which the test places 0.6 m above base_link looking straight down (optical z = base -z,
optical x = base x, optical y = base -y)."""
import numpy as np
from sensor_msgs.msg import PointCloud2, PointField

CAMERA_HEIGHT_M = 0.6
# tf of camera_rgb_optical_frame in base_link: translation and quaternion (x, y, z, w), a half
# turn about x.
CAMERA_TRANSLATION = (0.0, 0.0, CAMERA_HEIGHT_M)
CAMERA_ROTATION_XYZW = (1.0, 0.0, 0.0, 0.0)


def base_to_camera(points):
    """base_link (N, 3) -> optical frame: (x, -y, h - z)."""
    points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    return np.stack([points[:, 0], -points[:, 1], CAMERA_HEIGHT_M - points[:, 2]], axis=1)


def make_cloud(camera_points, frame_id='camera_rgb_optical_frame', stamp=None, width=None, height=1):
    """PointCloud2 with fields x y z rgb from (N, 3) camera-frame points (NaN/inf allowed)."""
    pts = np.asarray(camera_points, dtype=np.float32).reshape(-1, 3)
    n = pts.shape[0]
    data = np.zeros((n, 4), dtype=np.float32)
    data[:, :3] = pts
    msg = PointCloud2()
    msg.header.frame_id = frame_id
    if stamp is not None:
        msg.header.stamp = stamp
    msg.height = height
    msg.width = width if width is not None else (n // height if height else 0)
    msg.fields = [PointField(name=name, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                  for i, name in enumerate(('x', 'y', 'z', 'rgb'))]
    msg.is_bigendian = False
    msg.point_step = 16
    msg.row_step = 16 * msg.width
    msg.is_dense = bool(np.isfinite(pts).all())
    msg.data = data.tobytes()
    return msg


def grid(x0, x1, y0, y1, step):
    xs = np.arange(x0 + step / 2, x1, step)
    ys = np.arange(y0 + step / 2, y1, step)
    gx, gy = np.meshgrid(xs, ys)
    return gx.ravel(), gy.ravel()


def table(x0=0.3, x1=0.7, y0=-0.2, y1=0.2, z=0.0, step=0.005):
    gx, gy = grid(x0, x1, y0, y1, step)
    return np.stack([gx, gy, np.full_like(gx, z)], axis=1)


def box(cx, cy, size_x, size_y, size_z, z0=0.0, step=0.005):
    """Top and four sides of an axis-aligned box standing on z = z0."""
    faces = []
    gx, gy = grid(cx - size_x / 2, cx + size_x / 2, cy - size_y / 2, cy + size_y / 2, step)
    faces.append(np.stack([gx, gy, np.full_like(gx, z0 + size_z)], axis=1))
    gx, gz = grid(cx - size_x / 2, cx + size_x / 2, z0, z0 + size_z, step)
    for y in (cy - size_y / 2, cy + size_y / 2):
        faces.append(np.stack([gx, np.full_like(gx, y), gz], axis=1))
    gy, gz = grid(cy - size_y / 2, cy + size_y / 2, z0, z0 + size_z, step)
    for x in (cx - size_x / 2, cx + size_x / 2):
        faces.append(np.stack([np.full_like(gy, x), gy, gz], axis=1))
    return np.concatenate(faces)


def wall(x=0.5, y0=-0.2, y1=0.2, z0=0.0, z1=0.4, step=0.005):
    gy, gz = grid(y0, y1, z0, z1, step)
    return np.stack([np.full_like(gy, x), gy, gz], axis=1)
