#!/usr/bin/env bash
# One scene per array task: task i runs `pl2map run PIPELINE --scene SCENE_i --work
# WORK/SCENE_i`, every stage of that scene (docs/operations.md, "Past one machine"). The
# scenes are the arguments after WORK, by default the seven of 7-Scenes
# (datasets/7scenes.toml):
#
#   sbatch --array=0-6 deploy/slurm/scenes.sh pipeline/7scenes.toml /data/work
#   sbatch --array=0-1 deploy/slurm/scenes.sh pipeline/7scenes.toml /data/work chess fire
#
# A failed scene is resubmitted alone (the same arguments, its index): completed stages
# are skipped. The pl2map binary is $PL2MAP, else `pl2map` on PATH. One log per task.
# One scene per GPU: scenes-gpu.sh.
#SBATCH --job-name=pl2map-scene
#SBATCH --cpus-per-task=2
#SBATCH --output=pl2map-scene-%A_%a.out
set -euo pipefail

if [ $# -lt 2 ]; then
  echo "usage: sbatch --array=0-N deploy/slurm/scenes.sh PIPELINE WORK [SCENE...]" >&2
  exit 2
fi
pipeline=$1
work=$2
shift 2
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(chess fire heads office pumpkin redkitchen stairs)
fi
task=${SLURM_ARRAY_TASK_ID:?submit as an array job: sbatch --array=0-N scenes.sh ...}
if [ "$task" -ge ${#scenes[@]} ]; then
  echo "scenes.sh: array task $task, but only ${#scenes[@]} scenes: ${scenes[*]}" >&2
  exit 2
fi
scene=${scenes[$task]}
echo "task $task on $(hostname): scene $scene"
exec "${PL2MAP:-pl2map}" run "$pipeline" --scene "$scene" --work "$work/$scene"
