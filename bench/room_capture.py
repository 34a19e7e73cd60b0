#!/usr/bin/python3
"""Light as it was in the room (issue 39): the composite's error against the
probe's distance from the object, on a capture made by Blender Cycles
(independent of mr's renderer), same machine, same run.

The capture: an open corner room (a chequered floor, two walls, a ceiling,
counters along both walls; open at the front and the right, where the sky
comes in), a 0.5 m lamp panel under the ceiling, the Stanford bunny on the
floor.  Cycles renders the plate (the room alone), the truth (the plate
plus the converged difference the bunny makes, as bench/cycles_compare.py's
table-top) and a lat-long probe panorama from each of several points: at
the object, 0.5, 1.0 and 1.5 m from it towards the open side, and 1 m from
it towards the counters' corner.  The room's true geometry and albedo are
given to mr (the issue measured that a reconstruction does not change the
trend: the light model does).

For each probe, mr lights the bunny three ways, and pt renders it at
--spp into the plate:
  infinite  mr-lights --method blobs: lights at infinity plus the residual
            map (what mr did before issue 39), the room without its ceiling
            (whose mesh would hide the lamp's distant light: as a handheld
            RGB-D recording leaves it out);
  placed    the same with --room --probe-at: lights that land on the room
            become area lights there, and the residual keeps only the
            directions that leave the room;
  room      placed, and the scene's lighting.probes at the probe with
            --room-map's map: rays from the bunny that meet the room take
            the radiance the probe saw there (docs/methods.md, "The room's
            own light").
Error: relMSE in the bunny's region (its pixels and where it changes the
plate) against the truth (mr-eval compare --region); "nothing" is the plate
itself.  Prints a table (docs/benchmarks.md, "Light as it was in the
room") and writes OUT_DIR/results.csv.

Usage: bench/room_capture.py BIN_DIR OUT_DIR [--quick] [--threads N] [--spp N]
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
import cycles_compare as cc  # noqa: E402  (its Blender runner, image I/O, region error)
from cycles_compare import np  # noqa: E402

CAMERA = {"width": 320, "height": 240, "fx": 250.0, "fy": 250.0, "cx": 159.5, "cy": 119.5}
EYE, TARGET = np.array([1.7, 1.1, -2.4]), np.array([0.0, 0.2, 0.3])
OBJECT = np.array([0.0, 0.15, 0.3])  # the bunny's middle
PROBES = [("at the object", OBJECT),
          ("0.5 m away", OBJECT + [0.5, 0, 0]),
          ("1.0 m away", OBJECT + [1.0, 0, 0]),
          ("1.5 m away", OBJECT + [1.5, 0, 0]),
          ("1 m, counters' corner", OBJECT + [-0.7, 0, 0.7])]
LAMP_RADIANCE = 40.0
MAX_DEPTH = 12


def quad(a, b, c, d):
    return [a, b, c, d], [(0, 1, 2), (0, 2, 3)]


def box(lo, hi):
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    f = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4), (3, 7, 6), (3, 6, 2), (0, 4, 7), (0, 7, 3),
         (1, 2, 6), (1, 6, 5)]
    return v, f


def write_obj(path, parts):
    with open(path, "w") as out:
        base = 0
        for v, f in parts:
            out.writelines("v %r %r %r\n" % p for p in v)
            out.writelines("f %d %d %d\n" % (a + base + 1, b + base + 1, c + base + 1) for a, b, c in f)
            base += len(v)


def make_room(work):
    """The room's parts as OBJ files: [(name, path, albedo)], the lamp's OBJ, and one OBJ of the whole room."""
    tiles = [[], []]
    for i in range(10):
        for k in range(8):
            x0, z0 = -2.5 + 0.5 * i, -2 + 0.5 * k
            tiles[(i + k) % 2].append(quad((x0, 0, z0), (x0, 0, z0 + 0.5), (x0 + 0.5, 0, z0 + 0.5), (x0 + 0.5, 0, z0)))
    parts = [("floor-a", tiles[0], [0.55, 0.45, 0.35]),
             ("floor-b", tiles[1], [0.22, 0.22, 0.26]),
             ("back-wall", [quad((-2.5, 0, 2), (2.5, 0, 2), (2.5, 2.5, 2), (-2.5, 2.5, 2))], [0.7, 0.68, 0.62]),
             ("left-wall", [quad((-2.5, 0, -2), (-2.5, 0, 2), (-2.5, 2.5, 2), (-2.5, 2.5, -2))], [0.6, 0.65, 0.7]),
             ("ceiling", [quad((-2.5, 2.5, -2), (-2.5, 2.5, 2), (2.5, 2.5, 2), (2.5, 2.5, -2))], [0.8, 0.8, 0.8]),
             ("counters", [box((-2.5, 0, 1.4), (0.6, 0.9, 2.0)), box((-2.5, 0, -1.0), (-1.9, 0.9, 1.4))],
              [0.5, 0.32, 0.2])]
    out = []
    for name, geo, albedo in parts:
        path = os.path.join(work, name + ".obj")
        write_obj(path, geo)
        out.append((name, path, albedo))
    write_obj(os.path.join(work, "room.obj"), [g for _, geo, _ in parts for g in geo])
    lamp = os.path.join(work, "lamp.obj")  # 1 mm under the ceiling, facing down
    write_obj(lamp, [quad((0.05, 2.499, 0.15), (0.55, 2.499, 0.15), (0.55, 2.499, 0.65), (0.05, 2.499, 0.65))])
    return out, lamp


def look_at(eye, target):
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0.0, 1.0, 0.0])  # camera x right, y down, z forward
    x /= np.linalg.norm(x)
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = np.stack([x, np.cross(z, x), z], axis=1), eye
    return M


def tum_line(M):
    R, t = M[:3, :3], M[:3, 3]
    qw = math.sqrt(max(0.0, 1 + np.trace(R))) / 2
    q = [math.copysign(math.sqrt(max(0.0, 1 + 2 * R[i, i] - np.trace(R))) / 2, R[(i + 2) % 3, (i + 1) % 3] -
                       R[(i + 1) % 3, (i + 2) % 3]) for i in range(3)]
    return "0 %r %r %r %r %r %r %r\n" % (*t, *q, qw)


def blender_latlong_to_mr(src, dst, W, H):
    """Blender's equirectangular panorama (camera turned so that its centre
    column is world +z and its top +y, pixel edges on the image's edges)
    resampled to mr's lat-long map (pixel centres on both edges), bilinear."""
    img = cc.read_rgb(src)
    Hb, Wb = img.shape[:2]
    u = (np.arange(W) / (W - 1)) * Wb - 0.5  # Blender's continuous pixel of mr's longitude
    v = (np.arange(H) / (H - 1)) * Hb - 0.5
    u0 = np.floor(u).astype(int)
    fu = (u - u0)[None, :, None]
    v = np.clip(v, 0, Hb - 1)
    v0 = np.minimum(np.floor(v).astype(int), Hb - 2)
    fv = (v - v0)[:, None, None]
    a, b = u0 % Wb, (u0 + 1) % Wb

    def row(r):
        return img[r][:, a] * (1 - fu) + img[r][:, b] * fu

    cc.write_rgb(dst, row(v0) * (1 - fv) + row(v0 + 1) * fv)


