#!/usr/bin/python3
"""A glTF asset rendered by mr and by Blender Cycles from the same file (issue 38).

The asset: tests/data/assets/blender/blender.glb, written by Blender's own
glTF exporter: a cube with base-colour, metallic-roughness and normal
textures, a gold sphere of roughness 0.3 (smooth shading), and a glass slab
(transmission 1, ior 1.45).  mr reads it with its reader and renders it with
pt (render/pbr_bsdf.h, render/glass_bsdf.h); Blender reads it with its glTF
importer (Principled BSDF) and renders it with Cycles.  Same sky (a gradient
and a sun blob), ground plane, camera and pose in both.  --opaque: opaque.glb
(the cube and the sphere alone).

Printed and written to OUT/results.json: relMSE of mr against Cycles in the
asset's region (its coverage, from mr's mask layer), beside the two
renderers' own noise in that region (mr against mr with another seed, Cycles
against Cycles), and each one's render time.  Named differences the numbers
include: Blender's Principled BSDF (v1) adds its diffuse and specular lobes
without mr's albedo scaling, and with single-scattering GGX; Blender's
normal map node and its tangents (MikkTSpace) against mr's (docs/methods.md,
"Shading normals"); the slab is thin-walled for mr (the file has no
KHR_materials_volume: the glTF specification's thin wall, light passes
unbent) and a solid refracting box for Cycles (which has no thin walls).

--asset PATH: another asset (placed at the origin, raised by --lift Y metres);
tests/data/assets/khronos/BoxTextured.gltf is a public sample model written by
COLLADA2GLTF.

Usage: bench/asset_compare.py BIN_DIR OUT_DIR [--spp N] [--opaque | --asset PATH [--lift Y]]
"""
import json
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CROSS = os.path.join(HERE, "..", "tests", "crosscheck")
ASSETS = os.path.abspath(os.path.join(HERE, "..", "tests", "data", "assets", "blender"))
sys.path.insert(0, CROSS)
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"


def render_cycles_pair(blender, work, spec, times):
    """Cycles renders `spec` (tests/crosscheck/blender_scene.py's) twice, seeds
    5 and 6, into WORK/cycles.exr and cycles2.exr; their times into `times`."""
    for seed, out in ((5, "cycles"), (6, "cycles2")):
        json.dump(dict(spec, seed=seed), open(os.path.join(work, out + ".json"), "w"), indent=2)
        t0 = time.perf_counter()
        subprocess.run([blender, "-b", "--factory-startup", "-noaudio", "-P", os.path.join(CROSS, "blender_scene.py"), "--",
                        os.path.join(work, out + ".json"), os.path.join(work, out + ".exr")],
                       check=True, stdout=subprocess.DEVNULL)
        times[out] = time.perf_counter() - t0


def compare_in_region(bin_dir, work, spp, times, extra=None):
    """relMSE of WORK/mr/00000.exr against cycles.exr in the asset's region
    (mr's mask layer), beside each renderer against itself with another seed
    (mr2, cycles2); written to WORK/results.json and returned."""
    region = os.path.join(work, "region.exr")
    subprocess.run(["oiiotool", os.path.join(work, "mr", "00000.exr"), "--ch", "mask.Y", "--chnames", "Y", "-o", region],
                   check=True)

    def relmse(a, b):
        rep = os.path.join(work, "cmp.json")
        subprocess.run([os.path.join(bin_dir, "mr-eval"), "compare", a, b, "--region", region, "--report", rep, "-q"],
                       check=True, capture_output=True)
        return json.load(open(rep))["metrics"]["relmse"]

    mr1, mr2 = os.path.join(work, "mr", "00000.exr"), os.path.join(work, "mr2", "00000.exr")
    cy1, cy2 = os.path.join(work, "cycles.exr"), os.path.join(work, "cycles2.exr")
    r = dict(extra or {}, spp=spp, mr_vs_cycles=relmse(mr1, cy1), mr_vs_mr=relmse(mr1, mr2),
             cycles_vs_cycles=relmse(cy1, cy2), mr_seconds=times["mr"], cycles_seconds=times["cycles"])
    # Two independent renders of one image differ by the sum of their
    # variances: mr against Cycles is "within noise" below about
    # (mr_vs_mr + cycles_vs_cycles) / 2.
    r["noise_floor"] = (r["mr_vs_mr"] + r["cycles_vs_cycles"]) / 2
    json.dump(r, open(os.path.join(work, "results.json"), "w"), indent=2)
    return r


