#!/usr/bin/env bash
# mr-pipeline as users run it: three differently equipped pipeline files
# (what each leaves out, and why), up-to-date checks by content, --until,
# --force, --dry-run, a failing stage, and bad pipeline files.
# Usage: pipeline.sh BIN_DIR
set -u
bin=$1
src=$(cd "$(dirname "$0")/../.." && pwd)
source "$(dirname "$0")/lib.sh"
P="$bin/mr-pipeline"

check "mr-synth capture" 0 "" -- "$bin/mr-synth" --preset small --out "$tmp/capture" --truth-spp 4 -q
check "mr-synth rgbd" 0 "" -- "$bin/mr-synth" --rgbd --rgbd-size 80,60,12 --rgbd-spp 1 --out "$tmp/rgbd" -q
cp "$tmp/capture/meshes/object.ply" "$tmp/object.ply"

# 1. Everything given: camera model, environment map, room meshes, poses.
#    Only the scene and the render run.
cat > "$tmp/given.json" <<'JSON'
{"version": 1, "work": "given-work",
 "camera": {"model": "capture/camera.cameramodel"},
 "lighting": {"environment": "capture/env.exr"},
 "room": {"real": [{"mesh": "capture/meshes/floor.ply", "material": {"albedo": [0.55, 0.5, 0.45]}},
                   {"mesh": "capture/meshes/wall_back.ply", "material": {"albedo": [0.7, 0.7, 0.65]}}]},
 "video": {"frames": "capture/photos/%05d.exr", "poses": {"tum": "capture/trajectory.txt"}},
 "virtual": [{"name": "ball", "mesh": "object.ply", "transform": {"translation": [0.1, 0.9, 0]}}],
 "render": {"method": "pt", "spp": 2, "seed": 3}}
JSON
check "given: dry run plans scene and render" 0 "render      would run   an input is re-made" -- "$P" "$tmp/given.json" --dry-run
check "given: no calibration" 0 "calibrate   skipped     camera.model is given" -- "$P" "$tmp/given.json" --dry-run
check "given: no fusion" 0 "room.real gives 2 meshes: no RGB-D recording to fuse" -- "$P" "$tmp/given.json" --dry-run
check "given: no probe" 0 "lighting.environment is given: no photographs to merge" -- "$P" "$tmp/given.json" --dry-run
check "given: no lights" 0 "lighting.lights is not asked for" -- "$P" "$tmp/given.json" --dry-run
check "given: no form factors" 0 "render.method is pt: form factors are only used by prt" -- "$P" "$tmp/given.json" --dry-run
check "given: no sweep" 0 "outputs.sweep is not asked for" -- "$P" "$tmp/given.json" --dry-run
check "given: dry run writes nothing" 0 "" -- test ! -e "$tmp/given-work"
check "given: runs" 0 "" -- "$P" "$tmp/given.json" -q --report "$tmp/given-report.json"
check "given: composites" 0 "" -- test -s "$tmp/given-work/render/00001.png"
check "given: report aggregates stages" 0 '"stage": "render"' -- cat "$tmp/given-report.json"
check "given: stage report inside" 0 '"tool": "mr-render"' -- cat "$tmp/given-report.json"
check "given: skipped stages in the report" 0 '"what": "fuse"' -- cat "$tmp/given-report.json"
check "given: second run: up to date" 0 "render      up to date" -- "$P" "$tmp/given.json" --dry-run
before=$(stat -c %Y "$tmp/given-work/render/00000.exr")
check "given: second run does nothing" 0 "" -- "$P" "$tmp/given.json" -q
check "given: frames untouched" 0 "" -- test "$before" = "$(stat -c %Y "$tmp/given-work/render/00000.exr")"
check "given: --force render" 0 "render      would run   --force" -- "$P" "$tmp/given.json" --dry-run --force render
# A changed input re-runs what depends on it: content, not time stamps.
touch "$tmp/object.ply"
check "given: touched, same content: up to date" 0 "render      up to date" -- "$P" "$tmp/given.json" --dry-run
printf '\n' >> "$tmp/capture/trajectory.txt"
check "given: changed poses: scene re-made" 0 "scene       would run   inputs, options or the tool changed" -- "$P" "$tmp/given.json" --dry-run
check "given: an output edited: re-made" 0 "" -- "$P" "$tmp/given.json" -q
echo garbage >> "$tmp/given-work/scene.json"
check "given: edited output detected" 0 "output changed since" -- "$P" "$tmp/given.json" --dry-run
check "given: --until scene" 0 "after --until scene" -- "$P" "$tmp/given.json" --until scene --dry-run
check "given: --until a stage left out" 0 "render      skipped     after --until fuse" -- "$P" "$tmp/given.json" --until fuse --dry-run
check "given: unknown stage" 2 "no such stage" -- "$P" "$tmp/given.json" --until paint
# Only the object moved: the radiometry stage (the room alone) is not re-run, the render is.
check "given: up to date again" 0 "" -- "$P" "$tmp/given.json" -q
radiometry_before=$(stat -c %Y "$tmp/given-work/reports/radiometry.json")
render_before=$(stat -c %Y "$tmp/given-work/reports/render.json")
sleep 1
sed -i 's/"translation": \[0.1, 0.9, 0\]/"translation": [0.15, 0.9, 0]/' "$tmp/given.json"
check "given: object moved: runs" 0 "" -- "$P" "$tmp/given.json" -q
check "given: object moved: radiometry kept" 0 "" -- test "$radiometry_before" = "$(stat -c %Y "$tmp/given-work/reports/radiometry.json")"
check "given: object moved: render re-run" 0 "" -- test "$render_before" != "$(stat -c %Y "$tmp/given-work/reports/render.json")"

