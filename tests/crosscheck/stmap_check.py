"""mr-export's ST-maps against mrcal's own reprojection (issue 42): a real
fish-eye (the 24 photographs of shared/data/fisheye-mono-ros, calibrated by
mr-calibrate as OPENCV8) and a synthetic OPENCV8 lens of strong barrel
distortion.
  - The undistort map, read back as pixels, equals
    mrcal.image_transformation_map(lens, pinhole) (what mrcal-reproject-image
    applies) where both map: max difference under 1e-3 px (the maps are
    float32: 6e-8 of 800 px is 5e-5 px).
  - A board photograph remapped through the undistort map and back through
    the redistort map returns within the interpolation error: its error
    against the photograph at most 1.05 x that of the same round trip through
    mrcal's two maps, where every map is valid.
  - The fish-eye past the widest angle (70 degrees): its rays beyond are
    unmapped (alpha 0) in the redistort map and nowhere else.
Skips (77) the fish-eye where shared data is absent; the synthetic lens
always runs.
  /usr/bin/python3 stmap_check.py BIN_DIR WORK_DIR SHARED_DATA
"""
import glob
import os
import subprocess
import sys

os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
try:
    import cv2  # noqa: E402
    import mrcal  # noqa: E402
    import numpy as np  # noqa: E402
except ImportError as e:
    print("SKIP: /usr/bin/python3 lacks %s (python3-mrcal, python3-opencv)" % e.name)
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.dirname(os.path.dirname(HERE))


def read_map(path):
    m = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if m is None:
        raise SystemExit("stmap_check: cannot read %s" % path)
    b, g, r, a = [m[..., k].astype(np.float64) for k in range(4)]  # OpenCV's BGRA
    return r, g, a  # s, t, alpha


def st_to_pixels(s, t, w, h):
    # (s, t) = ((x + 0.5) / w, 1 - (y + 0.5) / h), mrcal's pixels (x, y).
    return s * w - 0.5, (1 - t) * h - 0.5


