#!/usr/bin/env bash
# The main job on example data the repository generates (no ../shared needed).
# Today (foundation): builds mr, generates a calibration board, a camera model,
# a room mesh, a trajectory and a scene, and checks every file with mr-info.
# The stage issues grow this into the full capture-and-relight pipeline.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
bin=build/bin
out=${1:-out/example}
mkdir -p "$out"
"$bin/mr-board" calib/boards/mrgingham-10x10-30mm.json --out "$out/board.svg"
cp examples/scene/* "$out/"
"$bin/mr-info" "$out/scene.cameramodel" "$out/room.obj" "$out/cube.obj" "$out/trajectory.txt" "$out/scene.json" \
               calib/boards/mrgingham-10x10-30mm.json
echo "example outputs in $out"
