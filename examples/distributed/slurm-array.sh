#!/bin/sh
# A Slurm array job that bakes a config in 4 shards, then merges them (docs/distributed.md).
# Submit from the repository root on a shared filesystem: `sh examples/distributed/slurm-array.sh`.
set -eu
CONFIG=${CONFIG:-bake-configs/demo.toml}
SHARDS=4
OUT=${OUT:-out}
# one task per shard; SLURM_ARRAY_TASK_ID is K
jobid=$(sbatch --parsable --array=0-$((SHARDS - 1)) --cpus-per-task=2 --job-name=penumbra-bake \
  --wrap="penumbra bake $CONFIG --shard \$SLURM_ARRAY_TASK_ID/$SHARDS --output-dir $OUT/shard-\$SLURM_ARRAY_TASK_ID")
# the merge runs once every task has succeeded
dirs=$(seq -f "$OUT/shard-%g" 0 $((SHARDS - 1)) | tr '\n' ' ')
sbatch --dependency=afterok:"$jobid" --job-name=penumbra-merge --wrap="penumbra bake merge $dirs -o $OUT/baked"
