#!/usr/bin/python3
"""The de-lit albedo's scale (issue 39, item 6) on bench/room_capture.py's
room: Cycles renders an RGB-D recording of it (--frames, 320 x 240, the
colour as a camera writes it: linear radiance times CAMERA_SCALE, sRGB,
8-bit, the lamp clipped; the depth from Cycles' depth pass, 16-bit mm),
mr-fuse fuses it along the true poses and de-lights the albedo with the
lights and the map mr-lights made from the probe at the object
(room_capture's OUT_DIR/room0-*; --env and --lights choose others), and the fused albedo is compared with the
true one per surface (the median over the vertices within 2 cm of it, away
from its edges).  Run bench/room_capture.py into OUT_DIR first.

Usage: bench/room_rgbd.py BIN_DIR OUT_DIR [--threads N] [--spp N]
"""
import argparse
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cycles_compare as cc  # noqa: E402
import room_capture as rc  # noqa: E402
from cycles_compare import cv2, np  # noqa: E402

CAMERA_SCALE = 0.8  # colour units per unit of radiance


def frame_poses(frames):
    """From the open corner, two sweeps across the room: one at the floor and
    counters, one at the walls' tops and the ceiling."""
    poses = []
    half = frames // 2
    for i in range(frames):
        high = i >= half
        t = (i - half if high else i) / max(1, (frames - half if high else half) - 1)
        eye = np.array([1.9 - 1.2 * t, 1.3 + (0.2 if high else 0.0), -1.7 + 0.6 * t])
        a = math.radians(200 - 160 * t)  # the view swings from the left wall past the back wall to the right
        target = np.array([eye[0] + 2.5 * math.cos(a), 2.3 if high else 0.5, eye[2] + 2.5 * abs(math.sin(a)) + 0.8])
        poses.append(rc.look_at(eye, target))
    return poses


def part_of(p, parts_truth):
    """The true albedo of the surface point p lies on (None: near an edge or on nothing known)."""
    x, y, z = p
    e = 0.02
    on = []
    if abs(y) < e and not (-2.5 <= x <= 0.6 and 1.4 <= z <= 2.0) and not (-2.5 <= x <= -1.9 and -1 <= z <= 1.4):
        fx, fz = (x + 2.5) / 0.5, (z + 2) / 0.5
        if min(fx % 1, 1 - fx % 1, fz % 1, 1 - fz % 1) > 0.1:
            on.append("floor-a" if (int(fx) + int(fz)) % 2 == 0 else "floor-b")
    if abs(z - 2) < e and y > 0.95:
        on.append("back-wall")
    if abs(x + 2.5) < e and y > 0.95:
        on.append("left-wall")
    if abs(y - 2.5) < e and not (-0.1 < x < 0.7 and 0.0 < z < 0.8):  # the lamp and its rim left out
        on.append("ceiling")
    if abs(y - 0.9) < e and -2.45 < x < 0.55 and 1.45 < z < 1.95:
        on.append("counters")
    return on[0] if len(on) == 1 else None


