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
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-system.sh
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/pl2map-rs/target}"
cargo build --locked --release -p cli
PL2MAP="$CARGO_TARGET_DIR/release/pl2map"
PIPELINE="${1:-pipeline/synthetic.toml}"
shift || true
WORK_ARGS=()
if [[ -n "${PL2MAP_WORK:-}" ]]; then
    WORK_ARGS=(--work "$PL2MAP_WORK/$(basename "$PIPELINE" .toml)")
fi
"$PL2MAP" run "$PIPELINE" "${WORK_ARGS[@]}" "$@"
