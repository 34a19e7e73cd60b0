#!/usr/bin/env bash
# A Slurm job array that renders a scene's frames in shards, one task per
# shard; a second job, started when every task has succeeded, merges them.
#
# Submit (the script submits itself twice):
#   bash examples/cluster/render-slurm.sh submit SCENE OUT FRAMES_PER_SHARD [MR_RENDER_OPTIONS...]
# What each array task runs (also how to test it without Slurm, see
# tests/cli/run.sh):
#   SLURM_ARRAY_TASK_ID=i bash examples/cluster/render-slurm.sh task SCENE OUT FRAMES_PER_SHARD [...]
#   bash examples/cluster/render-slurm.sh merge SCENE OUT
# MR_BIN names the folder of the mr tools when they are not on PATH.  Stage
# the scene's folder (meshes, maps, frames, poses) where every node reads it,
# or copy it to node-local scratch first (docs/cluster.md).
#SBATCH --job-name=mr-render
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=01:00:00
#SBATCH --output=mr-render-%A_%a.log
set -euo pipefail
what=$1 scene=$2 out=$3
bin=${MR_BIN:+$MR_BIN/}
frames() {  # the scene's rendered range, from mr-info's JSON
  local info
  info=$("${bin}mr-info" --json "$scene")
  begin=$(sed -n 's/.*"frame_begin": \([0-9]*\).*/\1/p' <<<"$info")
  end=$(sed -n 's/.*"frame_end": \([0-9]*\).*/\1/p' <<<"$info")
}
case $what in
  submit)
    per=$4; shift 4
    frames
    n=$(( (end - begin + per - 1) / per ))
    mkdir -p "$out/shards"
    job=$(sbatch --parsable --array=0-$((n - 1)) --export=ALL,MR_BIN="${MR_BIN:-}" "$0" task "$scene" "$out" "$per" "$@")
    sbatch --dependency=afterok:"$job" --export=ALL,MR_BIN="${MR_BIN:-}" --cpus-per-task=1 "$0" merge "$scene" "$out"
    ;;
  task)
    per=$4; shift 4
    frames
    a=$(( begin + SLURM_ARRAY_TASK_ID * per ))
    b=$(( a + per < end ? a + per : end ))
    mkdir -p "$out/shards"
    "${bin}mr-render" "$scene" --out "$out" --frames "$a:$b" --threads "${SLURM_CPUS_PER_TASK:-0}" \
      --report "$out/shards/$a-$b.json" -q "$@"
    ;;
  merge)
    "${bin}mr-eval" merge "$out"/shards/*.json --video "$out/composite.mp4" --report "$out/render-report.json"
    ;;
  *) echo "render-slurm: the first argument is submit, task or merge" >&2; exit 2 ;;
esac
