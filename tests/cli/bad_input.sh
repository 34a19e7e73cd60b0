#!/usr/bin/env bash
# The bad-input corpus: what users' scripts feed the tools when something went
# wrong upstream.  Each case must give exit code 1 (2 for a usage error), one
# error line naming the file and what is wrong (no library chatter before it,
# no binary bytes), and leave its output folder exactly as it was (no output,
# no temporary, not even an empty folder).
# Usage: bad_input.sh BIN_DIR
set -u
bin=$1
src=$(cd "$(dirname "$0")/../.." && pwd)
source "$(dirname "$0")/lib.sh"

out="$tmp/out"  # every case writes here; it must stay as it was
mkdir -p "$out"
# bad NAME RC NEEDLE -- COMMAND...: `check`, then one error line, printable
# output, and $out unchanged.
bad() {
  local name=$1 want=$2 needle=$3
  shift 4
  local before after text rc errors ok=1
  before=$(ls -A "$out")
  "$@" > "$tmp/stdout" 2> "$tmp/stderr"
  rc=$?
  text=$(cat "$tmp/stderr")
  if [ "$rc" -ne "$want" ]; then
    echo "FAIL $name: exit $rc, expected $want"; ok=0
  elif [ -n "$needle" ] && ! grep -qF -- "$needle" "$tmp/stderr"; then
    echo "FAIL $name: stderr lacks '$needle'"; ok=0
  fi
  errors=$(grep -c -E '^mr-[a-z]+: (usage )?error' <<<"$text")
  if [ "$errors" -ne 1 ]; then
    echo "FAIL $name: $errors error lines on stderr, expected 1"; ok=0
  elif [ "$(head -n 1 <<<"$text" | grep -c -E '^mr-[a-z]+: ')" -ne 1 ]; then
    echo "FAIL $name: stderr does not start with the tool's line"; ok=0
  fi
  if grep -q -P '[\x00-\x08\x0b-\x1f\x7f]' <<<"$text"; then
    echo "FAIL $name: binary bytes on stderr"; ok=0
  fi
  after=$(ls -A "$out")
  if [ "$before" != "$after" ]; then
    echo "FAIL $name: left in the output folder: $(comm -13 <(echo "$before") <(echo "$after") | tr '\n' ' ')"
    ok=0
    rm -rf "$out" && mkdir -p "$out"
  fi
  if [ "$ok" -eq 1 ]; then
    echo "ok   $name"; pass=$((pass + 1))
  else
    sed 's/^/    /' "$tmp/stderr"; fail=$((fail + 1))
  fi
}

d="$tmp/in"
mkdir -p "$d"
check "mr-synth capture" 0 "" -- "$bin/mr-synth" --preset small --out "$tmp/cap" --truth-spp 1 -q
cap="$tmp/cap"

# --- Meshes (section 1 of the robustness issue: each crashed or hung) -------
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n' > "$d/slash.obj"
for tool in mr-info; do
  bad "$tool: OBJ corner /1" 1 "slash.obj:4: face corner \"/1\" has no vertex index" -- "$bin/$tool" "$d/slash.obj"
