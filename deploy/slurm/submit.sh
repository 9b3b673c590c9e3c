#!/usr/bin/env bash
# Submits one pipeline's shard stage as a Slurm job array and training + scoring as a job
# that runs when every task succeeded (docs/operations.md, "Past one machine"):
#
#   deploy/slurm/submit.sh [--per-task K] [--logs DIR] [--tasks LIST] PIPELINE WORK
#
# 1. Runs the stages before the shards once, here (`pl2map run PIPELINE --work WORK
#    --until refine`; done stages are skipped): the units would otherwise take turns on
#    them.
# 2. Reads the number of shards in the plan (deploy/plan-shards.sh) and submits shards.sh
#    as an array of ceil(shards / K) tasks, K shards each (--per-task, default 4).
# 3. Submits train-score.sh with --dependency=afterok:<array> --kill-on-invalid-dep=yes
#    (a failed or cancelled task cancels it instead of leaving it pending forever).
# 4. Prints `shards_job=<id>`, `tasks=<indices>` and `train_score_job=<id>`.
#
# A task that failed or was cancelled is resubmitted alone with a new dependent job:
#
#   deploy/slurm/submit.sh --tasks 2 PIPELINE WORK          (or --tasks 1,3 / 0-2)
#
# Logs: DIR/pl2map-shards-<array>_<task>.out and DIR/pl2map-train-score-<job>.out (DIR:
# --logs, default ./slurm-logs). The pl2map binary is $PL2MAP, else `pl2map` on PATH; the
# jobs get the same (sbatch passes the environment on).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
pl2map=${PL2MAP:-pl2map}
per_task=4
logs=slurm-logs
tasks=""
usage="usage: deploy/slurm/submit.sh [--per-task K] [--logs DIR] [--tasks LIST] PIPELINE WORK"
while [ $# -gt 0 ]; do
  case $1 in
  --per-task) per_task=${2:?$usage}; shift 2 ;;
  --logs) logs=${2:?$usage}; shift 2 ;;
  --tasks) tasks=${2:?$usage}; shift 2 ;;
  -h | --help) echo "$usage"; exit 0 ;;
  -*) echo "submit.sh: unknown option $1; $usage" >&2; exit 2 ;;
  *) break ;;
  esac
done
if [ $# -ne 2 ]; then
  echo "$usage" >&2
  exit 2
fi
pipeline=$1
work=$2
case $per_task in
'' | *[!0-9]* | 0)
  echo "submit.sh: --per-task must be a whole number >= 1, got '$per_task'" >&2
  exit 2
  ;;
esac

# 1. The stages before the shards, once.
"$pl2map" --quiet run "$pipeline" --work "$work" --until refine

# 2. The plan's shard count.
shards=$("$here/../plan-shards.sh" "$pipeline" "$work")
count=$(((shards + per_task - 1) / per_task))
if [ "$count" -eq 0 ]; then
  echo "submit.sh: the plan of $pipeline has no shards" >&2
  exit 1
fi
if [ -z "$tasks" ]; then
  tasks="0-$((count - 1))"
fi

mkdir -p "$logs"
array=$(sbatch --parsable --array="$tasks" --output="$logs/%x-%A_%a.out" \
  "$here/shards.sh" "$pipeline" "$work" "$shards" "$per_task")
array=${array%%;*}
train=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
  --output="$logs/%x-%j.out" "$here/train-score.sh" "$pipeline" "$work")
train=${train%%;*}
echo "plan: $shards shards, $per_task per task, $count tasks"
echo "shards_job=$array"
echo "tasks=$tasks"
echo "train_score_job=$train"
