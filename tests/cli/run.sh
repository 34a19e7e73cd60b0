#!/usr/bin/env bash
# End-to-end tests of the tools, run exactly as users run them.
# Usage: run.sh BIN_DIR DATA_DIR
set -u
bin=$1
src=$(cd "$(dirname "$0")/../.." && pwd)
source "$(dirname "$0")/lib.sh"

# --help is the manual: synopsis, example, exit 0.
check "mr-info --help" 0 "Example:" -- "$bin/mr-info" --help
check "mr-board --help" 0 "Example:" -- "$bin/mr-board" --help
# Usage errors exit 2.
check "unknown flag" 2 "usage error" -- "$bin/mr-info" --no-such-flag x
check "bad number" 2 "usage error" -- "$bin/mr-info" --threads abc x
check "missing argument" 2 "usage error" -- "$bin/mr-info"

# A corrupt EXR: exit 1, the message names the file.
printf 'v/1\001\002\000\000garbage' > "$tmp/corrupt.exr"
check "corrupt EXR" 1 "mr-info: error: $tmp/corrupt.exr: OpenEXR header runs past the end of the file" -- "$bin/mr-info" "$tmp/corrupt.exr"

# A PLY with a NaN vertex.
cat > "$tmp/nan.ply" <<'PLY'
ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 0
1 nan 0
0 1 0
3 0 1 2
PLY
check "NaN PLY" 1 "mr-info: error: $tmp/nan.ply:11: vertex 1 has a non-finite coordinate (nan)" -- "$bin/mr-info" "$tmp/nan.ply"

# A scene with an unknown key.
touch "$tmp/cam.cameramodel" "$tmp/room.ply"
cat > "$tmp/scene.json" <<'JSON'
{"version": 1, "camera": {"model": "cam.cameramodel"}, "real": {"mesh": "room.ply", "colour": 1}}
JSON
check "scene unknown key" 1 "mr-info: error: $tmp/scene.json: real.colour: unknown key" -- "$bin/mr-info" "$tmp/scene.json"

# mr-info leaves nothing behind; mr-board writes its SVG atomically.
before=$(ls -A "$tmp" | wc -l)
check "mr-board" 0 "" -- "$bin/mr-board" --inner-corners 10x10 --square-mm 30 --out "$tmp/board.svg"
check "mr-board svg size" 0 'width="340mm"' -- cat "$tmp/board.svg"  # 11 x 30 mm + 2 x 5 mm margin
check "mr-board: larger than A4 said" 0 "larger than A4 (210 x 297 mm): print it on A2" -- "$bin/mr-board" --inner-corners 10x10 --square-mm 30 --out "$tmp/board.svg"
check "mr-board: the A4 board fits A4" 0 "fits A4" -- "$bin/mr-board" "$src/calib/boards/charuco-8x11-A4.json" --out "$tmp/board.svg"
check "mr-board bad folder" 1 "does not exist" -- "$bin/mr-board" --inner-corners 10x10 --square-mm 30 --out "$tmp/no/board.svg"
after=$(ls -A "$tmp" | wc -l)
check "no stray files" 0 "" -- test "$after" -eq $((before + 1))

# --report writes the one report layout, which mr-info itself validates.
check "report written" 0 "" -- "$bin/mr-board" --inner-corners 9x6 --square-mm 24.23 --out "$tmp/b2.svg" --report "$tmp/board-report.json"
check "report is sound" 0 "report of mr-board" -- "$bin/mr-info" "$tmp/board-report.json"
# No report is left behind by a failed run.
check "no report on failure" 1 "" -- "$bin/mr-board" --inner-corners 9x6 --square-mm 1 --out "$tmp/no/b.svg" --report "$tmp/failed-report.json"
check "failed report absent" 1 "" -- test -e "$tmp/failed-report.json"

# A good file: exit 0.
cat > "$tmp/traj.txt" <<'TUM'
# timestamp tx ty tz qx qy qz qw
0.0 0 0 0 0 0 0 1
0.5 0 0 1 0 0 0 1
TUM
check "TUM trajectory" 0 "2 poses, span 0.500 s, path length 1.0000 m" -- "$bin/mr-info" "$tmp/traj.txt"
check "json output" 0 '"kind": "trajectory"' -- "$bin/mr-info" --json "$tmp/traj.txt"
# One bad file among good ones: the rest is still described, exit 1.
check "batch goes on" 1 "2 poses" -- "$bin/mr-info" "$tmp/nan.ply" "$tmp/traj.txt"

