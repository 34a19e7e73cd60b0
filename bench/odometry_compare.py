#!/usr/bin/python3
"""mr-fuse's tracking beside Open3D's RGB-D odometry, same frames, same machine, same run.

Open3D (python3-open3d, 0.16): frame-to-frame RGB-D odometry (Steinbruecker et al. 2011 colour
term, and the hybrid colour + depth term of Park et al. 2017), each frame against the previous
one, chained; mr-fuse: KinectFusion's frame-to-model point-to-plane ICP (2 cm voxels, 10-5-4
iterations, no albedo pass).  Both start at the reference's first pose; ATE and RPE by mr-eval
traj against the recording's reference poses (7-Scenes: KinectFusion's own).  Time per frame:
Open3D's is the odometry call plus building its RGB-D images from decoded arrays (reading the
files is left out of it); mr-fuse's is its own per-frame pipeline (read, filter, track, fuse,
raycast).  Threads: as each runs by default on this machine (OpenMP and TBB: all cores).

Usage: bench/odometry_compare.py RECORDING OUT_DIR [BIN_DIR]   (RECORDING: a 7-Scenes folder)
Writes OUT/odometry.csv and prints it.
"""
import glob
import json
import os
import subprocess
import sys
import time

import numpy as np
import open3d as o3d
import cv2

rec, out = sys.argv[1], sys.argv[2]
bin_dir = sys.argv[3] if len(sys.argv) > 3 else "build/bin"
os.makedirs(out, exist_ok=True)
colours = sorted(glob.glob(os.path.join(rec, "frame-*.color.*")))
n = len(colours)
fx = fy = 585.0
cx, cy = 320.0, 240.0
if os.path.exists(os.path.join(rec, "camera-intrinsics.txt")):
    K = np.loadtxt(os.path.join(rec, "camera-intrinsics.txt"))
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
intr = o3d.camera.PinholeCameraIntrinsic(640, 480, fx, fy, cx, cy)
ref0 = np.loadtxt(colours[0].replace("color.jpg", "pose.txt").replace("color.png", "pose.txt"))
u, _, vt = np.linalg.svd(ref0[:3, :3])
ref0[:3, :3] = u @ vt  # 7-Scenes rotations are slightly non-orthonormal


def quat(R):
    q = np.empty(4)
    t = np.trace(R)
    if t > 0:
        s = 0.5 / np.sqrt(t + 1)
        q[:] = [(R[2, 1] - R[1, 2]) * s, (R[0, 2] - R[2, 0]) * s, (R[1, 0] - R[0, 1]) * s, 0.25 / s]
    else:
        i = np.argmax(np.diag(R))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * np.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
        q[i] = 0.25 * s
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
        q[3] = (R[k, j] - R[j, k]) / s
    return q


def write_tum(path, poses):
    with open(path, "w") as f:
        for i, P in enumerate(poses):
            f.write("%d %s %s\n" % (i, " ".join("%.9f" % v for v in P[:3, 3]), " ".join("%.9f" % v for v in quat(P[:3, :3]))))


frames = []
for c in colours:
    col = cv2.cvtColor(cv2.imread(c), cv2.COLOR_BGR2RGB)
    dep = cv2.imread(c.replace("color.jpg", "depth.png").replace("color.png", "depth.png"), cv2.IMREAD_UNCHANGED)
    dep = np.where(dep == 65535, 0, dep).astype(np.uint16)
    frames.append((col, dep))

rows = []
for name, jac in [("open3d-color", o3d.pipelines.odometry.RGBDOdometryJacobianFromColorTerm()),
                  ("open3d-hybrid", o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm())]:
    option = o3d.pipelines.odometry.OdometryOption()
    poses, failed = [ref0], 0
    prev = None
    t0 = time.perf_counter()
    for col, dep in frames:
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(col), o3d.geometry.Image(dep), depth_scale=1000.0, depth_trunc=4.0,
            convert_rgb_to_intensity=True)
        if prev is not None:
            ok, T, _ = o3d.pipelines.odometry.compute_rgbd_odometry(prev, rgbd, intr, np.eye(4), jac, option)
            if not ok:
                failed += 1
                T = np.eye(4)
            poses.append(poses[-1] @ np.linalg.inv(T))  # T: previous camera -> this camera
        prev = rgbd
    seconds = time.perf_counter() - t0
    write_tum(os.path.join(out, name + ".tum"), poses)
    rows.append((name, os.path.join(out, name + ".tum"), 1000 * seconds / (n - 1), failed))

# mr-fuse with and without loop closure; its time per frame includes the
# final fusing again of the output volume after loops closed.
for name, extra in (("mr-fuse-no-loops", ["--no-loop-closure"]), ("mr-fuse", [])):
    rep = os.path.join(out, name + ".json")
    subprocess.run([os.path.join(bin_dir, "mr-fuse"), rec, "--out", os.path.join(out, name), "--voxel", "0.02",
                    "--first-pose", "reference", "--no-albedo", "--report", rep, "-q"] + extra, check=True)
    m = json.load(open(rep))["metrics"]
    seconds = sum(f["seconds"] for f in m["frames"]) + m["summary"].get("final_refuse_seconds", 0)
    rows.append((name, os.path.join(out, name, "trajectory.txt"), 1000 * seconds / len(m["frames"]),
                 m["summary"]["lost"]))
    print("%s: %d keyframes, %d loop candidates, %d loops, %d frames fused again" % (
        name, m["summary"].get("keyframes", 0), m["summary"].get("loop_candidates", 0), m["summary"].get("loops", 0),
        m["summary"].get("refused_frames", 0)))

with open(os.path.join(out, "odometry.csv"), "w") as f:
    f.write("method,ate_m,rpe_m,rpe_deg,ms_per_frame,fps,failed\n")
    for name, traj, ms, failed in rows:
        tr = os.path.join(out, name + "-traj.json")
        subprocess.run([os.path.join(bin_dir, "mr-eval"), "traj", traj, rec, "--report", tr, "-q"], check=True,
                       stdout=subprocess.DEVNULL)
        e = json.load(open(tr))["metrics"]
        line = "%s,%.5f,%.5f,%.4f,%.1f,%.1f,%d" % (name, e["ate"]["rmse_m"], e["rpe"]["trans_rmse_m"],
                                                    e["rpe"]["rot_rmse_deg"], ms, 1000 / ms, failed)
        f.write(line + "\n")
        print(line)
