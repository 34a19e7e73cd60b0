#!/usr/bin/python3
"""Independent check of mr-render's `pt` against Blender Cycles.

One scene (a sky with a sun blob in a lat-long map, a diffuse ground plane,
a diffuse sphere) rendered by both; they must agree within their noise, which
catches the places where renderers silently disagree: environment-map
orientation, pixel centres, BSDF normalisation.

Usage: crosscheck.py MR_BIN_DIR WORK_DIR [--spp N]
Exit 0: agree; 1: disagree; 77: skipped (no blender, or no numpy/cv2).
"""
import json
import math
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    bin_dir, work = sys.argv[1], sys.argv[2]
    spp = int(sys.argv[sys.argv.index("--spp") + 1]) if "--spp" in sys.argv else 128
    blender = shutil.which("blender")
    if not blender:
        print("SKIP: blender is not installed (apt-get install blender to run this cross-check)")
        return 77
    try:
        os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
        import cv2
        import numpy as np
    except ImportError:
        print("SKIP: /usr/bin/python3 lacks numpy or cv2 (python3-opencv)")
        return 77
    os.makedirs(work, exist_ok=True)

    # The environment: a sky gradient and a sun blob (Gaussian, sigma 2 px,
    # peak 2000 x the sky) so that half-pixel differences in the map's
    # convention stay below the noise.
    sys.path.insert(0, HERE)
    from mr_to_blender import env_for_blender, look_at, write_pinhole, write_sky
    env_path = os.path.join(work, "env.exr")
    write_sky(env_path)

    # Meshes as OBJ, y up (Blender's importer maps them to z up).
    with open(os.path.join(work, "plane.obj"), "w") as f:
        f.write("v -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\nf 1 3 2\nf 1 4 3\n")
    n = 32
    with open(os.path.join(work, "sphere.obj"), "w") as f:
        for i in range(n + 1):
            for j in range(2 * n + 1):
                th, ph = math.pi * i / n, math.pi * j / n
                f.write("v %.9f %.9f %.9f\n" % (0.3 * math.sin(th) * math.cos(ph), 0.3 + 0.3 * math.cos(th),
                                                 0.3 * math.sin(th) * math.sin(ph)))
        row = 2 * n + 1
        for i in range(n):
            for j in range(2 * n):
                a, b = i * row + j + 1, (i + 1) * row + j + 1
                if i > 0:
                    f.write("f %d %d %d\n" % (a, a + 1, b))
                if i < n - 1:
                    f.write("f %d %d %d\n" % (a + 1, b + 1, b))

    # Camera: pinhole, 96x72, looking at the sphere from above and in front.
    w, h, fx = 96, 72, 90.0
    write_pinhole(os.path.join(work, "camera.cameramodel"), w, h, fx)
    M = look_at([0.3, 1.2, -1.6], [0.0, 0.3, 0.0], os.path.join(work, "trajectory.txt"))

    max_depth = 4
    scene = {"version": 1, "camera": {"model": "camera.cameramodel", "poses": {"format": "tum", "path": "trajectory.txt"}},
             "lighting": {"environment": "env.exr"},
             "real": {"mesh": "plane.obj", "material": {"albedo": [0.5, 0.5, 0.5]}},
             "virtual": [{"name": "sphere", "mesh": "sphere.obj", "material": {"albedo": [0.8, 0.6, 0.4]}}],
             "render": {"method": "pt", "spp": spp, "max_depth": max_depth, "seed": 3},
             "output": {"dir": "mr", "png": True}}
    json.dump(scene, open(os.path.join(work, "scene.json"), "w"), indent=2)
    subprocess.run([os.path.join(bin_dir, "mr-render"), os.path.join(work, "scene.json"), "-q"], check=True)
    scene["render"]["seed"] = 4
    scene["output"]["dir"] = "mr2"
    json.dump(scene, open(os.path.join(work, "scene2.json"), "w"), indent=2)
    subprocess.run([os.path.join(bin_dir, "mr-render"), os.path.join(work, "scene2.json"), "-q"], check=True)

    # The map in Blender's convention (a quarter turn, half a pixel and a
    # (W-1)/W stretch from OpenEXR's; docs/benchmarks.md "Cross-check").
    env_blender = os.path.join(work, "env-blender.exr")
    env_for_blender(env_path, env_blender)
    spec = {"meshes": [{"name": "plane", "path": os.path.join(work, "plane.obj"), "albedo": [0.5, 0.5, 0.5]},
                       {"name": "sphere", "role": "virtual", "path": os.path.join(work, "sphere.obj"), "albedo": [0.8, 0.6, 0.4]}],
            "environment": env_blender, "env_rotation_deg": 0.0,
            "camera": {"width": w, "height": h, "fx": fx, "fy": fx, "cx": (w - 1) / 2, "cy": (h - 1) / 2},
            "world_from_cam": M.tolist(), "spp": spp, "max_depth": max_depth}
    json.dump(spec, open(os.path.join(work, "blender.json"), "w"), indent=2)
    cycles = os.path.join(work, "cycles.exr")
    subprocess.run([blender, "-b", "--factory-startup", "-noaudio", "-P", os.path.join(HERE, "blender_scene.py"), "--",
                    os.path.join(work, "blender.json"), cycles], check=True, stdout=subprocess.DEVNULL)
    if not os.path.exists(cycles):
        print("FAIL: blender wrote no image (its Python script failed; run it by hand to see why)")
        return 1

    out = subprocess.run([os.path.join(bin_dir, "mr-eval"), "compare", os.path.join(work, "mr", "00000.exr"), cycles,
                          "--report", os.path.join(work, "vs-cycles.json"), "-q"], check=True, capture_output=True, text=True)
    noise = subprocess.run([os.path.join(bin_dir, "mr-eval"), "compare", os.path.join(work, "mr", "00000.exr"),
                            os.path.join(work, "mr2", "00000.exr"), "--report", os.path.join(work, "vs-mr.json"), "-q"],
                           check=True, capture_output=True, text=True)
    a = json.load(open(os.path.join(work, "vs-cycles.json")))["metrics"]
    b = json.load(open(os.path.join(work, "vs-mr.json")))["metrics"]
    c = cv2.imread(cycles, cv2.IMREAD_UNCHANGED)[:, :, :3].astype(np.float64)
    mean_cycles = float(c.mean())
    print("mr vs Cycles: relMSE %.4g, RMSE %.4g; mr vs mr (another seed): relMSE %.4g, RMSE %.4g; Cycles mean %.4g"
          % (a["relmse"], a["rmse"], b["relmse"], b["rmse"], mean_cycles))
    # Two independent estimates of the same image differ by twice the
    # per-image variance; mr vs Cycles should too.  Allow 2x that (3x the
    # relMSE of two mr runs would already flag a 15% bias in bright regions).
    ok = a["relmse"] < 2.0 * b["relmse"]
    print("AGREE" if ok else "DISAGREE")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
