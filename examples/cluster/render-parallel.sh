#!/usr/bin/env bash
# Renders a scene's frames in shards with GNU parallel, on this machine or
# over ssh hosts (parallel -S), then merges the shard reports into one report
# and one video.  Shards are byte-identical to an unsharded run (per-frame
# seeds; docs/cluster.md).
#
# Usage: render-parallel.sh SCENE OUT [FRAMES_PER_SHARD [JOBS]] [-- MR_RENDER_OPTIONS...]
#   MR_BIN=build/bin        where the mr tools are (default: on PATH)
#   PARALLEL_OPTS="-S host1,host2 --sshdelay 0.1"   extra options for parallel
# Example:
#   bash examples/cluster/render-parallel.sh capture/scene.json out/render 4 2 -- --spp 64
set -euo pipefail
args=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do args+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
[ ${#args[@]} -ge 2 ] || { sed -n '2,12p' "$0" >&2; exit 2; }
scene=${args[0]} out=${args[1]} per=${args[2]:-8} jobs=${args[3]:-0}
bin=${MR_BIN:+$MR_BIN/}
parallel --version 2>/dev/null | grep -q "GNU parallel" || { echo "render-parallel: GNU parallel is not installed (apt install parallel; moreutils has another parallel)" >&2; exit 1; }
# The frames the scene renders, from mr-info's JSON.
info=$("${bin}mr-info" --json "$scene")
begin=$(sed -n 's/.*"frame_begin": \([0-9]*\).*/\1/p' <<<"$info")
end=$(sed -n 's/.*"frame_end": \([0-9]*\).*/\1/p' <<<"$info")
mkdir -p "$out/shards"
for ((a = begin; a < end; a += per)); do echo "$a $(( a + per < end ? a + per : end ))"; done |
  parallel --colsep ' ' -j "$jobs" --halt now,fail=1 ${PARALLEL_OPTS:-} \
    "${bin}mr-render" "$scene" --out "$out" --frames {1}:{2} --report "$out/shards/{1}-{2}.json" -q "$@"
"${bin}mr-eval" merge "$out"/shards/*.json --video "$out/composite.mp4" --report "$out/render-report.json"
