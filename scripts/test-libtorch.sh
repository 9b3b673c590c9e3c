#!/usr/bin/env bash
# The LibTorch engine's tests (the `tch` cargo feature) on LibTorch's CPU device, a line of
# CI and of the README's test command: predictions, losses and gradients against the Flex
# backend for both network kinds, a short training that learns, checkpoints across engines
# (tests/engines_libtorch.rs), the device errors of the tch build (tests/gpu_errors.rs) and
# the GPU check's dry run with both CPU engines (tests/gpu_check_dry_run.rs).
#
# It builds against the PyTorch 2.9 of the test venv (scripts/libtorch-env.sh; installed by
# scripts/setup-python.sh), in the same CARGO_TARGET_DIR as the default build (other
# feature sets of the same crates sit beside each other there). Without that PyTorch it
# prints `SKIPPED ...` with the reason and exits 0; it exits non-zero when a test fails.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! lines="$(scripts/libtorch-env.sh 2>&1)"; then
    echo "SKIPPED the LibTorch engine's tests: $lines"
    exit 0
fi
eval "$lines"
# The dry run carries the examples beside pl2map: they must be the tch build's too.
cargo build -p bench --features tch --locked --release --example engine_check --example gpu_step
cargo test -p cli --features tch --locked --release \
    --test engines_libtorch --test gpu_errors --test gpu_check_dry_run
