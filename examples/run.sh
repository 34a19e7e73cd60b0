#!/usr/bin/env bash
# The main job on data the repository generates (no ../shared needed):
# a synthetic capture of a room with a sun, a virtual object inserted into
# every frame by differential path tracing, and the error against the
# capture's ground truth over time.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
bin=build/bin
out=${1:-out/example}
preset=${PRESET:-small}
mkdir -p "$out"
"$bin/mr-synth" --preset "$preset" --out "$out/capture" --report "$out/synth-report.json"
"$bin/mr-info" "$out/capture/scene.json" "$out/capture/camera.cameramodel" "$out/capture/trajectory.txt" >/dev/null
"$bin/mr-render" "$out/capture/scene.json" --out "$out/render" --report "$out/render-report.json"
"$bin/mr-board" calib/boards/mrgingham-10x10-30mm.json --out "$out/board.svg" -q
# Calibration: synthetic photographs of a board through a known lens, solved
# by mrcal (the true model is in boards/truth/; three photographs are left
# out with their reasons, see calibrate-report.json).
"$bin/mr-synth" --boards pinhole --out "$out/boards" -q
"$bin/mr-calibrate" camera --board "$out/boards/board.json" --lensmodel LENSMODEL_PINHOLE \
  --out "$out/boards/camera.cameramodel" "$out"/boards/photos/camera-*.png --report "$out/calibrate-report.json" -q
# The light probe: the mirror sphere's centre from its silhouette in the
# fish-eye light camera (truth in capture/probe/truth.json).
"$bin/mr-calibrate" sphere --camera "$out/capture/probe/light.cameramodel" --radius 0.0254 \
  --out "$out/capture/probe.json" "$out/capture/probe/sphere.exr" --report "$out/sphere-report.json" -q
# The lighting capture: the bracketed 8-bit photographs of the sphere merged
# into HDR (response recovered and kept), unwrapped into a world-aligned map,
# and turned into lights: the sun as a blob plus the residual map, and 64
# lights by variance cut; then the scene rendered with the blob and residual
# instead of the true environment.
"$bin/mr-hdr" "$out"/capture/probe/bracket/sphere-*.png --exposures "$out/capture/probe/bracket/exposures.txt" \
  --save-response "$out/capture/response.json" --out "$out/capture/probe-raw.exr" --report "$out/hdr-report.json" -q
"$bin/mr-probe" "$out/capture/probe-raw.exr" --probe "$out/capture/probe.json" --reflectance 0.6 --width 256 \
  --out "$out/capture/env-captured.exr" --report "$out/probe-report.json" -q
"$bin/mr-lights" "$out/capture/env-captured.exr" --method blobs --count 4 --threshold 20 --out "$out/capture/lights-blobs.json" \
  --residual "$out/capture/env-residual.exr" --residual-width 256 --report "$out/lights-report.json" -q
"$bin/mr-lights" "$out/capture/env-captured.exr" --sweep --table "$out/lights-vs-count.csv" --plot "$out/lights-vs-count.svg" -q >/dev/null
/usr/bin/python3 - "$out/capture/scene.json" "$out/capture/scene-lights.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["lighting"] = {"environment": "env-residual.exr", "lights": "lights-blobs.json"}
s["output"]["dir"] = "render-lights"
json.dump(s, open(sys.argv[2], "w"), indent=2)
PY
"$bin/mr-render" "$out/capture/scene-lights.json" --out "$out/render-lights" --report "$out/render-lights-report.json" -q
# The same object by precomputed form factors (prt): the transfer, then a
# render of the scene with the method prt.
"$bin/mr-formfactor" "$out/capture/meshes/object.ply" --resolution 8 --out "$out/capture/object.ffc" -q \
  --report "$out/formfactor-report.json"
