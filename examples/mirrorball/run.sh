#!/usr/bin/env bash
# The classic image-based-lighting insertion on real photographs
# (../shared/data/mirrorball-iphone, which users do not have: this example
# skips with a message without it). An iPhone 7 photographed a mirror ball on
# a granite counter at 1/10, 1/40 and 1/160 s, then the empty counter from
# about the same place (1/15 s, auto exposure). mr merges the bracket
# (mr-hdr, response recovered), locates the ball (mr-calibrate sphere) and
# unwraps it into a map (mr-probe); the local scene is the counter top, a
# plane placed by hand (below); mr-eval plate fits the photograph's gain
# against the plane rendered under the map, and mr-render puts a bunny and a
# chrome ball on the counter with pt, the plate in their reflections; then a
# generated glTF asset (textured base, steel, glass) beside the bunny; then
# the lamps placed on a ceiling, their reflections in the granite left to it.
# About 6 minutes on 2 cores after the build.
# Usage: examples/mirrorball/run.sh [OUT] [SHARED_DATA]
set -euo pipefail
cd "$(dirname "$0")/../.."
repo=$(pwd)
out=${1:-out/mirrorball}
data=${2:-${MR_SHARED_DATA:-../shared/data}}
mb=$data/mirrorball-iphone
if [ ! -d "$mb/mirrorball" ] || [ ! -f "$mb/background/bg_iphone7.JPG" ] || [ ! -f "$data/meshes/bun_zipper_res2.ply" ]; then
  echo "examples/mirrorball: skipped: the real data is not at $data (mirrorball-iphone, meshes; see ../shared/data/README.md)"
  exit 0
fi
if [ -z "${MR_BIN:-}" ]; then
  bash scripts/install-deps.sh
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build build -j "$(nproc)"
fi
bin=${MR_BIN:-build/bin}
bin=$(cd "$bin" && pwd)
data=$(cd "$data" && pwd)
mb=$data/mirrorball-iphone
mkdir -p "$out/plate"
out=$(cd "$out" && pwd)
cd "$out"

# 1. The light: the bracket merged (the phone's response recovered from it,
# times and f-number from EXIF), the ball located, unwrapped. The crops come
# from a 4032-pixel-wide frame: the lens is the iPhone 7's 28 mm equivalent
# (3261 px over the 4:3 frame's 5040-pixel diagonal), centred on the crop
# (the ball spans 8 degrees: nearly orthographic, the centre barely matters).
"$bin/mr-hdr" "$mb"/mirrorball/ball_exp_1-*.JPG --align --out ball.exr --save-response response.json --report hdr.json
read -r w h < <(oiiotool --info ball.exr | sed -E 's/.*: *([0-9]+) x +([0-9]+),.*/\1 \2/')
cat > ball.cameramodel <<CAM
# iPhone 7 back camera, 28 mm equivalent, centred on the ball's crop (examples/mirrorball/run.sh)
{
    'lensmodel':  'LENSMODEL_PINHOLE',
    'intrinsics': [ 3261, 3261, $(((w - 1) / 2)), $(((h - 1) / 2)), ],
    'imagersize': [ $w, $h, ],
    'extrinsics': [ 0, 0, 0, 0, 0, 0, ],
}
CAM
# The Hough transform prefers a round reflection inside this ball to its
# outline (docs/benchmarks.md): the circle is given, as measured on the crop.
"$bin/mr-calibrate" sphere --camera ball.cameramodel --radius 0.0254 \
  --circle "$((w / 2)),$((h / 2 + 5)),232" --out probe.json --report sphere.json ball.exr
# The world is the ball's camera frame (x right, y down, z forward), and the
# counter's photograph is taken as shot from the same place in the same
# direction (the two photographs' premise).
"$bin/mr-probe" ball.exr --probe probe.json --width 512 --out env.exr --report probe-report.json

# 2. The plate: the empty counter at 480x640 (a 0.159 scale of the
# 3024x4032 photograph, so f = 3261 x 0.159 = 517.6 px).
oiiotool "$mb/background/bg_iphone7.JPG" --resize 480x640 -d uint8 -o plate/00000.png
cat > plate.cameramodel <<'CAM'
# iPhone 7 back camera, 28 mm equivalent, at 480x640 (examples/mirrorball/run.sh)
{
    'lensmodel':  'LENSMODEL_PINHOLE',
    'intrinsics': [ 517.6, 517.6, 239.5, 319.5, ],
    'imagersize': [ 480, 640, ],
    'extrinsics': [ 0, 0, 0, 0, 0, 0, ],
}
CAM
echo "0 0 0 0 0 0 0 1" > poses.txt  # the camera is the world frame