# 2. A probe bracket (HDR merge, unwrapping with a given probe.json, lights),
#    a fused room, and prt: form factors are computed.
"$bin/mr-calibrate" sphere --camera "$tmp/capture/probe/light.cameramodel" --radius 0.0254 \
  --out "$tmp/probe.json" "$tmp/capture/probe/sphere.exr" -q
cat > "$tmp/probe.json.pipeline" <<'JSON'
{"version": 1, "work": "probe-work",
 "camera": {"model": "capture/camera.cameramodel"},
 "lighting": {"probe": {"photos": "capture/probe/bracket/sphere-*.png", "exposures": "capture/probe/bracket/exposures.txt",
                        "probe": "probe.json", "unwrap": {"reflectance": 0.6, "width": 64}},
              "lights": {"options": {"method": "blobs", "count": 2, "threshold": 20, "residual-width": 64}}},
 "room": {"rgbd": "rgbd", "options": {"first-pose": "reference", "no-albedo": true, "voxel": 0.04}},
 "video": {"frames": "capture/photos/%05d.exr", "poses": {"tum": "capture/trajectory.txt"}},
 "virtual": [{"name": "ball", "mesh": "object.ply", "transform": {"translation": [0.1, 0.9, 0]}}],
 "formfactor": {"resolution": 4},
 "render": {"method": "prt", "spp": 1},
 "reference": "capture/truth/%05d.exr",
 "outputs": {"render": true}}
JSON
check "probe: sphere given" 0 "lighting.probe.probe is given" -- "$P" "$tmp/probe.json.pipeline" --dry-run
check "probe: bracket merged" 0 "hdr         would run" -- "$P" "$tmp/probe.json.pipeline" --dry-run
check "probe: form factors for prt" 0 "formfactor  would run" -- "$P" "$tmp/probe.json.pipeline" --dry-run
check "probe: sweep not asked" 0 "outputs.sweep is not asked for" -- "$P" "$tmp/probe.json.pipeline" --dry-run
check "probe: runs" 0 "" -- "$P" "$tmp/probe.json.pipeline" -q --report "$tmp/probe-report.json"
check "probe: fused room in the scene" 0 '"mesh": "room/room.ply"' -- cat "$tmp/probe-work/scene.json"
check "probe: lights in the scene" 0 '"lights": "lights.json"' -- cat "$tmp/probe-work/scene.json"
check "probe: form factors in the scene" 0 '"formfactors": "ball.ffc"' -- cat "$tmp/probe-work/scene.json"
check "probe: the room's own albedo" 0 '"albedo_from_vertex_colors": true' -- cat "$tmp/probe-work/scene.json"
check "probe: up to date" 0 "fuse        up to date" -- "$P" "$tmp/probe.json.pipeline" --dry-run
# A changed option re-runs that stage and, when its output changes, those after it.
sed -i 's/"count": 2/"count": 3/' "$tmp/probe.json.pipeline"
check "probe: changed option" 0 "lights      would run   inputs, options or the tool changed" -- "$P" "$tmp/probe.json.pipeline" --dry-run
check "probe: fuse unaffected" 0 "fuse        up to date" -- "$P" "$tmp/probe.json.pipeline" --dry-run

