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
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
if [ ${#missing[@]} -ne 0 ]; then
  echo "installing system packages: ${missing[*]}" >&2
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Optional: Slurm and MUNGE for tests/slurm.rs, which starts a one-node Slurm on
# 127.0.0.1 and runs deploy/slurm/ on it (it skips, saying why, without them). Not needed
# to build or run pl2map, so a failure here only prints a line.
slurm_packages=(munge slurmctld slurmd slurm-client)
slurm_missing=()
for p in "${slurm_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || slurm_missing+=("$p")
done
if [ ${#slurm_missing[@]} -ne 0 ]; then
  echo "installing optional packages (Slurm tests): ${slurm_missing[*]}" >&2
  if ! { $sudo apt-get update -qq &&
    $sudo apt-get install -y -qq --no-install-recommends "${slurm_missing[@]}" >/dev/null; }; then
    echo "could not install ${slurm_missing[*]}: tests/slurm.rs will skip" >&2
  fi
fi

# Optional: the S3 server of the object-storage tests (scripts/setup-s3.sh; never fails).
"$(dirname "$0")/setup-s3.sh" || true
