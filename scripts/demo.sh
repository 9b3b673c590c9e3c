#!/usr/bin/env bash
# The main job, until `pl2map run pipeline/synthetic.toml` exists (issue 7): render the
# synthetic room, ingest it into the frames table, and print what came out.
# Installs missing system packages itself (idempotent), then builds.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-system.sh
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/pl2map-rs/target}"
cargo build --locked -p cli
PL2MAP="$CARGO_TARGET_DIR/debug/pl2map"
WORK="${PL2MAP_WORK:-work/demo}"
mkdir -p "$WORK"
"$PL2MAP" synth "$WORK/dataset" --tiny --overwrite
"$PL2MAP" ingest --dataset 7scenes --root "$WORK/dataset/synthroom" --depth none --out "$WORK/frames"
echo "demo outputs under $WORK"