# The rendering pipeline end to end: capture, render, compare.
check "mr-synth" 0 "" -- "$bin/mr-synth" --preset small --out "$tmp/cap" --truth-spp 16 -q
check "mr-render" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --out "$tmp/render" --spp 2 -q --report "$tmp/render.json"
check "render report" 0 '"region_relmse"' -- cat "$tmp/render.json"
check "render layers" 0 "composite" -- "$bin/mr-info" "$tmp/render/00001.exr"
check "mr-eval compare" 0 "relmse" -- "$bin/mr-eval" compare "$tmp/render/00000.exr" "$tmp/cap/truth/00000.exr" --diff "$tmp/diff.png" --report "$tmp/cmp.json"
# The compositor's passes rebuild the composite bit for bit (docs/formats.md):
# objects over (photo + difference), clamped at 0, as oiiotool computes it.
r="$tmp/render/00000.exr"
oiiotool "$r" --ch objects.R,objects.G,objects.B,objects.A --chnames R,G,B,A \
  "$r" --ch photo.R,photo.G,photo.B --chnames R,G,B "$r" --ch difference.R,difference.G,difference.B --chnames R,G,B \
  --add --ch R,G,B,A=1.0 --over --clamp:min=0 --ch R,G,B -o "$tmp/rebuilt.exr"
oiiotool "$r" --ch composite.R,composite.G,composite.B --chnames R,G,B -o "$tmp/composite.exr"
check "passes rebuild the composite" 0 "PASS" -- idiff -fail 0 -failpercent 0 -warn 0 "$tmp/rebuilt.exr" "$tmp/composite.exr"
# A plate in S-Log3 (16-bit PNG, converted by oiiotool through mr's OpenColorIO
# config) composites as the same plate in linear, and the pixels the objects
# leave unchanged keep their code values (docs/formats.md, "Plates through
# OpenColorIO").
mkdir -p "$tmp/cap/slog"
for f in "$tmp/cap/photos/"*.exr; do
  oiiotool "$f" --colorconfig "$src/ocio/mr.ocio" --colorconvert "Linear Rec.709 (sRGB)" "S-Log3 S-Gamut3" \
    -d uint16 -o "$tmp/cap/slog/$(basename "${f%.exr}").png"
done
/usr/bin/python3 - "$tmp/cap" <<'PY'
import json, sys
s = json.load(open(sys.argv[1] + "/scene.json"))
s["camera"].pop("frames_transfer", None)
s["camera"].update({"frames": "slog/%05d.png", "frames_colorspace": "S-Log3 S-Gamut3"})
s["output"] = {"dir": "render-slog", "png": True, "grain": "off"}  # the linear plate has none
json.dump(s, open(sys.argv[1] + "/scene-slog.json", "w"))
s["camera"]["frames_colorspace"] = "S-Log9"
json.dump(s, open(sys.argv[1] + "/scene-slog9.json", "w"))
PY
check "mr-render S-Log3 plate" 0 "" -- "$bin/mr-render" "$tmp/cap/scene-slog.json" --out "$tmp/rslog" --spp 2 -q --report "$tmp/rslog.json"
check "S-Log3 compositing stated" 0 'S-Log3 S-Gamut3' -- cat "$tmp/rslog.json"
check "unknown colour space refused" 1 'camera.frames_colorspace: "S-Log9" is not a colour space of mr.ocio' -- \
  "$bin/mr-render" "$tmp/cap/scene-slog9.json" --out "$tmp/rslog9" -q
check "S-Log3 plate as the linear plate" 0 "" -- /usr/bin/python3 - "$tmp" <<'PY'
import os, subprocess, sys
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2, numpy as np
t = sys.argv[1]
def layer(path, name, chans="R,G,B"):
    out = "%s/%s-%s.exr" % (t, os.path.basename(os.path.dirname(path)), name)
    subprocess.run(["oiiotool", path, "--ch", ",".join(name + "." + c for c in chans.split(",")), "--chnames", "R,G,B",
                    "-o", out], check=True)
    return cv2.imread(out, cv2.IMREAD_UNCHANGED).astype(np.float64)
