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
echo
echo "composites:     $out/render/*.png (layers in $out/render/*.exr)"
echo "render report:  $out/render-report.json"
echo "error vs time:  metrics.curve in $out/render-report.json:"
/usr/bin/python3 - "$out/render-report.json" <<'PY' || true
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
print("  %8s %6s %12s %14s" % ("seconds", "spp", "relMSE", "region relMSE"))
for c in m.get("curve", []):
    print("  %8.3f %6d %12.4g %14.4g" % (c["seconds"], c["spp"], c["relmse"], c["region_relmse"]))
PY
