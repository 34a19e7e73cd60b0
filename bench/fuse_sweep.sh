#!/bin/bash
# mr-fuse's error against run time: voxel size x ICP iterations on the
# synthetic room (mr-synth --rgbd --preset room: 300 frames at 640x480 with
# Kinect-like noise, true trajectory and geometry) and on the real 7-Scenes
# kitchen (ATE against its KinectFusion reference; no reference mesh).
# Usage: bench/fuse_sweep.sh [BIN_DIR] [OUT_DIR] [SHARED_DATA]; writes OUT/fuse.csv
# and OUT/fuse-*.svg.
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-out/bench-fuse}
DATA=${3:-../shared/data}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
[ -f "$OUT/room/groundtruth.txt" ] || "$BIN/mr-synth" --rgbd --preset room --out "$OUT/room" -q
PY=$(command -v python3)
metric() { "$PY" -c "import json,sys; r=json.load(open(sys.argv[1])); m=r['metrics']; print(eval(sys.argv[2]))" "$@"; }
echo "dataset,voxel_m,icp_iterations,ate_m,rpe_m,mesh_accuracy_m,mesh_within_1cm,ms_per_frame,fps,peak_mb,lost" > "$OUT/fuse.csv"
run() {  # run(dataset, input, reference_trajectory, reference_mesh_or_empty)
  for v in 0.01 0.02 0.04; do
    for it in 2,1,1 4,5,4 10,5,4; do
      "$BIN/mr-fuse" "$2" --out "$OUT/f" --voxel "$v" --icp-iterations "$it" --first-pose reference --no-albedo \
        --report "$OUT/f.json" -q
      "$BIN/mr-eval" traj "$OUT/f/trajectory.txt" "$3" --report "$OUT/t.json" -q > /dev/null
      acc=""; within=""
      if [ -n "$4" ]; then
        "$BIN/mr-eval" mesh "$OUT/f/room.ply" "$4" --report "$OUT/m.json" -q > /dev/null
        acc=$(metric "$OUT/m.json" "m['accuracy']['mean_m']")
        within=$(metric "$OUT/m.json" "m['accuracy']['within_threshold']")
      fi
      fps=$(metric "$OUT/f.json" "m['summary']['frames_per_second']")
      echo "$1,$v,${it//,/-},$(metric "$OUT/t.json" "m['ate']['rmse_m']"),$(metric "$OUT/t.json" "m['rpe']['trans_rmse_m']"),$acc,$within,$("$PY" -c "print(1000/$fps)"),$fps,$(metric "$OUT/f.json" "m['summary']['peak_volume_bytes']/1e6"),$(metric "$OUT/f.json" "m['summary']['lost']")" >> "$OUT/fuse.csv"
      tail -1 "$OUT/fuse.csv"
    done
  done
}
run synthetic-room "$OUT/room" "$OUT/room/groundtruth.txt" "$OUT/room/reference/room.ply"
[ -d "$DATA/rgbd-7scenes-kitchen" ] && run 7scenes-kitchen "$DATA/rgbd-7scenes-kitchen" "$DATA/rgbd-7scenes-kitchen" ""
"$PY" - "$OUT/fuse.csv" <<'PYEOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
for r in rows:
    r["config"] = f"{r['dataset']} {float(r['voxel_m'])*100:g} cm"
with open(sys.argv[1].replace(".csv", "-plot.csv"), "w") as f:
    w = csv.writer(f)
    w.writerow(["config", "ms_per_frame", "ate_m", "mesh_accuracy_m"])
    for r in rows:
        w.writerow([r["config"], r["ms_per_frame"], r["ate_m"], r["mesh_accuracy_m"] or "nan"])
PYEOF
"$BIN/mr-eval" plot "$OUT/fuse-plot.csv" --x ms_per_frame --y ate_m --group config --title "mr-fuse: ATE against time per frame (ICP iterations 2-1-1, 4-5-4, 10-5-4)" --out "$OUT/fuse-ate.svg"
echo "wrote $OUT/fuse.csv and $OUT/fuse-ate.svg"