# 3. The local scene, by hand (mr-planes needs points that two or more
# views with parallax triangulate; this is one photograph, and the ball's
# crops are blurred close-ups of the ball: docs/benchmarks.md). The objects
# are stood on it at pixels of the plate (transform.at_pixel), so that they
# rest on the counter exactly: the counter is a plane 0.35 m below the camera
# (the scale is a choice: it sets the objects' size), the camera pitched
# 26 degrees down (where the counter's edge meets the room in the ball's
# reflection, 0.21 of its radius below the centre: 2 asin(0.21) = 24 degrees,
# plus the edge's 2-3 degrees below the ball's horizon), its far edge 1.35 m
# ahead (the top of the counter in the plate). It is a 64x64 grid whose
# texture coordinates are its projection into the plate (clamped to the
# frame), for the albedo texture of step 5.
/usr/bin/python3 - "$data/meshes/bun_zipper_res2.ply" <<'PY'
import json, math, sys
import numpy as np
th, h = math.radians(26), 0.35
up = np.array([0, -math.cos(th), -math.sin(th)])   # world up in the camera frame
right = np.array([1.0, 0, 0])
fwd = np.cross(up, right)                          # horizontal, away from the camera
foot = -h * up                                     # the counter below the camera
f, cx, cy, W, H = 517.6, 239.5, 319.5, 480, 640
n = 64
with open("counter.obj", "w") as out:
    out.write("# the counter top, textured by its projection into the plate (examples/mirrorball/run.sh)\n")
    for j in range(n + 1):
        for i in range(n + 1):
            p = foot + (-1.5 + 3.0 * i / n) * right + (0.05 + 1.3 * j / n) * fwd
            u = np.clip((f * p[0] / p[2] + cx + 0.5) / W, 0.001, 0.999)
            v = np.clip(1 - (f * p[1] / p[2] + cy + 0.5) / H, 0.001, 0.999)  # (0, 0) at the bottom left
            out.write("v %.6f %.6f %.6f\nvt %.6f %.6f\n" % (p[0], p[1], p[2], u, v))
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i + 1
            b, c, d = a + 1, a + n + 1, a + n + 2
            out.write("f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n" % (a, a, c, c, d, d, a, a, d, d, b, b))
# A chrome ball, 5 cm in radius: flat facets (mr shades with the geometric
# normal), fine enough that a facet is below a pixel here.
n, m = 256, 128
with open("ball.obj", "w") as out:
    out.write("# a unit UV sphere\n")
    for j in range(m + 1):
        t = math.pi * j / m
        for i in range(n):
            p = 2 * math.pi * i / n
            out.write("v %.6f %.6f %.6f\n" % (math.sin(t) * math.cos(p), math.cos(t), math.sin(t) * math.sin(p)))
    for j in range(m):
        for i in range(n):
            a, b = j * n + i + 1, j * n + (i + 1) % n + 1
            c, d = a + n, b + n
            out.write("f %d %d %d\nf %d %d %d\n" % (a, b, d, a, d, c))
R = np.stack([right, up, np.cross(right, up)], axis=1)   # object +y up
# Each object stood on the counter seen at a pixel of the plate (scene.json's
# transform.at_pixel, along the counter's up: the world here is the camera's
# frame, whose +y is the environment's up, not the room's).
def standing(scale, pixel):
    ry = math.asin(-R[2, 0]); rx = math.atan2(R[2, 1], R[2, 2]); rz = math.atan2(R[1, 0], R[0, 0])  # R = Rz Ry Rx
    return {"at_pixel": {"frame": 0, "pixel": pixel, "up": [float(x) for x in up]},
            "rotation_deg": [math.degrees(rx), math.degrees(ry), math.degrees(rz)], "scale": scale}
scene = {
    "version": 1,
    "comment": "examples/mirrorball/run.sh: a bunny and a chrome ball on a real granite counter, lit by a real mirror ball",
    "camera": {"model": "plate.cameramodel", "frames": "plate/%05d.png", "frames_transfer": "response",
               "response": "response.json", "exposure": 0.0666667 / 1.8 ** 2,
               "poses": {"format": "tum", "path": "poses.txt"}},
    "lighting": {"environment": "env.exr"},
    "real": {"mesh": "counter.obj", "material": {"albedo": [0.5, 0.5, 0.5]}},
    "virtual": [
        {"name": "bunny", "mesh": sys.argv[1], "transform": standing(1.0, [176, 378]),
         "material": {"albedo": [0.75, 0.72, 0.68]}},
        {"name": "chrome", "mesh": "ball.obj", "transform": standing(0.05, [388, 428]),
         "material": {"albedo": [0, 0, 0], "specular": [0.9, 0.9, 0.9], "roughness": 0.02}}],
    "render": {"method": "pt", "spp": 256, "seed": 1},
    # One photograph cannot tell the granite's speckle from sensor noise
    # (docs/radiometry.md, "Grain"): no grain.
    "output": {"png": True, "review": True, "grain": "off"}}
