#!/bin/bash
# A world that changes during the video, measured (docs/benchmarks.md): the
# light captured from mr-synth --dynamic's light camera against the true
# skies (with and without the temporal filter), then every method over the
# frames against the truth, per frame and in flicker, with its world updates
# incremental and rebuilt.
# Usage: bench/dynamic.sh [BIN_DIR] [OUT_DIR] [PRESET] [FRAMES]; writes OUT/dynamic.csv, OUT/light.csv.
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-out/bench-dynamic}
PRESET=${3:-medium}
FRAMES=${4:-8}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
PY=/usr/bin/python3
C="$OUT/capture"
if [ ! -f "$C/scene.json" ]; then
  /usr/bin/time -f "truth: %e s" "$BIN/mr-synth" --preset "$PRESET" --dynamic --frames "$FRAMES" --truth-spp 256 \
    --out "$C" -q
fi
# The light: the light camera's video matched to the plate, exposures read.
echo "time_constant_s,mean_irradiance_relrms,mean_flicker" > "$OUT/light.csv"
for tau in 0 0.1 0.3; do
  "$BIN/mr-probe" --light "$C/lightcam/frames.txt" --fisheye "$C/lightcam/fisheye.cameramodel" \
    --plate-times "$C/trajectory.txt" --exposures "$C/lightcam/exposures.txt" --width 256 --time-constant "$tau" \
    --out "$OUT/env-$tau/%05d.exr" -q
  "$BIN/mr-eval" light "$OUT/env-$tau/%05d.exr" "$C/env/%05d.exr" --report "$OUT/light-$tau.json" -q > /dev/null
  "$PY" -c "import json,sys; m=json.load(open(sys.argv[1]))['metrics']; print('%s,%.4g,%.4g' % (sys.argv[2], m['mean_irradiance_relrms'], m['mean_flicker']))" \
    "$OUT/light-$tau.json" "$tau" >> "$OUT/light.csv"
done
# Every method, world updates incremental and rebuilt.
echo "method,spp,world_update,mean_region_relmse,flicker,seconds_per_frame,world_update_seconds" > "$OUT/dynamic.csv"
for ms in pt:64 ic:8 vpl:8 vct:8; do
  m=${ms%:*}
  spp=${ms#*:}
  for wu in incremental rebuild; do
    [ "$m" = pt ] && [ "$wu" = rebuild ] && continue
    "$PY" -c "import json,sys; s=json.load(open(sys.argv[1])); s['render']['world_update']=sys.argv[2]; json.dump(s, open(sys.argv[3], 'w'), indent=1)" \
      "$C/scene.json" "$wu" "$C/scene-$wu.json"
    "$BIN/mr-render" "$C/scene-$wu.json" --method "$m" --spp "$spp" --out "$OUT/r-$m-$wu" --report "$OUT/r-$m-$wu.json" -q
    "$PY" - "$OUT/r-$m-$wu.json" "$m" "$spp" "$wu" >> "$OUT/dynamic.csv" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
m = r["metrics"]
fr = m["frames"]
mean = sum(f["region_relmse"] for f in fr) / len(fr)
sec = sum(f["seconds"] for f in fr) / len(fr)
wu = r.get("timings", {}).get("world update", 0.0) / max(1, len(fr) - 1)
print("%s,%s,%s,%.4g,%.4g,%.3g,%.3g" % (sys.argv[2], sys.argv[3], sys.argv[4], mean, m["flicker"], sec, wu))
PY
  done
done
cat "$OUT/light.csv" "$OUT/dynamic.csv"
