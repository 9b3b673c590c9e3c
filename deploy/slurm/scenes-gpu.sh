#!/usr/bin/env bash
# scenes.sh with one GPU per scene: one network is one scene's map, so the unit of
# multi-GPU training is one scene per GPU (docs/operations.md, "Past one machine").
# Slurm sets CUDA_VISIBLE_DEVICES to the task's GPU, so `--device cuda` (its first
# visible device) is that GPU. Needs a binary built with `--features cuda`.
#
#   sbatch --array=0-6 deploy/slurm/scenes-gpu.sh pipeline/7scenes.toml /data/work
#
# The pl2map binary is $PL2MAP, else `pl2map` on PATH. One log per task.
#SBATCH --job-name=pl2map-scene-gpu
#SBATCH --gres=gpu:1
#SBATCH --cpus-per-task=4
#SBATCH --output=pl2map-scene-gpu-%A_%a.out
set -euo pipefail

if [ $# -lt 2 ]; then
  echo "usage: sbatch --array=0-N deploy/slurm/scenes-gpu.sh PIPELINE WORK [SCENE...]" >&2
  exit 2
fi
pipeline=$1
work=$2
shift 2
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(chess fire heads office pumpkin redkitchen stairs)
fi
task=${SLURM_ARRAY_TASK_ID:?submit as an array job: sbatch --array=0-N scenes-gpu.sh ...}
if [ "$task" -ge ${#scenes[@]} ]; then
  echo "scenes-gpu.sh: array task $task, but only ${#scenes[@]} scenes: ${scenes[*]}" >&2
  exit 2
fi
scene=${scenes[$task]}
echo "task $task on $(hostname), GPU ${CUDA_VISIBLE_DEVICES:-none}: scene $scene"
exec "${PL2MAP:-pl2map}" run "$pipeline" --scene "$scene" --work "$work/$scene" --device cuda
