#!/usr/bin/python3
"""mr against Blender Cycles on the same machine in the same run (issue 22).

Two scenes, each with a plate, a converged truth of the plate with the
virtual object and the object's region (where the object changes the plate):
  bunny-room  mr-synth's room (--preset medium, a pinhole lens, the Stanford
              bunny on the glossy table, sun 1e6 x the sky); plate and truth
              are mr-synth's (mr's pt; the truth at 4 x its samples where the
              object changes the image), the region is where they differ.
  table-top   built here, independently of mr-synth: the bunny on a floor
              before a wall, a lat-long sky with a sun 2000 x brighter,
              320x240.  Plate and truth are Cycles' own: the plate the real
              scene at PLATE_SPP, the truth the plate plus the converged
              difference of two Cycles renders with and without the bunny
              (same seed, so paths that miss the bunny cancel) at 2 x the
              truth's spp, rendered only inside the region's bounding box;
              where the bunny covers a
              pixel, its own render (weighted by its coverage).
Each renderer composites the object into the plate:
  mr pt, ic, vpl, vct  mr-render's differential composite;
  cycles-diff          two Cycles renders (with and without the object)
                       differenced: M I_m + (1 - M)(I_c + I_m - I_r), M from a
                       third render of the object's coverage;
  cycles-catcher       the real meshes as shadow catchers, the plate
                       multiplied by the shadow-catcher pass and the object
                       over it, in Blender's compositor (what a Blender user
                       does).
Error: relMSE in the region against the truth (mr-eval compare --region).
Time: each renderer's own render time (mr-render's per-frame seconds;
Cycles' bpy.ops.render.render, which includes its scene sync and BVH build),
summed over the renders a composite needs, and the wall time of the
processes (start-up, loading, writing).  The truth's own noise is stated
(relMSE of its two halves / 4, in the region).

Usage: bench/cycles_compare.py BIN_DIR OUT_DIR [--quick] [--scenes bunny-room,table-top]
         [--mesh PLY] [--threads N] [--renderers mr,mr-fast,cycles] [--spps 4,16,64,256]
         [--seeds K]
Writes OUT_DIR/SCENE/results.csv and OUT_DIR/results.csv (every scene's rows),
and prints each row as it is measured.  --seeds K renders every setting with
K render seeds (mr's render.seed 1..K, Cycles' 5..K+4: a heavy-tailed error
needs the mean of several) and prints each setting's mean error; the rows
carry their seed.  A scene's plate and truth are kept
and reused by later runs into the same OUT_DIR.
"""
import argparse
import ast
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
BLENDER_SCENE = os.path.join(HERE, "..", "tests", "crosscheck", "blender_scene.py")
sys.path.insert(0, os.path.join(HERE, "..", "tests", "crosscheck"))
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2  # noqa: E402  (python3-opencv)
import numpy as np  # noqa: E402
from mr_to_blender import env_for_blender  # noqa: E402

EPS = 0.01  # mr's relMSE epsilon (core/image_metrics.h)


def read_rgb(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise SystemExit("cycles_compare: cannot read %s" % path)
    return img[:, :, 2::-1].astype(np.float64)  # BGR(A) -> RGB


def read_alpha(path):
    return cv2.imread(path, cv2.IMREAD_UNCHANGED)[:, :, 3].astype(np.float64)


def write_rgb(path, rgb):
    if not cv2.imwrite(path, rgb[:, :, ::-1].astype(np.float32)):
        raise SystemExit("cycles_compare: cannot write %s" % path)


def run(cmd, **kw):
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, **kw)
    return time.perf_counter() - t0


