#!/usr/bin/env bash
# The main job, on data the repository generates (no ../shared needed): a
# synthetic capture from mr-synth (board photographs, a bracketed mirror-sphere
# probe, an RGB-D recording of the room, a video with known poses and its
# ground truth), then the whole chain in one command, mr-pipeline
# (examples/synthetic/pipeline.json): calibrate -> sphere -> hdr -> probe ->
# lights -> fuse -> scene -> radiometry -> render -> sweep (error against run time);
# then a glTF asset with textures, a metal and a glass part in the same
# plates; then a short dynamic capture (the light and the object change every
# frame) through its own pipeline file and every method.  About 5 minutes on 2 cores
# after the build.
#   bash examples/run.sh [OUT] [--inputs-only] [--object MESH]
# --inputs-only: the raw inputs alone (OUT/capture, OUT/boards, OUT/rgbd:
# what docs/tutorial.md starts from), about a minute; --object MESH: the
# capture's virtual object and its truth are MESH (mr-synth --object).
set -euo pipefail
cd "$(dirname "$0")/.."
out=out/example inputs_only=0 object=sphere
while [ $# -gt 0 ]; do
  case $1 in
    --inputs-only) inputs_only=1 ;;
    --object) object=$(realpath "$2"); shift ;;
    -*) echo "usage: bash examples/run.sh [OUT] [--inputs-only] [--object MESH]" >&2; exit 2 ;;
    *) out=$1 ;;
  esac
  shift
done
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
bin=build/bin
mkdir -p "$out"
start=$(date +%s)
# The raw inputs a user would bring, here synthetic with exact ground truth.
"$bin/mr-synth" --preset medium --object "$object" --out "$out/capture" --report "$out/synth-report.json" -q
"$bin/mr-synth" --boards "$out/capture/camera.cameramodel" --out "$out/boards" -q 2>/dev/null
"$bin/mr-synth" --rgbd --rgbd-size 160,120,60 --out "$out/rgbd" -q
cp examples/synthetic/pipeline.json "$out/pipeline.json"
if [ "$object" != sphere ]; then
  # The user's mesh where mr-synth put it in the truth (its report's object:
  # scale and turn; transform.rest_on puts it on the fused table).
  /usr/bin/python3 - "$out" <<'PY'
import json, sys
o = sys.argv[1]
obj = json.load(open(o + "/synth-report.json"))["metrics"]["object"]
p = json.load(open(o + "/pipeline.json"))
x, y, z = obj["rests_on"]
p["virtual"][0]["transform"] = {"rest_on": [x, y + 0.75, z], "rotation_deg": obj["rotation_deg"], "scale": obj["scale"]}
json.dump(p, open(o + "/pipeline.json", "w"), indent=2)
PY
fi
if [ "$inputs_only" = 1 ]; then
  echo "inputs in $out (capture, boards, rgbd) in $(( $(date +%s) - start )) s; docs/tutorial.md goes on from there"
  exit 0
fi
# Everything else, in one command (a second run re-runs nothing: try it).
"$bin/mr-pipeline" "$out/pipeline.json" --dry-run
"$bin/mr-pipeline" "$out/pipeline.json" --report "$out/pipeline-report.json"
# The whole chain against the truth: trajectory and mesh of the room.
"$bin/mr-eval" traj "$out/work/room/trajectory.txt" "$out/rgbd/groundtruth.txt" --report "$out/traj-report.json" -q > /dev/null
"$bin/mr-eval" mesh "$out/work/room/room.ply" "$out/rgbd/reference/room.ply" --samples 50000 --report "$out/mesh-report.json" -q > /dev/null
w=$out/work
echo
echo "in $(( $(date +%s) - start )) s:"
echo "camera:          $w/camera.cameramodel (true model: $out/capture/camera.cameramodel)"
echo "captured light:  $w/env.exr (merged bracket $w/probe-raw.exr), lights $w/lights.json + residual $w/env-residual.exr"
echo "room:            $w/room/room.ply, trajectory $w/room/trajectory.txt"
echo "scene:           $w/scene.json"
echo "composites:      $w/render/*.png (layers in $w/render/*.exr)"
echo "review sheet:    $(ls "$w"/render/*-review.png | head -1) (plate | composite | difference | mask; one per frame)"
echo "error vs time:   $w/sweep/sweep.csv, plots $w/sweep/error-vs-time*.svg, differences $w/sweep/diff/"
echo "reports:         $w/reports/*.json, all of them in $out/pipeline-report.json; logs in $w/logs/"
/usr/bin/python3 - "$out" <<'PY' || true
import json, sys
o = sys.argv[1]
p = json.load(open(o + "/pipeline-report.json"))
print("stages:")
for s in p["metrics"]["stages"]:
    print("  %-11s %-10s %s" % (s["stage"], s["status"], s.get("why", "")))
