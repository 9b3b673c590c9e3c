#!/usr/bin/env bash
# The shard stage of one pipeline as a Slurm job array: array task i is the work unit
# `pl2map run PIPELINE --work WORK --until shard --shards a..b` with a = i * PER_TASK and
# b = min(a + PER_TASK, SHARDS), SHARDS being the number of shards in the plan
# (docs/operations.md, "Past one machine"). Whichever task completes the set writes
# manifest.json and stage.json, byte for byte what one `pl2map run` writes; the dependent
# job (train-score.sh) then trains and scores. deploy/slurm/submit.sh runs the stages
# before the shards once, reads SHARDS from the plan and submits both jobs:
#
#   sbatch --array=0-3 deploy/slurm/shards.sh PIPELINE WORK SHARDS PER_TASK
#
# A task that failed or was cancelled is resubmitted alone, with the same arguments:
#
#   sbatch --array=2 deploy/slurm/shards.sh PIPELINE WORK SHARDS PER_TASK
#
# It rewrites the shards of its range (a killed unit leaves only complete shard files and
# no unit manifest) and completes the set. The pl2map binary is $PL2MAP, else `pl2map` on
# PATH. One log per task: --output below, or as submit.sh passes it.
#SBATCH --job-name=pl2map-shards
#SBATCH --cpus-per-task=1
#SBATCH --output=pl2map-shards-%A_%a.out
set -euo pipefail

usage="usage: sbatch --array=0-N deploy/slurm/shards.sh PIPELINE WORK SHARDS PER_TASK"
if [ $# -ne 4 ]; then
  echo "$usage" >&2
  exit 2
fi
pipeline=$1
work=$2
shards=$3
per_task=$4
for n in "$shards" "$per_task"; do
  case $n in
  '' | *[!0-9]*)
    echo "shards.sh: SHARDS and PER_TASK must be whole numbers, got '$shards' '$per_task'" >&2
    exit 2
    ;;
  esac
done
if [ "$per_task" -eq 0 ]; then
  echo "shards.sh: PER_TASK must be at least 1" >&2
  exit 2
fi
if [ -z "${SLURM_ARRAY_TASK_ID:-}" ]; then
  echo "shards.sh: no SLURM_ARRAY_TASK_ID: submit it as an array job ($usage)" >&2
  exit 2
fi
task=$SLURM_ARRAY_TASK_ID
start=$((task * per_task))
end=$((start + per_task))
if [ "$end" -gt "$shards" ]; then
  end=$shards
fi
if [ "$start" -ge "$end" ]; then
  echo "task $task: no shards (the plan has $shards, $per_task per task)"
  exit 0
fi
echo "task $task on $(hostname): shards $start..$end of $shards"
exec "${PL2MAP:-pl2map}" run "$pipeline" --work "$work" --until shard --shards "$start..$end"
