#!/usr/bin/env bash
# Trains and scores once the shard array (shards.sh) is done: a plain `pl2map run`, which
# finds every stage up to the shards recorded and skips them (docs/operations.md, "Past
# one machine"). deploy/slurm/submit.sh submits it after the array with
# --dependency=afterok:<array job> --kill-on-invalid-dep=yes:
#
#   sbatch --dependency=afterok:ARRAY_JOB deploy/slurm/train-score.sh PIPELINE WORK [PL2MAP_ARGS...]
#
# Arguments after WORK go to `pl2map run` (e.g. `--device cuda` with --gres=gpu:1 and a
# binary built with --features cuda). The pl2map binary is $PL2MAP, else `pl2map` on PATH.
#SBATCH --job-name=pl2map-train-score
#SBATCH --cpus-per-task=2
#SBATCH --output=pl2map-train-score-%j.out
set -euo pipefail

if [ $# -lt 2 ]; then
  echo "usage: sbatch deploy/slurm/train-score.sh PIPELINE WORK [PL2MAP_ARGS...]" >&2
  exit 2
fi
pipeline=$1
work=$2
shift 2
echo "train and score on $(hostname): $pipeline in $work"
exec "${PL2MAP:-pl2map}" run "$pipeline" --work "$work" "$@"
