#!/usr/bin/env bash
# Runs are deterministic whatever the thread count: every tool that claims it
# runs once with --threads 1 and once with --threads 2, and its outputs must be
# the same bytes, except for the provenance that records the command line
# (images: the pixels and every other attribute are compared; text files: the
# lines that quote the command line are left out, and the two output folders'
# names are made one).  mr-register's COLMAP step
# is the exception, and says so in its report (camera/register.h).
# Usage: determinism.sh BIN_DIR
set -u
bin=$1
source "$(dirname "$0")/lib.sh"

# same NAME DIR1 DIR2: every file of DIR1 equals its namesake in DIR2.
same() {
  local name=$1 a=$2 b=$3 f rel bad=0 n=0
  while IFS= read -r f; do
    rel=${f#"$a"/}
    n=$((n + 1))
    cmp -s "$f" "$b/$rel" && continue
    case "$f" in
      *.exr|*.png|*.jpg|*.hdr|*.tif)
        # The same pixels in every layer and channel (the attributes other
        # than the command line are compared by mr-info's listing).
        if ! "$bin/mr-eval" compare "$f" "$b/$rel" 2>&1 | grep -q "^rmse 0 "; then
          echo "    pixels differ: $rel"; bad=1
        elif ! diff <("$bin/mr-info" "$f" | grep -v -e command_line -e "^/") \
                    <("$bin/mr-info" "$b/$rel" | grep -v -e command_line -e "^/") > /dev/null; then
          echo "    layers or statistics differ: $rel"; bad=1
        fi ;;
      *.mp4|*.avi) ;;  # encoded from the PNG frames compared above
      *)
        if ! diff <(grep -av -e "--threads" "$f" | sed "s|$tmp/t[12]|T|g") \
                  <(grep -av -e "--threads" "$b/$rel" | sed "s|$tmp/t[12]|T|g") > /dev/null; then
          echo "    differs: $rel"; bad=1
        fi ;;
    esac
  done < <(find "$a" -type f ! -name '*report*.json' ! -name '*.log' ! -path '*/.mr-pipeline/*' ! -path '*/.mr-render/*' | sort)
  if [ "$bad" -eq 0 ] && [ "$n" -gt 0 ]; then
    echo "ok   $name ($n files)"; pass=$((pass + 1))
  else
    echo "FAIL $name ($n files)"; fail=$((fail + 1))
  fi
}

for t in 1 2; do
  o="$tmp/t$t"
  mkdir -p "$o"
  "$bin/mr-synth" --preset small --out "$o/cap" --truth-spp 4 -q --threads "$t"
  "$bin/mr-synth" --rgbd --rgbd-size 160,120,20 --rgbd-spp 1 --out "$o/rgbd" -q --threads "$t"
  mkdir -p "$o/ff"
  "$bin/mr-formfactor" "$o/cap/meshes/object.ply" --resolution 4 --out "$o/ff/object.ffc" -q --threads "$t"
  sed 's|"name": "object"|"name": "object", "formfactors": "../ff/object.ffc"|' "$o/cap/scene.json" > "$o/cap/scene-ff.json"
  for m in pt ic vpl vct prt; do
    "$bin/mr-render" "$o/cap/scene-ff.json" --method "$m" --spp 2 --out "$o/render-$m" -q --threads "$t"
  done
  mkdir -p "$o/light"
  "$bin/mr-hdr" "$o/cap/probe/bracket"/sphere-*.png --exposures "$o/cap/probe/bracket/exposures.txt" \
    --save-response "$o/light/response.json" --out "$o/light/raw.exr" -q --threads "$t"
  "$bin/mr-calibrate" sphere --camera "$o/cap/probe/light.cameramodel" --radius 0.0254 --out "$o/light/probe.json" \
    "$o/cap/probe/sphere.exr" -q --threads "$t"
  "$bin/mr-probe" "$o/light/raw.exr" --probe "$o/light/probe.json" --reflectance 0.6 --width 64 \
    --out "$o/light/env.exr" -q --threads "$t"
  "$bin/mr-lights" "$o/light/env.exr" --method median-cut --count 8 --out "$o/light/lights.json" \
    --residual "$o/light/rest.exr" -q --threads "$t"
  "$bin/mr-fuse" "$o/rgbd" --out "$o/fused" --first-pose reference -q --threads "$t"
  mkdir -p "$o/eval"
  "$bin/mr-eval" compare "$o/render-pt/00000.exr" "$o/cap/truth/00000.exr" --diff "$o/eval/diff.png" -q \
    --threads "$t" > "$o/eval/compare.txt"
done
for d in cap rgbd ff render-pt render-ic render-vpl render-vct render-prt light fused eval; do
  same "threads 1 and 2: $d" "$tmp/t1/$d" "$tmp/t2/$d"
done

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