a, b = layer(t + "/rslog/00000.exr", "composite"), layer(t + "/render/00000.exr", "composite")
# S-Log3 holds linear values up to 38.4 (code 1): the plate's sun is clipped there.
p = layer(t + "/render/00000.exr", "photo")
held = (p.max(axis=2) < 30)
rel = np.abs(a - b)[held] / (np.abs(b[held]) + 1e-2)
print("composite from the S-Log3 plate against the linear plate: max relative difference %.2e over %d pixels "
      "(%d beyond S-Log3's range left out)" % (rel.max(), held.sum(), (~held).sum()))
# 16-bit log codes: 1/65535 of S-Log3's range is ~1e-4 relative.
ok = rel.max() < 2e-3
# Unchanged pixels keep the plate's 16-bit codes.
d = layer(t + "/rslog/00000.exr", "difference")
m = layer(t + "/rslog/00000.exr", "mask", "Y,Y,Y")
still = (np.abs(d).max(axis=2) == 0) & (m[..., 0] == 0)
plate = cv2.imread(t + "/cap/slog/00000.png", cv2.IMREAD_UNCHANGED)
out = cv2.imread(t + "/rslog/00000.png", cv2.IMREAD_UNCHANGED)
same = (plate == out).all(axis=2)
print("unchanged pixels %d, of them with the plate's codes %d; out PNG %s" % (still.sum(), (same & still).sum(), out.dtype))
ok = ok and still.sum() > 0 and (same[still]).all() and out.dtype == np.uint16
sys.exit(0 if ok else 1)
PY
check "unknown method" 2 'voxels' -- "$bin/mr-render" "$tmp/cap/scene.json" --out "$tmp/r2" --method voxels
# The fast GI methods, their reports and the error-against-time sweep.
check "mr-render ic" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --out "$tmp/ric" --method ic --spp 1 -q --report "$tmp/ric.json"
check "ic report" 0 '"records_created"' -- cat "$tmp/ric.json"
check "ic temporal figure" 0 '"temporal_change"' -- cat "$tmp/ric.json"
check "mr-render vpl" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --out "$tmp/rvpl" --method vpl --spp 1 -q --report "$tmp/rvpl.json"
check "vpl report" 0 '"clamp_bias_mixed"' -- cat "$tmp/rvpl.json"
check "mr-render vct" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --out "$tmp/rvct" --method vct --spp 1 -q --report "$tmp/rvct.json"
check "vct report" 0 '"injected_bounces"' -- cat "$tmp/rvct.json"
sed 's/"render": {/"render": {"vct": {"resolution": 16, "relight": "both"},/' "$tmp/cap/scene.json" > "$tmp/cap/scene-badvct.json"
check "bad vct value" 1 "relight" -- "$bin/mr-render" "$tmp/cap/scene-badvct.json" --out "$tmp/rbadvct" -q
check "mr-eval sweep" 0 "region relMSE" -- "$bin/mr-eval" sweep "$tmp/cap/scene.json" --out "$tmp/sweep" --methods pt,ic,vpl,vct --pt-spp 1,2 --ic-rays 16 --ic-spp 1 --vpl-paths 16 --vpl-spp 1 --vct-resolution 16 --vct-spp 1 --frames 0:1
check "sweep outputs" 0 "sweep.csv" -- ls "$tmp/sweep"
check "sweep plot" 0 "" -- test -s "$tmp/sweep/error-vs-time.png"
sed 's/"render": {/"render": {"vpl": {"paths": 16, "clamp": 0.1},/' "$tmp/cap/scene.json" > "$tmp/cap/scene-badvpl.json"
check "unknown vpl key" 1 "clamp" -- "$bin/mr-render" "$tmp/cap/scene-badvpl.json" --out "$tmp/rbad" -q
check "mr-info checks method blocks" 1 "render.vpl.clamp: unknown key" -- "$bin/mr-info" "$tmp/cap/scene-badvpl.json"
sed 's/"render": {/"render": {"vlp": {"paths": 16},/' "$tmp/cap/scene.json" > "$tmp/cap/scene-badblock.json"
check "block of no method" 1 "render.vlp: unknown key" -- "$bin/mr-render" "$tmp/cap/scene-badblock.json" --out "$tmp/rbad" -q
check "mr-render --method lists the registry" 0 "vct: delta global illumination" -- "$bin/mr-render" --help
check "unknown --method" 2 'unknown method "magic" (pt, ic, vpl, vct, prt)' -- "$bin/mr-render" "$tmp/cap/scene.json" --method magic --out "$tmp/rbad" -q
# A generic sweep axis: any key of a method's block.
check "sweep --set" 0 "relight=delta spp=1" -- "$bin/mr-eval" sweep "$tmp/cap/scene.json" --out "$tmp/sweep-set" --methods vct --set vct.resolution=8 --set vct.relight=split,delta --set vct.spp=1 --frames 0:1
check "sweep --set dirs" 0 "vct-resolution8-relightdelta-spp1.png" -- ls "$tmp/sweep-set/diff"
check "sweep --set bad key" 1 "render.vct.resolutoin: unknown key" -- "$bin/mr-eval" sweep "$tmp/cap/scene.json" --out "$tmp/sweep-bad" --methods vct --set vct.resolutoin=8 --frames 0:1
check "sweep --set bad form" 2 "expected METHOD.KEY=V1,V2" -- "$bin/mr-eval" sweep "$tmp/cap/scene.json" --out "$tmp/sweep-bad" --set spp=1
check "sweep --set lengths" 2 "vct.spp has 2 values for 3 settings" -- "$bin/mr-eval" sweep "$tmp/cap/scene.json" --out "$tmp/sweep-bad" --methods vct --set vct.resolution=8,16,32 --set vct.spp=1,2
# Deterministic: the same command writes the same bytes (provenance names the
# command line, so the command must be the same, output folder included).
cp -r "$tmp/cap" "$tmp/cap.first"
check "mr-synth again" 0 "" -- "$bin/mr-synth" --preset small --out "$tmp/cap" --truth-spp 16 -q
for f in scene.json env.exr truth/00001.exr photos/00000.png photos.mp4 meshes/object.ply; do
  check "same bytes: $f" 0 "" -- cmp "$tmp/cap.first/$f" "$tmp/cap/$f"
