"""mr's inputs in Blender's conventions (for crosscheck.py and bench/cycles_compare.py)."""
import os

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2  # noqa: E402  (python3-opencv)
import numpy as np  # noqa: E402


def env_for_blender(src, dst, k=8):
    """mr's lat-long map (OpenEXR's convention: pixel centres on both edges,
    each pixel's radiance over the cell of the directions nearest to it,
    docs/conventions.md) resampled k times finer into Blender's
    equirectangular convention (pixel edges on the image's edges, z up), so
    that both renderers see the same radiance function to 1/k of a pixel.
    Blender's lookup is OpenEXR's turned a quarter about the up axis, with a
    half-pixel shift and a (W-1)/W stretch: all of it is in the resampled
    map, so blender_scene.py's env_rotation_deg is 0 with it."""
    env = cv2.imread(src, cv2.IMREAD_UNCHANGED)
    if env is None:
        raise SystemExit("mr_to_blender: cannot read %s" % src)
    env = env[:, :, :3]  # kept in OpenCV's BGR order: written back as read
    H, W = env.shape[:2]
    Wb, Hb = k * W, k * W // 2
    u = (np.arange(Wb) + 0.5) / Wb
    v = 1 - (np.arange(Hb) + 0.5) / Hb  # file row 0 is Blender's top (v = 1)
    phi = (0.5 - u) * 2 * np.pi  # Blender: u = 0.5 - atan2(y, x) / 2 pi
    theta = (v - 0.5) * np.pi  # elevation
    ct = np.cos(theta)[:, None]
    xb, yb, zb = ct * np.cos(phi)[None, :], ct * np.sin(phi)[None, :], np.sin(theta)[:, None] * np.ones((1, Wb))
    x, y, z = xb, zb, -yb  # Blender's world (x, y, z) is mr's (x, -z, y)
    lat, lon = np.arcsin(np.clip(y, -1, 1)), np.arctan2(x, z)
    px = np.clip(np.rint((0.5 - lon / (2 * np.pi)) * (W - 1)), 0, W - 1).astype(int)
    py = np.clip(np.rint((0.5 - lat / np.pi) * (H - 1)), 0, H - 1).astype(int)
    if not cv2.imwrite(dst, env[py, px].astype(np.float32)):
        raise SystemExit("mr_to_blender: cannot write %s" % dst)


def write_sky(path, W=256, H=129, sun=(80, 30), sun_peak=2000.0):
    """The cross-checks' lat-long sky: a gradient (blue above, brown below
    the horizon) and a Gaussian sun blob (sigma 2 px, `sun_peak` x the sky),
    so that half-pixel differences in a map convention stay below the noise."""
    import math
    env = np.zeros((H, W, 3), np.float32)
    for y in range(H):
        lat = math.pi / 2 - y * math.pi / (H - 1)
        c = (0.35, 0.5, 0.9) if lat >= 0 else (0.25, 0.22, 0.2)
        s = 0.6 + 0.4 * max(0.0, math.sin(lat))
        env[y, :, :] = [c[2] * s, c[1] * s, c[0] * s]  # BGR for OpenCV
    yy, xx = np.mgrid[0:H, 0:W]
    blob = np.exp(-((xx - sun[0]) ** 2 + (yy - sun[1]) ** 2) / (2 * 2.0 ** 2)).astype(np.float32) * sun_peak
    env += blob[:, :, None]
    cv2.imwrite(path, env)


def write_pinhole(path, w, h, fx):
    """A pinhole .cameramodel, principal point at the image's centre."""
    with open(path, "w") as f:
        f.write("{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [ %r, %r, %r, %r ], "
                "'extrinsics': [ 0, 0, 0, 0, 0, 0 ], 'imagersize': [ %d, %d ] }\n" % (fx, fx, (w - 1) / 2, (h - 1) / 2, w, h))


def quaternion(R):
    """(x, y, z, w) of a rotation matrix (Shepperd's method: the largest of
    the four squares first, so that no branch divides by a small number)."""
    import math
    t = R[0, 0] + R[1, 1] + R[2, 2]
    if t > 0:
        s = 2 * math.sqrt(t + 1)
        return (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, s / 4
    if R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2 * math.sqrt(1 + R[0, 0] - R[1, 1] - R[2, 2])
        return s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s, (R[2, 1] - R[1, 2]) / s
    if R[1, 1] > R[2, 2]:
        s = 2 * math.sqrt(1 + R[1, 1] - R[0, 0] - R[2, 2])
        return (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s, (R[0, 2] - R[2, 0]) / s
    s = 2 * math.sqrt(1 + R[2, 2] - R[0, 0] - R[1, 1])
    return (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4, (R[1, 0] - R[0, 1]) / s


def look_at(eye, target, trajectory_path):
    """mr's camera (x right, y down, z forward) at `eye` looking at `target`
    in mr's world (y up): its 4x4 world_from_cam, also written as a
    one-pose TUM trajectory at time 0."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z], axis=1)
    assert np.linalg.det(R) > 0
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, eye
    qx, qy, qz, qw = quaternion(R)
    with open(trajectory_path, "w") as f:
        f.write("0 %r %r %r %r %r %r %r\n" % (eye[0], eye[1], eye[2], qx, qy, qz, qw))
    return M