# 3. Only a video and a fused recording whose colour is the video: poses from
#    mr-fuse; a failing stage stops the run and keeps what finished (the
#    probe's map, made before the room).
mkdir -p "$tmp/notrgbd" && echo nothing > "$tmp/notrgbd/readme.txt"
cat > "$tmp/fail.json" <<'JSON'
{"version": 1, "work": "fail-work",
 "camera": {"model": "capture/camera.cameramodel"},
 "lighting": {"probe": {"photos": "capture/probe/sphere.exr", "probe": "probe.json",
                        "unwrap": {"reflectance": 0.6, "width": 64}}},
 "room": {"rgbd": "notrgbd"},
 "video": {"frames": "capture/photos/%05d.exr", "poses": {"fuse": true}},
 "virtual": [{"mesh": "object.ply"}]}
JSON
check "fail: poses from fuse" 0 "its poses are mr-fuse's trajectory" -- "$P" "$tmp/fail.json" --dry-run
check "fail: stage named" 1 "stage fuse failed (mr-fuse exited with 1)" -- "$P" "$tmp/fail.json" -q
check "fail: tool's message" 1 "is not an RGB-D recording" -- "$P" "$tmp/fail.json" -q
check "fail: finished outputs kept" 0 "" -- test -s "$tmp/fail-work/env.exr"
check "fail: no scene written" 0 "" -- test ! -e "$tmp/fail-work/scene.json"
check "fail: probe not re-run" 0 "probe       up to date" -- "$P" "$tmp/fail.json" --dry-run

# 4. Video poses from a COLMAP model (here made from the recording's true
#    poses moved by a known similarity, as COLMAP would give them: arbitrary
#    scale and frame), aligned by mr-register to the fused trajectory.
mkdir -p "$tmp/colmap"
/usr/bin/python3 - "$tmp/rgbd/groundtruth.txt" "$tmp/colmap" <<'PY'
import sys, numpy as np
def qmat(x, y, z, w):
    return np.array([[1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w)], [2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w)],
                     [2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y)]])
def quat(R):  # w, x, y, z
    w = np.sqrt(max(0, 1 + np.trace(R))) / 2
    return w, (R[2,1]-R[1,2])/(4*w), (R[0,2]-R[2,0])/(4*w), (R[1,0]-R[0,1])/(4*w)
