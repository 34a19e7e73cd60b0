#!/usr/bin/python3
"""Registration in pixels on an independent capture (issue 40): Blender
Cycles renders an RGB-D recording of bench/room_capture.py's room (a
chequered floor, two walls, a ceiling, counters, a lamp panel and the sky
through the open sides) along a known camera path, and the whole chain runs
on it through mr-pipeline, as a user's RGB-D video would:

  truth     the room's true meshes and albedos, the exact poses: what the
            measurement reads when nothing is misregistered (the renderers'
            differences and Cycles' noise: the floor);
  fused     mr-fuse along the exact poses (the reconstruction's own error);
  tracked   mr-fuse tracking the depth (no poses given; started at the
            recording's first pose, so that its world is the truth's), the
            video's poses are the fused trajectory (the colour is the depth
            camera's: an RGB-D sensor registered in itself);
  colmap    tracked, and the video registered by COLMAP (sequential
            matching) and aligned to the fused trajectory (a separate colour
            camera, as examples/real/run.sh; --matcher exhaustive).

Each case: mr-eval plate's registration in pixels (mean over the fitted
frames and the worst frame) before and after the pose refinement
(video.refine_poses), the poses' error against the exact ones before and
after, and the bunny's swim (pt at 4 spp; the plate's flow at its contact
points on the chequered floor).  The lamp is given as the true area light
and the sky as the true map, so that light plays no part in the figures.

Usage: bench/registration_blender.py BIN_DIR OUT_DIR [--frames N] [--spp N] [--threads N] [--cases ...]
Writes OUT_DIR/registration-blender.csv and prints a table (docs/benchmarks.md,
"Registration on an independent capture").
"""
import argparse
import csv
import json
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cycles_compare as cc  # noqa: E402
import room_capture as rc  # noqa: E402
import room_rgbd  # noqa: E402
from cycles_compare import np  # noqa: E402

CASES = ("truth", "fused", "tracked", "colmap")


def path_poses(frames):
    """One continuous sweep, as a hand-held recording: from the open corner
    along the room towards the left wall, the view turning from the back wall
    to the left wall (90 degrees) and nodding between the floor and the
    counters' tops.  4 cm and 1.5 degrees a frame at 60 frames."""
    poses = []
    for i in range(frames):
        t = i / max(1, frames - 1)
        eye = np.array([1.5 - 2.2 * t, 1.35 + 0.1 * math.sin(2 * math.pi * t), -1.5 + 0.5 * t])
        a = math.radians(80 + 90 * t)
        target = eye + 2.5 * np.array([math.cos(a), 0.0, math.sin(a)])
        target[1] = 0.55 + 0.3 * math.sin(2 * math.pi * t)
        poses.append(rc.look_at(eye, target))
    return poses


def load_tum(path):
    out = {}
    for line in open(path):
        if line.strip() and not line.startswith("#"):
            v = [float(x) for x in line.split()]
            out[int(round(v[0]))] = v[1:]
    return out


def quat_to_R(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def pose_error(path, truth):
    """Mean rotation (degrees) and centre (mm) error of a TUM file's poses against the truth's, by frame number."""
    est = load_tum(path)
    deg, mm = [], []
    for k, p in est.items():
        if k not in truth:
            continue
        d = quat_to_R(truth[k][3:7]).T @ quat_to_R(p[3:7])
        deg.append(math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(d) - 1) / 2)))))
        mm.append(1000 * np.linalg.norm(np.array(p[:3]) - np.array(truth[k][:3])))
    return (float(np.mean(deg)), float(np.mean(mm))) if deg else (float("nan"), float("nan"))


