#!/usr/bin/env bash
# Installs the system packages the build needs, only those missing (idempotent).
# OpenCV (SIFT, LSD) is linked through the `opencv` crate, which needs libclang;
# libhdf5-dev is the HDF5 library `pl2map features` writes hloc's feature files with.
set -euo pipefail

packages=(pkg-config clang libclang-dev libopencv-dev libhdf5-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "installing system packages: ${missing[*]}" >&2
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
