#!/usr/bin/python3
"""The showcase asset inserted into the real photograph, by mr and as a Blender
user would do it (issue 38): mr's differential composite against Cycles'
shadow-catcher composite over the same linear plate.

Takes the scene examples/mirrorball/run.sh step 7 writes (OUT/scene-asset.json:
the iPhone photograph of the granite counter, the mirror ball's map env.exr,
the showcase .glb on the counter) without the bunny, the counter at a uniform
albedo (the median of its de-lit texture, as bench/asset_plate_compare.py:
Blender's side takes one colour).  mr renders it with pt and composites
differentially (I_c + I_m - I_r outside the object).  Blender imports the .glb
with its glTF importer, the counter as a shadow catcher, and composites as its
manual says: the plate times the shadow-catcher pass, the objects' pass over
it (tests/crosscheck/blender_scene.py, mode "catcher"); the plate is mr's own
linear reading of the photograph (the EXR's photo layer), so that both start
from the same pixels.  Printed and written to OUT_DIR/results.json, each
beside the two renderers' own noise (each against itself with another seed):
relMSE in the asset's region (mr's mask; and in its parts: the steel and
the glass sphere's discs, the base the rest), in a 40-pixel ring around it (its
contact shadow) and beyond the ring (where only the light the asset sends to
the counter changes the plate); and OUT_DIR/side-by-side.png (mr left,
Cycles right, at the plate's exposure).

Usage: bench/asset_catcher_compare.py BIN_DIR MIRRORBALL_OUT OUT_DIR [--spp N] [--reuse]
(--reuse: compare the renders a previous run left in OUT_DIR)
"""
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "crosscheck"))
sys.path.insert(0, HERE)
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
from asset_plate_compare import setup, showcase  # noqa: E402


