#!/usr/bin/env bash
# Faults users' render farms meet: a run killed (SIGKILL) at random points and
# resumed, a full disk, a read-only folder, an output path under a file.
# Nothing under a final name may ever be partial; a resumed run's outputs
# equal one uninterrupted run's, byte for byte.
# Usage: faults.sh BIN_DIR
set -u
bin=$1
source "$(dirname "$0")/lib.sh"
chmod 755 "$tmp"

# Every image under its final name reads back whole (mr-info decodes every pixel).
all_readable() {
  local f
  for f in "$@"; do
    [ -e "$f" ] || continue
    "$bin/mr-info" -q "$f" > /dev/null 2>&1 || { echo "    partial or unreadable: $f"; return 1; }
  done
  return 0
}

# A 12-frame video of the small capture (no photographs: the composite is over
# the rendered room), so that a run lasts long enough to be killed mid-way.
check "mr-synth capture" 0 "" -- "$bin/mr-synth" --preset small --out "$tmp/cap" --truth-spp 1 -q
cap="$tmp/cap"
awk '/^#/ {print; next} !done {for (i = 0; i < 12; i++) {$1 = i * 0.1; $2 = $2 + 0.01; print} done = 1}' \
  "$cap/trajectory.txt" > "$cap/twelve.txt"
sed 's|"trajectory.txt"|"twelve.txt"|; /"frames": "photos/d; /"frames_transfer"/d; /"reference"/d' "$cap/scene.json" > "$cap/video.json"
check "12-frame scene" 0 "frames: 12" -- "$bin/mr-info" "$cap/video.json"
check "uninterrupted run" 0 "" -- "$bin/mr-render" "$cap/video.json" --out "$tmp/one" --spp 4 -q

