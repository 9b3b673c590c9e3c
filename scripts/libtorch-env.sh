#!/usr/bin/env bash
# Prints the environment the LibTorch engine (the `tch` cargo feature) needs, to build and
# to run, for the PyTorch of a Python environment:
#
#   eval "$(scripts/libtorch-env.sh)"            # the test venv, or $PL2MAP_PYTHON
#   eval "$(scripts/libtorch-env.sh /path/to/python)"
#   cargo build --release --locked -p cli --features tch
#
# - Building: torch-sys (tch 0.22) compiles its C++ glue against PyTorch's headers and
#   links PyTorch's libraries. LIBTORCH_USE_PYTORCH=1 makes it ask the Python on PATH
#   (`python` in a virtualenv, else `python3`) where they are, so the venv's bin folder
#   goes first on PATH. tch 0.22 expects PyTorch 2.9.0; another 2.9.x patch release has
#   the same C++ interface, so the version check is bypassed for it (and only for it).
# - Running: torch-sys sets no rpath in the binaries that link it (the -rpath flag it
#   passes only reaches its own static glue library), so the loader must find
#   torch/lib through LD_LIBRARY_PATH. A binary built this way runs on any machine with
#   the same PyTorch minor release, once this script's LD_LIBRARY_PATH points at it.
#
# Fails (non-zero, one line on stderr) when the interpreter has no PyTorch, or a PyTorch
# other than 2.9.x.
set -euo pipefail

python="${1:-${PL2MAP_PYTHON:-$HOME/.cache/pl2map-rs/venv/bin/python}}"
if ! command -v "$python" >/dev/null 2>&1; then
    echo "libtorch-env.sh: no Python interpreter at $python (give one as the argument or in PL2MAP_PYTHON; scripts/setup-python.sh makes the test venv)" >&2
    exit 1
fi
info="$("$python" -c 'import os, torch; print(torch.__version__.split("+")[0]); print(os.path.join(os.path.dirname(torch.__file__), "lib"))' 2>/dev/null)" || {
    echo "libtorch-env.sh: $python cannot import torch (pip install torch==2.9.*)" >&2
    exit 1
}
version="$(sed -n 1p <<<"$info")"
lib="$(sed -n 2p <<<"$info")"
case "$version" in
    2.9.0) bypass="" ;;
    2.9.*) bypass=1 ;;
    *)
        echo "libtorch-env.sh: $python has PyTorch $version; the tch feature (tch 0.22) needs 2.9.x" >&2
        exit 1
        ;;
esac
bin="$(cd "$(dirname "$(command -v "$python")")" && pwd)"
echo "export LIBTORCH_USE_PYTORCH=1"
if [ -n "$bypass" ]; then
    echo "export LIBTORCH_BYPASS_VERSION_CHECK=1"
fi
echo "export PATH=\"$bin:\$PATH\""
echo "export LD_LIBRARY_PATH=\"$lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}\""