def main():
    bin_dir, work = sys.argv[1], sys.argv[2]
    spp = int(sys.argv[sys.argv.index("--spp") + 1]) if "--spp" in sys.argv else 256
    ASSET = os.path.join(ASSETS, "opaque.glb" if "--opaque" in sys.argv else "blender.glb")
    if "--asset" in sys.argv:
        ASSET = os.path.abspath(sys.argv[sys.argv.index("--asset") + 1])
    blender = shutil.which("blender")
    if not blender:
        print("SKIP: blender is not installed")
        return 77
    import cv2
    import numpy as np
    from mr_to_blender import env_for_blender, look_at, write_pinhole, write_sky
    os.makedirs(work, exist_ok=True)

    env_path = os.path.join(work, "env.exr")
    write_sky(env_path)
    with open(os.path.join(work, "plane.obj"), "w") as f:
        f.write("v -6 0 -6\nv 6 0 -6\nv 6 0 6\nv -6 0 6\nf 1 3 2\nf 1 4 3\n")
    w, h, fx = 240, 120, 200.0
    write_pinhole(os.path.join(work, "camera.cameramodel"), w, h, fx)
    if "--opaque" in sys.argv or "--asset" in sys.argv:
        M = look_at([1.0, 1.6, -2.8], [1.0, 0.4, 0.0], os.path.join(work, "trajectory.txt"))
    else:  # the slab at x = -2 too
        M = look_at([0.0, 1.8, -4.6], [0.0, 0.4, 0.0], os.path.join(work, "trajectory.txt"))
    place = np.eye(4)
    place[:3, 3] = [0.0, float(sys.argv[sys.argv.index("--lift") + 1]) if "--lift" in sys.argv else 0.0, 0.0]

    depth = 6
    times = {}
    for seed, out in ((3, "mr"), (4, "mr2")):
        scene = {"version": 1,
                 "camera": {"model": "camera.cameramodel", "poses": {"format": "tum", "path": "trajectory.txt"}},
                 "lighting": {"environment": "env.exr"},
                 "real": {"mesh": "plane.obj", "material": {"albedo": [0.5, 0.5, 0.5]}},
                 "virtual": [{"name": "asset", "mesh": ASSET, "transform": {"matrix": place.flatten().tolist()}}],
                 "render": {"method": "pt", "spp": spp, "max_depth": depth, "seed": seed},
                 "output": {"dir": out, "png": True}}
        json.dump(scene, open(os.path.join(work, out + ".json"), "w"), indent=2)
        t0 = time.perf_counter()
        subprocess.run([os.path.join(bin_dir, "mr-render"), os.path.join(work, out + ".json"), "-q", "--threads", "2",
                        "--report", os.path.join(work, out + "-report.json")], check=True)
        times[out] = time.perf_counter() - t0

    env_blender = os.path.join(work, "env-blender.exr")
    env_for_blender(env_path, env_blender)
    render_cycles_pair(blender, work, {
        "meshes": [{"name": "plane", "path": os.path.join(work, "plane.obj"), "albedo": [0.5, 0.5, 0.5]},
                   {"name": "asset", "role": "virtual", "path": ASSET, "world_from_object": place.tolist()}],
        "environment": env_blender, "env_rotation_deg": 0.0,
        "camera": {"width": w, "height": h, "fx": fx, "fy": fx, "cx": (w - 1) / 2, "cy": (h - 1) / 2},
        "world_from_cam": M.tolist(), "spp": spp, "max_depth": depth, "threads": 2}, times)
    r = compare_in_region(bin_dir, work, spp, times)
    print("region relMSE at %d spp: mr vs Cycles %.4g; noise floor %.4g (mr vs mr %.4g, Cycles vs Cycles %.4g); "
          "wall time mr %.1f s, Cycles %.1f s" % (spp, r["mr_vs_cycles"], r["noise_floor"], r["mr_vs_mr"],
                                                  r["cycles_vs_cycles"], r["mr_seconds"], r["cycles_seconds"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