done
bad "mr-formfactor: OBJ corner /1" 1 "slash.obj:4: face corner" -- "$bin/mr-formfactor" "$d/slash.obj" --resolution 2 --out "$out/o.ffc"
bad "mr-eval mesh: OBJ corner /1" 1 "slash.obj:4: face corner" -- "$bin/mr-eval" mesh "$d/slash.obj" "$cap/meshes/object.ply"
bad "mr-synth: OBJ corner /1" 1 "slash.obj:4: face corner" -- "$bin/mr-synth" --preset small --object "$d/slash.obj" --out "$out/c"
sed "s|\"mesh\": \"meshes/object.ply\"|\"mesh\": \"$d/slash.obj\"|" "$cap/scene.json" > "$cap/scene-slash.json"
bad "mr-render: OBJ corner /1" 1 "slash.obj:4: face corner" -- "$bin/mr-render" "$cap/scene-slash.json" --out "$out/r" --spp 1
printf 'hello\n' > "$d/x.off"
bad "OFF: not OFF" 1 "x.off:1: not an OFF file" -- timeout 20 "$bin/mr-info" "$d/x.off"
printf 'OFF\n99999999999 1 0\n' > "$d/big.off"
bad "OFF: 1e11 vertices" 1 "header declares 99999999999 vertices and 1 faces, more than the" -- timeout 20 "$bin/mr-info" "$d/big.off"
printf 'OFF\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n' > "$d/faces.off"
bad "OFF: 2e9 faces" 1 "2000000000 faces, more than the" -- timeout 20 "$bin/mr-info" "$d/faces.off"
bad "mr-formfactor: OFF 2e9 faces" 1 "2000000000 faces" -- timeout 20 "$bin/mr-formfactor" "$d/faces.off" --out "$out/o.ffc"
head -c 200 "$src/README.md" > "$d/t.stl"
bad "STL: text" 1 "t.stl: binary STL header declares" -- timeout 20 "$bin/mr-info" "$d/t.stl"
{ head -c 80 /dev/zero; printf '\x00\x28\x6b\xee'; } > "$d/b.stl"
bad "STL: 4e9 triangles" 1 "declares 4000000000 triangles" -- timeout 20 "$bin/mr-info" "$d/b.stl"
printf 'v 0 0 0\nv nan 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 2\nf 1 3 4\n' > "$d/n.obj"
bad "OBJ: NaN vertex" 1 "n.obj:2: vertex 2 has a non-finite coordinate" -- "$bin/mr-info" "$d/n.obj"
printf 'ply\nformat ascii 1.0\nelement vertex 900\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n' > "$d/short.ply"
bad "PLY: header claims more" 1 "header declares 900 vertices" -- "$bin/mr-info" "$d/short.ply"
: > "$d/empty.ply"
bad "empty mesh" 1 "empty.ply: empty file" -- "$bin/mr-info" "$d/empty.ply"
bad "missing mesh (a path on the command line: usage)" 2 "File does not exist: $d/nope.obj" -- "$bin/mr-formfactor" "$d/nope.obj" --out "$out/o.ffc"
printf '{"version": 1, "camera": {"model": "%s"}, "real": {"mesh": "%s"}}\n' "$cap/camera.cameramodel" "$d/nope.ply" > "$d/nomesh.json"
bad "missing mesh named by a scene" 1 "nomesh.json: real.mesh: mesh $d/nope.ply does not exist" -- "$bin/mr-render" "$d/nomesh.json" --out "$out/r"

# --- Images --------------------------------------------------------------
size=$(stat -c %s "$cap/photos/00000.png")
head -c $((size / 2)) "$cap/photos/00000.png" > "$d/trunc.png"
bad "truncated PNG" 1 "trunc.png: PNG chunk \"IDAT\"" -- "$bin/mr-info" "$d/trunc.png"
# fuzz/fuzz_depth's finding: a 358-byte PNG whose text chunk claims 1 GB made libpng clear 1 GB (10 s).
bad "PNG chunk longer than the file" 1 "declares 1090519147 bytes, the file holds 292 more" -- timeout 20 "$bin/mr-info" "$src/fuzz/corpus/depth/regression-huge-text-chunk.png"
printf 'v/1\001\002\000\000garbage' > "$d/corrupt.exr"
bad "corrupt EXR" 1 "corrupt.exr: OpenEXR header runs past the end of the file" -- "$bin/mr-info" "$d/corrupt.exr"
: > "$d/empty.exr"
bad "empty EXR" 1 "empty.exr" -- "$bin/mr-lights" "$d/empty.exr" --out "$out/l.json"
oiiotool --pattern constant:color=1,1,1 8x4 3 --subc 2 -o "$d/negative.exr" 2>/dev/null
bad "negative environment" 1 "negative.exr: pixel (0, 0) has negative radiance" -- "$bin/mr-lights" "$d/negative.exr" --out "$out/l.json"
# A portable float map (little-endian) with one NaN and one Inf.
python3 -c "
import struct, sys
v = [0.5] * 96; v[5] = float('nan'); v[17] = float('inf')
sys.stdout.buffer.write(b'PF\n8 4\n-1.0\n' + struct.pack('<96f', *v))" > "$d/nan.pfm"
bad "NaN pixels" 1 "nan.pfm: 2 NaN/Inf values" -- "$bin/mr-info" "$d/nan.pfm"
bad "NaN environment" 1 "nan.pfm: 1 NaN and 1 Inf values" -- "$bin/mr-lights" "$d/nan.pfm" --out "$out/l.json"
oiiotool --pattern constant:color=1,1,1 8x8 3 -o "$d/small.exr" 2>/dev/null
bad "compare: size mismatch" 1 "small.exr: image is 8x8, the reference" -- "$bin/mr-eval" compare "$d/small.exr" "$cap/env.exr" --diff "$out/d.png"
# --region: an mr-render EXR's mask layer (here a checker: half the pixels), a layered image
# without one refused rather than compared by its first layer.
size=$(oiiotool "$cap/truth/00000.exr" --echo "{TOP.width}x{TOP.height}" 2>/dev/null | tail -n 1)
oiiotool --pattern constant:color=0.5,0.5,0.5 "$size" 3 --chnames composite.R,composite.G,composite.B \
  --pattern checker:width=1:height=1:color1=1:color2=0 "$size" 1 --chnames mask.Y --chappend -o "$d/layered-mask.exr" 2>/dev/null