done
# A real spot light: lights.json is written, named by scene.json, and rendered.
check "mr-synth spot" 0 "" -- "$bin/mr-synth" --preset small --out "$tmp/spot" --truth-spp 4 --spot-light -q
check "scene names lights" 0 '"lights": "lights.json"' -- cat "$tmp/spot/scene.json"
check "lights file" 0 "lights: 1 (0 virtual)" -- "$bin/mr-info" "$tmp/spot/lights.json"
check "mr-render spot" 0 "" -- "$bin/mr-render" "$tmp/spot/scene.json" --out "$tmp/spot/r" --spp 1 -q
# Form factors: compute, describe, shade with a reference; a changed mesh is refused.
check "mr-formfactor" 0 "" -- "$bin/mr-formfactor" "$tmp/cap/meshes/object.ply" --resolution 4 --out "$tmp/o.ffc" -q
check "ffc info" 0 "cube 4x4x6, 96 coefficients per vertex" -- "$bin/mr-info" "$tmp/o.ffc"
check "mr-formfactor shade" 0 "" -- "$bin/mr-formfactor" "$tmp/cap/meshes/object.ply" --ffc "$tmp/o.ffc" --shade "$tmp/cap/env.exr" --out "$tmp/lit.ply" --reference-rays 16 -q --report "$tmp/ff.json"
check "shade report" 0 '"vertex_relative_rms"' -- cat "$tmp/ff.json"
check "ffc for another mesh" 1 "was computed for another mesh" -- "$bin/mr-formfactor" "$tmp/cap/meshes/floor.ply" --ffc "$tmp/o.ffc" --shade "$tmp/cap/env.exr" --out "$tmp/x.ply"
check "bad order" 2 "--order 9 is outside 1..8" -- "$bin/mr-formfactor" "$tmp/cap/meshes/object.ply" --basis sh --order 9 --out "$tmp/x.ffc"
# mr-calibrate refuses what it cannot use, naming it.
check "calibrate without images" 2 "images is required" -- "$bin/mr-calibrate" camera --board "$src/calib/boards/chessboard-8x6.json" --out "$tmp/c.cameramodel"
check "calibrate unknown model" 2 'unknown lens model "LENSMODEL_NOPE"' -- "$bin/mr-calibrate" camera --board "$src/calib/boards/chessboard-8x6.json" --lensmodel LENSMODEL_NOPE --out "$tmp/c.cameramodel" "$tmp/cap/photos/00000.png"
# The mirror sphere of mr-synth's probe: found, its centre written to probe.json.
check "calibrate sphere" 0 "sphere centre" -- "$bin/mr-calibrate" sphere --camera "$tmp/cap/probe/light.cameramodel" --radius 0.0254 --out "$tmp/probe.json" "$tmp/cap/probe/sphere.exr"
check "probe.json" 0 '"format": "mr-probe"' -- cat "$tmp/probe.json"
check "probe.json names its camera" 0 '"camera": "cap/probe/light.cameramodel"' -- cat "$tmp/probe.json"
check "sphere: negative radius" 2 "--radius" -- "$bin/mr-calibrate" sphere --camera "$tmp/cap/probe/light.cameramodel" --radius -1 --out "$tmp/p4.json" "$tmp/cap/probe/sphere.exr"
check "sphere without radius" 2 "--radius is required" -- "$bin/mr-calibrate" sphere --camera "$tmp/cap/probe/light.cameramodel" --out "$tmp/p2.json" "$tmp/cap/probe/sphere.exr"
check "sphere: wrong camera" 1 "the camera model is for" -- "$bin/mr-calibrate" sphere --camera "$tmp/cap/camera.cameramodel" --radius 0.0254 --out "$tmp/p3.json" "$tmp/cap/probe/sphere.exr"
check "no probe.json left" 1 "" -- test -e "$tmp/p3.json"
# Synthetic board photographs calibrate; the three bad ones are left out with their reasons.
check "mr-synth boards" 0 "" -- "$bin/mr-synth" --boards pinhole --out "$tmp/boards" -q
check "calibrate synthetic" 0 "14 of 17 photographs used" -- "$bin/mr-calibrate" camera --board "$tmp/boards/board.json" --lensmodel LENSMODEL_PINHOLE --out "$tmp/boards/camera.cameramodel" "$tmp"/boards/photos/camera-*.png --report "$tmp/calib.json"
check "calibrate report: blurry" 0 "blurry" -- cat "$tmp/calib.json"
check "unknown board lens" 2 'unknown --boards lens "wide"' -- "$bin/mr-synth" --boards wide --out "$tmp/b2"
check "unknown preset" 2 'unknown preset "huge"' -- "$bin/mr-synth" --preset huge --out "$tmp/c2"