/usr/bin/python3 - "$out/capture/scene.json" "$out/capture/scene-prt.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["virtual"][0]["formfactors"] = "object.ffc"
s["output"]["dir"] = "render-prt"
json.dump(s, open(sys.argv[2], "w"), indent=2)
PY
"$bin/mr-render" "$out/capture/scene-prt.json" --method prt --out "$out/render-prt" --report "$out/render-prt-report.json" -q
# The fast differential GI methods against pt: error against run time.
"$bin/mr-eval" sweep "$out/capture/scene.json" --out "$out/sweep" --methods pt,ic,vpl,vct --pt-spp 1,4,16,64 --vct-resolution 16,32 --vct-spp 4 \
  --ic-rays 32,128 --ic-spp 4,16 --vpl-paths 64,256 --vpl-spp 2,8 --report "$out/sweep-report.json" -q
# The room from RGB-D: a synthetic Kinect-like recording of the room,
# reconstructed by mr-fuse (tracking, hashed TSDF, meshing, albedo de-lit by
# the captured environment), then its trajectory and mesh against the truth.
"$bin/mr-synth" --rgbd --rgbd-size 160,120,60 --out "$out/rgbd" -q
"$bin/mr-fuse" "$out/rgbd" --out "$out/room" --first-pose reference --env "$out/capture/env-captured.exr" \
  --albedo-rays 64 --report "$out/fuse-report.json" -q
"$bin/mr-eval" traj "$out/room/trajectory.txt" "$out/rgbd/groundtruth.txt" --report "$out/traj-report.json" -q > /dev/null
"$bin/mr-eval" mesh "$out/room/room.ply" "$out/rgbd/reference/room.ply" --samples 50000 --report "$out/mesh-report.json" -q > /dev/null
echo
echo "composites:     $out/render/*.png (layers in $out/render/*.exr)"
echo "render report:  $out/render-report.json"
echo "prt composites: $out/render-prt/*.png (report $out/render-prt-report.json)"
echo "captured light: $out/capture/env-captured.exr (from the 8-bit bracket), lights $out/capture/lights-blobs.json,"
echo "                composites lit by them: $out/render-lights/*.png; error vs lights: $out/lights-vs-count.csv/.svg"
echo "error vs time:  $out/sweep/sweep.csv, plots $out/sweep/error-vs-time*.png/.svg, differences $out/sweep/diff/"
echo "room from RGB-D: $out/room/room.ply, trajectory $out/room/trajectory.txt, report $out/room/fuse-report.json"
/usr/bin/python3 - "$out" <<'PY' || true
import json, sys
o = sys.argv[1]
t = json.load(open(o + "/traj-report.json"))["metrics"]
m = json.load(open(o + "/mesh-report.json"))["metrics"]
f = json.load(open(o + "/fuse-report.json"))["metrics"]["summary"]
print("                 ATE %.1f mm, mesh accuracy %.1f mm mean, %d frames at %.1f frames/s, %d lost"
      % (1000 * t["ate"]["rmse_m"], 1000 * m["accuracy"]["mean_m"], f["frames"], f["frames_per_second"], f["lost"]))
PY
echo "error vs time:  metrics.curve in $out/render-report.json:"
/usr/bin/python3 - "$out/render-report.json" <<'PY' || true
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
print("  %8s %6s %12s %14s" % ("seconds", "spp", "relMSE", "region relMSE"))
for c in m.get("curve", []):
    print("  %8.3f %6d %12.4g %14.4g" % (c["seconds"], c["spp"], c["relmse"], c["region_relmse"]))
p = json.load(open(sys.argv[1].replace("render-report", "render-prt-report")))["metrics"]
print("  prt: relMSE %.4g, region relMSE %.4g (the object only: no shadows on the room)" % (p["relmse"], p["region_relmse"]))
l = json.load(open(sys.argv[1].replace("render-report", "render-lights-report")))["metrics"]
print("  lit by the captured probe's lights + residual: relMSE %.4g, region relMSE %.4g" % (l["relmse"], l["region_relmse"]))
PY
