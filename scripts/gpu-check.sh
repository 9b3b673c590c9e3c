#!/usr/bin/env bash
# The GPU check (issue 50): on a GPU machine with no Rust toolchain and no network, from
# binaries built beforehand on the CPU machine, in under 8 minutes, for every engine
# built (CubeCL `cuda`, LibTorch `tch`):
#   1. device detection (nvidia-smi, the driver as pl2map sees it, PyTorch's CUDA);
#   2. the engine against the CPU (Flex): `engine_check` (crates/bench/src/engines.rs);
#   3. the training step on the GPU beside PyTorch on the same GPU (D = 128 and 256, the
#      reference computation, crates/bench/python/torch_step.py), with the first step's
#      wall time: `gpu_step`;
#   4. the paper network (pipeline/synthetic-paper.toml's [train]) on the synthetic
#      room's shards for a fixed budget of GPU time (iterations = budget / the step time
#      of a short calibration run), scored (points + lines under 5 cm / 5 deg), and the
#      first training step's seconds with an empty kernel cache (the calibration run) and
#      with the cache it left (the training run);
# then one table. `--dry-run` runs the same steps on the CPU (libtorch:cpu for the tch
# build, cpu for the cuda build; step 2 only where an engine has a CPU device) with small
# budgets and the tiny synthetic scene.
#
# Build and carry (on the CPU machine, in the repository; about 10 min per engine on 2
# cores; the default build is untouched):
#   export CARGO_TARGET_DIR=$HOME/.cache/pl2map-rs/target; T=$CARGO_TARGET_DIR/release
#   mkdir -p carry/cuda carry/tch
#   cargo build --release --locked -p cli --features cuda
#   cargo build --release --locked -p bench --features cuda --example engine_check --example gpu_step
#   cp $T/pl2map $T/examples/engine_check $T/examples/gpu_step carry/cuda/
#   eval "$(scripts/libtorch-env.sh)"        # PyTorch 2.9 of the venv: build and link
#   cargo build --release --locked -p cli --features tch
#   cargo build --release --locked -p bench --features tch --example engine_check --example gpu_step
#   cp $T/pl2map $T/examples/engine_check $T/examples/gpu_step carry/tch/
#   strip carry/*/*                          # pl2map and the examples: tens of MB each before
#   cp scripts/gpu-check.sh pipeline/synthetic-paper.toml pipeline/synthetic-tiny.toml carry/
#   # optional, saves regenerating them there (about 1 min on 16 cores):
#   carry/tch/pl2map run pipeline/synthetic-paper.toml --work carry/work --until shard
#   tar czf gpu-check.tgz carry
# There: tar xzf gpu-check.tgz && carry/gpu-check.sh [--budget SECONDS] [--python PY]
#
# What it expects there: the NVIDIA driver (nvidia-smi, libcuda.so.1); for `cuda`,
# CUDA's nvrtc (libnvrtc.so on the library path: CubeCL compiles its kernels with it);
# for `tch` and the PyTorch columns, a Python with PyTorch 2.9.x with CUDA (--python, or
# $PL2MAP_TORCH_PYTHON, or python3): the tch binaries load its torch/lib, which this
# script puts on LD_LIBRARY_PATH. An engine whose binaries are missing is skipped.
#
# Options: --dry-run, --dir DIR (the carried folder; default: this script's folder),
# --budget SECONDS (training time per engine; default 100, dry run 10), --python PY,
# --out DIR (work and logs; default DIR/gpu-check-out, emptied first).
set -uo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
dir="$here"
dry=0
budget=""
python="${PL2MAP_TORCH_PYTHON:-python3}"
out=""
while [ $# -gt 0 ]; do
    case "$1" in
        --dry-run | --cpu) dry=1 ;;
        --dir) dir="$2"; shift ;;
        --budget) budget="$2"; shift ;;
        --python) python="$2"; shift ;;
        --out) out="$2"; shift ;;
        *) echo "gpu-check.sh: unknown argument $1" >&2; exit 2 ;;
    esac
    shift
done
[ -n "$budget" ] || budget=$([ $dry = 1 ] && echo 10 || echo 100)
out="${out:-$dir/gpu-check-out}"
rm -rf "$out" && mkdir -p "$out" || exit 1
log="$out/gpu-check.log"
table="$out/table.txt"
started=$(date +%s)
say() { echo "== $*" | tee -a "$log"; }

