#!/usr/bin/python3
"""The chrome-to-diffuse prediction (issue 39): a chrome ball and a diffuse
ball photographed under the same light, the diffuse one predicted from the
chrome one, against the classic brightest-blob method, on photographs made
by Blender Cycles (independent of mr's renderer), same machine, same run.

Three lightings: one lamp, three lamps (equally bright), a lamp and a
window.  The lamps are emitting spheres 3 m from the balls (0.1 m radius,
2.2 degrees across), the window a 1.2 x 1.5 m emitting rectangle 3 m away;
a dim room-like lat-long map around.  Each ball (radius 0.05 m, the chrome
a GGX mirror of reflectance 0.9, the diffuse one albedo 0.5) is rendered
by Cycles at 320 x 320 from 1 m, then written as a phone would: one
exposure for the pair (the diffuse ball's brightest pixel at 80% of full
scale), a lens's point spread (97% in the pixel, 3% in a Gaussian halo of
sigma 4 px), clipped at full scale, sRGB, 8-bit JPEG (quality 92).  The
lamps clip on the chrome ball; the diffuse ball does not.

mr's chain on the chrome photograph: mr-calibrate sphere (a first circle
2 px off), mr-probe --reflectance 0.9, mr-lights --method blobs, and
mr-render (pt, 256 spp) of a diffuse ball of albedo 0.5 under the lights
and the residual map.  The baseline takes the same unwrapped map: the
brightest pixels (over half the map's maximum), their 8-connected regions
in energy order (at most 4), each a distant light along its
energy-weighted centroid with the region's energy, and the rest of the
map as the residual; rendered by the same mr-render.
Reported per lighting and method: the direction error of each lamp (the
nearest light), its strength (irradiance) over the truth's in the
photograph's units (clipped: a lower bound), and the diffuse ball's
prediction against its photograph over the ball (3 px inside its rim): RMS
in code values and the correlation.  Then, as the issue's test on real
balls: each light's and the residual's strength fitted to the diffuse
photograph (linear least squares over its unclipped pixels, one render per
light), the fitted lamp strengths over the truth (equal lamps should come
out equal) and the fitted prediction's RMS and correlation.  Prints a table (docs/benchmarks.md, "Light as it was in the
room") and writes OUT_DIR/results.csv.

Usage: bench/ball_pairs.py BIN_DIR OUT_DIR [--threads N] [--spp N]
"""
import argparse
import csv
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cycles_compare as cc  # noqa: E402  (its Blender runner and image I/O)
from cycles_compare import cv2, np  # noqa: E402

W = H = 320
F = 1500.0  # px: the ball (0.05 m at 1 m) 75 px in radius
RADIUS = 0.05
CAM_Z = -1.0
REFLECTANCE = 0.9
ALBEDO = 0.5
LAMP_R, LAMP_DIST, LAMP_L = 0.1, 3.0, 300.0


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# Lamp directions (from the balls; the camera looks along +z from -z, so
# lights on the camera's side are at negative z).
LIGHTINGS = {
    "one lamp": {"lamps": [unit([0.5, 0.6, -0.6])]},
    "three lamps": {"lamps": [unit([0.6, 0.5, -0.6]), unit([-0.6, 0.6, -0.5]), unit([0.1, 0.9, -0.3])]},
    "lamp and window": {"lamps": [unit([0.4, 0.7, -0.6])], "window": (unit([-0.8, 0.3, -0.5]), 1.2, 1.5, 3.0)},
}


def write_sphere_obj(path, r, centre=(0, 0, 0), nu=96, nv=48):
    with open(path, "w") as f:
        for j in range(nv + 1):
            th = math.pi * j / nv
            for i in range(nu):
                ph = 2 * math.pi * i / nu
                n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
                f.write("v %r %r %r\nvn %r %r %r\n" % (centre[0] + r * n[0], centre[1] + r * n[1], centre[2] + r * n[2],
                                                       *n))
        for j in range(nv):
            for i in range(nu):
                a, b = j * nu + i + 1, j * nu + (i + 1) % nu + 1
                c, d = a + nu, b + nu
                f.write("f %d//%d %d//%d %d//%d\nf %d//%d %d//%d %d//%d\n" % (a, a, b, b, c, c, b, b, d, d, c, c))


