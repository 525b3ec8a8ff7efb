#!/usr/bin/env bash
# Baking a PVS in shards on Slurm: a job array runs one task per shard, and
# each task's `hom pvs bake --shard auto/N` takes its shard from
# SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN (so --array=1-8 works as well as
# 0-7). Submit it, then the merge once every task succeeded:
#
#   jobid=$(sbatch --parsable docs/batch/pvs-bake-slurm.sh)
#   sbatch --dependency=afterok:$jobid --wrap \
#       "hom pvs merge --out level.pvs shards/shard-*.pvs"
#
# The merged file is byte for byte the one a single bake would write. Keep the
# array's size and N in --shard auto/N equal.
#SBATCH --job-name=hom-pvs-bake
#SBATCH --array=0-7
#SBATCH --cpus-per-task=4
#SBATCH --mem=4G
#SBATCH --time=04:00:00
#SBATCH --output=shards/bake-%a.log
set -euo pipefail
mkdir -p shards
hom pvs bake --scene level.obj --cell-size 4 --shard auto/8 \
    --out "shards/shard-${SLURM_ARRAY_TASK_ID}.pvs"
