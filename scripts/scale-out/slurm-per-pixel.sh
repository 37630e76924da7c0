#!/usr/bin/env bash
# Per-pixel decay maps of one photo series on a Slurm cluster: one array task per shard, then
# one dependent job that merges them (docs/scale-out.md).
#
#   sbatch --array=0-15 scripts/scale-out/slurm-per-pixel.sh SERIES/manifest.csv RUN_DIR
#   sbatch --dependency=afterok:<array job id> --export=ALL,MERGE=1 \
#       scripts/scale-out/slurm-per-pixel.sh SERIES/manifest.csv RUN_DIR
#
# Every task reads the same series (a shared file system) and writes RUN_DIR/shard-<i>/; the
# merge writes RUN_DIR/maps/. Shard i of n is $SLURM_ARRAY_TASK_ID of $SLURM_ARRAY_TASK_COUNT.
#SBATCH --job-name=lumifit-maps
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=01:00:00
#SBATCH --output=lumifit-maps-%A_%a.log
set -euo pipefail

SERIES=${1:?usage: slurm-per-pixel.sh SERIES RUN_DIR}
RUN_DIR=${2:?usage: slurm-per-pixel.sh SERIES RUN_DIR}
LUMIFIT=${LUMIFIT:-lumifit}

if [[ "${MERGE:-0}" == 1 ]]; then
    shopt -s nullglob
    shards=("$RUN_DIR"/shard-*)
    exec "$LUMIFIT" phos merge-maps "${shards[@]}" --out "$RUN_DIR/maps"
fi

: "${SLURM_ARRAY_TASK_ID:?submit with sbatch --array=0-(n-1)}"
: "${SLURM_ARRAY_TASK_COUNT:?submit with sbatch --array=0-(n-1)}"
# leave 1 GiB of the job's memory to the rest of the node's accounting
MEM_GB=$(( ${SLURM_MEM_PER_NODE:-8192} / 1024 - 1 ))
export RAYON_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
exec "$LUMIFIT" phos fit-decay "$SERIES" --per-pixel \
    --shard "$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT" \
    --memory-gb "$MEM_GB" --scratch-dir "${TMPDIR:-/tmp}" \
    --out "$RUN_DIR/shard-$SLURM_ARRAY_TASK_ID"