t = json.load(open(o + "/traj-report.json"))["metrics"]
m = json.load(open(o + "/mesh-report.json"))["metrics"]
r = json.load(open(o + "/work/reports/render.json"))["metrics"]
c = json.load(open(o + "/work/reports/calibrate.json"))["metrics"]
print("calibration RMS %.3f px; room ATE %.1f mm, mesh accuracy %.1f mm mean"
      % (c["rms_px"], 1000 * t["ate"]["rmse_m"], 1000 * m["accuracy"]["mean_m"]))
if "relmse" in r:
    print("composite against the truth (whole chain, pt %s spp): relMSE %.4g, region relMSE %.4g"
          % (json.load(open(o + "/work/scene.json"))["render"]["spp"], r["relmse"], r["region_relmse"]))
else:  # every frame kept by mr-render --resume: a run again into the same folder with nothing changed
    print("composite: every frame kept from the earlier run into this folder (nothing changed)")
g = json.load(open(o + "/work/reports/radiometry.json"))["metrics"]
print("capture chain re-rendering the plate (mr-eval plate, a check for these linear plates): relMSE %.4g, SSIM %.3f;"
      " fitted gain %.3f..%.3f (G)" % (g["relmse"], g["ssim"], g["gain_min"][1], g["gain_max"][1]))
print("error vs time (mr-eval sweep):")
print(open(o + "/work/sweep/sweep.csv").read())
print("the fastest to each of pt's errors (region relMSE; %s/work/sweep/fastest.csv):" % o)
PY
/usr/bin/python3 examples/synthetic/fastest.py "$w/reports/sweep.json" || true

# An asset as users bring them, generated here (examples/synthetic/make_asset.py,
# no third-party file): a glTF with a tiled, normal-mapped base (base-colour,
# metallic-roughness and normal textures), a steel sphere and a solid glass
# sphere with a faint green absorption, rendered into the same plates where
# the object stood, on the table top (y = 0.75 in mr-synth's room), with the
# scene's own method; the glass shows the plate behind it.
/usr/bin/python3 examples/synthetic/make_asset.py "$w/showcase.glb"
/usr/bin/python3 - "$w" <<'PY'
import json, sys
w = sys.argv[1]
s = json.load(open(w + "/scene.json"))
m = list(s["virtual"][0]["transform"]["matrix"])
m[7] = 0.75  # its base on the table top (the object's centre was 0.15 above it)
s["virtual"] = [{"name": "showcase", "mesh": "showcase.glb", "transform": {"matrix": m}}]
s.pop("reference", None)  # the truth has the other object
s["output"] = {"dir": "render-showcase", "png": True, "review": True}
json.dump(s, open(w + "/scene-showcase.json", "w"), indent=2)
PY
"$bin/mr-render" "$w/scene-showcase.json" --report "$w/reports/render-showcase.json" -q
echo "asset:           $w/render-showcase/*.png, review sheets $w/render-showcase/*-review.png ($(/usr/bin/python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))['metrics']['frames'][0]
p = r.get('plate_reflections') or {}
print('%.1f s a frame; of the real points seen through the glass or in the steel, %.0f %% from the plate' % (r['seconds'], 100 * p.get('share', 0)))
" "$w/reports/render-showcase.json" 2>/dev/null || echo "see $w/reports/render-showcase.json"))"

# The shot handed to Blender: the showcase scene (room, the glTF asset merged
# in, the camera path, the light, the plate) as a glTF scene, the lens as
# ST-maps, and Blender's script beside it; where Blender is installed, it is
# imported headless and saved as a .blend (docs/tutorial.md, step 9).
mkdir -p "$w/shot"
"$bin/mr-export" "$w/scene-showcase.json" --out "$w/shot/shot.glb" --stmaps --report "$w/reports/export.json" -q
if command -v blender > /dev/null; then
  blender -b --factory-startup -noaudio --python "$w/shot/shot-blender.py" -- "$w/shot/shot.glb" \
    --blend "$w/shot/shot.blend" --describe "$w/shot/blender.json" > "$w/logs/blender.log" 2>&1 \
    && echo "shot in Blender:  $w/shot/shot.blend (from $w/shot/shot.glb; ST-maps $w/shot/shot-*distort.exr)" \
    || echo "shot in Blender:  failed, see $w/logs/blender.log"