# The lighting capture: bracket -> HDR -> world-aligned map -> lights, and what each refuses.
probe="$tmp/cap/probe"
check "mr-hdr bracket" 0 "" -- "$bin/mr-hdr" "$probe"/bracket/sphere-*.png --exposures "$probe/bracket/exposures.txt" --save-response "$tmp/response.json" --out "$tmp/raw.exr" --report "$tmp/hdr.json" -q
check "hdr layers" 0 "saturated.Y" -- "$bin/mr-info" "$tmp/raw.exr"
check "hdr report: the sun is censored" 0 '"censored_pixels"' -- cat "$tmp/hdr.json"
check "response file" 0 "camera response (debevec)" -- "$bin/mr-info" "$tmp/response.json"
check "mr-hdr reuses a response" 0 "" -- "$bin/mr-hdr" "$probe"/fisheye/sky-*.png --exposures "$probe/fisheye/exposures.txt" --response "$tmp/response.json" --out "$tmp/sky.exr" -q
printf '1\n0.25\n' > "$tmp/two.txt"
check "hdr: too few times" 1 "has 2 exposure times for 4 images" -- "$bin/mr-hdr" "$probe"/bracket/sphere-*.png --exposures "$tmp/two.txt" --out "$tmp/x.exr"
check "hdr: no exposure time" 1 "has no ExposureTime" -- "$bin/mr-hdr" "$tmp/cap/photos/00000.png" "$tmp/cap/photos/00001.png" --out "$tmp/x.exr"
printf 'sphere-0.png 1e-9\nsphere-1.png 2.5e-10\nsphere-2.png 6.25e-11\nsphere-3.png 1.5625e-11\n' > "$tmp/tiny.txt"
check "hdr: half overflow refused" 1 "65504" -- "$bin/mr-hdr" "$probe"/bracket/sphere-*.png --exposures "$tmp/tiny.txt" --half --save-response "$tmp/r-failed.json" --out "$tmp/half.exr"
check "no half-written HDR" 1 "" -- test -e "$tmp/half.exr"
check "no response from a failed run" 1 "" -- test -e "$tmp/r-failed.json"
check "mr-probe" 0 "" -- "$bin/mr-probe" "$tmp/raw.exr" --probe "$tmp/probe.json" --reflectance 0.6 --width 128 --out "$tmp/env.exr" --report "$tmp/probe-report.json" -q
check "env layers" 0 "confidence.Y" -- "$bin/mr-info" "$tmp/env.exr"
check "probe file" 0 "mirror sphere of radius 0.0254 m" -- "$bin/mr-info" "$tmp/probe.json"
check "mr-probe fish-eye" 0 "" -- "$bin/mr-probe" "$tmp/sky.exr" --fisheye "$probe/fisheye.cameramodel" --width 128 --out "$tmp/env-sky.exr" -q
check "probe: photograph of another camera" 1 "but its camera model is" -- "$bin/mr-probe" "$tmp/cap/env.exr" --probe "$tmp/probe.json" --out "$tmp/x.exr"
check "probe: bad reflectance" 2 "reflectance 2 not in (0, 1]" -- "$bin/mr-probe" "$tmp/raw.exr" --probe "$tmp/probe.json" --reflectance 2 --out "$tmp/x.exr"
check "mr-lights" 0 "" -- "$bin/mr-lights" "$tmp/env.exr" --method median-cut --count 16 --out "$tmp/lights.json" --report "$tmp/lights-report.json" -q
check "lights.json" 0 "lights: 16 (0 virtual)" -- "$bin/mr-info" "$tmp/lights.json"
check "lights report" 0 '"irradiance_error"' -- cat "$tmp/lights-report.json"
check "mr-lights blobs" 0 "" -- "$bin/mr-lights" "$tmp/cap/env.exr" --method blobs --count 4 --out "$tmp/blobs.json" --residual "$tmp/rest.exr" -q
check "mr-lights: fewer than asked, said why" 0 "regions brighter than --threshold 20" -- "$bin/mr-lights" "$tmp/cap/env.exr" --method blobs --count 64 --threshold 20 --out "$tmp/blobs64.json"
check "blobs name their residual" 0 '"map": "rest.exr"' -- cat "$tmp/blobs.json"
sed 's|"environment": "env.exr"|"environment": "../rest.exr", "lights": "../blobs.json"|' "$tmp/cap/scene.json" > "$tmp/cap/scene-blobs.json"
check "scene lit by the blobs and their residual" 0 "valid" -- "$bin/mr-info" "$tmp/cap/scene-blobs.json"
check "render with extracted lights" 0 "" -- "$bin/mr-render" "$tmp/cap/scene-blobs.json" --out "$tmp/r-lights" --spp 1 -q
# Over time: a map per frame, lights per frame keeping their names.
mkdir -p "$tmp/envs" && cp "$tmp/cap/env.exr" "$tmp/envs/00000.exr" && cp "$tmp/cap/env.exr" "$tmp/envs/00001.exr"
check "mr-lights over time" 0 "" -- "$bin/mr-lights" "$tmp/envs/%05d.exr" --method blobs --count 2 --out "$tmp/lt/%05d.json" --residual "$tmp/lt/res-%05d.exr" --report "$tmp/lt.json" -q
check "a light keeps its name" 0 '"name": "light0"' -- cat "$tmp/lt/00001.json"
check "identities reported" 0 '"kept_identity"' -- cat "$tmp/lt.json"
check "mr-lights over time again" 0 "" -- "$bin/mr-lights" "$tmp/envs/%05d.exr" --method blobs --count 2 --out "$tmp/lt/%05d.json" --residual "$tmp/lt/res-%05d.exr" --report "$tmp/lt2.json" -q
check "an up-to-date frame is kept" 0 '"frames_kept": 2' -- cat "$tmp/lt2.json"
check "over time needs patterns out" 2 "needs patterns" -- "$bin/mr-lights" "$tmp/envs/%05d.exr" --out "$tmp/one.json"
check "mr-lights sweep" 0 "variance-cut,1024" -- "$bin/mr-lights" "$tmp/cap/env.exr" --sweep --counts 1,1024 --table "$tmp/sweep.csv" --plot "$tmp/sweep.svg" -q
check "sweep plot" 0 "<svg" -- cat "$tmp/sweep.svg"
check "mr-eval plot" 0 "" -- "$bin/mr-eval" plot "$tmp/sweep.csv" --x count --y irradiance_rms --group method --out "$tmp/plot.svg"
check "plot names its lines" 0 "variance-cut" -- cat "$tmp/plot.svg"
check "plot: unknown column" 1 'has no column "error"' -- "$bin/mr-eval" plot "$tmp/sweep.csv" --x count --y error --out "$tmp/p2.svg"
check "unknown lights method" 2 "kmeans" -- "$bin/mr-lights" "$tmp/env.exr" --method kmeans --out "$tmp/x.json"

