#!/usr/bin/python3
"""The generated showcase asset under a real captured light, rendered by mr and
by Blender Cycles from the same files (issue 38).

Takes the scene examples/mirrorball/run.sh step 7 writes (OUT/scene-asset.json
in its output folder: the counter of the iPhone photograph, the mirror ball's
unwrapped map env.exr, the plate's pinhole, the showcase .glb on the counter)
and renders the local scene alone, without the photograph (so that neither
renderer's plate handling enters): the counter at a uniform albedo (the median
of the de-lit texture), the asset with its own materials, lit by the map.  mr
renders it with pt; Blender imports the .glb with its glTF importer and the
counter as an OBJ, and Cycles renders them.  Printed and written to
OUT_DIR/results.json: relMSE of mr against Cycles in the asset's region (mr's
mask), beside the two renderers' own noise (each against itself with another
seed), and each one's time.  The named differences of bench/asset_compare.py
apply (Principled v1's energy, docs/benchmarks.md).

Usage: bench/asset_plate_compare.py BIN_DIR MIRRORBALL_OUT OUT_DIR [--spp N]
"""
import json
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CROSS = os.path.join(HERE, "..", "tests", "crosscheck")
sys.path.insert(0, CROSS)
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"


def setup(default_spp):
    """The command line and the inputs' presence: (bin_dir, mirrorball_out,
    work, spp, blender), or an exit code (77: skipped, and why printed)."""
    bin_dir, mb, work = sys.argv[1], os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3])
    spp = int(sys.argv[sys.argv.index("--spp") + 1]) if "--spp" in sys.argv else default_spp
    blender = shutil.which("blender")
    if not blender:
        print("SKIP: blender is not installed")
        return 77
    if not os.path.exists(os.path.join(mb, "scene-asset.json")):
        print("SKIP: run examples/mirrorball/run.sh %s first" % mb)
        return 77
    os.makedirs(work, exist_ok=True)
    return bin_dir, mb, work, spp, blender


def showcase(mb):
    """What examples/mirrorball/run.sh step 7 wrote: its scene (src), the
    counter's median de-lit albedo (rho), the showcase entry, its placement
    M (4x4), the .glb, and the plate's pinhole (fx, fy, cx, cy, w, h)."""
    import ast

    import cv2
    import numpy as np
    src = json.load(open(os.path.join(mb, "scene-asset.json")))
    albedo = cv2.imread(os.path.join(mb, "counter-albedo.exr"), cv2.IMREAD_UNCHANGED)[:, :, ::-1]
    asset = [v for v in src["virtual"] if v["name"] == "showcase"][0]
    model = open(os.path.join(mb, src["camera"]["model"])).read()
    cm = ast.literal_eval(model[model.index("{"):])
    fx, fy, cx, cy = cm["intrinsics"]
    w, h = cm["imagersize"]
    return dict(src=src, rho=[float(x) for x in np.median(albedo.reshape(-1, 3), axis=0)], asset=asset,
                M=np.array(asset["transform"]["matrix"], float).reshape(4, 4), glb=os.path.join(mb, asset["mesh"]),
                fx=fx, fy=fy, cx=cx, cy=cy, w=w, h=h)


def main():
    s = setup(256)
    if isinstance(s, int):
        return s
    bin_dir, mb, work, spp, blender = s
    import numpy as np
    from mr_to_blender import env_for_blender
    from asset_compare import compare_in_region, render_cycles_pair
    sc = showcase(mb)
    src, rho, M, glb = sc["src"], sc["rho"], sc["M"], sc["glb"]
    fx, fy, cx, cy, w, h = (sc[k] for k in ("fx", "fy", "cx", "cy", "w", "h"))

    times = {}
    for seed, out in ((3, "mr"), (4, "mr2")):
        scene = {"version": 1,
                 "camera": {"model": os.path.join(mb, src["camera"]["model"]),
                            "poses": {"format": "tum", "path": os.path.join(mb, "poses.txt")}},
                 "lighting": {"environment": os.path.join(mb, "env.exr")},
                 "real": {"mesh": os.path.join(mb, "counter.obj"), "material": {"albedo": rho}},
                 "virtual": [{"name": "showcase", "mesh": glb, "transform": {"matrix": M.flatten().tolist()}}],
                 "render": {"method": "pt", "spp": spp, "max_depth": 8, "seed": seed},
                 "output": {"dir": out}}
        json.dump(scene, open(os.path.join(work, out + ".json"), "w"), indent=2)
        t0 = time.perf_counter()
        subprocess.run([os.path.join(bin_dir, "mr-render"), os.path.join(work, out + ".json"), "-q", "--threads", "2"],
                       check=True)
        times[out] = time.perf_counter() - t0

    env_blender = os.path.join(work, "env-blender.exr")
    env_for_blender(os.path.join(mb, "env.exr"), env_blender)
    render_cycles_pair(blender, work, {
        "meshes": [{"name": "counter", "path": os.path.join(mb, "counter.obj"), "albedo": rho},
                   {"name": "showcase", "role": "virtual", "path": glb, "world_from_object": M.tolist()}],
        "environment": env_blender, "env_rotation_deg": 0.0,
        "camera": {"width": w, "height": h, "fx": fx, "fy": fy, "cx": cx, "cy": cy},
        "world_from_cam": np.eye(4).tolist(), "spp": spp, "max_depth": 8, "threads": 2}, times)
    r = compare_in_region(bin_dir, work, spp, times, {"counter_albedo": rho})
    print("under the mirror ball's light, region relMSE at %d spp: mr vs Cycles %.4g; noise floor %.4g (mr vs mr %.4g, "
          "Cycles vs Cycles %.4g); wall time mr %.1f s, Cycles %.1f s" %
          (spp, r["mr_vs_cycles"], r["noise_floor"], r["mr_vs_mr"], r["cycles_vs_cycles"], r["mr_seconds"],
           r["cycles_seconds"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
