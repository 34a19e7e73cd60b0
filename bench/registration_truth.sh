#!/bin/bash
# Registration in pixels against exact poses (issue 40's synthetic truth):
# an mr-synth capture (the room, its plate and its exact trajectory), then the
# same plate with the poses spoilt as real captures spoil them: a constant
# offset (an RGB-D sensor whose depth camera, which made the room, is not the
# colour camera: 2.5 cm and 0.8 degree) and drift (a trajectory that walks
# off: 0 to 4 cm and 0 to 1.2 degrees over the frames).  For each: mr-eval
# plate's registration in pixels and its pose refinement (smoothed, the
# default, and one shared correction), the refined poses' error against the
# exact ones, and the object's swim (mr-render, pt at 1 spp: the swim depends
# on the poses and the plate only).
# Each over the room's texture (every pixel) and over its geometric edges
# only (mr-eval plate --register-on).
# Usage: bench/registration_truth.sh [BIN_DIR] [OUT_DIR] [FRAMES] [REGISTER_ON...]; writes OUT/registration-truth.csv
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-out/bench-registration}
FRAMES=${3:-8}
REGISTER=${4:-texture edges}
PY=/usr/bin/python3
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
[ -f "$OUT/capture/scene.json" ] || "$BIN/mr-synth" --preset medium --frames "$FRAMES" --out "$OUT/capture" -q
# The spoilt trajectories and a scene.json per case.
"$PY" - "$OUT" <<'PY'
import json, math, os, sys
import numpy as np
out = sys.argv[1]
scene = json.load(open(os.path.join(out, "capture", "scene.json")))
path = scene["camera"]["poses"]["path"]
if not os.path.isabs(path):
    path = os.path.join(out, "capture", path)
rows = [l.split() for l in open(path) if l.strip() and not l.startswith("#")]
def quat_to_R(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
def R_to_quat(R):
    w = math.sqrt(max(0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return [x, y, z, w]
def axis_angle(axis, deg):
    a = np.asarray(axis, float); a /= np.linalg.norm(a); t = math.radians(deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K
n = len(rows)
cases = {
    "exact": lambda i: (np.eye(3), np.zeros(3)),
    # camera-frame offset: pose * (R, t)
    "offset": lambda i: (axis_angle([0.3, 1, 0.2], 0.8), np.array([0.025, -0.01, 0.01])),
    "drift": lambda i: (axis_angle([0.2, 1, 0.1], 1.2 * i / max(1, n - 1)), np.array([0.04, 0.0, 0.02]) * i / max(1, n - 1)),
}
for name, spoil in cases.items():
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "poses.txt"), "w") as f:
        for i, r in enumerate(rows):
            t = np.array([float(v) for v in r[1:4]]); R = quat_to_R([float(v) for v in r[4:8]])
            dR, dt = spoil(i)
            R2 = R @ dR; t2 = R @ dt + t
            f.write("%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n" % ((r[0],) + tuple(t2) + tuple(R_to_quat(R2))))
    s = json.loads(json.dumps(scene))
    s["camera"]["poses"]["path"] = os.path.join(d, "poses.txt")
    base = os.path.join(out, "capture")
    def absolutise(node):  # every relative path in the scene is the capture's
        if isinstance(node, dict):
            return {k: absolutise(v) for k, v in node.items()}
        if isinstance(node, list):
            return [absolutise(v) for v in node]
        if isinstance(node, str) and not os.path.isabs(node) and os.path.exists(os.path.join(base, node.split("%")[0].split("*")[0]) if "%" not in node else os.path.dirname(os.path.join(base, node))):
            return os.path.join(base, node)
        return node
    s = absolutise(s)
    s["camera"]["poses"]["path"] = os.path.join(d, "poses.txt")
    json.dump(s, open(os.path.join(d, "scene.json"), "w"), indent=1)
PY
echo "case,register_on,mode,registration_px,worst_px,after_px,rot_err_deg,trans_err_mm,rot_err_after_deg,trans_err_after_mm,swim_rms_px,swim_after_rms_px,seconds" > "$OUT/registration-truth.csv"
err() {  # err ESTIMATE.tum -> "mean_deg mean_mm" against the exact poses
  "$PY" - "$1" "$OUT/exact/poses.txt" <<'PY'
import math, sys
import numpy as np
def load(p):
    return [[float(v) for v in l.split()] for l in open(p) if l.strip() and not l.startswith("#")]
a, b = load(sys.argv[1]), load(sys.argv[2])
def R(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
deg, mm = [], []
for pa, pb in zip(a, b):
    d = R(pb[4:8]).T @ R(pa[4:8])
    deg.append(math.degrees(math.acos(max(-1, min(1, (np.trace(d) - 1) / 2)))))
    mm.append(1000 * np.linalg.norm(np.array(pa[1:4]) - np.array(pb[1:4])))
print("%.3f %.1f" % (sum(deg) / len(deg), sum(mm) / len(mm)))
PY
}
swim() {  # swim SCENE REPORT -> RMS px of the first object's swim
  "$BIN/mr-render" "$1" --out "$(dirname "$2")/render" --method pt --spp 1 --report "$2" -q
  "$PY" -c "import json,sys; s=json.load(open(sys.argv[1]))['metrics'].get('swim',{}); print('%.3f' % (list(s.values())[0]['rms_px'] if s else float('nan')))" "$2"
}
for reg_on in $REGISTER; do
for c in exact offset drift; do
  for mode in smooth shared; do
    [ "$c" = exact ] && [ "$mode" = shared ] && continue
    d=$OUT/$c/$reg_on-$mode
    mkdir -p "$d"
    t0=$(date +%s.%N)
    "$BIN/mr-eval" plate "$OUT/$c/scene.json" --out "$d" --refine-poses "$d/refined.tum" --refine-mode "$mode" \
      --register-on "$reg_on" --report "$d/plate.json" -q
    t1=$(date +%s.%N)
    read -r reg worst after <<< "$("$PY" -c "import json,sys; m=json.load(open(sys.argv[1]))['metrics']; g=m['registration']; p=m.get('pose_refinement',{}); print(g['mean_px'], g['worst_mean_px'], p.get('mean_px_after', float('nan')))" "$d/plate.json")"
    read -r rdeg tmm <<< "$(err "$OUT/$c/poses.txt")"
    read -r rdeg2 tmm2 <<< "$(err "$d/refined.tum")"
    s_before=$(swim "$OUT/$c/scene.json" "$d/swim-before/render.json")
    "$PY" -c "import json,sys; s=json.load(open(sys.argv[1])); s['camera']['poses']['path']=sys.argv[2]; json.dump(s, open(sys.argv[3],'w'), indent=1)" \
      "$OUT/$c/scene.json" "$d/refined.tum" "$d/scene-refined.json"
    s_after=$(swim "$d/scene-refined.json" "$d/swim-after/render.json")
    echo "$c,$reg_on,$mode,$reg,$worst,$after,$rdeg,$tmm,$rdeg2,$tmm2,$s_before,$s_after,$("$PY" -c "print('%.1f' % ($t1 - $t0))")" \
      | tee -a "$OUT/registration-truth.csv"
  done
done
done
