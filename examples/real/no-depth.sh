#!/usr/bin/env bash
# The kitchen of examples/real/run.sh without its depth sensor: the room is
# what the colour video alone supports. COLMAP registers the 30 frames with
# no trajectory to align to (its own frame and units) and writes its sparse
# points (mr-register --points-out); mr-planes turns them into the room's
# planes (floor, table top, counter), scaled to metres by the camera's
# height over the floor (1.37 m: a number a user states; here it is the
# fused room's, measured once, see docs/benchmarks.md), in the first
# camera's frame as mr-fuse's room is; the pipeline then renders the bunny,
# stood on the table top at the same pixel of the first frame as
# run.sh, under the same light. With DEPTH_OUT (run.sh's output) the two
# composites are compared frame by frame.
# About 5 minutes on 2 cores after the build.
# Usage: examples/real/no-depth.sh [OUT] [SHARED_DATA] [DEPTH_OUT]
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-out/real-no-depth}
data=${2:-${MR_SHARED_DATA:-../shared/data}}
depth_out=${3:-}
kitchen=$data/rgbd-7scenes-kitchen
if [ ! -d "$kitchen" ] || [ ! -f "$data/meshes/bun_zipper_res2.ply" ] || [ ! -f "$data/probes-latlong/grace.hdr" ]; then
  echo "examples/real/no-depth: skipped: the real data is not at $data (rgbd-7scenes-kitchen, meshes, probes-latlong; see ../shared/data/README.md)"
  exit 0
fi
if [ -z "${MR_BIN:-}" ]; then
  bash scripts/install-deps.sh
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build build -j "$(nproc)"
fi
bin=$(cd "${MR_BIN:-build/bin}" && pwd)
data=$(cd "$data" && pwd)
kitchen=$data/rgbd-7scenes-kitchen
mkdir -p "$out/video" "$out/planes"
out=$(cd "$out" && pwd)
# The video (every 10th colour frame) and its camera (examples/real/kitchen-video.sh).
source examples/real/kitchen-video.sh
kitchen_video "$kitchen" "$out"
w=$out/planes
# 1. COLMAP alone: poses and points in its own frame and units. Exhaustive
# matching (435 pairs for 30 frames): the video returns to the table at its
# end, and without those matches COLMAP's sequential model of these frames
# folds its scale between frames 4 and 7 (with depth, mr-register refuses
# such a model against the fused trajectory; here nothing could).
"$bin/mr-register" colmap "$out/video/%05d.jpg" --workspace "$w/colmap" --camera "$out/kitchen.cameramodel" --matcher exhaustive \
  --out "$w/poses-colmap.tum" --points-out "$w/points.ply" --report "$w/register.json"
# 2. The room: the planes of its points, in metres, in the first camera's frame.
"$bin/mr-planes" "$w/points.ply" --poses "$w/poses-colmap.tum" --camera "$out/kitchen.cameramodel" \
  --frames "$out/video/%05d.jpg" --height 1.37 --world first-camera --poses-out "$w/poses.tum" \
  --out "$w/room.ply" --report "$w/planes.json"
