#!/usr/bin/env bash
# Long videos in bounded memory: renders a FRAMES-frame video (the small
# capture's 64x48 camera moving along a line, no photographs) with every
# method, and again with a tenth of the frames; prints per method the peak
# resident memory of both runs (equal when nothing grows per frame) and the
# mean time per frame over the first and the last tenth of the long run
# (equal when time per frame stays flat).
# Usage: bench/long_run.sh BIN_DIR [FRAMES]   (default 1000)
set -euo pipefail
bin=$1
frames=${2:-1000}
short=$((frames / 10))
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$bin/mr-synth" --preset small --out "$tmp/cap" --truth-spp 1 -q
"$bin/mr-formfactor" "$tmp/cap/meshes/object.ply" --resolution 4 --out "$tmp/cap/object.ffc" -q
for n in "$frames" "$short"; do
  awk -v n="$n" '/^#/ {print; next} !done {for (i = 0; i < n; i++) {$1 = i / 30; $2 = -0.4 + 0.4 * i / n; print} done = 1}' \
    "$tmp/cap/trajectory.txt" > "$tmp/cap/poses-$n.txt"
  sed "s|\"trajectory.txt\"|\"poses-$n.txt\"|; /\"frames\": \"photos/d; /\"frames_transfer\"/d; /\"reference\"/d; s|\"name\": \"object\"|\"name\": \"object\", \"formfactors\": \"object.ffc\"|" \
    "$tmp/cap/scene.json" > "$tmp/cap/video-$n.json"
done

printf '%-6s %8s %14s %14s %14s %14s\n' method frames "peak MiB" "peak MiB" "s/frame" "s/frame"
printf '%-6s %8s %14s %14s %14s %14s\n' "" "" "($short fr.)" "($frames fr.)" "(first 10%)" "(last 10%)"
for m in pt ic vpl vct prt; do
  peak=()
  for n in "$short" "$frames"; do
    /usr/bin/time -f '%M' -o "$tmp/rss" "$bin/mr-render" "$tmp/cap/video-$n.json" --method "$m" --spp 1 \
      --out "$tmp/r-$m-$n" -q --report "$tmp/report-$m-$n.json"
    peak+=("$(awk '{printf "%.1f", $1 / 1024}' "$tmp/rss")")
    rm -rf "$tmp/r-$m-$n"
  done
  read -r first last < <(/usr/bin/python3 -c "
import json, sys
f = json.load(open('$tmp/report-$m-$frames.json'))['metrics']['frames']
s = [x['seconds'] for x in f]; k = max(1, len(s) // 10)
print(f'{sum(s[:k]) / k:.4f} {sum(s[-k:]) / k:.4f}')")
  printf '%-6s %8s %14s %14s %14s %14s\n' "$m" "$frames" "${peak[0]}" "${peak[1]}" "$first" "$last"
done
