#!/usr/bin/env bash
# The chain on real data (../shared/data, which users do not have: this
# example skips with a message without it): Microsoft 7-Scenes "redkitchen"
# (300 RGB-D frames). mr-pipeline fuses every 10th depth frame into the room,
# registers the 30 matching colour frames with COLMAP and aligns them to the
# fused trajectory, extracts lights from a real light probe (grace.hdr; the
# kitchen's own light was not captured), fits the plate's gains per frame
# against the rendered room (mr-eval plate: no hand-set exposure) and
# renders the Stanford bunny, set upright on a surface in front of the first
# camera, into the colour frames with vct.  About 7 minutes on 2 cores after the build (COLMAP may run up
# to 3 times: see docs/benchmarks.md).
# Usage: examples/real/run.sh [OUT] [SHARED_DATA]
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-out/real}
data=${2:-${MR_SHARED_DATA:-../shared/data}}
kitchen=$data/rgbd-7scenes-kitchen
if [ ! -d "$kitchen" ] || [ ! -f "$data/meshes/bun_zipper_res2.ply" ] || [ ! -f "$data/probes-latlong/grace.hdr" ]; then
  echo "examples/real: skipped: the real data is not at $data (rgbd-7scenes-kitchen, meshes, probes-latlong; see ../shared/data/README.md)"
  exit 0
fi
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
bin=build/bin
data=$(cd "$data" && pwd)
kitchen=$data/rgbd-7scenes-kitchen
mkdir -p "$out/video"
out=$(cd "$out" && pwd)
# The video (every 10th colour frame) and its camera (examples/real/kitchen-video.sh).
source examples/real/kitchen-video.sh
kitchen_video "$kitchen" "$out"
# The room's frame is the first camera's (y down): the probe's zenith goes
# against gravity (7-Scenes gives it in that frame).
up=$(/usr/bin/python3 -c "import numpy as n, sys; g = n.loadtxt(sys.argv[1]); g /= n.linalg.norm(g); print('[%.6f, %.6f, %.6f]' % tuple(-g))" "$kitchen/gravity-direction.txt")
write_pipeline() {  # write_pipeline TRANSFORM_JSON
  cat > "$out/pipeline.json" <<JSON
{
  "version": 1,
  "comment": "examples/real/run.sh: 7-Scenes redkitchen, COLMAP poses aligned to the fused room, the bunny under grace.hdr",
  "work": "work",
  "camera": {"model": "kitchen.cameramodel"},
  "lighting": {
    "environment": "$data/probes-latlong/grace.hdr", "environment_up": $up,
    "lights": {"options": {"method": "blobs", "count": 4, "threshold": 20, "residual-width": 128}}
  },
  "room": {"rgbd": "$kitchen", "options": {"stride": 10, "voxel": 0.02, "albedo-rays": 32}},
  "video": {"frames": "video/%05d.jpg", "frames_transfer": "display",
            "gains": {"options": {"spp": 16, "stride": 3, "images": true}},
            "poses": {"register": {"matcher": "sequential", "overlap": 10}}},
  "virtual": [{"name": "bunny", "mesh": "$data/meshes/bun_zipper_res2.ply", "transform": $1,
               "material": {"albedo": [0.75, 0.72, 0.68]}}],
  "render": {"method": "vct", "spp": 8, "seed": 1}
}
JSON
}
# The bunny upright (its +y against gravity) on the table top seen at pixel
# (330, 300) of the first frame (scene.json's transform.at_pixel: the ray
# through that pixel meets the fused room; the same pixel places it on the
# planes of examples/real/no-depth.sh).
transform=$(/usr/bin/python3 - "$up" <<'PY'
import json, math, sys
import numpy as np
y = np.array(json.loads(sys.argv[1])); y /= np.linalg.norm(y)
x = np.cross(y, [0, 0, 1.0]); x /= np.linalg.norm(x); z = np.cross(x, y)
R = np.stack([x, y, z], axis=1)   # object y -> up
# R = Rz Ry Rx (scene.json's rotation_deg order)
ry = math.asin(-R[2, 0]); rx = math.atan2(R[2, 1], R[2, 2]); rz = math.atan2(R[1, 0], R[0, 0])
print(json.dumps({"at_pixel": {"frame": 0, "pixel": [330, 300]},
                  "rotation_deg": [math.degrees(rx), math.degrees(ry), math.degrees(rz)], "scale": 1.5}))
PY
)
write_pipeline "$transform"
"$bin/mr-pipeline" "$out/pipeline.json" --report "$out/pipeline-report.json"
w=$out/work
echo
echo "room:        $w/room/room.ply (every 10th depth frame), trajectory $w/room/trajectory.txt"
echo "video poses: $w/video/poses.txt (COLMAP, aligned to the room); COLMAP's workspace $w/video/colmap"
echo "composites:  $w/render/*.png"
/usr/bin/python3 - "$w" <<'PYR' || true
import json, sys
w = sys.argv[1]
r = json.load(open(w + "/reports/register.json"))["metrics"]
a = r["alignment"]
print("registration: %d of %d frames registered; alignment to the fused trajectory: scale %.4g, "
      "centre residual %.1f mm RMS, rotation residual %.2f deg RMS"
      % (r["registered"], r["frames"], a["scale"], 1000 * a["centre_rmse_m"], a["rotation_rmse_deg"]))
f = json.load(open(w + "/reports/fuse.json"))["metrics"]["summary"]
print("fusion: %d frames, %d lost" % (f["frames"], f["lost"]))
p = json.load(open(w + "/reports/radiometry.json"))["metrics"]
print("plate gains (fitted, no hand-set exposure): R %.3f..%.3f G %.3f..%.3f B %.3f..%.3f, %d exposure jumps"
      % (p["gain_min"][0], p["gain_max"][0], p["gain_min"][1], p["gain_max"][1], p["gain_min"][2], p["gain_max"][2],
         p["exposure_jumps"]))
# (the radiometry stage renders the room alone, scene-plate.json: it has no
# pixels around the bunny, and its report no region error)
print("capture chain re-rendering the plate: relMSE %.4g, SSIM %.3f (%s/radiometry/*-rerender.png)"
      % (p["relmse"], p["ssim"], w))
g = p.get("registration")
if g:
    print("registration in pixels (the room rendered against the plate): %.1f px mean over %d frames, worst frame %.1f"
          % (g["mean_px"], g["frames_measured"], g["worst_mean_px"]))
pr = p.get("pose_refinement")
if pr:
    print("after refining the poses against the room: %.1f px mean over %d frames" % (pr["mean_px_after"], pr["frames_refined"]))
s = json.load(open(w + "/reports/render.json"))["metrics"].get("swim", {})
for name, v in s.items():
    print("swim of the %s against the plate: %.2f px RMS, %.2f at most, over %d frame steps" % (name, v["rms_px"], v["max_px"], v["frames"]))
PYR
