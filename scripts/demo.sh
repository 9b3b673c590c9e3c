#!/usr/bin/env bash
# The main job, until `pl2map run pipeline/synthetic.toml` exists (issue 7): render the
# synthetic room with its SfM / LIMAP ground truth, ingest, import, refine with depth
# (printing the label ablation) and write the MCAP label shards.
# Installs missing system packages itself (idempotent), then builds.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-system.sh
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/pl2map-rs/target}"
cargo build --locked -p cli
PL2MAP="$CARGO_TARGET_DIR/debug/pl2map"
WORK="${PL2MAP_WORK:-work/demo}"
mkdir -p "$WORK"
S="$WORK/dataset/synthroom"
# SfM labels with 5 cm of noise, so that the refine stage has something to remove; it
# prints the ablation against the exact labels the generator keeps.
"$PL2MAP" synth "$WORK/dataset" --tiny --overwrite --label-noise-cm 5
"$PL2MAP" ingest --dataset 7scenes --root "$S" --depth "rendered:$S" --out "$WORK/frames"
"$PL2MAP" import --frames "$WORK/frames/frames.parquet" --model "$S/sfm_gt/colmap" --limap "$S/sfm_gt/limap" --out "$WORK/labels"
"$PL2MAP" refine --frames "$WORK/frames/frames.parquet" --labels "$WORK/labels" --out "$WORK/refined" --exact "$S/sfm_gt/exact.json"
"$PL2MAP" shard --frames "$WORK/frames/frames.parquet" --labels "$WORK/refined" --out "$WORK/shards"
echo "demo outputs under $WORK"
