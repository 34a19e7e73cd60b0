#!/bin/bash
# The light captured from the mirror sphere in the plate, measured
# (docs/benchmarks.md): mr-synth --dynamic --plate-sphere's capture; the
# maps from the sphere in the plate and from the light camera's video, each
# against the light at the sphere's centre (reference/sphere/) and against
# the true skies (env/); then pt lit by each source (the lamp's lights file
# given in every case: it has no body a probe could see, and the sphere's
# maps hold its highlight too) against the truth, per frame and in flicker.
# Usage: bench/plate_sphere.sh [BIN_DIR] [OUT_DIR] [FRAMES] [SPP]; writes OUT/light.csv, OUT/render.csv.
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-out/bench-plate-sphere}
FRAMES=${3:-8}
SPP=${4:-32}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
PY=/usr/bin/python3
C="$OUT/capture"
if [ ! -f "$C/scene.json" ]; then
  /usr/bin/time -f "truth: %e s" "$BIN/mr-synth" --preset medium --dynamic --plate-sphere --frames "$FRAMES" \
    --truth-spp 256 --out "$C" -q
fi
read -r centre radius reflectance < <("$PY" -c "import json,sys; s=json.load(open(sys.argv[1])); \
print('%.9g,%.9g,%.9g' % tuple(s['centre']), s['radius'], s['reflectance'])" "$C/plate-sphere.json")
mean() {  # REPORT KEY
  "$PY" -c "import json,sys; print('%.4g' % json.load(open(sys.argv[1]))['metrics'][sys.argv[2]])" "$1" "$2"
}
echo "source,time_constant_s,s_per_frame,vs_centre_irradiance_relrms,vs_centre_flicker,vs_sky_irradiance_relrms" \
  > "$OUT/light.csv"
for tau in 0 0.1; do
  for src in sphere lightcam; do
    if [ "$src" = sphere ]; then
      args=(--sphere-in-plate "$C/scene.json" --sphere "$centre,$radius" --reflectance "$reflectance")
    else
      args=(--light "$C/lightcam/frames.txt" --fisheye "$C/lightcam/fisheye.cameramodel"
        --plate-times "$C/trajectory.txt" --exposures "$C/lightcam/exposures.txt")
    fi
    t0=$(date +%s.%N)
    "$BIN/mr-probe" "${args[@]}" --width 256 --time-constant "$tau" --out "$OUT/env-$src-$tau/%05d.exr" -q
    t1=$(date +%s.%N)
    "$BIN/mr-eval" light "$OUT/env-$src-$tau/%05d.exr" "$C/reference/sphere/%05d.exr" \
      --report "$OUT/light-$src-$tau-centre.json" -q > /dev/null
    "$BIN/mr-eval" light "$OUT/env-$src-$tau/%05d.exr" "$C/env/%05d.exr" --report "$OUT/light-$src-$tau-sky.json" \
      -q > /dev/null
    echo "$src,$tau,$("$PY" -c "print('%.3g' % (($t1 - $t0) / $FRAMES))"),$(mean "$OUT/light-$src-$tau-centre.json" \
      mean_irradiance_relrms),$(mean "$OUT/light-$src-$tau-centre.json" mean_flicker),$(mean \
      "$OUT/light-$src-$tau-sky.json" mean_irradiance_relrms)" >> "$OUT/light.csv"
  done
done
# pt under each light (the filtered maps, tau 0.1) against the truth.
echo "light,spp,mean_region_relmse,flicker,seconds_per_frame" > "$OUT/render.csv"
for src in sky sphere lightcam; do
  env=$([ "$src" = sky ] && echo "env/%05d.exr" || echo "$OUT/env-$src-0.1/%05d.exr")
  "$PY" -c "import json,sys; s=json.load(open(sys.argv[1])); s['lighting']['environment']=sys.argv[2]; \
json.dump(s, open(sys.argv[3], 'w'), indent=1)" "$C/scene.json" "$env" "$C/scene-$src.json"
  "$BIN/mr-render" "$C/scene-$src.json" --method pt --spp "$SPP" --out "$OUT/r-$src" --report "$OUT/r-$src.json" -q
  "$PY" - "$OUT/r-$src.json" "$src" "$SPP" >> "$OUT/render.csv" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
fr = m["frames"]
print("%s,%s,%.4g,%.4g,%.3g" % (sys.argv[2], sys.argv[3], sum(f["region_relmse"] for f in fr) / len(fr), m["flicker"],
                                sum(f["seconds"] for f in fr) / len(fr)))
PY
done
cat "$OUT/light.csv" "$OUT/render.csv"