# Step-size settings: the full check, or the dry run's.
if [ $dry = 1 ]; then
    dims=32; step_args=(--points 64 --lines 8 --warmup 1 --iters 3)
    calib_iters=6; pipeline_file="$dir/synthetic-tiny.toml"
else
    dims=128,256; step_args=(--warmup 3 --iters 20)
    calib_iters=40; pipeline_file="$dir/synthetic-paper.toml"
fi
for f in "$dir/synthetic-paper.toml" "$pipeline_file"; do
    [ -f "$f" ] || { echo "gpu-check.sh: $f is missing (copy pipeline/*.toml beside the script)" >&2; exit 2; }
done

# PyTorch: its torch/lib for the tch binaries, and the reference step.
torch_lib=""
torch_info="none"
if "$python" -c 'import torch' 2>/dev/null; then
    torch_lib="$("$python" -c 'import os, torch; print(os.path.join(os.path.dirname(torch.__file__), "lib"))')"
    torch_info="$("$python" -c 'import torch; print(torch.__version__, "cuda" if torch.cuda.is_available() else "no-cuda", torch.cuda.device_count())')"
fi

say "1. device detection"
{
    if command -v nvidia-smi >/dev/null; then nvidia-smi -L; nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
    else echo "nvidia-smi: not found"; fi
    echo "PyTorch ($python): $torch_info"
} 2>&1 | tee -a "$log"
gpu_name="$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1)"
[ -n "$gpu_name" ] || gpu_name="none"

