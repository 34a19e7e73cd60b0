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
