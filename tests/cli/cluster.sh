#!/usr/bin/env bash
# Rendering past one machine (docs/cluster.md): mr-render --frames shards are
# byte-identical to one run; mr-eval merge joins their reports and video; the
# GNU parallel recipe and the Slurm array script of examples/cluster run here
# (Slurm's array tasks simulated by SLURM_ARRAY_TASK_ID).
# Usage: cluster.sh BIN_DIR
set -u
bin=$1
src=$(cd "$(dirname "$0")/../.." && pwd)
source "$(dirname "$0")/lib.sh"

same_frames() {  # same_frames DIR_A DIR_B: every EXR and PNG of A is byte-identical in B
  local f n=0
  for f in "$1"/*.exr "$1"/*.png; do
    cmp -s "$f" "$2/$(basename "$f")" || { echo "$f differs from $2/$(basename "$f")"; return 1; }
    n=$((n + 1))
  done
  echo "$n files identical"
}

check "mr-synth (4 frames)" 0 "" -- "$bin/mr-synth" --preset small --frames 4 --out "$tmp/cap" --truth-spp 4 -q
for m in pt vct; do
  check "$m: one run" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --method $m --spp 2 --out "$tmp/$m-one" --report "$tmp/$m-one.json" -q
  check "$m: shard 0:1" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --method $m --spp 2 --out "$tmp/$m-sh" --frames 0:1 --report "$tmp/$m-s0.json" -q
  check "$m: shard 1:4" 0 "" -- "$bin/mr-render" "$tmp/cap/scene.json" --method $m --spp 2 --out "$tmp/$m-sh" --frames 1:4 --report "$tmp/$m-s1.json" -q
  check "$m: shards byte-identical" 0 "8 files identical" -- same_frames "$tmp/$m-one" "$tmp/$m-sh"
done
check "merge" 0 "merged 2 shards: 4 frames" -- "$bin/mr-eval" merge "$tmp/pt-s1.json" "$tmp/pt-s0.json" --video "$tmp/pt-sh/composite.mp4" --report "$tmp/pt-merged.json"
check "merged video" 0 "" -- test -s "$tmp/pt-sh/composite.mp4"
# The merged error figures are the one run's (same pixels, same averaging).
relmse() { sed -n 's/^    "relmse": \(.*\),$/\1/p' "$1"; }
check "merged relMSE = one run's" 0 "" -- test "$(relmse "$tmp/pt-one.json")" = "$(relmse "$tmp/pt-merged.json")"
check "merge: a gap" 1 "no shard rendered frames 0:1" -- "$bin/mr-eval" merge "$tmp/pt-s1.json"
check "merge: partial allowed" 0 "merged 1 shards" -- "$bin/mr-eval" merge "$tmp/pt-s1.json" --allow-gaps
check "merge: overlap" 1 "overlap" -- "$bin/mr-eval" merge "$tmp/pt-s0.json" "$tmp/pt-s1.json" "$tmp/pt-one.json"
check "merge: methods differ" 1 "method vct differs" -- "$bin/mr-eval" merge "$tmp/pt-s0.json" "$tmp/vct-s1.json"
"$bin/mr-info" "$tmp/cap/scene.json" --report "$tmp/info.json" > /dev/null
check "merge: not a render report" 1 "a report of mr-info, not of mr-render" -- "$bin/mr-eval" merge "$tmp/pt-s0.json" "$tmp/info.json"

# The recipes, as users run them.
export MR_BIN=$bin
check "GNU parallel recipe" 0 "merged 2 shards: 4 frames" -- bash "$src/examples/cluster/render-parallel.sh" "$tmp/cap/scene.json" "$tmp/par" 3 2 -- --spp 2
check "parallel: byte-identical" 0 "8 files identical" -- same_frames "$tmp/pt-one" "$tmp/par"
for i in 0 1; do
  check "slurm task $i" 0 "" -- env SLURM_ARRAY_TASK_ID=$i bash "$src/examples/cluster/render-slurm.sh" task "$tmp/cap/scene.json" "$tmp/slurm" 2 --spp 2
done
check "slurm merge" 0 "merged 2 shards: 4 frames" -- bash "$src/examples/cluster/render-slurm.sh" merge "$tmp/cap/scene.json" "$tmp/slurm"
check "slurm: byte-identical" 0 "8 files identical" -- same_frames "$tmp/pt-one" "$tmp/slurm"
check "slurm: video" 0 "" -- test -s "$tmp/slurm/composite.mp4"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
