//! `scripts/gpu-check.sh --dry-run` end to end: the GPU check's steps on the CPU with
//! small budgets (device detection, the engine check where an engine has a CPU device,
//! the step beside PyTorch, the network trained on the tiny synthetic scene for a fixed
//! budget and scored, the table), from a carried folder laid out as the script's header
//! says: this build's `pl2map` under `tch/` (a `--features tch` build), `cuda/` or
//! `cpu/`, with `engine_check` and `gpu_step` when they were built beside it. The
//! PyTorch columns use $PL2MAP_PYTHON (without it they say "skipped" and the rest runs).

use std::path::Path;
use std::process::Command;

#[test]
fn the_gpu_check_runs_end_to_end_on_the_cpu() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let pl2map = Path::new(env!("CARGO_BIN_EXE_pl2map"));
    let engine = if cfg!(feature = "tch") {
        "tch"
    } else if cfg!(feature = "cuda") {
        "cuda"
    } else {
        "cpu"
    };
    let dir = tempfile::tempdir().unwrap();
    let carry = dir.path();
    let bin = carry.join(engine);
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::copy(pl2map, bin.join("pl2map")).unwrap();
    let examples = pl2map.parent().unwrap().join("examples");
    for ex in ["engine_check", "gpu_step"] {
        if examples.join(ex).is_file() {
            std::fs::copy(examples.join(ex), bin.join(ex)).unwrap();
        } else {
            eprintln!(
                "note: no {ex} built beside pl2map (cargo build -p bench --example {ex}): its step is skipped"
            );
        }
    }
    for f in [
        "pipeline/synthetic-paper.toml",
        "pipeline/synthetic-tiny.toml",
    ] {
        std::fs::copy(repo.join(f), carry.join(Path::new(f).file_name().unwrap())).unwrap();
    }
    let mut cmd = Command::new("bash");
    cmd.arg(repo.join("scripts/gpu-check.sh"))
        .args(["--dry-run", "--dir"])
        .arg(carry)
        .args(["--budget", "8"]);
    match std::env::var_os("PL2MAP_PYTHON") {
        Some(py) => {
            cmd.arg("--python").arg(py);
        }
        None => eprintln!("note: PL2MAP_PYTHON unset: the PyTorch columns are skipped"),
    }
    let started = std::time::Instant::now();
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stdout}\n{stderr}\n({:.0?})", started.elapsed());
    assert!(out.status.success(), "gpu-check.sh --dry-run failed");
    let table = std::fs::read_to_string(carry.join("gpu-check-out/table.txt")).unwrap();
    let row = table
        .lines()
        .find(|l| l.starts_with(engine))
        .unwrap_or_else(|| panic!("no {engine} row in\n{table}"));
    let cells: Vec<&str> = row.split_whitespace().collect();
    // engine device agreement D=128 D=256 torch first-step-cold/warm iters score
    assert_eq!(cells.len(), 9, "{row}");
    let first_steps: Vec<&str> = cells[6].split('/').collect();
    assert!(
        first_steps.len() == 2 && first_steps.iter().all(|s| s.ends_with('s')),
        "first step cold/warm: {row}"
    );
    assert!(
        cells[7].parse::<u32>().is_ok_and(|n| n >= 1),
        "iterations: {row}"
    );
    assert!(cells[8].ends_with('%'), "no score: {row}");
    if examples.join("gpu_step").is_file() {
        assert!(cells[3].ends_with("ms"), "no step time: {row}");
    }
    if engine == "tch" && examples.join("engine_check").is_file() {
        assert_eq!(cells[2], "agree", "{row}");
    }
}