json.dump(scene, open("scene-uniform.json", "w"), indent=1)
PY

# 4. The photograph's gain against the counter rendered under the map at a
# guessed albedo of 0.5 (response mode: the plate decoded through the
# bracket's response at its EXIF exposure; the gain is what the ISO, the
# albedo and the model leave over): the chain's re-rendering error.
"$bin/mr-eval" plate scene-uniform.json --out radiometry --spp 64 --images --report radiometry.json

# 5. The counter's own albedo, as Debevec's local scene: the plate over the
# room rendered at albedo 0.5 and the fitted gain (its irradiance, smoothed
# over 3 px against the render's noise), projected back as a texture.
/usr/bin/python3 -c "
import json; s = json.load(open('scene-uniform.json')); s['camera']['gains'] = 'radiometry/gains.json'
s['output'] = {'layers': ['composite', 'real', 'photo'], 'grain': 'off'}
json.dump(s, open('scene-delight.json', 'w'), indent=1)"
"$bin/mr-render" scene-delight.json --out delight --report delight.json
oiiotool delight/00000.exr --ch real.R,real.G,real.B --chnames R,G,B -o delight/real.exr
oiiotool delight/00000.exr --ch photo.R,photo.G,photo.B --chnames R,G,B -o delight/photo.exr
OPENCV_IO_ENABLE_OPENEXR=1 /usr/bin/python3 - <<'PY'
import json
import cv2
import numpy as np
real = cv2.imread("delight/real.exr", cv2.IMREAD_UNCHANGED)[:, :, ::-1]    # RGB
photo = cv2.imread("delight/photo.exr", cv2.IMREAD_UNCHANGED)[:, :, ::-1]
g = np.array(json.load(open("radiometry/gains.json"))["frames"][0]["gain"])
seen = (real.sum(axis=2) > 0).astype(np.float32)
blur = lambda x: cv2.GaussianBlur(x, (0, 0), 3)
irr = blur(real) / np.maximum(blur(seen), 1e-6)[:, :, None]   # over the room's pixels only
albedo = np.clip(0.5 * photo / np.maximum(g * irr, 1e-9), 0, 1)
albedo[seen == 0] = np.median(albedo[seen > 0], axis=0)
cv2.imwrite("counter-albedo.exr", np.ascontiguousarray(albedo[:, :, ::-1]).astype(np.float32))
print("counter albedo: median %.3f %.3f %.3f" % tuple(np.median(albedo[seen > 0], axis=0)))
s = json.load(open("scene-uniform.json"))
s["camera"]["gains"] = "radiometry/gains.json"
s["real"]["material"] = {"albedo_texture": "counter-albedo.exr"}
json.dump(s, open("scene.json", "w"), indent=1)
PY

# 6. The objects, in the plate's units, on the counter's own albedo.
"$bin/mr-render" scene.json --out render --report render.json
echo
/usr/bin/python3 - <<'PY' || true
import json
p = json.load(open("radiometry.json"))["metrics"]
print("plate gains R %.3f G %.3f B %.3f (the counter at albedo 0.5 under the ball's light, the plate at its EXIF exposure)"
      % tuple(p["gain_min"]))
print("the counter re-rendered at uniform albedo against the plate: relMSE %.4g, SSIM %.3f" % (p["relmse"], p["ssim"]))
f = json.load(open("render.json"))["metrics"]["frames"][0]
print("render: %d spp in %.1f s, %d negative pixels clamped; plate in reflections: %.0f%%"
      % (f["spp"], f["seconds"], f["clamped_negative"], 100 * f.get("plate_reflections", {}).get("share", 0)))
PY
# 7. A glTF asset as users bring them, generated by the project
# (examples/synthetic/make_asset.py: a tiled, normal-mapped base, a steel and
# a solid glass sphere) on the counter behind the bunny, rendered into the
# same real plate with pt: the glass shows the real counter behind it from
# the plate, the steel reflects it.
/usr/bin/python3 "$repo/examples/synthetic/make_asset.py" showcase.glb
/usr/bin/python3 - <<'PY'
import json, math
import numpy as np
th, h = math.radians(26), 0.35  # as in step 3
up = np.array([0, -math.cos(th), -math.sin(th)])
right = np.array([1.0, 0, 0])
fwd = np.cross(up, right)
R = np.stack([right, up, np.cross(right, up)], axis=1)
M = np.eye(4)
M[:3, :3] = R
M[:3, 3] = -h * up + 0.12 * right + 0.75 * fwd + 0.001 * up  # its base 1 mm above the counter
s = json.load(open("scene.json"))
s["virtual"] = [v for v in s["virtual"] if v["name"] == "bunny"] + [
    {"name": "showcase", "mesh": "showcase.glb", "transform": {"matrix": [float(x) for x in M.reshape(-1)]}}]
