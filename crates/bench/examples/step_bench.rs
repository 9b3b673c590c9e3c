//! Prints the training-step benchmark table (see `bench::step`).
//!
//! cargo run --release -p bench --example step_bench -- [--python PATH] [--dims 128,256]
//!     [--iters N] [--warmup N] [--threads N] [--backend flex|ndarray|cuda] [--json]
//! The Python interpreter defaults to $PL2MAP_TORCH_PYTHON; without one the PyTorch
//! columns are skipped. Each descriptor dimension runs in a fresh child process (this
//! program again, with --in-process) so that its peak-memory figure starts from a clean
//! process; pass --in-process to run everything in this one.

use bench::step::{BenchBackend, StepBenchConfig, StepBenchTable, run_step_benchmark};
use std::path::PathBuf;
use std::process::Command;

/// Runs one dimension in a child process and returns its table.
fn child(cfg: &StepBenchConfig, dim: usize) -> Result<StepBenchTable, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find this program: {e}"))?;
    let mut cmd = Command::new(exe);
    cmd.args(["--in-process", "--json", "--quiet"])
        .args(["--dims", &dim.to_string()])
        .args(["--iters", &cfg.iterations.to_string()])
        .args(["--warmup", &cfg.warmup.to_string()])
        .args(["--threads", &cfg.threads.to_string()])
        .args(["--points", &cfg.keypoints.to_string()])
        .args(["--lines", &cfg.lines.to_string()])
        .args([
            "--backend",
            match cfg.backend {
                BenchBackend::Flex => "flex",
                BenchBackend::NdArray => "ndarray",
                BenchBackend::Cuda => "cuda",
            },
        ]);
    match &cfg.python {
        Some(p) => cmd.arg("--python").arg(p),
        None => cmd.arg("--no-python"),
    };
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run the child: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().last().unwrap_or("");
    serde_json::from_str(line).map_err(|e| format!("cannot parse the child's table: {e}"))
}

fn main() {
    let mut cfg = StepBenchConfig {
        python: std::env::var_os("PL2MAP_TORCH_PYTHON").map(PathBuf::from),
        ..Default::default()
    };
    let mut json = false;
    let mut in_process = false;
    let mut quiet = false;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| {
            args.next().unwrap_or_else(|| {
                eprintln!("{name} needs a value");
                std::process::exit(2)
            })
        };
        let number = |s: String| -> usize {
            s.parse().unwrap_or_else(|_| {
                eprintln!("not a number: {s}");
                std::process::exit(2)
            })
        };
        match arg.as_str() {
            "--python" => cfg.python = Some(PathBuf::from(value("--python"))),
            "--no-python" => cfg.python = None,
            "--dims" => {
                cfg.dims = value("--dims")
                    .split(',')
                    .map(|s| number(s.to_string()))
                    .collect()
            }
            "--iters" => cfg.iterations = number(value("--iters")),
            "--warmup" => cfg.warmup = number(value("--warmup")),
            "--threads" => cfg.threads = number(value("--threads")),
            "--points" => cfg.keypoints = number(value("--points")),
            "--lines" => cfg.lines = number(value("--lines")),
            "--backend" => {
                cfg.backend = match value("--backend").as_str() {
                    "flex" => BenchBackend::Flex,
                    "ndarray" => BenchBackend::NdArray,
                    "cuda" => BenchBackend::Cuda,
                    other => {
                        eprintln!("unknown backend {other} (flex, ndarray, cuda)");
                        std::process::exit(2)
                    }
                }
            }
            "--json" => json = true,
            "--in-process" => in_process = true,
            "--quiet" => quiet = true,
            other => {
                eprintln!("unknown argument {other}");
                std::process::exit(2)
            }
        }
    }
    let result = if in_process || cfg.dims.len() < 2 {
        run_step_benchmark(&cfg).map_err(|e| e.to_string())
    } else {
        let mut merged: Option<StepBenchTable> = None;
        let mut failure = None;
        for &dim in &cfg.dims {
            match child(&cfg, dim) {
                Ok(t) => match merged.as_mut() {
                    None => merged = Some(t),
                    Some(m) => {
                        m.rows.extend(t.rows);
                        m.load_average_after = t.load_average_after;
                    }
                },
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            }
        }
        match (failure, merged) {
            (Some(e), _) => Err(e),
            (None, Some(t)) => Ok(t),
            (None, None) => Err("no dimensions to run".into()),
        }
    };
    match result {
        Ok(table) => {
            if !quiet {
                print!("{table}");
            }
            if json {
                println!("{}", serde_json::to_string(&table).unwrap_or_default());
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1)
        }
    }
}
