#!/usr/bin/env bash
# Installs the S3 server the object-storage tests start on 127.0.0.1
# (crates/remote/tests/, tests/remote_shards.rs): s3s-fs, the file-system S3 server of
# the s3s project (crates.io, Apache-2.0), built from source with `cargo install --locked`
# into $HOME/.cache/pl2map-rs/tools/bin. Idempotent: an installed binary is kept.
#
# Why s3s-fs and not Garage: Garage 2.x is a distributed store of several hundred crates
# (AGPL) that needs a cluster layout, keys and buckets made through its admin CLI before
# a test can PUT anything; s3s-fs is one small binary that serves a folder (a bucket is
# a subfolder) with SigV4 authentication, so a test starts it in a temporary folder in
# well under a second. Its install took 5 min 27 s on the 2-core VM, with another build
# running (docs/operations.md, "Shards from object storage"). 0.14.1 is its newest
# release that builds with Rust 1.92-1.95 (0.16 and later need Rust 1.96).
#
# Optional: pl2map neither builds nor runs with it. On failure this prints why on stderr,
# nothing on stdout, and exits 0, so that CI goes on and the tests skip, naming the reason.
set -uo pipefail

version=0.14.1
tools="${PL2MAP_TOOLS:-$HOME/.cache/pl2map-rs/tools}"
bin="$tools/bin/s3s-fs"

if [ -x "$bin" ] && "$bin" --version 2>/dev/null | grep -q "$version"; then
  exit 0
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup-s3.sh: no cargo on PATH: s3s-fs not installed, the S3 tests will skip" >&2
  exit 0
fi
echo "setup-s3.sh: installing s3s-fs $version into $tools (a few minutes)" >&2
# A target folder of its own, removed afterwards: the workspace's is not touched.
target="$tools/build-s3s-fs"
if CARGO_TARGET_DIR="$target" cargo install --quiet --locked --root "$tools" \
  --features binary "s3s-fs@$version" >&2; then
  rm -rf "$target"
  echo "setup-s3.sh: installed $bin" >&2
else
  rm -rf "$target"
  echo "setup-s3.sh: cargo install s3s-fs@$version failed: the S3 tests will skip" >&2
fi
exit 0