class Blender:
    def __init__(self, work, threads):
        self.blender = shutil.which("blender")
        if not self.blender:
            raise SystemExit("cycles_compare: blender is not installed (apt-get install blender)")
        self.work, self.threads = work, threads

    def render(self, spec, name, **over):
        """Renders spec updated by `over` to WORK/NAME.exr; returns (path, render s, wall s)."""
        s = dict(spec, threads=self.threads, **over)
        sp = os.path.join(self.work, name + ".json")
        json.dump(s, open(sp, "w"), indent=1)
        out = os.path.join(self.work, name + ".exr")
        wall = run([self.blender, "-b", "--factory-startup", "-noaudio", "-P", BLENDER_SCENE, "--", sp, out],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t = json.load(open(out + ".json"))
        return out, t["render_seconds"], wall


def region_relmse(bin_dir, estimate, truth, region_png, report):
    run([os.path.join(bin_dir, "mr-eval"), "compare", estimate, truth, "--region", region_png, "--report", report,
         "-q"], stdout=subprocess.DEVNULL)
    return json.load(open(report))["metrics"]["relmse"]


def pose_matrix(tum_line):
    t = [float(v) for v in tum_line.split()[1:8]]
    x, y, z, w = t[3:7]
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, t[:3]
    return M


def read_cameramodel(path):
    text = "\n".join(line.split("#")[0] for line in open(path))
    m = ast.literal_eval(text)
    if m["lensmodel"] != "LENSMODEL_PINHOLE":
        raise SystemExit("cycles_compare: %s is %s; Cycles needs a pinhole" % (path, m["lensmodel"]))
    fx, fy, cx, cy = m["intrinsics"]
    return {"width": m["imagersize"][0], "height": m["imagersize"][1], "fx": fx, "fy": fy, "cx": cx, "cy": cy}


def write_pinhole_cameramodel(path, cam, extrinsics=(0, 0, 0, 0, 0, 0)):
    """An mrcal pinhole .cameramodel of `cam` ({width, height, fx, fy, cx, cy}); `extrinsics`: rt_cam_ref."""
    with open(path, "w") as f:
        f.write("{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [ %r, %r, %r, %r ], "
                "'extrinsics': [ %r, %r, %r, %r, %r, %r ], 'imagersize': [ %d, %d ] }\n"
                % (cam["fx"], cam["fy"], cam["cx"], cam["cy"], *extrinsics, cam["width"], cam["height"]))


def blender_spec(scene_path):
    """The Blender spec of an mr scene.json (meshes, materials, environment, frame 0's camera)."""
    d = os.path.dirname(os.path.abspath(scene_path))
    s = json.load(open(scene_path))
    if "lights" in s.get("lighting", {}):
        raise SystemExit("cycles_compare: point and spot lights are not exported to Blender yet")
    meshes = []
    for role, key in (("real", "real"), ("virtual", "virtual")):
        parts = s.get(key, [])
        for i, p in enumerate(parts if isinstance(parts, list) else [parts]):
            mat = p.get("material", {})
            m = {"name": p.get("name", "%s%d" % (role, i)), "role": role, "path": os.path.join(d, p["mesh"]),
                 "albedo": mat.get("albedo", [0.5] * 3)}
            if "specular" in mat:
                m["specular"], m["roughness"] = mat["specular"], mat.get("roughness", 0.5)
            if "transform" in p:
                m["world_from_object"] = np.array(p["transform"]["matrix"]).reshape(4, 4).tolist()
            meshes.append(m)
    cam = s["camera"]
    pose = [line for line in open(os.path.join(d, cam["poses"]["path"])) if line.strip() and line[0] != "#"][0]
    env = os.path.join(d, s["lighting"]["environment"])
    env_blender = os.path.splitext(env)[0] + "-blender.exr"
    env_for_blender(env, env_blender)
    return {"meshes": meshes, "environment": env_blender, "env_rotation_deg": 0.0, "camera": read_cameramodel(os.path.join(d, cam["model"])),
            "world_from_cam": pose_matrix(pose).tolist(), "max_depth": s["render"].get("max_depth", 5), "seed": 1}


def sky_with_sun(path, width=512, sun_ratio=2000.0):
    """A lat-long sky (mr's convention: row 0 the zenith) with a Gaussian sun."""
    h = width // 2 + 1
    env = np.zeros((h, width, 3))
    for y in range(h):
        lat = math.pi / 2 - y * math.pi / (h - 1)
        c = (0.35, 0.5, 0.9) if lat >= 0 else (0.25, 0.22, 0.2)
        env[y] = np.array(c) * (0.6 + 0.4 * max(0.0, math.sin(lat)))
    yy, xx = np.mgrid[0:h, 0:width]
    sx, sy = int(width * 0.3), int(h * 0.22)  # 50 degrees up
    env += (np.exp(-((xx - sx) ** 2 + (yy - sy) ** 2) / (2 * 1.5 ** 2)) * sun_ratio * 0.8)[:, :, None]
    write_rgb(path, env)


def make_table_top(work, mesh):
    """The independent scene as an mr scene.json (the plate filled in later)."""
    os.makedirs(work, exist_ok=True)
    sky_with_sun(os.path.join(work, "env.exr"))
    with open(os.path.join(work, "floor.obj"), "w") as f:
        f.write("v -3 0 -3\nv 3 0 -3\nv 3 0 3\nv -3 0 3\nf 1 3 2\nf 1 4 3\n")
    with open(os.path.join(work, "wall.obj"), "w") as f:
        f.write("v -3 0 0.6\nv 3 0 0.6\nv 3 2.5 0.6\nv -3 2.5 0.6\nf 1 2 3\nf 1 3 4\n")
    w, h, fx = 320, 240, 300.0
    write_pinhole_cameramodel(os.path.join(work, "camera.cameramodel"),
                              {"width": w, "height": h, "fx": fx, "fy": fx, "cx": (w - 1) / 2, "cy": (h - 1) / 2})
    eye, target = np.array([0.15, 0.45, -0.9]), np.array([0.0, 0.12, 0.1])
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0.0, 1.0, 0.0])  # camera x right, y down, z forward
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z], axis=1)
    qw = math.sqrt(max(0.0, 1 + np.trace(R))) / 2
    q = [math.copysign(math.sqrt(max(0.0, 1 + 2 * R[i, i] - np.trace(R))) / 2, R[(i + 2) % 3, (i + 1) % 3] -
                       R[(i + 1) % 3, (i + 2) % 3]) for i in range(3)]
    with open(os.path.join(work, "trajectory.txt"), "w") as f:
        f.write("0 %r %r %r %r %r %r %r\n" % (*eye, *q, qw))
    # The bunny (Stanford's, y up, about 0.15 m tall) standing on the floor.
    s = 1.5
    scene = {"version": 1,
             "camera": {"model": "camera.cameramodel", "poses": {"format": "tum", "path": "trajectory.txt"},
                        "frames": "plate/%05d.exr", "frames_transfer": "linear"},
             "lighting": {"environment": "env.exr"},
             "real": [{"mesh": "floor.obj", "material": {"albedo": [0.5, 0.48, 0.45]}},
                      {"mesh": "wall.obj", "material": {"albedo": [0.7, 0.68, 0.62]}}],
             "virtual": [{"name": "bunny", "mesh": os.path.abspath(mesh),
                          "material": {"albedo": [0.8, 0.7, 0.6]},
                          "transform": {"matrix": [s, 0, 0, 0.02, 0, s, 0, -0.0334 * s, 0, 0, s, 0.0, 0, 0, 0, 1]}}],
             "render": {"method": "pt", "spp": 16, "max_depth": 8, "seed": 1},
             "output": {"dir": "render", "png": False}}
    path = os.path.join(work, "scene.json")
    json.dump(scene, open(path, "w"), indent=1)
    return path