# The data: carried shards, else regenerated with the first engine's pl2map.
engines=()
for e in cuda tch; do [ -x "$dir/$e/pl2map" ] && engines+=("$e"); done
# A CPU-only build (carried as cpu/) takes part in the dry run only.
[ $dry = 1 ] && [ -x "$dir/cpu/pl2map" ] && engines+=(cpu)
[ ${#engines[@]} -gt 0 ] || { echo "gpu-check.sh: no engine binaries under $dir/{cuda,tch}/" >&2; exit 2; }
env_for() { # the environment of engine $1's binaries
    # cuda: CubeCL's compiled kernels and autotune results in a folder of this check, empty
    # at the start (crates/model/src/kernel_cache.rs): the calibration run of step 4
    # starts cold, the training run after it warm.
    if [ "$1" = tch ]; then echo "LD_LIBRARY_PATH=$torch_lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"; else echo "PL2MAP_KERNEL_CACHE=$out/kernel-cache-$1"; fi
}
first_step() { # the first training step's seconds (compilation included) of run folder $1
    [ -f "$1/metrics.csv" ] || { echo "-"; return; }
    python3 -c 'import csv,sys; r=next(csv.DictReader(open(sys.argv[1])), None); print("-" if r is None else "%.1fs" % float(r["seconds"]))' "$1/metrics.csv"
}
find_shards() { find "$1" -name 'manifest.json' -path '*shard*' 2>/dev/null | head -1 | xargs -r dirname; }
shards=""
[ $dry = 1 ] || shards="$(find_shards "$dir/work")"
if [ -z "$shards" ]; then
    say "data: the synthetic room's shards ($(basename "$pipeline_file"), made here)"
    e0="${engines[0]}"
    t0=$(date +%s)
    env "$(env_for "$e0")" "$dir/$e0/pl2map" --quiet run "$pipeline_file" --work "$out/data" --until shard >>"$log" 2>&1 \
        || { echo "gpu-check.sh: making the shards failed (see $log)" >&2; exit 1; }
    shards="$(find_shards "$out/data")"
    echo "   shards in $shards ($(( $(date +%s) - t0 )) s)" | tee -a "$log"
fi
# The paper's [train] as a train configuration file: the section, its subsections unprefixed.
awk '/^\[train\]/{on=1; next} /^\[train\./{on=1; sub(/^\[train\./, "["); print; next} /^\[/{on=0} on' \
    "$dir/synthetic-paper.toml" >"$out/paper-train.toml"

printf '%-8s %-18s %-10s %-22s %-22s %-22s %-16s %-9s %-10s\n' engine device agreement \
    "D=128 1st/median" "D=256 1st/median" "torch 128/256 median" "1st step cold/warm" iters "5cm/5deg" >"$table"

for e in "${engines[@]}"; do
    bin="$dir/$e"
    envv="$(env_for "$e")"
    if [ $dry = 1 ] || [ "$e" = cpu ]; then
        device=$([ "$e" = tch ] && echo libtorch:cpu || echo cpu)
    else
        device=$([ "$e" = tch ] && echo libtorch:cuda || echo cuda)
    fi
    say "engine $e on $device"

    agreement="-"
    if [ "$device" != cpu ] && [ -x "$bin/engine_check" ]; then
        say "2. $e: engine_check --device $device"
        timeout 180 env "$envv" "$bin/engine_check" --device "$device" >"$out/$e-agreement.txt" 2>&1
        rc=$?
        cat "$out/$e-agreement.txt" >>"$log"
        agreement=$(case $rc in 0) echo agree ;; 1) echo DISAGREE ;; 124) echo timeout ;; *) echo error ;; esac)
        tail -1 "$out/$e-agreement.txt"
    fi

    step128="-"; step256="-"; torchs="-"
    if [ -x "$bin/gpu_step" ]; then
        say "3. $e: gpu_step --device $device --dims $dims (PyTorch beside it)"
        timeout 240 env "$envv" "$bin/gpu_step" --device "$device" --dims "$dims" "${step_args[@]}" \
            --python "$python" --json >"$out/$e-step.txt" 2>&1
        cat "$out/$e-step.txt" | tee -a "$log" | grep -v '^{'
        rows="$(grep '^{' "$out/$e-step.txt")"
        if [ -n "$rows" ]; then
            read -r step128 step256 torchs < <(python3 - "$rows" <<'PY'
import json, sys
rows = [json.loads(l) for l in sys.argv[1].splitlines()]
ms = lambda v: "-" if v is None else f"{1e3 * v:.1f}"
cell = lambda r: f"{r['first_step_s']:.2f}s/{ms(r['median_step_s'])}ms"
by = {r["dim"]: r for r in rows}
first = rows[0]
a = cell(by[128]) if 128 in by else cell(first)
b = cell(by[256]) if 256 in by else "-"
t = "/".join(ms(r.get("torch_median_step_s")) for r in rows) + "ms"
print(a, b, t)
PY
)
        fi
    fi

    say "4. $e: the paper network, $budget s of training, scored"
    iters="-"; score="-"
    t0=$(date +%s)
    timeout 300 env "$envv" "$bin/pl2map" --quiet train --config "$out/paper-train.toml" --shards "$shards" \
        --out "$out/$e-calib" --device "$device" --iterations "$calib_iters" >>"$log" 2>&1
    if [ -f "$out/$e-calib/metrics.csv" ]; then
        iters=$(python3 - "$out/$e-calib/metrics.csv" "$budget" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
t = sorted(float(r["seconds"]) for r in rows[len(rows) // 2:])
step = t[len(t) // 2]
print(max(1, min(30000, int(float(sys.argv[2]) / (1.1 * step)))))
PY
)
        echo "   calibration: $calib_iters steps in $(( $(date +%s) - t0 )) s; $iters iterations fit $budget s" | tee -a "$log"
        timeout $(( budget * 3 + 120 )) env "$envv" "$bin/pl2map" --quiet train --config "$out/paper-train.toml" \
            --shards "$shards" --out "$out/$e-train" --device "$device" --iterations "$iters" >>"$log" 2>&1
        if [ -f "$out/$e-train/model.ckpt" ]; then
            timeout 300 env "$envv" "$bin/pl2map" --quiet score --shards "$shards" --checkpoint "$out/$e-train/model.ckpt" \
                --out "$out/$e-score" --device "$device" >>"$log" 2>&1
            if [ -f "$out/$e-score/summary.json" ]; then
                score=$(python3 - "$out/$e-score/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
best = None
for v in s["variants"]:
    for a in v["accuracy"]:
        if a["cm"] == 5 and a["deg"] == 5 and "line" in json.dumps(v["variant"]).lower():
            best = a["fraction"]
print("-" if best is None else f"{100 * best:.1f}%")
PY
)
            fi
        fi
    fi
    printf '%-8s %-18s %-10s %-22s %-22s %-22s %-16s %-9s %-10s\n' "$e" "$device" "$agreement" \
        "$step128" "$step256" "$torchs" "$(first_step "$out/$e-calib")/$(first_step "$out/$e-train")" \
        "$iters" "$score" >>"$table"
done

echo
say "GPU: $gpu_name; PyTorch: $torch_info; $(date -u +%Y-%m-%d); $(( $(date +%s) - started )) s in all; log $log"
cat "$table" | tee -a "$log"