json.dump(s, open("scene-asset.json", "w"), indent=1)
PY
"$bin/mr-render" scene-asset.json --out render-asset --report render-asset.json
/usr/bin/python3 - <<'PY' || true
import json
f = json.load(open("render-asset.json"))["metrics"]["frames"][0]
p = f.get("plate_reflections", {})
print("asset: %d spp in %.1f s; real points seen in the steel or through the glass: %.0f%% from the plate "
      "(through the glass: %d, %.0f%% from the plate)" % (f["spp"], f["seconds"], 100 * p.get("share", 0),
                                                       p.get("through_glass", 0), 100 * p.get("through_glass_share", 0)))
PY
# 8. The lamps where they are (docs/methods.md, "Lights where they are"):
# the room is the counter and a ceiling 1.4 m above it (an assumption in
# the scene's scale, where the camera is 0.35 m above the counter: a 2.7 m
# ceiling over a 0.9 m counter photographed from 0.45 m above it), the
# ball on the counter where the plate's optical axis meets it.  mr-lights
# places the lamps it sees on the ceiling as area lights, leaves their
# reflections in the polished granite to the room (the two photographs
# were not taken from one place: the reflections lie 12-22 degrees from
# their lamps' mirror directions, hence --mirror-tolerance-deg 25), and
# splits the rest of the map into the room's own light (a probe) and what
# leaves the room.
/usr/bin/python3 - <<'PY'
import json, math
import numpy as np
th, h, hc = math.radians(26), 0.35, 1.4  # as in step 3; the ceiling's height above the counter
up = np.array([0, -math.cos(th), -math.sin(th)])
right = np.array([1.0, 0, 0])
fwd = np.cross(up, right)
centre = (hc - h) * up + 0.5 * fwd
corners = [centre + s * 3 * fwd + t * 3 * right for s, t in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
counter = open("counter.obj").read()
nv = sum(1 for l in counter.splitlines() if l.startswith("v "))
nvt = sum(1 for l in counter.splitlines() if l.startswith("vt ")) + 1
with open("counter-room.obj", "w") as out:  # the counter (textured) and the ceiling (facing down)
    out.write(counter + "# the ceiling, %.2f m above the counter\nvt 0.5 0.5\n" % hc)
    for c in corners:
        out.write("v %.6f %.6f %.6f\n" % tuple(c))
    a = nv + 1
    out.write("f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n" % (a, nvt, a + 1, nvt, a + 2, nvt, a, nvt, a + 2, nvt, a + 3, nvt))
probe = h / math.sin(th) * np.array([0, 0, 1.0]) + 0.0254 * up  # the ball's centre on the counter
open("probe-at.txt", "w").write(",".join("%.4f" % x for x in probe))
s = json.load(open("scene.json"))
s["real"]["mesh"] = "counter-room.obj"
s["lighting"] = {"environment": "sky.exr", "lights": "lights-room.json",
                 "probes": [{"at": [float(x) for x in probe], "map": "room-map.exr"}]}
json.dump(s, open("scene-room.json", "w"), indent=1)
PY
"$bin/mr-lights" env.exr --method blobs --count 12 --threshold 3 --room counter-room.obj --probe-at "$(cat probe-at.txt)" \
  --mirror-tolerance-deg 25 --out lights-room.json --residual sky.exr --room-map room-map.exr --report lights-room-report.json
"$bin/mr-render" scene-room.json --out render-room --report render-room.json
/usr/bin/python3 - <<'PY' || true
import json
p = json.load(open("lights-room-report.json"))["metrics"]
print("lamps placed: %d on the ceiling, %d reflections left to the room, %d at infinity; the map's light %.0f%% placed, "
      "%.0f%% the room's own, %.0f%% at infinity" % (p["positioned"]["lights"], p["positioned"]["reflections"],
      p["positioned"]["distant"], 100 * p["light_model"]["placed"], 100 * p["light_model"]["room"],
      100 * p["light_model"]["infinity"]))
PY
echo "map:        $out/env.exr"
echo "rerender:   $out/radiometry/00000-rerender.png"
echo "composite:  $out/render/00000.png; review sheet $out/render/00000-review.png"
echo "asset:      $out/render-asset/00000.png; review sheet $out/render-asset/00000-review.png"
echo "lamps placed: $out/render-room/00000.png"