def dilate(mask, px):
    return cv2.dilate(mask.astype(np.uint8), np.ones((2 * px + 1, 2 * px + 1), np.uint8)) > 0


def write_region(path, region):
    cv2.imwrite(path, (region * 255).astype(np.uint8))


def truth_noise(half_a, half_b, truth, region):
    """The noise of the mean of two halves: relMSE(a, b) / 4 over the region."""
    e = ((half_a - half_b) ** 2 / (truth ** 2 + EPS))[region]
    return float(e.mean() / 4)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--quick", action="store_true", help="few settings, a noisier truth (a smoke test)")
    ap.add_argument("--scenes", default="bunny-room,table-top")
    ap.add_argument("--mesh", default=os.path.join(HERE, "..", "..", "shared", "data", "meshes", "bun_zipper_res2.ply"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spps", help="pt's and Cycles' samples per pixel (default 4,16,64,256; --quick 4,16)")
    ap.add_argument("--seeds", type=int, default=1, help="render seeds per setting (their mean error is printed)")
    ap.add_argument("--renderers", default="mr,mr-fast,cycles",
                    help="which to run: mr (pt), mr-fast (ic, vpl, vct), cycles; the rows of those left out are "
                         "kept from OUT's earlier results")
    a = ap.parse_args()
    renderers = set(a.renderers.split(","))
    bin_dir, out = os.path.abspath(a.bin_dir), os.path.abspath(a.out_dir)
    if not os.path.isfile(a.mesh):
        raise SystemExit("cycles_compare: no bunny mesh at %s (--mesh)" % a.mesh)
    os.makedirs(out, exist_ok=True)
    spps = [int(v) for v in a.spps.split(",")] if a.spps else [4, 16] if a.quick else [4, 16, 64, 256]
    seeds = range(max(1, a.seeds))
    fast = ([("ic", {"rays": 32}, 4), ("vpl", {"paths": 64}, 2), ("vct", {}, 4)] if a.quick else
            [("ic", {"rays": 32}, 4), ("ic", {"rays": 64}, 8), ("ic", {"rays": 128}, 16),
             ("vpl", {"paths": 64}, 2), ("vpl", {"paths": 128}, 4), ("vpl", {"paths": 256}, 8),
             ("vct", {}, 4), ("vct", {}, 16), ("vct", {"resolution": 64}, 16)])
    truth_spp = 256 if a.quick else 1024
    rows = []
    for name in a.scenes.split(","):
        work = os.path.join(out, name)
        os.makedirs(work, exist_ok=True)
        bl = Blender(work, a.threads)
        t0 = time.perf_counter()
        if name == "bunny-room":
            cap = os.path.join(work, "capture")
            if not os.path.isfile(os.path.join(cap, "scene.json")):
                run([os.path.join(bin_dir, "mr-synth"), "--preset", "medium", "--frames", "1", "--lens", "pinhole",
                     "--object", a.mesh, "--truth-spp", str(truth_spp),
                     # The object's region (where the scores are) at 4x: the truth's
                     # noise a tenth of the smallest error scored (issue 22).
                     "--truth-region-spp", str(4 * truth_spp), "--out", cap, "--report",
                     os.path.join(work, "synth.json"), "-q", "--threads", str(a.threads)])
            scene_path = os.path.join(cap, "scene.json")
            plate_path, truth_path = os.path.join(cap, "photos", "00000.exr"), os.path.join(cap, "truth", "00000.exr")
            plate, truth = read_rgb(plate_path), read_rgb(truth_path)
            region = np.any(plate != truth, axis=2)
            noise = json.load(open(os.path.join(work, "synth.json")))["metrics"]["truth_noise_region_relmse"]
            spec = blender_spec(scene_path)
        elif name == "table-top":
            scene_path = make_table_top(work, a.mesh)
            spec = blender_spec(scene_path)
            plate_path = os.path.join(work, "plate", "00000.exr")
            truth_path = os.path.join(work, "truth.exr")
            if not os.path.isfile(truth_path):
                os.makedirs(os.path.dirname(plate_path), exist_ok=True)
                p, _, _ = bl.render(spec, "t-plate", mode="real", spp=truth_spp // 4, seed=7)
                write_rgb(plate_path, read_rgb(p))
                # The region: the object's coverage grown by 3 px, and where a
                # 64-spp difference (same seed with and without the object)
                # exceeds 2% of the plate.
                m, _, _ = bl.render(spec, "t-mask", mode="mask", spp=64)
                f, _, _ = bl.render(spec, "t-full64", mode="full", spp=64, seed=3)
                r, _, _ = bl.render(spec, "t-real64", mode="real", spp=64, seed=3)
                diff = np.abs(read_rgb(f) - read_rgb(r)).max(axis=2)
                plate = read_rgb(plate_path)
                region = dilate(read_alpha(m) > 0, 3) | (diff > 0.02 * plate.max(axis=2) + 1e-4)
                ys, xs = np.nonzero(region)
                border = [int(max(0, xs.min() - 4)), int(max(0, ys.min() - 4)), int(xs.max() + 5), int(ys.max() + 5)]
                # The truth is the photograph with the bunny in it: the
                # bunny's own render where it covers the pixel, the plate
                # plus the bunny's change elsewhere (the composite's form).
                inside = np.zeros_like(region)
                inside[border[1]:border[3], border[0]:border[2]] = True
                M = read_alpha(m)[:, :, None] * inside[:, :, None]
                # 2 x truth_spp: the truth's noise a tenth of the smallest
                # error scored (Cycles' 256-spp 3.4e-4; 1024 spp gave 6.5e-5).
                halves = []
                for k in range(2):
                    f, _, _ = bl.render(spec, "t-full%d" % k, mode="full", spp=truth_spp, seed=11 + k, border=border)
                    r, _, _ = bl.render(spec, "t-real%d" % k, mode="real", spp=truth_spp, seed=11 + k, border=border)
                    F, R = read_rgb(f), read_rgb(r)
                    halves.append(M * F + (1 - M) * (plate + (F - R) * inside[:, :, None]))
                region &= inside
                truth = 0.5 * (halves[0] + halves[1])
                write_rgb(truth_path, truth)
                np.save(os.path.join(work, "region.npy"), region)
                noise = truth_noise(halves[0], halves[1], truth, region)
                json.dump({"truth_noise_region_relmse": noise}, open(os.path.join(work, "truth.json"), "w"))
            plate, truth = read_rgb(plate_path), read_rgb(truth_path)
            region = np.load(os.path.join(work, "region.npy"))
            noise = json.load(open(os.path.join(work, "truth.json")))["truth_noise_region_relmse"]
        else:
            raise SystemExit("cycles_compare: unknown scene %s" % name)
        region_png = os.path.join(work, "region.png")
        write_region(region_png, region)
        print("%s: truth and plate in %.0f s; region %d pixels; the truth's own noise %.2g (region relMSE)"
              % (name, time.perf_counter() - t0, int(region.sum()), noise), flush=True)

        def add(renderer, setting, spp, render_s, wall_s, composite, seed):
            e = region_relmse(bin_dir, composite, truth_path, region_png, composite + ".cmp.json")
            rows.append({"scene": name, "renderer": renderer, "setting": setting, "spp": spp, "seed": seed,
                         "render_seconds": round(render_s, 3), "wall_seconds": round(wall_s, 3),
                         "region_relmse": "%.4g" % e, "truth_noise": "%.2g" % noise})
            print("  %-15s %-12s %5d spp seed %d  %8.2f s (wall %7.2f s)  region relMSE %.3g"
                  % (renderer, setting, spp, seed, render_s, wall_s, e), flush=True)

        # mr: one mr-render per setting (its report's per-frame seconds).
        s = json.load(open(scene_path))
        s.pop("reference", None)
        s["output"] = {"dir": "render", "png": False, "layers": ["composite", "mask"]}
        todo = ([("pt", {}, n) for n in spps] if "mr" in renderers else []) + (fast if "mr-fast" in renderers else [])
        base_seed = int(s["render"].get("seed", 1))
        for (method, block, spp), k in ((t, k) for t in todo for k in seeds):
            s["render"]["seed"] = base_seed + k
            s["render"]["method"] = method
            s["render"]["spp"] = spp
            for m in ("ic", "vpl", "vct"):
                s["render"].pop(m, None)
            if block:
                s["render"][method] = block
            setting = ",".join("%s=%s" % kv for kv in block.items()) or "-"
            sp = os.path.join(os.path.dirname(scene_path), "cmp-%s.json" % method)
            json.dump(s, open(sp, "w"), indent=1)
            rdir = os.path.join(work, "mr-%s-%s-%d%s" % (method, setting.replace("=", ""), spp, "-s%d" % k if k else ""))
            wall = run([os.path.join(bin_dir, "mr-render"), sp, "--out", rdir, "--report", rdir + ".json", "-q",
                        "--threads", str(a.threads)])
            rep = json.load(open(rdir + ".json"))
            add("mr " + method, setting, spp, rep["metrics"]["frames"][0]["seconds"], wall,
                os.path.join(rdir, "00000.exr"), base_seed + k)
        # Cycles: the coverage once (shared by every cycles-diff setting,
        # counted in each), then per spp the two renders differenced and the
        # shadow catcher.
        if "cycles" not in renderers:
            continue
        mask_path, mask_s, mask_wall = bl.render(spec, "c-mask", mode="mask", spp=64)
        M = read_alpha(mask_path)[:, :, None]
        for spp, k in ((n, k) for n in spps for k in seeds):
            tag = "%d%s" % (spp, "-s%d" % k if k else "")
            f, fs, fw = bl.render(spec, "c-full-%s" % tag, mode="full", spp=spp, seed=5 + k)
            r, rs, rw = bl.render(spec, "c-real-%s" % tag, mode="real", spp=spp, seed=5 + k)
            I_m, I_r = read_rgb(f), read_rgb(r)
            comp = np.maximum(0.0, M * I_m + (1 - M) * (plate + I_m - I_r))
            cp = os.path.join(work, "cycles-diff-%s.exr" % tag)
            write_rgb(cp, comp)
            add("cycles-diff", "-", spp, fs + rs + mask_s, fw + rw + mask_wall, cp, 5 + k)
            c, cs, cw = bl.render(spec, "c-catcher-%s" % tag, mode="catcher", spp=spp, seed=5 + k, plate=plate_path)
            cp = os.path.join(work, "cycles-catcher-%s.exr" % tag)
            write_rgb(cp, read_rgb(c))
            add("cycles-catcher", "-", spp, cs, cw, cp, 5 + k)
    if len(seeds) > 1:
        print("means over %d seeds:" % len(seeds))
        means = {}
        for r in rows:
            means.setdefault((r["scene"], r["renderer"], r["setting"], r["spp"]), []).append(r)
        for (scene, renderer, setting, spp), rs in means.items():
            print("  %-10s %-15s %-12s %5d spp  %8.2f s  region relMSE %.3g (%s)"
                  % (scene, renderer, setting, spp, sum(r["render_seconds"] for r in rs) / len(rs),
                     sum(float(r["region_relmse"]) for r in rs) / len(rs), ", ".join(r["region_relmse"] for r in rs)))
    # Per scene, then every scene's table in OUT (a scene run again replaces its rows).
    fields = list(rows[0].keys())

    def group(renderer):
        return "cycles" if renderer.startswith("cycles") else "mr" if renderer == "mr pt" else "mr-fast"

    for name in a.scenes.split(","):
        path = os.path.join(out, name, "results.csv")
        kept = [r for r in csv.DictReader(open(path)) if group(r["renderer"]) not in renderers] \
            if os.path.isfile(path) else []
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields)
            w.writeheader()
            w.writerows([r for r in rows if r["scene"] == name] + kept)
    with open(os.path.join(out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for name in sorted(os.listdir(out)):
            path = os.path.join(out, name, "results.csv")
            if os.path.isfile(path):
                w.writerows(csv.DictReader(open(path)))
    print("wrote %s" % os.path.join(out, "results.csv"))


if __name__ == "__main__":
    sys.exit(main())