def main():
    s = setup(64)
    if isinstance(s, int):
        return s
    bin_dir, mb, work, spp, blender = s
    import cv2
    import numpy as np
    from asset_compare import render_cycles_pair
    from mr_to_blender import env_for_blender
    sc = showcase(mb)
    src, rho, asset, M, glb = sc["src"], sc["rho"], sc["asset"], sc["M"], sc["glb"]
    fx, fy, cx, cy, w, h = (sc[k] for k in ("fx", "fy", "cx", "cy", "w", "h"))

    times = {}
    for seed, out in ((3, "mr"), (4, "mr2")) if "--reuse" not in sys.argv else ():
        scene = dict(src)
        scene["camera"] = dict(src["camera"])
        for key in ("model", "frames", "response", "gains"):
            scene["camera"][key] = os.path.join(mb, src["camera"][key])
        scene["camera"]["poses"] = {"format": "tum", "path": os.path.join(mb, "poses.txt")}
        scene["lighting"] = {"environment": os.path.join(mb, "env.exr")}
        scene["real"] = {"mesh": os.path.join(mb, "counter.obj"), "material": {"albedo": rho}}
        scene["virtual"] = [{"name": "showcase", "mesh": glb, "transform": asset["transform"]}]
        scene["render"] = {"method": "pt", "spp": spp, "max_depth": 8, "seed": seed}
        scene["output"] = {"dir": out, "grain": "off"}
        json.dump(scene, open(os.path.join(work, out + ".json"), "w"), indent=2)
        t0 = time.perf_counter()
        subprocess.run([os.path.join(bin_dir, "mr-render"), os.path.join(work, out + ".json"), "-q", "--threads", "2"],
                       check=True)
        times[out] = time.perf_counter() - t0
    mr_exr = os.path.join(work, "mr", "00000.exr")
    plate = os.path.join(work, "plate.exr")
    subprocess.run(["oiiotool", mr_exr, "--ch", "photo.R,photo.G,photo.B", "--chnames", "R,G,B", "-o", plate],
                   check=True)

    env_blender = os.path.join(work, "env-blender.exr")
    env_for_blender(os.path.join(mb, "env.exr"), env_blender)
    # mr multiplies what it renders by the frame's measured render-to-plate
    # gain (camera.gains, from mr-eval plate); a Blender user matches the
    # exposure by hand: here the map is scaled by the same gain, which scales
    # the objects' pass alike (light transport is linear) and leaves the
    # shadow-catcher pass, a ratio, as it is.
    gain = json.load(open(os.path.join(mb, src["camera"]["gains"])))["frames"][0]["gain"]
    subprocess.run(["oiiotool", env_blender, "--mulc", ",".join("%.9g" % g for g in gain), "-o", env_blender],
                   check=True)
    spec = {"mode": "catcher", "plate": plate,
            "meshes": [{"name": "counter", "path": os.path.join(mb, "counter.obj"), "albedo": rho},
                       {"name": "showcase", "role": "virtual", "path": glb, "world_from_object": M.tolist()}],
            "environment": env_blender, "env_rotation_deg": 0.0,
            "camera": {"width": w, "height": h, "fx": fx, "fy": fy, "cx": cx, "cy": cy},
            "world_from_cam": np.eye(4).tolist(), "spp": spp, "max_depth": 8, "threads": 2}
    if "--reuse" in sys.argv:  # the renders of a previous run: the comparison alone
        times = json.load(open(os.path.join(work, "times.json")))
    else:
        render_cycles_pair(blender, work, spec, times)
        json.dump(times, open(os.path.join(work, "times.json"), "w"))

    def layer(path, names):
        plain = "Y" if names.count(",") == 0 else "R,G,B"
        subprocess.run(["oiiotool", path, "--ch", names, "--chnames", plain, "-d", "float", "-o",
                        os.path.join(work, "l.exr")], check=True)
        return cv2.imread(os.path.join(work, "l.exr"), cv2.IMREAD_UNCHANGED)

    comp = {k: layer(os.path.join(work, k, "00000.exr"), "composite.R,composite.G,composite.B") for k in ("mr", "mr2")}
    for k in ("cycles", "cycles2"):
        comp[k] = layer(os.path.join(work, k + ".exr"), "R,G,B")
    mask = layer(mr_exr, "mask.Y")
    mask = (mask if mask.ndim == 2 else mask[:, :, 0]) > 0
    ring = cv2.dilate(mask.astype(np.uint8), np.ones((81, 81), np.uint8)) > 0
    beyond = ~ring
    ring &= ~mask

    # The asset's parts on screen: each sphere's disc (its node's place and
    # its POSITION accessor's bounds, which glTF requires, through the
    # pinhole), within mr's mask; the base is the rest of the mask.
    def glb_json(path):
        data = open(path, "rb").read()
        n = int.from_bytes(data[12:16], "little")
        return json.loads(data[20:20 + n])

    g = glb_json(glb)
    parts = {}
    yy, xx = np.mgrid[0:mask.shape[0], 0:mask.shape[1]]
    for node in g["nodes"]:
        if node.get("name") not in ("metal", "glass"):
            continue
        acc = g["accessors"][g["meshes"][node["mesh"]]["primitives"][0]["attributes"]["POSITION"]]
        lo, hi = np.array(acc["min"]), np.array(acc["max"])
        scale = np.array(node.get("scale", [1, 1, 1]))
        centre = M @ np.append(np.array(node.get("translation", [0, 0, 0])) + scale * (lo + hi) / 2, 1)
        radius = float(np.max(scale * (hi - lo))) / 2
        u, v = fx * centre[0] / centre[2] + cx, fy * centre[1] / centre[2] + cy
        r_px = 1.05 * fx * radius / np.sqrt(max(centre[2] ** 2 - radius ** 2, 1e-9))
        parts[node["name"]] = mask & ((xx - u) ** 2 + (yy - v) ** 2 <= r_px ** 2)
    parts["base"] = mask & ~parts["metal"] & ~parts["glass"]

    def relmse(a, b, region):
        d = (a - b)[region]
        return float(np.mean(d * d / (b[region] ** 2 + 1e-2)))  # mr-eval compare's relMSE: eps 1e-2

    exposure = float(src["camera"].get("exposure", 1.0))  # the plate's display scale, as mr's PNGs

    def srgb(x):
        x = np.clip(x * exposure, 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)

    r = {"spp": spp, "counter_albedo": rho, "gain": gain, "mr_seconds": times["mr"], "cycles_seconds": times["cycles"]}
    regions = [("object", mask), ("object_base", parts["base"]), ("object_steel", parts["metal"]),
               ("object_glass", parts["glass"]), ("ring", ring), ("beyond", beyond)]
    for name, region in regions:
        r[name] = {"mr_vs_cycles": relmse(comp["mr"], comp["cycles"], region),
                   "mr_vs_mr": relmse(comp["mr"], comp["mr2"], region),
                   "cycles_vs_cycles": relmse(comp["cycles"], comp["cycles2"], region)}
        r[name]["noise_floor"] = (r[name]["mr_vs_mr"] + r[name]["cycles_vs_cycles"]) / 2
        r[name]["pixels"] = int(region.sum())
        r[name]["mean_ratio_mr_over_cycles"] = (comp["mr"][region].mean(0) / comp["cycles"][region].mean(0)).tolist()
    json.dump(r, open(os.path.join(work, "results.json"), "w"), indent=2)
    side = np.concatenate([srgb(comp["mr"]), srgb(comp["cycles"])], axis=1)
    cv2.imwrite(os.path.join(work, "side-by-side.png"), np.round(side * 255).astype(np.uint8))
    print(json.dumps(r, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