# Killed at seeded random points, resumed each time, until it finishes.
RANDOM=7
finished=0
for attempt in 1 2 3 4 5 6 7 8; do
  "$bin/mr-render" "$cap/video.json" --out "$tmp/killed" --spp 4 --resume -q 2>/dev/null &
  pid=$!
  sleep "0.$((RANDOM % 9 + 1))"
  kill -9 "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
  if ! all_readable "$tmp"/killed/*.exr "$tmp"/killed/*.png; then
    echo "FAIL kill $attempt: a partial output under its final name"; fail=$((fail + 1))
  fi
done
echo "ok   killed 8 times: every file under its final name complete ($(ls "$tmp"/killed/*.exr 2>/dev/null | wc -l) frames)"
pass=$((pass + 1))
# A kill lands mid-write only now and then: plant what it leaves, a dead
# process's temporaries beside the frames and beside the inputs keys.
true & dead=$!; wait "$dead"
mkdir -p "$tmp/killed/.mr-render"
for d in "$tmp/killed" "$tmp/killed/.mr-render"; do
  echo partial > "$d/.mr-tmp-$dead@$(uname -n | tr '@/' '__')@0-00003.part"
done
check "resume finishes" 0 "" -- "$bin/mr-render" "$cap/video.json" --out "$tmp/killed" --spp 4 --resume -q --report "$tmp/resume.json"
left=$(find "$tmp/killed" -name '.mr-tmp-*')
check "resume: no temporaries left" 0 "" -- test -z "$left"
[ -z "$left" ] || echo "    left: $left"
same=1
for f in "$tmp"/one/*.exr "$tmp"/one/*.png; do
  cmp -s "$f" "$tmp/killed/$(basename "$f")" || { echo "    differs: $(basename "$f")"; same=0; }
done
check "resumed outputs equal one run's, byte for byte" 0 "" -- test "$same" -eq 1
check "resume again: nothing to render" 0 "--resume: complete in the output folder" -- bash -c "'$bin/mr-render' '$cap/video.json' --out '$tmp/killed' --spp 4 --resume -q --report '$tmp/r2.json' && cat '$tmp/r2.json'"
# Frames kept by --resume still carry their error against the truth (over
# the region the object changes) and their flicker.
"$bin/mr-render" "$cap/scene.json" --out "$tmp/kept" --spp 2 -q
check "resumed frames keep their figures" 0 "" -- bash -c "'$bin/mr-render' '$cap/scene.json' --out '$tmp/kept' --spp 2 --resume -q --report '$tmp/r5.json' && grep -q 'complete in the output folder' '$tmp/r5.json' && grep -q '\"region_relmse\"' '$tmp/r5.json' && grep -q '\"flicker\"' '$tmp/r5.json'"
check "other settings are not resumed" 0 "" -- bash -c "'$bin/mr-render' '$cap/video.json' --out '$tmp/killed' --spp 2 --resume -q --report '$tmp/r3.json' && ! grep -q 'resume: complete' '$tmp/r3.json'"
# Inputs are compared by content: a map per frame, frame 6's changed, keeps
# frames 0-5 and renders 6 on.
mkdir -p "$cap/e"
for i in $(seq 0 11); do cp "$cap/env.exr" "$cap/e/$(printf %05d $i).exr"; done
sed 's|"environment": "env.exr"|"environment": "e/%05d.exr"|' "$cap/video.json" > "$cap/video-pf.json"
check "per-frame light rendered" 0 "" -- "$bin/mr-render" "$cap/video-pf.json" --out "$tmp/pf" --spp 1 --resume -q
oiiotool "$cap/env.exr" --mulc 1.5 -o "$cap/e/00006.exr"
check "a changed frame's input re-renders it and the frames after" 0 '"frames 0:6"' -- bash -c "'$bin/mr-render' '$cap/video-pf.json' --out '$tmp/pf' --spp 1 --resume -q --report '$tmp/r4.json' && cat '$tmp/r4.json'"

# mr-pipeline killed at random points and run again: it resumes from the
# stages that finished, and its outputs equal an uninterrupted run's.
cp "$cap/meshes/object.ply" "$tmp/object.ply"
for w in one killed; do
  cat > "$tmp/pipe-$w.json" <<JSON
{"version": 1, "work": "pipe-$w",
 "camera": {"model": "cap/camera.cameramodel"},
 "lighting": {"environment": "cap/env.exr"},
 "room": {"real": [{"mesh": "cap/meshes/floor.ply", "material": {"albedo": [0.55, 0.5, 0.45]}},
                   {"mesh": "cap/meshes/wall_back.ply", "material": {"albedo": [0.7, 0.7, 0.65]}}]},
 "video": {"frames": "cap/photos/%05d.exr", "poses": {"tum": "cap/trajectory.txt"}},
 "virtual": [{"name": "ball", "mesh": "object.ply", "transform": {"translation": [0.1, 0.9, 0]}}],
 "render": {"method": "pt", "spp": 8, "seed": 3}}
JSON
done
check "pipeline: uninterrupted" 0 "" -- "$bin/mr-pipeline" "$tmp/pipe-one.json" -q
for attempt in 1 2 3 4 5; do
  "$bin/mr-pipeline" "$tmp/pipe-killed.json" -q > /dev/null 2>&1 &
  pid=$!
  sleep "0.$((RANDOM % 5 + 1))"
  kill -9 "$pid" 2>/dev/null
  pkill -9 -f "pipe-killed/" 2>/dev/null  # the stage it was running
  wait "$pid" 2>/dev/null
  if ! all_readable "$tmp"/pipe-killed/render/*.exr "$tmp"/pipe-killed/render/*.png; then
    echo "FAIL pipeline kill $attempt: a partial output"; fail=$((fail + 1))
  fi
done
check "pipeline: run again finishes" 0 "" -- "$bin/mr-pipeline" "$tmp/pipe-killed.json" -q
same=1
for f in "$tmp"/pipe-one/render/*.exr "$tmp"/pipe-one/render/*.png; do
  cmp -s "$f" "$tmp/pipe-killed/render/$(basename "$f")" || { echo "    differs: $(basename "$f")"; same=0; }
done
check "pipeline: outputs equal an uninterrupted run's" 0 "" -- test "$same" -eq 1
check "pipeline: no temporaries left" 0 "" -- test -z "$(find "$tmp/pipe-killed" -name '.mr-tmp-*')"

# A subprocess (colmap) that hangs, crashes or writes garbage: reported with
# the step and its log, and mr does not hang.  A stand-in colmap plays each.
mkdir -p "$tmp/frames" && cp "$cap"/photos/*.png "$tmp/frames/" && cp "$cap/photos/00000.png" "$tmp/frames/00002.png"
cat > "$tmp/colmap-hang" <<'SH'
#!/bin/sh
echo "colmap $1: starting"; exec sleep 60
SH
cat > "$tmp/colmap-crash" <<'SH'
#!/bin/sh
echo "colmap $1: about to crash"; kill -SEGV $$
SH
cat > "$tmp/colmap-garbage" <<'SH'
#!/bin/sh
step=$1; out=""
while [ $# -gt 0 ]; do [ "$1" = "--output_path" ] && out=$2; shift; done
case $step in
  mapper) mkdir -p "$out/0" ;;
  model_converter) printf '\001garbage\n' > "$out/cameras.txt"; printf 'garbage\n' > "$out/images.txt" ;;
esac
exit 0
SH
chmod +x "$tmp"/colmap-*
start=$(date +%s)
check "colmap hangs: ended at the limit, named" 1 "colmap feature_extractor ran past the time limit of 2 s" -- "$bin/mr-register" colmap "$tmp/frames" --workspace "$tmp/ws-hang" --colmap "$tmp/colmap-hang" --colmap-timeout 2 --out "$tmp/p.txt"
check "colmap hangs: mr does not" 0 "" -- test $(($(date +%s) - start)) -lt 30
check "colmap crashes: the signal named" 1 "colmap feature_extractor failed (killed by signal 11" -- "$bin/mr-register" colmap "$tmp/frames" --workspace "$tmp/ws-crash" --colmap "$tmp/colmap-crash" --out "$tmp/p.txt"
check "colmap crashes: its log named" 1 "ws-crash/colmap.log" -- "$bin/mr-register" colmap "$tmp/frames" --workspace "$tmp/ws-crash" --colmap "$tmp/colmap-crash" --out "$tmp/p.txt"
check "colmap writes garbage: the file named" 1 "cameras.txt:1" -- "$bin/mr-register" colmap "$tmp/frames" --workspace "$tmp/ws-garbage" --colmap "$tmp/colmap-garbage" --out "$tmp/p.txt"
check "no poses written by a failed registration" 1 "" -- test -e "$tmp/p.txt"

# An output path under a file, and a folder that does not exist for the file.
touch "$tmp/afile"
check "output under a file" 1 "afile/r: cannot create the output folder" -- "$bin/mr-render" "$cap/video.json" --out "$tmp/afile/r" --spp 1
check "nothing made under the file" 0 "" -- test -f "$tmp/afile"

if [ "$(id -u)" -eq 0 ] && mkdir -p "$tmp/full" && mount -t tmpfs -o size=96k tmpfs "$tmp/full" 2>/dev/null; then
  # A full disk: 96 KiB holds a few frames.  The error names the file; what
  # is there is whole; no temporary is left.
  check "full disk: error names the file" 1 "No space left on device" -- "$bin/mr-render" "$cap/video.json" --out "$tmp/full/r" --spp 1
  check "full disk: no temporaries" 0 "" -- test -z "$(find "$tmp/full" -name '.mr-tmp-*')"
  check "full disk: what is there is whole" 0 "" -- all_readable "$tmp"/full/r/*.exr "$tmp"/full/r/*.png
  check "full disk: mr-synth" 1 "No space left on device" -- "$bin/mr-synth" --preset small --out "$tmp/full/cap" --truth-spp 1
  check "full disk: mr-synth leaves no temporaries" 0 "" -- test -z "$(find "$tmp/full" -name '.mr-tmp-*')"
  umount "$tmp/full"
  # mr-pipeline on a disk that fills during its render stage: the stage is
  # named, the earlier stages' outputs stay whole, nothing partial is left.
  mkdir -p "$tmp/full2" && mount -t tmpfs -o size=160k tmpfs "$tmp/full2"
  sed "s|\"work\": \"pipe-one\"|\"work\": \"$tmp/full2/w\"|" "$tmp/pipe-one.json" > "$tmp/pipe-full.json"
  check "full disk: pipeline names the stage" 1 "stage render failed" -- "$bin/mr-pipeline" "$tmp/pipe-full.json" -q
  check "full disk: the scene stage's output intact" 0 "valid" -- "$bin/mr-info" "$tmp/full2/w/scene.json"
  check "full disk: pipeline leaves no temporaries" 0 "" -- test -z "$(find "$tmp/full2" -name '.mr-tmp-*')"
  check "full disk: pipeline's renders whole" 0 "" -- all_readable "$tmp"/full2/w/render/*.exr "$tmp"/full2/w/render/*.png
  umount "$tmp/full2"
else
  echo "ok   full disk: skipped (needs root to mount a small tmpfs)"
fi

chmod -R a+rX "$tmp/cap"
if [ "$(id -u)" -eq 0 ] && command -v runuser > /dev/null && runuser -u nobody -- test -x "$bin/mr-render" &&
   runuser -u nobody -- test -r "$cap/video.json"; then
  # A read-only folder, as a user who cannot write there.
  mkdir -p "$tmp/ro"
  chmod -R a+rX "$tmp/cap"
  check "read-only folder: error names the file" 1 "Permission denied" -- runuser -u nobody -- env ASAN_OPTIONS="${ASAN_OPTIONS:-}" UBSAN_OPTIONS="${UBSAN_OPTIONS:-}" "$bin/mr-render" "$cap/video.json" --out "$tmp/ro" --spp 1 --frames 0:1
  check "read-only folder: nothing written" 0 "" -- test -z "$(ls -A "$tmp/ro")"
  check "read-only parent: no folder" 1 "ro/sub: cannot create the output folder: Permission denied" -- runuser -u nobody -- env ASAN_OPTIONS="${ASAN_OPTIONS:-}" UBSAN_OPTIONS="${UBSAN_OPTIONS:-}" "$bin/mr-render" "$cap/video.json" --out "$tmp/ro/sub" --spp 1
else
  echo "ok   read-only folder: skipped (needs root, and a build and folder that user nobody can read)"
fi

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