s, Rs, ts = 3.0, qmat(0.2, -0.3, 0.1, np.sqrt(1 - 0.14)), np.array([1.0, -2.0, 0.5])  # colmap = s Rs world + ts
lines = [l.split() for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
with open(sys.argv[2] + "/images.txt", "w") as f:
    for i, l in enumerate(lines):
        t = np.array(list(map(float, l[1:4]))); R = qmat(*map(float, l[4:8]))   # world_from_cam
        Rc, c = Rs @ R, s * Rs @ t + ts                                             # in COLMAP's frame
        Rcw = Rc.T; tcw = -Rcw @ c                                                  # cam_from_world
        f.write("%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g 1 %05d.png\n\n" % ((i + 1,) + quat(Rcw) + tuple(tcw) + (i,)))
open(sys.argv[2] + "/cameras.txt", "w").write("1 PINHOLE 80 60 60 60 40 30\n")
open(sys.argv[2] + "/points3D.txt", "w").write("")
PY
cat > "$tmp/colmap.json" <<'JSON'
{"version": 1, "work": "colmap-work",
 "camera": {"model": "capture/camera.cameramodel"},
 "lighting": {"environment": "capture/env.exr"},
 "room": {"rgbd": "rgbd", "options": {"poses": "reference", "no-albedo": true, "voxel": 0.04}},
 "video": {"frames": "capture/photos/%05d.exr", "poses": {"colmap": "colmap"}},
 "virtual": [{"mesh": "object.ply"}],
 "outputs": {"render": false}}
JSON
check "colmap: align planned" 0 "register    would run" -- "$P" "$tmp/colmap.json" --dry-run
check "colmap: runs" 0 "" -- "$P" "$tmp/colmap.json" -q --until register
check "colmap: poses in the scene's frame" 0 "" -- test -s "$tmp/colmap-work/video/poses.txt"
# Fused with the recording's true poses (tracking a 12-frame 80x60
# recording is not what this checks), so the alignment is exact up to the
# text format's digits (bound: 1 mm) and finds the scale 1/3.
check "colmap: residual" 0 "" -- /usr/bin/python3 -c "
import json, sys; a = json.load(open('$tmp/colmap-work/reports/register.json'))['metrics']['alignment']
print(a); sys.exit(0 if a['centre_rmse_m'] < 1e-3 and abs(a['scale'] - 1/3.0) < 1e-6 and a['pairs'] == 12 else 1)"
sed 's#"poses": {"colmap": "colmap"}#"poses": {"register": true}#; s#"rgbd": "rgbd", "options": {"poses": "reference", "no-albedo": true, "voxel": 0.04}#"real": [{"mesh": "capture/meshes/floor.ply"}]#' "$tmp/colmap.json" > "$tmp/bad6.json"
check "bad: register to meshes needs a start" 1 "needs \"initial\"" -- "$P" "$tmp/bad6.json" --dry-run

# 5. A dynamic capture whose light is the mirror sphere in its own plate
#    (the main job's second dynamic chain, smaller): plate_probe unwraps
#    each frame from its pose, the lamp's lights file passes through, and a
#    second run is up to date.
check "mr-synth plate sphere" 0 "" -- "$bin/mr-synth" --preset medium --dynamic --plate-sphere --frames 2 \
  --truth-spp 2 --out "$tmp/dyn/capture" -q
/usr/bin/python3 "$src/examples/synthetic/dynamic_pipeline.py" "$tmp/dyn/capture/scene.json" sphere \
  | sed 's#"spp": 16#"spp": 1#' > "$tmp/dyn/sphere.json"
check "sphere: plan" 0 "plate_probe would run   not run before" -- "$P" "$tmp/dyn/sphere.json" --dry-run
check "sphere: no light camera" 0 "the light is the mirror sphere in the plate" -- "$P" "$tmp/dyn/sphere.json" --dry-run
check "sphere: runs" 0 "" -- "$P" "$tmp/dyn/sphere.json" -q --report "$tmp/dyn/report.json"
check "sphere: the plate's scene" 0 '"frames": "../capture/photos/%05d.exr"' -- cat "$tmp/dyn/work-sphere/plate.json"
check "sphere: a map per frame" 0 "" -- test -s "$tmp/dyn/work-sphere/env/00001.exr"
check "sphere: the scene lit by them" 0 '"environment": "env/%05d.exr"' -- cat "$tmp/dyn/work-sphere/scene.json"
check "sphere: composites" 0 "" -- test -s "$tmp/dyn/work-sphere/render/00001.exr"
check "sphere: mr-probe saw the sphere" 0 '"sphere_in_view": true' -- cat "$tmp/dyn/work-sphere/reports/plate_probe.json"
check "sphere: second run up to date" 0 "plate_probe up to date" -- "$P" "$tmp/dyn/sphere.json" --dry-run

# The real-data example skips cleanly where ../shared/data is absent.
check "real example without the data" 0 "examples/real: skipped: the real data is not at $tmp/none" -- bash "$src/examples/real/run.sh" "$tmp/real" "$tmp/none"

# Bad pipeline files: one message naming the file and the key.
echo '{"version": 1, "camera": {"model": "capture/camera.cameramodel"}, "colour": 1}' > "$tmp/bad1.json"
check "bad: unknown key" 1 "bad1.json: colour: unknown key" -- "$P" "$tmp/bad1.json" --dry-run
sed 's#"model": "capture/camera.cameramodel"#"model": "capture/camera.cameramodel", "boards": {}#' "$tmp/given.json" > "$tmp/bad2.json"
check "bad: model and boards" 1 "give either camera.model or camera.boards" -- "$P" "$tmp/bad2.json" --dry-run
sed 's#capture/env.exr#capture/nothere.exr#' "$tmp/given.json" > "$tmp/bad3.json"
check "bad: missing file" 1 "lighting.environment: environment map" -- "$P" "$tmp/bad3.json" --dry-run
sed 's#"method": "pt"#"method": "rays"#' "$tmp/given.json" > "$tmp/bad4.json"
check "bad: the scene's own checks" 1 "rays" -- "$P" "$tmp/bad4.json" --dry-run
sed 's#"tum": "capture/trajectory.txt"#"fuse": true#' "$tmp/given.json" > "$tmp/bad5.json"
check "bad: poses from no fusion" 1 "the room is not fused" -- "$P" "$tmp/bad5.json" --dry-run

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