pixels=$("$bin/mr-eval" compare "$cap/truth/00000.exr" "$cap/truth/00001.exr" --region "$d/layered-mask.exr" -q 2>/dev/null | sed -n 's/.*(\([0-9]*\) pixels).*/\1/p')
w=${size%x*}; h=${size#*x}
if [ "$pixels" != "$(( w * h / 2 ))" ]; then echo "FAIL compare --region: the mask layer gave $pixels pixels, expected $(( w * h / 2 ))"; fail=$((fail + 1)); fi
oiiotool --pattern constant:color=0.5,0.5,0.5 "$size" 3 --chnames a.R,a.G,a.B \
  --pattern constant:color=1 "$size" 1 --chnames b.Y --chappend -o "$d/layered.exr" 2>/dev/null
bad "compare: layered region without mask" 1 "layered.exr: region has 2 layers and none is \"mask\"" -- "$bin/mr-eval" compare "$cap/truth/00000.exr" "$cap/truth/00001.exr" --region "$d/layered.exr"
bad "hdr: one image" 1 "" -- "$bin/mr-hdr" "$cap/photos/00000.png" --out "$out/x.exr"

# --- Scenes: checked before the first frame -------------------------------
# Three poses; frame 1 of the three is missing.
mkdir -p "$cap/gap"
cp "$cap/photos/00000.exr" "$cap/gap/00000.exr"; cp "$cap/photos/00001.exr" "$cap/gap/00002.exr"
{ cat "$cap/trajectory.txt"; tail -n 1 "$cap/trajectory.txt" | awk '{$1 = $1 + 1; print}'; } > "$cap/three.txt"
sed 's|"photos/%05d.exr"|"gap/%05d.exr"|; s|"trajectory.txt"|"three.txt"|; /"reference"/d' "$cap/scene.json" > "$cap/gap.json"
bad "missing middle frame: mr-render" 1 "gap/00001.exr: frame 1 is missing" -- "$bin/mr-render" "$cap/gap.json" --out "$out/r" --spp 1
bad "missing middle frame: mr-info" 1 "gap/00001.exr: frame 1 is missing" -- "$bin/mr-info" "$cap/gap.json"
# An environment video that is not a video, and one with no frames.
echo "not a video" > "$cap/junk.mp4"
sed 's|"env.exr"|"junk.mp4"|' "$cap/scene.json" > "$cap/junk-env.json"
bad "environment video: not a video" 1 "junk.mp4: cannot open video" -- "$bin/mr-render" "$cap/junk-env.json" --out "$out/r" --spp 1
: > "$cap/empty.mkv"
sed 's|"env.exr"|"empty.mkv"|' "$cap/scene.json" > "$cap/empty-env.json"
bad "environment video: empty" 1 "empty.mkv" -- "$bin/mr-render" "$cap/empty-env.json" --out "$out/r" --spp 1
check "frames before the gap still render" 0 "" -- "$bin/mr-render" "$cap/gap.json" --out "$tmp/r-gap" --spp 1 --frames 0:1 -q
head -n "$(($(wc -l < "$cap/trajectory.txt") - 1))" "$cap/trajectory.txt" > "$cap/few.txt"
sed 's|"trajectory.txt"|"few.txt"|; /"reference"/d' "$cap/scene.json" > "$cap/few.json"
check "fewer poses than frames: mr-info warns" 0 "frames 1 and later are not rendered" -- "$bin/mr-info" "$cap/few.json"
check "fewer poses than frames: mr-render warns" 0 "frames 1 and later are not rendered" -- "$bin/mr-render" "$cap/few.json" --out "$tmp/r-few" --spp 1
sed 's/imagersize.*/imagersize'"'"': [ 1000000, 1000000, ],/' "$cap/camera.cameramodel" > "$cap/huge.cameramodel"
sed 's|"camera.cameramodel"|"huge.cameramodel"|' "$cap/scene.json" > "$cap/huge.json"
bad "1e6 x 1e6 camera: mr-info" 1 "huge.cameramodel: camera is 1000000x1000000" -- "$bin/mr-info" "$cap/huge.json"
bad "1e6 x 1e6 camera: mr-render" 1 "huge.cameramodel: camera is 1000000x1000000" -- "$bin/mr-render" "$cap/huge.json" --out "$out/r"
oiiotool --pattern constant:color=0.5,0.5,0.5 32x24 3 -o "$cap/gap/00001.exr" 2>/dev/null
bad "frame of another size (mismatched intrinsics)" 1 "gap/00001.exr: frame 1 is 32x24, the camera model" -- "$bin/mr-render" "$cap/gap.json" --out "$out/r" --spp 1
printf '{"version": 1, "camera": {"model": "%s"}, "real": {"mesh": "%s"}, "colour": 1}\n' "$cap/camera.cameramodel" "$cap/meshes/floor.ply" > "$d/unknown.json"
bad "scene: unknown key" 1 "unknown.json: colour: unknown key" -- "$bin/mr-render" "$d/unknown.json" --out "$out/r"
bad "render: --spp 0" 2 "--spp: 0 must be greater than 0" -- "$bin/mr-render" "$cap/scene.json" --out "$out/r" --spp 0
bad "render: --spp -1" 2 "must be greater than 0" -- "$bin/mr-render" "$cap/scene.json" --out "$out/r" --spp -1
bad "render: bad frames" 2 "--frames must be A:B" -- "$bin/mr-render" "$cap/scene.json" --out "$out/r" --frames x:y
bad "render: frames past the end" 2 "frame range 50:60 is empty" -- "$bin/mr-render" "$cap/scene.json" --out "$out/r" --frames 50:60
check "no DBL_MAX in messages" 1 "" -- grep -q 1797693 <<<"$("$bin/mr-render" "$cap/scene.json" --out "$out/r" --spp 0 2>&1)"

# --- Small text formats ---------------------------------------------------
printf '# timestamp tx ty tz qx qy qz qw\n0 0 0 0 0 0 0 1\n0.1 0 0 zero 0 0 0 1\n' > "$d/traj.txt"
bad "TUM: bad number" 1 "traj.txt:3" -- "$bin/mr-eval" traj "$d/traj.txt" "$cap/trajectory.txt"
printf '{"version": 1, "lights": [{"name": "a", "type": "point", "position": [0, 1, 0], "intensity": [1, 1, 1], "color": 1}]}\n' > "$d/lights.json"
bad "lights: unknown key" 1 "lights.json" -- "$bin/mr-info" "$d/lights.json"
printf '{"format": "mr-probe", "version": 1, "radius": -1}\n' > "$d/probe.json"
bad "probe.json: bad" 1 "probe.json" -- "$bin/mr-probe" "$cap/env.exr" --probe "$d/probe.json" --out "$out/e.exr"
# A light camera's frame list: a bad timestamp, a missing frame, times that go back.
cp "$cap/env.exr" "$d/l0.exr"
printf '0.0 l0.exr\nsoon l0.exr\n' > "$d/frames.txt"
bad "light list: bad timestamp" 1 "frames.txt:2: \"soon\" is not a timestamp" -- "$bin/mr-probe" --light "$d/frames.txt" --fisheye "$cap/probe/fisheye.cameramodel" --out "$out/env/%05d.exr"
printf '0.0 l0.exr\n0.1 gone.exr\n' > "$d/frames.txt"
bad "light list: missing frame" 1 "frames.txt:2: $d/gone.exr: no such file" -- "$bin/mr-probe" --light "$d/frames.txt" --fisheye "$cap/probe/fisheye.cameramodel" --out "$out/env/%05d.exr"
printf '0.5 l0.exr\n0.1 l0.exr\n' > "$d/frames.txt"
bad "light list: back in time" 1 "timestamps go backwards" -- "$bin/mr-probe" --light "$d/frames.txt" --fisheye "$cap/probe/fisheye.cameramodel" --out "$out/env/%05d.exr"
printf '{"format": "mr-response", "version": 1, "curves": "nope"}\n' > "$d/response.json"
bad "response.json: bad" 1 "response.json" -- "$bin/mr-hdr" "$cap/probe/bracket/sphere-0.png" "$cap/probe/bracket/sphere-1.png" --exposures "$cap/probe/bracket/exposures.txt" --response "$d/response.json" --out "$out/x.exr"
printf 'sphere-0.png 1\nsphere-1.png zero\n' > "$d/exposures.txt"
bad "exposures.txt: bad number" 1 "exposures.txt:2" -- "$bin/mr-hdr" "$cap/probe/bracket/sphere-0.png" "$cap/probe/bracket/sphere-1.png" --exposures "$d/exposures.txt" --out "$out/x.exr"
printf '{"version": 1, "work": "w", "stages": {"paint": {}}}\n' > "$d/pipeline.json"
bad "pipeline: unknown key" 1 "pipeline.json: stages: unknown key" -- "$bin/mr-pipeline" "$d/pipeline.json" --dry-run
printf '{"name": "b", "type": "chessboard", "inner_corners": [8, 6], "square_m": -0.03}\n' > "$d/board.json"
bad "board: bad square" 1 "board.json" -- "$bin/mr-board" "$d/board.json" --out "$out/b.svg"
printf 'not a camera model\n' > "$d/bad.cameramodel"
bad "camera model: not a dict" 1 "bad.cameramodel:1: not a valid .cameramodel" -- "$bin/mr-info" "$d/bad.cameramodel"
printf "{'lensmodel': 'LENSMODEL_NOPE', 'intrinsics': [1, 2, 3, 4], 'extrinsics': [0, 0, 0, 0, 0, 0], 'imagersize': [10, 10]}\n" > "$d/nope.cameramodel"
bad "camera model: libmrcal's words folded into one line" 1 "nope.cameramodel: not a valid mrcal .cameramodel (libmrcal's parser rejected it: " -- "$bin/mr-info" "$d/nope.cameramodel"
mkdir -p "$d/colmap"
printf '# cameras\n1 PINHOLE 64 48 50 50 32 24\n' > "$d/colmap/cameras.txt"
printf '1 1 0 0 0 0 0 0 7 a.png\n\n' > "$d/colmap/images.txt"
: > "$d/colmap/points3D.txt"
bad "COLMAP: image of a missing camera" 1 "images.txt" -- "$bin/mr-register" align "$d/colmap" --trajectory "$cap/trajectory.txt" --out "$out/p.txt"
printf '# cameras\n1 PINHOLE 64 48 50 50 32 24\n' > "$d/colmap/cameras.txt"
: > "$d/colmap/images.txt"
bad "COLMAP: empty model" 1 "colmap/images.txt: the COLMAP model has no registered images" -- "$bin/mr-register" align "$d/colmap" --trajectory "$cap/trajectory.txt" --out "$out/p.txt"
printf '1 PINHOLE 64 48 50 50 32 24\n\001\002\033[31mred\377\376\n' > "$d/colmap/cameras.txt"
bad "COLMAP: binary bytes not echoed" 1 "cameras.txt:2" -- "$bin/mr-register" align "$d/colmap" --trajectory "$cap/trajectory.txt" --out "$out/p.txt"
# mr-planes: a cloud on no plane (scattered points), and a PLY with no vertices.
{ printf 'ply\nformat ascii 1.0\nelement vertex 200\nproperty float x\nproperty float y\nproperty float z\nend_header\n'
  for i in $(seq 0 199); do echo "$(( (i * 37) % 101 )).$((i % 7)) $(( (i * 53) % 97 )).$((i % 5)) $(( (i * 71) % 89 )).$((i % 3))"; done; } > "$d/cloud.ply"
printf '0 0 0 0 0 0 0 1\n' > "$d/one.tum"
bad "planes: points on no plane" 1 "the points support no plane" -- "$bin/mr-planes" "$d/cloud.ply" --poses "$d/one.tum" --out "$out/room.ply"
printf 'ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n' > "$d/empty.ply"
bad "planes: no vertices" 1 "empty.ply: mesh has no vertices" -- "$bin/mr-planes" "$d/empty.ply" --poses "$d/one.tum" --out "$out/room.ply"
mkdir -p "$d/noboard"
cp "$cap/photos/00000.png" "$d/noboard/a.png"; cp "$cap/photos/00001.png" "$d/noboard/b.png"
bad "calibrate: no board in view" 1 "usable views of the board" -- "$bin/mr-calibrate" camera --board "$src/calib/boards/chessboard-8x6.json" --out "$out/c.cameramodel" "$d/noboard/a.png" "$d/noboard/b.png"
head -c 100 "$cap/truth/00000.exr" > "$d/trunc.exr"
bad "formfactor: truncated .ffc" 1 "short.ffc: too short" -- sh -c "head -c 10 /dev/zero > '$d/short.ffc'; '$bin/mr-formfactor' '$cap/meshes/object.ply' --ffc '$d/short.ffc' --shade '$cap/env.exr' --out '$out/lit.ply'"
bad "fuse: not a recording" 1 "is not an RGB-D recording" -- "$bin/mr-fuse" "$cap" --out "$out/f"

# --- File names users have: spaces, quotes, a leading dash, non-ASCII ------
for name in "with space.obj" "quo'te\".obj" "-dash.obj" "ünïcødé.obj"; do
  cp "$d/slash.obj" "$d/$name"
  bad "file name: $name" 1 "$name:4: face corner" -- "$bin/mr-info" "$d/$name"
done

# --- Writes that fail: a file-size limit stands for a full disk ------------
# (ulimit -f in a subshell; SIGXFSZ is ignored by every tool, so the write
# fails with EFBIG and is reported; nothing partial is left.)
bad "PNG write fails" 1 "d.png: write failed: File too large" -- bash -c "ulimit -f 1; exec '$bin/mr-eval' compare '$cap/truth/00000.exr' '$cap/truth/00001.exr' --diff '$out/d.png'"
bad "EXR write fails" 1 "write failed: File too large" -- bash -c "ulimit -f 1; exec '$bin/mr-render' '$cap/scene.json' --out '$out' --spp 1 --frames 0:1"
bad ".ffc write fails" 1 "o.ffc: write failed: File too large" -- bash -c "ulimit -f 1; exec '$bin/mr-formfactor' '$cap/meshes/object.ply' --resolution 2 --out '$out/o.ffc'"
check "synth write fails" 1 "write failed: File too large" -- bash -c "ulimit -f 1; exec '$bin/mr-synth' --preset small --truth-spp 1 --out '$out/c'"
# --- mr-export: a shot that cannot be written leaves nothing ----------------
/usr/bin/python3 - "$cap" <<'PY'
import json, sys
s = json.load(open(sys.argv[1] + "/scene.json"))
s["virtual"][0]["mesh"] = "meshes/gone.ply"
json.dump(s, open(sys.argv[1] + "/scene-gone.json", "w"))
s = json.load(open(sys.argv[1] + "/scene.json"))
s["camera"].pop("frames_transfer", None)
s["camera"]["frames_colorspace"] = "S-Log3 S-Gamut3"
s["camera"]["frames_transfer"] = "linear"
json.dump(s, open(sys.argv[1] + "/scene-two-decodings.json", "w"))
PY
bad "mr-export: a missing mesh" 1 "gone.ply" -- "$bin/mr-export" "$cap/scene-gone.json" --out "$out/shot.glb"
bad "mr-export: not a glTF name" 1 "shot.fbx" -- "$bin/mr-export" "$cap/scene.json" --out "$out/shot.fbx" --stmaps
bad "mr-export: frames past the poses" 1 "outside the" -- "$bin/mr-export" "$cap/scene.json" --out "$out/shot.glb" --frames 5:90
bad "a colour space beside frames_transfer" 1 "replaces frames_transfer" -- "$bin/mr-render" "$cap/scene-two-decodings.json" --out "$out/r"
check "no temporaries anywhere" 0 "" -- test -z "$(find "$tmp" -name '.mr-tmp-*')"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
