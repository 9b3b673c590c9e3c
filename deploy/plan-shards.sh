#!/usr/bin/env bash
# Prints the number of shards in the plan of PIPELINE's shard stage (training shards,
# then test shards), which sizes the shard arrays (deploy/slurm/shards.sh, the Indexed Job
# deploy/k8s/shards-job.yaml). The stages before the shards must be done
# (`pl2map run PIPELINE --work WORK --until refine`):
#
#   deploy/plan-shards.sh PIPELINE WORK
#
# pl2map has no command that prints the plan; a work unit past the plan is refused before
# it writes anything, naming the plan's count (crates/shards/src/shard_stage/error.rs,
# ShardStageError::Range), and that is what is read here. The pl2map binary is $PL2MAP,
# else `pl2map` on PATH.
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: deploy/plan-shards.sh PIPELINE WORK" >&2
  exit 2
fi
said=$("${PL2MAP:-pl2map}" --quiet run "$1" --work "$2" --until shard \
  --shards 0..1000000000 2>&1 || true)
shards=$(printf '%s\n' "$said" | sed -n "s/.*outside the plan's \([0-9][0-9]*\) shards.*/\1/p" | head -n 1)
if [ -z "$shards" ]; then
  echo "plan-shards.sh: could not read the number of shards of $1's plan in $2; pl2map said:" >&2
  printf '%s\n' "$said" >&2
  exit 1
fi
echo "$shards"