def room_spec(work, mesh):
    """The capture's Blender spec (the plate's camera), the room's parts and the bunny's placement."""
    parts, lamp = make_room(work)
    cc.sky_with_sun(os.path.join(work, "sky.exr"), width=256, sun_ratio=0.0)
    cc.env_for_blender(os.path.join(work, "sky.exr"), os.path.join(work, "sky-blender.exr"))
    s = 2.0  # the bunny about 0.3 m tall, standing on the floor
    bunny_m = [[s, 0, 0, 0.0], [0, s, 0, -0.0334 * s], [0, 0, s, 0.3], [0, 0, 0, 1]]
    meshes = [{"name": n, "role": "real", "path": p, "albedo": alb} for n, p, alb in parts]
    meshes.append({"name": "lamp", "role": "real", "path": lamp, "albedo": [0, 0, 0],
                   "emission": [LAMP_RADIANCE] * 3})
    meshes.append({"name": "bunny", "role": "virtual", "path": os.path.abspath(mesh), "albedo": [0.8, 0.7, 0.6],
                   "world_from_object": bunny_m})
    spec = {"meshes": meshes, "environment": os.path.join(work, "sky-blender.exr"), "env_rotation_deg": 0.0,
            "camera": CAMERA, "world_from_cam": look_at(EYE, TARGET).tolist(), "max_depth": MAX_DEPTH, "seed": 1}
    return spec, parts, bunny_m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--quick", action="store_true", help="small probes, a noisier truth (a smoke test)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spp", type=int, default=64, help="pt's samples per pixel")
    ap.add_argument("--mesh", default=os.path.join(HERE, "..", "..", "shared", "data", "meshes", "bun_zipper_res2.ply"))
    a = ap.parse_args()
    bin_dir, work = os.path.abspath(a.bin_dir), os.path.abspath(a.out_dir)
    if not os.path.isfile(a.mesh):
        raise SystemExit("room_capture: no bunny mesh at %s (--mesh)" % a.mesh)
    os.makedirs(work, exist_ok=True)
    bl = cc.Blender(work, a.threads)
    truth_spp, probe_w, probe_spp = (256, 256, 64) if a.quick else (1024, 512, 256)
    t0 = time.perf_counter()
    spec, parts, bunny_m = room_spec(work, a.mesh)
    cam_pose = look_at(EYE, TARGET)

    # The plate and the truth (kept for later runs into the same folder).
    plate_path, truth_path = os.path.join(work, "plate", "00000.exr"), os.path.join(work, "truth.exr")
    if not os.path.isfile(truth_path):
        os.makedirs(os.path.dirname(plate_path), exist_ok=True)
        p, _, _ = bl.render(spec, "b-plate", mode="real", spp=truth_spp // 2, seed=7)
        cc.write_rgb(plate_path, cc.read_rgb(p))
        plate = cc.read_rgb(plate_path)
        m, _, _ = bl.render(spec, "b-mask", mode="mask", spp=64)
        f, _, _ = bl.render(spec, "b-full64", mode="full", spp=64, seed=3)
        r, _, _ = bl.render(spec, "b-real64", mode="real", spp=64, seed=3)
        diff = np.abs(cc.read_rgb(f) - cc.read_rgb(r)).max(axis=2)
        region = cc.dilate(cc.read_alpha(m) > 0, 3) | (diff > 0.02 * plate.max(axis=2) + 1e-4)
        ys, xs = np.nonzero(region)
        border = [int(max(0, xs.min() - 4)), int(max(0, ys.min() - 4)), int(xs.max() + 5), int(ys.max() + 5)]
        inside = np.zeros_like(region)
        inside[border[1]:border[3], border[0]:border[2]] = True
        M = cc.read_alpha(m)[:, :, None] * inside[:, :, None]
        halves = []
        for k in range(2):
            f, _, _ = bl.render(spec, "b-full%d" % k, mode="full", spp=truth_spp, seed=11 + k, border=border)
            r, _, _ = bl.render(spec, "b-real%d" % k, mode="real", spp=truth_spp, seed=11 + k, border=border)
            F, R = cc.read_rgb(f), cc.read_rgb(r)
            halves.append(M * F + (1 - M) * (plate + (F - R) * inside[:, :, None]))
        region &= inside
        truth = 0.5 * (halves[0] + halves[1])
        cc.write_rgb(truth_path, truth)
        np.save(os.path.join(work, "region.npy"), region)
        json.dump({"truth_noise_region_relmse": cc.truth_noise(halves[0], halves[1], truth, region)},
                  open(os.path.join(work, "truth.json"), "w"))
    region = np.load(os.path.join(work, "region.npy"))
    noise = json.load(open(os.path.join(work, "truth.json")))["truth_noise_region_relmse"]
    region_png = os.path.join(work, "region.png")
    cc.write_region(region_png, region)
    # The probes: Cycles' panorama from each point, the camera turned about
    # its forward axis so that the panorama's centre is world +z, its top +y.
    turn = np.diag([-1.0, -1.0, 1.0, 1.0])
    for i, (_, at) in enumerate(PROBES):
        dst = os.path.join(work, "probe%d.exr" % i)
        if os.path.isfile(dst):
            continue
        pose = np.eye(4)
        pose[:3, 3] = at
        p, _, _ = bl.render(spec, "b-probe%d" % i, mode="real", spp=probe_spp, seed=21 + i,
                            camera={"type": "equirect", "width": probe_w, "height": probe_w // 2},
                            world_from_cam=(pose @ turn).tolist())
        blender_latlong_to_mr(p, dst, probe_w, probe_w // 2 + 1)
    print("capture (Cycles) in %.0f s; region %d pixels; the truth's own noise %.2g (region relMSE)"
          % (time.perf_counter() - t0, int(region.sum()), noise), flush=True)

    # mr's scene, lit three ways from each probe.
    cc.write_pinhole_cameramodel(os.path.join(work, "camera.cameramodel"), CAMERA)
    with open(os.path.join(work, "trajectory.txt"), "w") as f:
        f.write(tum_line(cam_pose))
    base = {"version": 1,
            "camera": {"model": "camera.cameramodel", "poses": {"format": "tum", "path": "trajectory.txt"},
                       "frames": "plate/%05d.exr", "frames_transfer": "linear"},
            "real": [{"mesh": os.path.basename(p), "material": {"albedo": alb}} for _, p, alb in parts],
            "virtual": [{"name": "bunny", "mesh": os.path.abspath(a.mesh), "material": {"albedo": [0.8, 0.7, 0.6]},
                         "transform": {"matrix": [v for r in bunny_m for v in r]}}],
            "render": {"method": "pt", "spp": a.spp, "max_depth": MAX_DEPTH, "seed": 1},
            "output": {"dir": "render", "png": False, "layers": ["composite", "mask"]}}
    nothing = cc.region_relmse(bin_dir, plate_path, truth_path, region_png, os.path.join(work, "nothing.cmp.json"))
    rows = []
    lights_bin = os.path.join(bin_dir, "mr-lights")
    for i, (name, at) in enumerate(PROBES):
        probe = os.path.join(work, "probe%d.exr" % i)
        centre = "%r,%r,%r" % tuple(at)
        row = {"probe": name, "distance_m": round(float(np.linalg.norm(at - OBJECT)), 2), "nothing": "%.4g" % nothing}
        for how in ("infinite", "placed", "room"):
            tag = "%s%d" % (how, i)
            lights, residual = os.path.join(work, tag + "-lights.json"), os.path.join(work, tag + "-residual.exr")
            cmd = [lights_bin, probe, "--method", "blobs", "--count", "4", "--out", lights, "--residual", residual,
                   "--report", os.path.join(work, tag + "-lights.report.json"), "-q"]
            room_map = os.path.join(work, tag + "-room.exr")
            if how != "infinite":
                cmd += ["--room", os.path.join(work, "room.obj"), "--probe-at", centre]
            if how == "room":
                cmd += ["--room-map", room_map]
            cc.run(cmd, stdout=cc.subprocess.DEVNULL)
            sc = json.loads(json.dumps(base))
            if how == "infinite":
                sc["real"] = [r for r in sc["real"] if r["mesh"] != "ceiling.obj"]
            sc["lighting"] = {"environment": os.path.basename(residual), "lights": os.path.basename(lights)}
            if how == "room":
                sc["lighting"]["probes"] = [{"at": [float(v) for v in at], "map": os.path.basename(room_map)}]
            sp = os.path.join(work, tag + ".json")
            json.dump(sc, open(sp, "w"), indent=1)
            rdir = os.path.join(work, "mr-" + tag)
            cc.run([os.path.join(bin_dir, "mr-render"), sp, "--out", rdir, "--report", rdir + ".json", "-q",
                    "--threads", str(a.threads)])
            comp = os.path.join(rdir, "00000.exr")
            row[how] = "%.4g" % cc.region_relmse(bin_dir, comp, truth_path, region_png, comp + ".cmp.json")
            row[how + "_seconds"] = round(json.load(open(rdir + ".json"))["metrics"]["frames"][0]["seconds"], 2)
        rows.append(row)
        print("  %-22s %.2f m  infinite %s  placed %s  room %s  (nothing %s)"
              % (name, row["distance_m"], row["infinite"], row["placed"], row["room"], row["nothing"]), flush=True)
    with open(os.path.join(work, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    at0 = {how: float(rows[0][how]) for how in ("infinite", "placed", "room")}
    print("\n| probe | distance | infinite | placed | placed + room | room / at the object |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %.1f m | %s | %s | %s | %.2fx |" % (r["probe"], r["distance_m"], r["infinite"], r["placed"],
                                                        r["room"], float(r["room"]) / at0["room"]))
    print("nothing (the plate): %.4g; the truth's own noise %.2g; pt %d spp" % (nothing, noise, a.spp))


if __name__ == "__main__":
    sys.exit(main())