def write_quad_obj(path, centre, normal, w, h):
    n = unit(normal)
    u = unit(np.cross([0.0, 1.0, 0.0], n)) if abs(n[1]) < 0.99 else np.array([1.0, 0, 0])
    v = np.cross(n, u)
    pts = [centre + sx * w / 2 * u + sy * h / 2 * v for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    with open(path, "w") as f:
        f.writelines("v %r %r %r\n" % tuple(p) for p in pts)
        f.write("f 1 2 3\nf 1 3 4\n")


def room_map(path, width=256):
    """A dim room around: brighter above, darker below (mr's lat-long convention)."""
    h = width // 2 + 1
    env = np.zeros((h, width, 3))
    for y in range(h):
        lat = math.pi / 2 - y * math.pi / (h - 1)
        env[y] = np.array([0.25, 0.23, 0.2]) * (0.5 + 0.4 * math.sin(lat))
    cc.write_rgb(path, env)


def srgb(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_to_linear(v):
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def photograph(linear, k, path):
    """As a phone would: exposure, the lens's point spread, the clip, sRGB, 8-bit JPEG."""
    x = k * linear
    x = 0.97 * x + 0.03 * cv2.GaussianBlur(x, (0, 0), 4.0)
    codes = np.round(255 * srgb(x)).astype(np.uint8)
    if not cv2.imwrite(path, codes[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, 92]):
        raise SystemExit("ball_pairs: cannot write %s" % path)


def latlong_dirs(w, h):
    px, py = np.meshgrid(np.arange(w), np.arange(h))
    lon = -2 * np.pi * (px / (w - 1) - 0.5)
    lat = -np.pi * (py / (h - 1) - 0.5)
    return np.stack([np.sin(lon) * np.cos(lat), np.sin(lat), np.cos(lon) * np.cos(lat)], axis=2), lat


def solid_angles(w, h):
    _, lat = latlong_dirs(w, h)
    return np.cos(lat) * (np.pi / (h - 1)) * (2 * np.pi / (w - 1))


def brightest_blobs(map_path, lights_path, residual_path, count=4):
    """The classic method on the unwrapped map: the brightest pixels' regions, each a distant light."""
    env = cc.read_rgb(map_path)
    h, w = env.shape[:2]
    lum = env @ np.array([0.2126, 0.7152, 0.0722])
    dirs, _ = latlong_dirs(w, h)
    omega = solid_angles(w, h)
    n, labels = cv2.connectedComponents((lum > 0.5 * lum.max()).astype(np.uint8), connectivity=8)
    regions = []
    for k in range(1, n):
        m = labels == k
        e = (env[m] * omega[m][:, None]).sum(axis=0)
        regions.append((float(e @ [0.2126, 0.7152, 0.0722]), m, e))
    regions.sort(key=lambda r: -r[0])
    lights, residual = [], env.copy()
    for i, (_, m, e) in enumerate(regions[:count]):
        wgt = (lum * omega)[m]
        d = unit((dirs[m] * wgt[:, None]).sum(axis=0))
        lights.append({"type": "distant", "name": "blob%d" % i, "direction": d.tolist(), "irradiance": e.tolist()})
        residual[m] = 0
    json.dump({"version": 1, "lights": lights}, open(lights_path, "w"), indent=1)
    cc.write_rgb(residual_path, residual)


def score(lights_path, truth_dirs, truth_e):
    """Per lamp: the nearest light's direction error (degrees) and strength over the truth's."""
    lights = [lt for lt in json.load(open(lights_path))["lights"] if lt["type"] == "distant"]
    out = []
    for d, e in zip(truth_dirs, truth_e):
        if not lights:
            out.append((float("nan"), 0.0))
            continue
        best = max(lights, key=lambda lt: float(np.dot(unit(lt["direction"]), d)))
        ang = math.degrees(math.acos(min(1.0, float(np.dot(unit(best["direction"]), d)))))
        out.append((ang, float(np.mean(best["irradiance"])) / e))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spp", type=int, default=256, help="Cycles' and pt's samples per pixel")
    a = ap.parse_args()
    bin_dir, out = os.path.abspath(a.bin_dir), os.path.abspath(a.out_dir)
    os.makedirs(out, exist_ok=True)
    bl = cc.Blender(out, a.threads)
    room_map(os.path.join(out, "room.exr"))
    cc.env_for_blender(os.path.join(out, "room.exr"), os.path.join(out, "room-blender.exr"))
    ball = os.path.join(out, "ball.obj")
    write_sphere_obj(ball, RADIUS)
    cam = {"width": W, "height": H, "fx": F, "fy": F, "cx": (W - 1) / 2, "cy": (H - 1) / 2}
    pose = np.eye(4)
    pose[:3, :3] = np.diag([-1.0, -1.0, 1.0])  # looking along +z, image up world +y
    pose[2, 3] = CAM_Z
    # mrcal's extrinsics: rt_cam_ref (the world's origin in the camera: 1 m ahead; a half turn about z).
    cc.write_pinhole_cameramodel(os.path.join(out, "camera.cameramodel"), cam, (0, 0, math.pi, 0, 0, -CAM_Z))
    rows = []
    for name, lighting in LIGHTINGS.items():
        tag = name.replace(" ", "-")
        work = os.path.join(out, tag)
        os.makedirs(work, exist_ok=True)
        meshes, truth_dirs, truth_e = [], [], []
        for i, d in enumerate(lighting["lamps"]):
            p = os.path.join(work, "lamp%d.obj" % i)
            write_sphere_obj(p, LAMP_R, tuple(LAMP_DIST * d), nu=24, nv=12)
            meshes.append({"name": "lamp%d" % i, "role": "real", "path": p, "albedo": [0, 0, 0],
                           "emission": [LAMP_L] * 3, "smooth": True})
            truth_dirs.append(d)
            truth_e.append(LAMP_L * 2 * math.pi * (1 - math.sqrt(1 - (LAMP_R / LAMP_DIST) ** 2)))
        if "window" in lighting:
            d, ww, wh, dist = lighting["window"]
            p = os.path.join(work, "window.obj")
            write_quad_obj(p, dist * d, -d, ww, wh)
            meshes.append({"name": "window", "role": "real", "path": p, "albedo": [0, 0, 0], "emission": [1.5] * 3})
        chrome = {"name": "ball", "role": "real", "path": ball, "albedo": [0, 0, 0], "specular": [REFLECTANCE] * 3,
                  "roughness": 0.0, "smooth": True}
        diffuse = {"name": "ball", "role": "real", "path": ball, "albedo": [ALBEDO] * 3, "smooth": True}
        spec = {"environment": os.path.join(out, "room-blender.exr"), "env_rotation_deg": 0.0, "camera": cam,
                "world_from_cam": pose.tolist(), "max_depth": 8, "seed": 1}
        lin = {}
        for ball_name, m in (("chrome", chrome), ("diffuse", diffuse)):
            path = os.path.join(work, "b-%s.exr" % ball_name)
            if not os.path.isfile(path):
                p, _, _ = bl.render(dict(spec, meshes=meshes + [m]), "%s/b-%s" % (tag, ball_name), mode="real",
                                    spp=a.spp, seed=3)
            lin[ball_name] = cc.read_rgb(path)
        # The ball's pixels (3 px inside its rim) and the pair's exposure.
        yy, xx = np.mgrid[0:H, 0:W]
        r_px = F * RADIUS / math.sqrt(CAM_Z ** 2 - RADIUS ** 2)
        inside = np.hypot(xx - cam["cx"], yy - cam["cy"]) < r_px - 3
        k = 0.8 / lin["diffuse"][inside].max()
        photograph(lin["chrome"], k, os.path.join(work, "chrome.jpg"))
        photograph(lin["diffuse"], k, os.path.join(work, "diffuse.jpg"))
        truth_e = [k * e for e in truth_e]
        clipped = int((cv2.imread(os.path.join(work, "chrome.jpg"))[inside] >= 250).any(axis=1).sum())
        # mr's chain from the chrome photograph.
        q = ["-q"]
        cc.run([os.path.join(bin_dir, "mr-calibrate"), "sphere", "--camera", os.path.join(out, "camera.cameramodel"),
                "--radius", str(RADIUS), "--circle", "%r,%r,%r" % (cam["cx"] + 2, cam["cy"] - 1, r_px + 1), "--out",
                os.path.join(work, "probe.json"), os.path.join(work, "chrome.jpg")] + q)
        cc.run([os.path.join(bin_dir, "mr-probe"), os.path.join(work, "chrome.jpg"), "--probe",
                os.path.join(work, "probe.json"), "--reflectance", str(REFLECTANCE), "--width", "256", "--out",
                os.path.join(work, "map.exr"), "--report", os.path.join(work, "probe.report.json")] + q)
        cc.run([os.path.join(bin_dir, "mr-lights"), os.path.join(work, "map.exr"), "--method", "blobs", "--count", "4",
                "--out", os.path.join(work, "mr-lights.json"), "--residual", os.path.join(work, "mr-residual.exr")] + q)
        brightest_blobs(os.path.join(work, "map.exr"), os.path.join(work, "blob-lights.json"),
                        os.path.join(work, "blob-residual.exr"))
        photo = cv2.imread(os.path.join(work, "diffuse.jpg"))[:, :, ::-1].astype(float)
        with open(os.path.join(work, "trajectory.txt"), "w") as f:
            f.write("0 0 0 %r 0 0 1 0\n" % CAM_Z)  # a half turn about z: x, y, z, w = 0, 0, 1, 0
        photo_lin = srgb_to_linear(photo / 255)
        usable = inside & (photo < 254).all(axis=2)  # the diffuse photograph's unclipped pixels

        def render(method, tag, lights, env):
            """pt's render of the diffuse ball (linear, the photograph's units) under `lights` and `env`."""
            lighting = {}
            if lights is not None:
                lp = os.path.join(work, "%s-%s-lights.json" % (method, tag))
                json.dump({"version": 1, "lights": lights}, open(lp, "w"), indent=1)
                lighting["lights"] = os.path.basename(lp)
            if env:
                lighting["environment"] = env
            scene = {"version": 1,
                     "camera": {"model": os.path.join(out, "camera.cameramodel"),
                                "poses": {"format": "tum", "path": "trajectory.txt"}},
                     "lighting": lighting,
                     "virtual": [{"name": "ball", "mesh": ball,
                                  "material": {"albedo": [ALBEDO] * 3, "normals": "vertex"}}],
                     "render": {"method": "pt", "spp": a.spp, "max_depth": 8, "seed": 1},
                     "output": {"dir": "render-%s-%s" % (method, tag), "png": False, "layers": ["composite"]}}
            sp = os.path.join(work, "scene-%s-%s.json" % (method, tag))
            json.dump(scene, open(sp, "w"), indent=1)
            cc.run([os.path.join(bin_dir, "mr-render"), sp, "--threads", str(a.threads)] + q)
            rgb = os.path.join(work, "render-%s-%s.exr" % (method, tag))  # plain R G B for OpenCV
            cc.run(["oiiotool", os.path.join(work, "render-%s-%s" % (method, tag), "00000.exr"), "--ch",
                    "R=composite.R,G=composite.G,B=composite.B", "-o", rgb])
            return cv2.imread(rgb, cv2.IMREAD_UNCHANGED)[:, :, 2::-1].astype(float)

        def versus(pred_lin):
            pred = np.round(255 * srgb(pred_lin))
            rms = float(np.sqrt(((pred - photo)[inside] ** 2).mean()))
            corr = float(np.corrcoef(pred[inside].mean(axis=1), photo[inside].mean(axis=1))[0, 1])
            return rms, corr

        for method in ("mr", "blob"):
            lights = json.load(open(os.path.join(work, "%s-lights.json" % method)))["lights"]
            residual = "%s-residual.exr" % method
            # As extracted (the clipped lamps' strengths are lower bounds).
            rms, corr = versus(render(method, "all", lights, residual))
            per = score(os.path.join(work, "%s-lights.json" % method), truth_dirs, truth_e)
            # Each light's and the residual's share fitted to the diffuse
            # photograph (least squares over its unclipped pixels, linear):
            # the light's direction and shape judged by the strength the
            # photograph asks of it (the test on real balls).
            basis = [render(method, "light%d" % i, [lt], None) for i, lt in enumerate(lights)]
            basis.append(render(method, "residual", None, residual))
            A = np.stack([b[usable].ravel() for b in basis], axis=1)
            scale, *_ = np.linalg.lstsq(A, photo_lin[usable].ravel(), rcond=None)
            fitted = sum(sc * b for sc, b in zip(scale, basis))
            rms_fit, corr_fit = versus(fitted)
            fitted_strength = []
            for d, e in zip(truth_dirs, truth_e):
                j = max(range(len(lights)), key=lambda j: float(np.dot(unit(lights[j]["direction"]), d))) \
                    if lights else None
                fitted_strength.append(float(scale[j]) * float(np.mean(lights[j]["irradiance"])) / e
                                       if j is not None and lights[j]["type"] == "distant" else float("nan"))
            row = {"lighting": name, "method": method, "lights": len(lights), "clipped_pixels": clipped,
                   "lower_bounds": sum(1 for lt in lights if "lower_bound" in lt),
                   "direction_deg": ";".join("%.2f" % p[0] for p in per),
                   "strength": ";".join("%.3f" % p[1] for p in per),
                   "rms_codes": round(rms, 2), "correlation": round(corr, 4),
                   "fitted_strength": ";".join("%.3f" % v for v in fitted_strength),
                   "fitted_rms_codes": round(rms_fit, 2), "fitted_correlation": round(corr_fit, 4)}
            rows.append(row)
            print("%-16s %-5s %d lights (%d lower bounds); lamps: direction %s deg, strength %s of the truth "
                  "(fitted to the diffuse photograph: %s); diffuse ball RMS %.2f codes, correlation %.4f "
                  "(fitted: %.2f, %.4f); %d clipped pixels on the chrome ball"
                  % (name, method, len(lights), row["lower_bounds"], row["direction_deg"], row["strength"],
                     row["fitted_strength"], rms, corr, rms_fit, corr_fit, clipped), flush=True)
    with open(os.path.join(out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    print("\n| lighting | method | lights (lower bounds) | lamp direction error (deg) | lamp strength / truth | "
          "diffuse ball RMS (codes), correlation | fitted: lamp strength / truth | fitted: RMS, correlation |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %s | %d (%d) | %s | %s | %.2f, %.4f | %s | %.2f, %.4f |"
              % (r["lighting"], r["method"], r["lights"], r["lower_bounds"], r["direction_deg"], r["strength"],
                 r["rms_codes"], r["correlation"], r["fitted_strength"], r["fitted_rms_codes"],
                 r["fitted_correlation"]))


if __name__ == "__main__":
    sys.exit(main())
