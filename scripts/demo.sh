#!/usr/bin/env bash
# The main job: on a fresh machine, install the system packages (idempotent), build the
# release binary and run a pipeline end to end (default pipeline/synthetic.toml: render
# the synthetic room with its SfM / LIMAP ground truth, ingest, import, refine with
# depth, shard, train, score), printing the stage table and the score.
#
#   scripts/demo.sh                                   # pipeline/synthetic.toml
#   scripts/demo.sh pipeline/synthetic-tiny.toml      # a smoke run of a few minutes
#   scripts/demo.sh pipeline/synthetic.toml --compare-refine
#
# A second run skips every stage whose record matches (work folder: the pipeline's
# `work`, or PL2MAP_WORK/<pipeline name> when PL2MAP_WORK is set).
#
# The last lines say how long each phase took (system packages, build, pipeline): the
# 20-minute goal of the main job is measured on a fresh machine, where the build counts.
set -euo pipefail
cd "$(dirname "$0")/.."
phase_start=$SECONDS
phases=()
end_phase() {
    phases+=("$(printf '%-16s %6d s' "$1" $((SECONDS - phase_start)))")
    phase_start=$SECONDS
}
scripts/setup-system.sh
end_phase "system packages"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/pl2map-rs/target}"
cargo build --locked --release -p cli
end_phase "build"
PL2MAP="$CARGO_TARGET_DIR/release/pl2map"
PIPELINE="${1:-pipeline/synthetic.toml}"
shift || true
WORK_ARGS=()
if [[ -n "${PL2MAP_WORK:-}" ]]; then
    WORK_ARGS=(--work "$PL2MAP_WORK/$(basename "$PIPELINE" .toml)")
fi
"$PL2MAP" run "$PIPELINE" "${WORK_ARGS[@]}" "$@"
end_phase "pipeline"
printf '\nmain job phases:\n' >&2
printf '  %s\n' "${phases[@]}" "$(printf '%-16s %6d s' total "$SECONDS")" >&2