# RGB-D reconstruction: synthetic recording -> mr-fuse -> mr-eval traj / mesh.
check "mr-synth --rgbd" 0 "" -- "$bin/mr-synth" --rgbd --rgbd-size 160,120,20 --rgbd-spp 1 --out "$tmp/rgbd" -q
check "mr-fuse" 0 "" -- "$bin/mr-fuse" "$tmp/rgbd" --out "$tmp/fused" --first-pose reference --report "$tmp/fuse.json" -q
check "fuse writes its report beside the mesh" 0 '"frames_per_second"' -- cat "$tmp/fused/fuse-report.json"
check "room.ply carries albedo and confidence" 0 "property float confidence" -- head -c 600 "$tmp/fused/room.ply"
check "room.ply is a mesh mr-info reads" 0 "triangles" -- "$bin/mr-info" "$tmp/fused/room.ply"
check "mr-eval traj" 0 "ATE rmse" -- "$bin/mr-eval" traj "$tmp/fused/trajectory.txt" "$tmp/rgbd/groundtruth.txt"
check "traj: no common timestamps" 1 "too few for ATE" -- "$bin/mr-eval" traj "$tmp/cap/trajectory.txt" "$tmp/rgbd/groundtruth.txt" --max-dt 0.001
check "mr-eval mesh" 0 "accuracy" -- "$bin/mr-eval" mesh "$tmp/fused/room.ply" "$tmp/rgbd/reference/room.ply" --samples 20000
check "fuse: not a recording" 1 "is not an RGB-D recording" -- "$bin/mr-fuse" "$tmp/cap" --out "$tmp/f2"
[ ! -e "$tmp/f2/room.ply" ] && echo "ok   fuse: nothing written on failure" && pass=$((pass + 1))
sed -n 1,2p "$tmp/rgbd/depth.txt" > "$tmp/rgbd-bad.txt"
mkdir -p "$tmp/rgbd-bad" && cp -r "$tmp/rgbd/depth" "$tmp/rgbd/depth.cameramodel" "$tmp/rgbd-bad/"
printf '0.0 depth/0.000000.png\nabc depth/x.png\n' > "$tmp/rgbd-bad/depth.txt"
check "fuse: bad list line" 1 "depth.txt:2: \"abc\" is not a timestamp" -- "$bin/mr-fuse" "$tmp/rgbd-bad" --out "$tmp/f3"
check "fuse: wrong depth scale warned" 1 "5000 would make it plausible" -- "$bin/mr-fuse" "$tmp/rgbd" --out "$tmp/f4" --depth-scale 1000 --max-depth 30 --no-albedo --count 6
check "fuse around the scene's object" 0 "" -- "$bin/mr-fuse" "$tmp/rgbd" --out "$tmp/f6" --first-pose reference --roi-from "$tmp/cap/scene.json" --preview-every 10 --no-albedo --report "$tmp/f6.json" -q
check "roi reported as a skip" 0 "virtual objects' bounds" -- cat "$tmp/f6.json"
check "preview written" 0 "" -- test -s "$tmp/f6/preview/000010.png"
check "fuse: bad ROI" 2 "minimum corner" -- "$bin/mr-fuse" "$tmp/rgbd" --out "$tmp/f5" --roi 1,1,1,0,0,0
check "fuse: unknown layout is a usage error" 2 "--layout" -- "$bin/mr-fuse" "$tmp/rgbd" --out "$tmp/f5" --layout kinect

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