def check_lens(bin_dir, work, model_path, photo, max_angle, tag):
    failures = []
    out = os.path.join(work, tag + "-pinhole.cameramodel")
    subprocess.run([os.path.join(bin_dir, "mr-export"), model_path, "--out", out, "--stmap-max-angle", str(max_angle),
                    "-q"], check=True, capture_output=True)
    lens, pinhole = mrcal.cameramodel(model_path), mrcal.cameramodel(out)
    w, h = lens.imagersize()
    W, H = pinhole.imagersize()
    s, t, a = read_map(os.path.join(work, tag + "-pinhole-undistort.exr"))
    if s.shape != (H, W):
        return ["%s: the undistort map is %s, the pinhole %dx%d" % (tag, s.shape, W, H)]
    x, y = st_to_pixels(s, t, w, h)
    ref = mrcal.image_transformation_map(lens, pinhole, intrinsics_only=True)
    valid = (a > 0) & np.isfinite(ref).all(axis=2) & (ref[..., 0] >= -0.5) & (ref[..., 0] <= w - 0.5) \
        & (ref[..., 1] >= -0.5) & (ref[..., 1] <= h - 0.5)
    err = np.maximum(np.abs(x - ref[..., 0]), np.abs(y - ref[..., 1]))[valid]
    print("%s: undistort map against mrcal.image_transformation_map over %d pixels: max %.2e px, %d pixels mapped "
          "by one only" % (tag, valid.sum(), err.max(), ((a > 0) != valid).sum()))
    if not err.max() < 1e-3:
        failures.append("%s: the undistort map differs from mrcal's by %.3g px" % (tag, err.max()))
    # Mapped by one and not the other: allowed only within a pixel of the lens's border.
    one_only = (a > 0) != valid
    border = (ref[..., 0] < 0.5) | (ref[..., 0] > w - 1.5) | (ref[..., 1] < 0.5) | (ref[..., 1] > h - 1.5)
    if (one_only & ~border & np.isfinite(ref).all(axis=2)).sum() > 0:
        failures.append("%s: %d pixels inside the lens's image are mapped by one map only"
                        % (tag, (one_only & ~border).sum()))
    # The round trip of a photograph.
    img = cv2.imread(photo, cv2.IMREAD_GRAYSCALE).astype(np.float32)
    rs, rt, ra = read_map(os.path.join(work, tag + "-pinhole-redistort.exr"))
    rx, ry = st_to_pixels(rs, rt, W, H)
    und = cv2.remap(img, x.astype(np.float32), y.astype(np.float32), cv2.INTER_CUBIC)
    back = cv2.remap(und, rx.astype(np.float32), ry.astype(np.float32), cv2.INTER_CUBIC)
    ref_back_map = mrcal.image_transformation_map(pinhole, lens, intrinsics_only=True)
    und_m = cv2.remap(img, ref[..., 0].astype(np.float32), ref[..., 1].astype(np.float32), cv2.INTER_CUBIC)
    back_m = cv2.remap(und_m, ref_back_map[..., 0].astype(np.float32), ref_back_map[..., 1].astype(np.float32),
                       cv2.INTER_CUBIC)
    # Where every map is valid, two pixels in from where any is not.
    ok = (ra > 0) & np.isfinite(ref_back_map).all(axis=2)
    ok = cv2.erode(ok.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    ok &= cv2.erode((cv2.remap((a > 0).astype(np.float32), rx.astype(np.float32), ry.astype(np.float32),
                               cv2.INTER_NEAREST) > 0).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    e_mr, e_mrcal = np.abs(back - img)[ok].mean(), np.abs(back_m - img)[ok].mean()
    print("%s: a photograph through both maps and back: mean error %.3f grey levels (through mrcal's maps %.3f) "
          "over %d pixels; %d lens pixels beyond %g degrees unmapped" % (tag, e_mr, e_mrcal, ok.sum(),
                                                                        (ra == 0).sum(), max_angle))
    if not e_mr <= 1.05 * e_mrcal + 1e-3:
        failures.append("%s: the round trip's error %.3f exceeds mrcal's %.3f" % (tag, e_mr, e_mrcal))
    # Unmapped only beyond the widest angle.
    v = mrcal.unproject(np.stack(np.meshgrid(np.arange(w), np.arange(h)), axis=-1).astype(float), *lens.intrinsics(),
                        normalize=True)
    beyond = v[..., 2] < np.cos(np.radians(max_angle)) - 1e-6
    inside = v[..., 2] > np.cos(np.radians(max_angle)) + 1e-6
    if (ra[inside] == 0).sum() or (ra[beyond] > 0).sum():
        failures.append("%s: %d pixels within %g degrees unmapped, %d beyond mapped" %
                        (tag, (ra[inside] == 0).sum(), max_angle, (ra[beyond] > 0).sum()))
    return failures


def main():
    bin_dir, work, shared = sys.argv[1], sys.argv[2], sys.argv[3]
    os.makedirs(work, exist_ok=True)
    failures = []
    # A synthetic lens: OPENCV8 with strong barrel distortion, and a
    # chessboard drawn in it (sharp edges: the hardest case for interpolation).
    synth = os.path.join(work, "barrel.cameramodel")
    mrcal.cameramodel(intrinsics=("LENSMODEL_OPENCV8", np.array([400., 410., 330.2, 241.7, -0.3, 0.1, 0.001, -0.002,
                                                                    0, 0.05, 0.02, 0])),
                      imagersize=(640, 480)).write(synth)
    yy, xx = np.indices((480, 640))
    board = (((xx // 40) + (yy // 40)) % 2 * 200 + 30).astype(np.uint8)
    photo = os.path.join(work, "barrel-board.png")
    cv2.imwrite(photo, board)
    failures += check_lens(bin_dir, work, synth, photo, 80, "barrel")
    photos = sorted(glob.glob(os.path.join(shared, "fisheye-mono-ros", "calibrationdata", "*.png")))
    if not photos:
        print("SKIP (the fish-eye): %s/fisheye-mono-ros is absent" % shared)
    else:
        fish = os.path.join(work, "fisheye.cameramodel")
        subprocess.run([os.path.join(bin_dir, "mr-calibrate"), "camera", "--board",
                        os.path.join(SRC, "calib", "boards", "chessboard-8x6.json"), "--out", fish, "-q"]
                       + photos[::2], check=True, capture_output=True)
        failures += check_lens(bin_dir, work, fish, photos[1], 70, "fisheye")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
