#!/usr/bin/env bash
# The test suite: system packages, the optional Python peers, then every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-system.sh
if [ -z "${PL2MAP_PYTHON:-}" ]; then
  PL2MAP_PYTHON="$(scripts/setup-python.sh || true)"
  export PL2MAP_PYTHON
fi
# A target dir outside the clone survives fresh checkouts (CI); a new machine builds cold.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/pl2map-rs/target}"
cargo test --workspace --locked "$@"