def pipeline(case, rec, work, parts, lights, env, mesh, bunny_m, stride, matcher):
    """mr-pipeline's file for one case."""
    gt = os.path.join(rec, "groundtruth.txt")
    p = {"version": 1, "comment": "bench/registration_blender.py: " + case, "work": "work",
         "camera": {"model": os.path.join(rec, "camera.cameramodel")},
         "lighting": {"environment": env, "lights": lights},
         "video": {"frames": os.path.join(rec, "rgb", "%05d.png"), "frames_transfer": "srgb",
                   "gains": {"options": {"spp": 16, "stride": stride}}, "refine_poses": True},
         "virtual": [{"name": "bunny", "mesh": mesh, "material": {"albedo": [0.8, 0.7, 0.6]},
                      "transform": {"matrix": [v for r in bunny_m for v in r]}}],
         "render": {"method": "pt", "spp": 4, "seed": 1}}
    fuse = {"layout": "plain", "voxel": 0.02, "max-depth": 7, "albedo-rays": 64, "albedo-stride": 2,
            "camera-scale": room_rgbd.CAMERA_SCALE}
    if case == "truth":
        p["room"] = {"real": [{"mesh": path, "material": {"albedo": alb}} for _, path, alb in parts]}
        p["video"]["poses"] = {"tum": gt}
    elif case == "fused":
        p["room"] = {"rgbd": rec, "options": dict(fuse, poses=gt)}
        p["video"]["poses"] = {"tum": gt}
    else:
        p["room"] = {"rgbd": rec, "options": dict(fuse, **{"first-pose": "reference"})}
        p["video"]["poses"] = {"fuse": True} if case == "tracked" else {"register": {"matcher": matcher}}
    d = os.path.join(work, case)
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, "pipeline.json")
    json.dump(p, open(path, "w"), indent=1)
    return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--frames", type=int, default=60, help="frames in the recording")
    ap.add_argument("--spp", type=int, default=32, help="Cycles' samples per pixel for the recording")
    ap.add_argument("--stride", type=int, default=4, help="mr-eval plate fits and refines every Nth frame")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--matcher", default="sequential", help="COLMAP's matcher for the colmap case")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    ap.add_argument("--mesh", default=os.path.join(HERE, "..", "..", "shared", "data", "meshes", "bun_zipper_res2.ply"))
    a = ap.parse_args()
    bin_dir, work = os.path.abspath(a.bin_dir), os.path.abspath(a.out_dir)
    mesh = os.path.abspath(a.mesh)
    if not os.path.isfile(mesh):
        raise SystemExit("registration_blender: no bunny mesh at %s (--mesh)" % mesh)
    os.makedirs(work, exist_ok=True)
    spec, parts, bunny_m = rc.room_spec(work, mesh)
    rec = os.path.join(work, "rgbd%d" % a.frames)
    t0 = time.perf_counter()
    room_rgbd.record(rec, spec, path_poses(a.frames), a.spp, a.threads)
    print("recording in %.0f s" % (time.perf_counter() - t0), flush=True)
    lights = os.path.join(work, "lamp.json")  # the lamp as it is: 0.5 m square, 1 mm under the ceiling, facing down
    json.dump({"version": 1, "lights": [{"type": "area", "name": "lamp", "position": [0.3, 2.499, 0.4],
                                         "direction": [0, -1, 0], "radiance": [rc.LAMP_RADIANCE] * 3,
                                         "shape": "rect", "width": 0.5, "height": 0.5}]}, open(lights, "w"), indent=1)
    env = os.path.join(work, "sky.exr")
    truth = load_tum(os.path.join(rec, "groundtruth.txt"))
    rows = []
    for case in a.cases:
        pj = pipeline(case, rec, work, parts, lights, env, mesh, bunny_m, a.stride, a.matcher)
        w = os.path.join(os.path.dirname(pj), "work")
        t = time.perf_counter()
        run = cc.subprocess.run([os.path.join(bin_dir, "mr-pipeline"), pj, "--report",
                                 os.path.join(os.path.dirname(pj), "report.json"), "--threads", str(a.threads), "-q"],
                                stderr=cc.subprocess.PIPE, text=True)
        seconds = time.perf_counter() - t
        if run.returncode != 0:  # a chain that fails is a result too: its message goes in the table
            why = [line.strip() for line in run.stderr.splitlines() if "error:" in line][-1:]
            print("  %-8s failed: %s" % (case, why[0] if why else run.stderr.strip()), flush=True)
            rows.append({"case": case, "failed": why[0] if why else "see " + pj, "seconds": round(seconds, 1)})
            continue
        m = json.load(open(os.path.join(w, "reports", "radiometry.json")))["metrics"]
        g, pr = m.get("registration", {}), m.get("pose_refinement", {})
        poses = {"truth": os.path.join(rec, "groundtruth.txt"), "fused": os.path.join(rec, "groundtruth.txt"),
                 "tracked": os.path.join(w, "room", "trajectory.txt"),
                 "colmap": os.path.join(w, "video", "poses.txt")}[case]
        refined = os.path.join(w, "radiometry", "poses.tum")
        swim = json.load(open(os.path.join(w, "reports", "render.json")))["metrics"].get("swim", {})
        s = list(swim.values())[0] if swim else {}
        before = pose_error(poses, truth)
        after = pose_error(refined, truth) if os.path.isfile(refined) else (float("nan"), float("nan"))
        row = {"case": case, "registration_px": g.get("mean_px", float("nan")),
               "worst_px": g.get("worst_mean_px", float("nan")), "frames_measured": g.get("frames_measured", 0),
               "after_px": pr.get("mean_px_after", float("nan")), "frames_refined": pr.get("frames_refined", 0),
               "rot_err_deg": before[0], "trans_err_mm": before[1],
               "rot_err_after_deg": after[0], "trans_err_after_mm": after[1],
               "swim_rms_px": s.get("rms_px", float("nan")), "swim_max_px": s.get("max_px", float("nan")),
               "relmse": m.get("relmse", float("nan")), "seconds": round(seconds, 1)}
        rows.append(row)
        print("  %-8s registration %.2f px (worst %.2f, %d frames) after %.2f px; poses %.3f deg %.1f mm -> "
              "%.3f deg %.1f mm; swim %.2f px RMS; %.0f s" % (case, row["registration_px"], row["worst_px"],
                                                              row["frames_measured"], row["after_px"],
                                                              row["rot_err_deg"], row["trans_err_mm"],
                                                              row["rot_err_after_deg"], row["trans_err_after_mm"],
                                                              row["swim_rms_px"], seconds), flush=True)
    with open(os.path.join(work, "registration-blender.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        wr.writeheader()
        wr.writerows(rows)
    print("\n| case | registration (worst) | after refinement | pose error | after | swim RMS (max) | run |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        if "failed" in r:
            print("| %s | failed: %s | | | | | %.0f s |" % (r["case"], r["failed"], r["seconds"]))
            continue
        print("| %s | %.2f px (%.2f) | %.2f px (%d frames) | %.3f°, %.1f mm | %.3f°, %.1f mm | %.2f (%.2f) px | %.0f s |"
              % (r["case"], r["registration_px"], r["worst_px"], r["after_px"], r["frames_refined"], r["rot_err_deg"],
                 r["trans_err_mm"], r["rot_err_after_deg"], r["trans_err_after_mm"], r["swim_rms_px"],
                 r["swim_max_px"], r["seconds"]))


if __name__ == "__main__":
    sys.exit(main())