def read_ply_albedo(path):
    """mr-fuse's binary PLY: the vertices' positions and their de-lit albedo (albedo_r/g/b, unclamped)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    props, n, in_vertex = [], 0, False
    for line in data[:end].decode().splitlines():
        w = line.split()
        if w[:2] == ["element", "vertex"]:
            n, in_vertex = int(w[2]), True
        elif w[:1] == ["element"]:
            in_vertex = False
        elif w[:1] == ["property"] and in_vertex:
            props.append((w[2], {"float": "<f4", "uchar": "u1", "int": "<i4"}[w[1]]))
    v = np.frombuffer(data, dtype=np.dtype(props), count=n, offset=end)
    return (np.stack([v["x"], v["y"], v["z"]], axis=1).astype(float),
            np.stack([v["albedo_r"], v["albedo_g"], v["albedo_b"]], axis=1).astype(float))


def record(rec, spec, poses, spp, threads):
    """Cycles renders an RGB-D recording of the spec's room (no virtual
    objects) along world_from_cam poses into mr-fuse's plain layout: rgb/
    (linear radiance times CAMERA_SCALE, sRGB 8-bit, clipped at 1), depth/
    (Cycles' depth pass, 16-bit mm), camera.cameramodel and the true poses as
    poses.tum and groundtruth.txt (the recording's reference).  Frames
    already rendered are kept."""
    os.makedirs(os.path.join(rec, "rgb"), exist_ok=True)
    os.makedirs(os.path.join(rec, "depth"), exist_ok=True)
    cc.write_pinhole_cameramodel(os.path.join(rec, "camera.cameramodel"), rc.CAMERA)
    bl = cc.Blender(rec, threads)
    tum = []
    clipped = 0
    for i, pose in enumerate(poses):
        tum.append(rc.tum_line(pose).replace("0 ", "%d " % i, 1))
        png = os.path.join(rec, "rgb", "%05d.png" % i)
        if os.path.isfile(png):
            continue
        p, _, _ = bl.render(spec, "f%05d" % i, mode="real", spp=spp, seed=31 + i, world_from_cam=pose.tolist(),
                            depth=True)
        rgb, z = os.path.join(rec, "f%05d-rgb.exr" % i), os.path.join(rec, "f%05d-z.exr" % i)
        cc.run(["oiiotool", p, "--ch", "R=ViewLayer.Combined.R,G=ViewLayer.Combined.G,B=ViewLayer.Combined.B",
                "-o", rgb])
        cc.run(["oiiotool", p, "--ch", "Y=ViewLayer.Depth.Z", "-o", z])
        lin = cc.read_rgb(rgb) * CAMERA_SCALE
        codes = np.round(255 * np.where(np.clip(lin, 0, 1) <= 0.0031308, 12.92 * np.clip(lin, 0, 1),
                                        1.055 * np.power(np.clip(lin, 0, 1), 1 / 2.4) - 0.055)).astype(np.uint8)
        clipped += int((lin.max(axis=2) >= 1).sum())
        cv2.imwrite(png, codes[:, :, ::-1])
        depth = cv2.imread(z, cv2.IMREAD_UNCHANGED)
        depth = depth if depth.ndim == 2 else depth[:, :, 0]
        mm = np.where(np.isfinite(depth) & (depth < 60), np.round(depth * 1000), 0).astype(np.uint16)
        cv2.imwrite(os.path.join(rec, "depth", "%05d.png" % i), mm)
    for name in ("poses.tum", "groundtruth.txt"):
        with open(os.path.join(rec, name), "w") as f:
            f.writelines(tum)
    print("recording: %d frames (%d clipped colour pixels in the ones rendered now)" % (len(poses), clipped),
          flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spp", type=int, default=64, help="Cycles' samples per pixel for the recording")
    ap.add_argument("--frames", type=int, default=24, help="frames in the recording")
    ap.add_argument("--env", default="room0-residual.exr",
                    help="the map mr-fuse de-lights with (in OUT_DIR): room0-residual.exr (the sky alone), "
                         "room0-room.exr (all of it less the lights), infinite0-residual.exr")
    ap.add_argument("--lights", default="room0-lights.json", help="the lights mr-fuse de-lights with (in OUT_DIR)")
    ap.add_argument("--mesh", default=os.path.join(HERE, "..", "..", "shared", "data", "meshes", "bun_zipper_res2.ply"))
    a = ap.parse_args()
    bin_dir, work = os.path.abspath(a.bin_dir), os.path.abspath(a.out_dir)
    for f in (a.lights, a.env):
        if not os.path.isfile(os.path.join(work, f)):
            raise SystemExit("room_rgbd: no %s in %s: run bench/room_capture.py first" % (f, work))
    spec, parts, _ = rc.room_spec(work, a.mesh)
    rec = os.path.join(work, "rgbd%d" % a.frames)
    record(rec, spec, frame_poses(a.frames), a.spp, a.threads)
    fused = os.path.join(work, "fused%d" % a.frames)
    cc.run([os.path.join(bin_dir, "mr-fuse"), rec, "--layout", "plain", "--depth-scale", "1000", "--poses",
            os.path.join(rec, "poses.tum"), "--voxel", "0.02", "--max-depth", "7", "--albedo-stride", "1",
            "--lights", os.path.join(work, a.lights), "--env", os.path.join(work, a.env),
            "--camera-scale", str(CAMERA_SCALE), "--out", fused, "--report", fused + ".json", "-q",
            "--threads", str(a.threads)])
    P, C = read_ply_albedo(os.path.join(fused, "room.ply"))
    truth = {n: np.array(alb) for n, _, alb in parts}
    ratios = {}
    for p, c in zip(P, C):
        n = part_of(p, truth)
        if n:
            ratios.setdefault(n, []).append(c / truth[n])
    print("\n| surface | true albedo | vertices | fused albedo / true (median R, G, B) |")
    print("|---|---|---|---|")
    allr = []
    for n in truth:
        if n not in ratios:
            print("| %s | %s | 0 | - |" % (n, truth[n].tolist()))
            continue
        r = np.median(np.array(ratios[n]), axis=0)
        allr += ratios[n]
        print("| %s | %s | %d | %.3f, %.3f, %.3f |" % (n, truth[n].tolist(), len(ratios[n]), *r))
    rep = json.load(open(fused + ".json"))["metrics"]
    print("all: median %.3f over %d vertices; fuse: %s" % (float(np.median(np.array(allr))), len(allr),
                                                         {k: v for k, v in rep.items() if k.startswith("albedo")}))


if __name__ == "__main__":
    sys.exit(main())