# 3. The chain on that room: run.sh's light, gains and render; up is the
# planes' (the floor's normal), the bunny upright on what pixel (330, 300)
# of the first frame sees.
read -r up transform < <(/usr/bin/python3 - "$w/planes.json" <<'PY'
import json, math, sys
import numpy as np
y = np.array(json.load(open(sys.argv[1]))["metrics"]["up"]["direction"]); y /= np.linalg.norm(y)
x = np.cross(y, [0, 0, 1.0]); x /= np.linalg.norm(x); z = np.cross(x, y)
R = np.stack([x, y, z], axis=1)   # object y -> up; R = Rz Ry Rx
ry = math.asin(-R[2, 0]); rx = math.atan2(R[2, 1], R[2, 2]); rz = math.atan2(R[1, 0], R[0, 0])
print(json.dumps(list(y)).replace(" ", ""),
      json.dumps({"at_pixel": {"frame": 0, "pixel": [330, 300]},
                  "rotation_deg": [math.degrees(rx), math.degrees(ry), math.degrees(rz)], "scale": 1.5}))
PY
)
cat > "$out/pipeline.json" <<JSON
{
  "version": 1,
  "comment": "examples/real/no-depth.sh: 7-Scenes redkitchen from its colour video alone: COLMAP's points as planes, the bunny under grace.hdr",
  "work": "work",
  "camera": {"model": "kitchen.cameramodel"},
  "lighting": {
    "environment": "$data/probes-latlong/grace.hdr", "environment_up": $up,
    "lights": {"options": {"method": "blobs", "count": 4, "threshold": 20, "residual-width": 128}}
  },
  "room": {"real": [{"mesh": "planes/room.ply", "material": {"albedo_from_vertex_colors": true}}]},
  "video": {"frames": "video/%05d.jpg", "frames_transfer": "display",
            "gains": {"options": {"spp": 16, "stride": 3, "images": true}},
            "poses": {"tum": "planes/poses.tum"}},
  "virtual": [{"name": "bunny", "mesh": "$data/meshes/bun_zipper_res2.ply", "transform": $transform,
               "material": {"albedo": [0.75, 0.72, 0.68]}}],
  "render": {"method": "vct", "spp": 8, "seed": 1}
}
JSON
"$bin/mr-pipeline" "$out/pipeline.json" --report "$out/pipeline-report.json"
echo
echo "room:        $w/room.ply (planes of COLMAP's points; $w/planes.json lists them)"
echo "composites:  $out/work/render/*.png"
/usr/bin/python3 - "$out" "$depth_out" <<'PYR' || true
import glob, json, os, sys
import numpy as np
out, depth = sys.argv[1], sys.argv[2]
w = out + "/work"
p = json.load(open(out + "/planes/planes.json"))["metrics"]
print("planes: %d (up from %s, %.1f deg from the cameras' mean up), %d of %d points on none, scale %.4g"
      % (len(p["planes"]), p["up"]["from"], p["up"]["from_hint_deg"], p["points"]["unexplained"], p["points"]["total"],
         p["scale"]["factor"]))
for i, q in enumerate(p["planes"]):
    print("  %d %-10s %5d points, rms %.1f mm, turned %.1f deg" % (i, q["kind"], q["inliers"], 1000 * q["rms"], q["turned_deg"]))
r = json.load(open(w + "/reports/radiometry.json"))["metrics"]
g = r.get("registration")
if g:
    print("registration in pixels (the planes rendered against the plate): %.1f px mean, worst frame %.1f"
          % (g["mean_px"], g["worst_mean_px"]))
s = json.load(open(w + "/reports/render.json"))["metrics"].get("swim", {})
for name, v in s.items():
    print("swim of the %s: %.2f px RMS over %d frame steps" % (name, v["rms_px"], v["frames"]))
if depth and os.path.isdir(depth + "/work/render"):
    import cv2
    plates = sorted(glob.glob(out + "/video/*.jpg"))
    a_all, b_all = sorted(glob.glob(w + "/render/*.png")), sorted(glob.glob(depth + "/work/render/*.png"))
    diffs = []
    for pa, pb, pp in zip(a_all, b_all, plates):
        a, b, c = (cv2.imread(x).astype(float) for x in (pa, pb, pp))
        ca, cb = np.abs(a - c).sum(2) > 6, np.abs(b - c).sum(2) > 6   # pixels each composite changed
        iou = (ca & cb).sum() / max(1, (ca | cb).sum())
        diffs.append((iou, ca.sum(), cb.sum(), np.abs(a - b)[ca | cb].mean() if (ca | cb).any() else 0))
    d = np.array(diffs)
    print("against the fused room's composites (%s): changed pixels overlap (IoU) %.2f mean, %.2f worst; "
          "changed %.0f px without depth vs %.0f with; mean |difference| where either changed %.1f of 255"
          % (depth, d[:, 0].mean(), d[:, 0].min(), d[:, 1].mean(), d[:, 2].mean(), d[:, 3].mean()))
PYR
