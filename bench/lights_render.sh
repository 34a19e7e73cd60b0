#!/bin/bash
# The rendered-image half of mr-lights' error-vs-count curve: mr-synth's
# small capture, its environment replaced by N extracted lights (blobs:
# the lights plus the residual map as the environment), rendered with
# mr-render pt and compared with the capture's truth (lit by the full map).
# Usage: bench/lights_render.sh [BIN_DIR] [OUT_DIR]; writes OUT/render.csv.
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-out/bench-lights}
SPP=${SPP:-64}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
[ -f "$OUT/capture/scene.json" ] || "$BIN/mr-synth" --out "$OUT/capture" --seed 1 -q
PY=$(command -v python3)
scene() {  # scene(lights_json, environment_or_empty, out_scene)
  "$PY" - "$OUT/capture/scene.json" "$1" "$2" "$3" <<'PYEOF'
import json, sys
s = json.load(open(sys.argv[1]))
s["lighting"] = {"lights": sys.argv[2]}
if sys.argv[3]:
    s["lighting"]["environment"] = sys.argv[3]
s["output"] = {"dir": "render-lights", "png": False}
json.dump(s, open(sys.argv[4], "w"), indent=1)
PYEOF
}
metric() { "$PY" -c "import json,sys; r=json.load(open(sys.argv[1])); m=r['metrics']; t=r['timings']; print(eval(sys.argv[2]))" "$@"; }
echo "method,count,lights,extract_s,render_s,relmse,region_relmse" > "$OUT/render.csv"
# The full map itself, the floor (Monte Carlo noise at this spp).
"$BIN/mr-render" "$OUT/capture/scene.json" --out "$OUT/r-env" --spp "$SPP" --report "$OUT/rr.json" -q
echo "environment,0,0,0,$(metric "$OUT/rr.json" "t['total']"),$(metric "$OUT/rr.json" "m['relmse']"),$(metric "$OUT/rr.json" "m['region_relmse']")" >> "$OUT/render.csv"
for m in median-cut variance-cut importance blobs; do
  for n in 1 4 16 64 256 1024; do
    args=(--method "$m" --count "$n" --out "$OUT/lights.json" --report "$OUT/lr.json" -q)
    env=""
    if [ "$m" = blobs ]; then
      [ "$n" -gt 16 ] && continue
      args+=(--residual "$OUT/residual.exr" --residual-width 256)
      env="$OUT/residual.exr"
    fi
    "$BIN/mr-lights" "$OUT/capture/env.exr" "${args[@]}"
    scene "$OUT/lights.json" "$env" "$OUT/capture/scene-lights.json"
    "$BIN/mr-render" "$OUT/capture/scene-lights.json" --out "$OUT/r" --spp "$SPP" --report "$OUT/rr.json" -q
    echo "$m,$n,$(metric "$OUT/lr.json" "m['lights']"),$(metric "$OUT/lr.json" "m['extraction_seconds']"),$(metric "$OUT/rr.json" "t['total']"),$(metric "$OUT/rr.json" "m['relmse']"),$(metric "$OUT/rr.json" "m['region_relmse']")" >> "$OUT/render.csv"
    tail -1 "$OUT/render.csv"
  done
done