else
  echo "shot for Blender: $w/shot/shot.glb (blender -b --python $w/shot/shot-blender.py -- $w/shot/shot.glb --blend shot.blend)"
fi

# A world that changes during the video: the sun moving, a lamp switched on
# halfway, the object sliding across the table and turning (mr-synth
# --dynamic, truth per frame).  The chain from a pipeline file: the light
# captured per frame from the light camera's video (matched to the plate by
# timestamp, with a dropped frame), the lamp's lights and the trajectory
# passed through to scene.json, the plate check running each frame's room
# under its own light; then every method against the truth of each frame,
# with its flicker.
d=$out/dynamic
"$bin/mr-synth" --preset medium --dynamic --plate-sphere --frames 4 --truth-spp 256 --out "$d/capture" \
  --report "$d/synth-report.json" -q
/usr/bin/python3 examples/synthetic/dynamic_pipeline.py "$d/capture/scene.json" > "$d/pipeline.json"
"$bin/mr-pipeline" "$d/pipeline.json" --report "$d/pipeline-report.json"
echo "the light captured from the light camera's video, against each frame's true sky:"
"$bin/mr-eval" light "$d/work/env/%05d.exr" "$d/capture/env/%05d.exr" --report "$d/light-eval.json"
# The same chain with the light from the mirror sphere in the plate itself,
# unwrapped from each frame's pose (the plate_probe stage).
/usr/bin/python3 examples/synthetic/dynamic_pipeline.py "$d/capture/scene.json" sphere > "$d/pipeline-sphere.json"
"$bin/mr-pipeline" "$d/pipeline-sphere.json" --report "$d/pipeline-sphere-report.json"
echo "the light captured from the sphere in the plate, against the light at the sphere's centre, then the sky:"
"$bin/mr-eval" light "$d/work-sphere/env/%05d.exr" "$d/capture/reference/sphere/%05d.exr" \
  --report "$d/light-sphere-eval.json"
"$bin/mr-eval" light "$d/work-sphere/env/%05d.exr" "$d/capture/env/%05d.exr" --report "$d/light-sphere-sky-eval.json"
for ms in ic:4 vpl:1 vct:4; do
  m=${ms%:*}
  "$bin/mr-render" "$d/work/scene.json" --method "$m" --spp "${ms#*:}" --out "$d/work/render-$m" \
    --report "$d/render-$m.json" -q
done
echo
echo "dynamic capture: $d/capture (lightcam/, env/ the true skies, lights/, the trajectory in scene.json);"
echo "captured maps $d/work/env/ (light camera), $d/work-sphere/env/ (the sphere in the plate); composites $d/work/render/*.png, $d/work-sphere/render/*.png"
/usr/bin/python3 - "$d" <<'PYD' || true
import json, sys
d = sys.argv[1]
print("per frame against the truth (region relMSE), flicker against the truth's change, seconds a frame:")
runs = [("pt 16 spp", d + "/work/reports/render.json")] + [("%s %d spp" % (m, n), d + "/render-%s.json" % m)
                                                            for m, n in (("ic", 4), ("vpl", 1), ("vct", 4))]
for name, f in runs:
    r = json.load(open(f))["metrics"]
    fr = r["frames"]
    # A run again into the same folder keeps frames whose inputs did not
    # change (mr-render --resume): their figures are the earlier run's.
    rendered = [x for x in fr if not x.get("resumed")]
    figures = "%s  flicker %s" % (" ".join("%.3g" % x["region_relmse"] if "region_relmse" in x else "-" for x in fr),
                                  "%.3g" % r["flicker"] if "flicker" in r else "-")
    if not rendered:
        print("  %-10s %s  (every frame kept from the earlier run into this folder)" % (name, figures))
        continue
    print("  %-10s %s  %.2f s  rebuilt: %s" % (
        name, figures, sum(x["seconds"] for x in rendered) / len(rendered),
        ", ".join(rendered[min(1, len(rendered) - 1)].get("world", {}).get("rebuilt", [])) or "nothing"))
PYD
echo "the fastest to each of pt's errors on this capture (mr-eval sweep over its 4 frames; $d/work/sweep/):"
/usr/bin/python3 examples/synthetic/fastest.py "$d/work/reports/sweep.json" || true
