#!/usr/bin/env bash
# Optional: a Python venv with the independent tools the interop tests and the
# benchmarks compare against (pycolmap, poselib, mcap). Prints the venv's python on
# success; on failure (no python3, no network) prints nothing and the tests that need
# it skip with a reason.
set -uo pipefail

# The real tools' test (crates/labels/tests/limap_real.rs, scripts/limap-tiny.py): LIMAP
# 2.0 and its LSD in a venv of their own, since pylimap pins pycolmap 4.2.0 and the
# interop venv below pins 4.2.1. The test finds it at this path (or PL2MAP_LIMAP_PYTHON).
# Its failures are tolerated and it writes nothing to stdout, so the interop venv and the
# line this script prints are unaffected. pip installs wheels only (no compiler).
limap_venv="$HOME/.cache/pl2map-rs/limap-venv"
limap_want="pylimap==2.0.0 pytlsd==0.0.2"
limap_stamp="$limap_venv/.pl2map-requirements"
if command -v python3 >/dev/null 2>&1 &&
   ! { [ -x "$limap_venv/bin/python" ] && [ "$(cat "$limap_stamp" 2>/dev/null)" = "$limap_want" ]; }; then
  {
    python3 -m venv "$limap_venv" &&
    "$limap_venv/bin/python" -m pip install -q $limap_want &&
    echo "$limap_want" > "$limap_stamp"
  } >&2 || echo "LIMAP venv not installed ($limap_venv): the real tools' test will skip" >&2
fi

venv="${PL2MAP_VENV:-$HOME/.cache/pl2map-rs/venv}"
# torch (the SuperPoint peer, crates/superpoint/tests), opencv-python-headless (its
# resize) and h5py (reads `pl2map features` files). PyPI's torch wheel; the CPU build
# from download.pytorch.org is smaller where that index is reachable.
want="pycolmap==4.2.1 poselib==2.0.5 mcap==1.6.0 mcap-protobuf-support==0.6.0 protobuf numpy torch==2.9.1 opencv-python-headless==5.1.0.95 h5py==3.16.0"
stamp="$venv/.pl2map-requirements"
if ! { [ -x "$venv/bin/python" ] && [ "$(cat "$stamp" 2>/dev/null)" = "$want" ]; }; then
  command -v python3 >/dev/null 2>&1 || exit 0
  {
    python3 -m venv "$venv" &&
    "$venv/bin/python" -m pip install -q $want &&
    echo "$want" > "$stamp"
  } >&2 || exit 0
fi

# The Python package over the shard reader (crates/py, docs/formats.md section 6), built
# by maturin (from PyPI, pinned in crates/py/pyproject.toml) with cargo into
# CARGO_TARGET_DIR when set, so that it shares the workspace's build. Reinstalled when
# the sources of it or of any workspace crate it uses (cargo tree), Cargo.toml or
# Cargo.lock change; when that hash cannot be made, always. A failure leaves the venv
# usable: crates/py/tests then skip with their reason.
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
package_hash() {
  local dirs
  dirs=$(cd "$repo" && cargo tree -p py -e normal,build --prefix none --locked --offline 2>/dev/null |
    sed -n 's|.*(\(/[^)]*\)).*|\1|p' | sort -u)
  [ -n "$dirs" ] || return 1
  {
    for d in $dirs; do
      find "$d" -type f -not -path '*/target/*' -print0 | sort -z | xargs -0 sha256sum
    done
    sha256sum "$repo/Cargo.toml" "$repo/Cargo.lock"
  } | sha256sum | cut -d' ' -f1
}
package_stamp="$venv/.pl2map-shards-package"
package_want="$(package_hash || echo "unknown $(date +%s%N)")"
if [ "$(cat "$package_stamp" 2>/dev/null)" != "$package_want" ]; then
  {
    "$venv/bin/python" -m pip install -q "$repo/crates/py" &&
    echo "$package_want" > "$package_stamp"
  } >&2 || echo "pl2map-shards not installed into $venv: crates/py/tests will skip" >&2
fi
echo "$venv/bin/python"
