//! The training step on one engine and device beside PyTorch on the same device: the
//! first step's wall time (what a run waits before training starts: a JIT engine
//! compiles its kernels there) and the median of the following steps, for each
//! descriptor dimension, at the step benchmark's size (1,024 keypoints, 128 lines;
//! `bench::step`). PyTorch runs the reference computation
//! (`crates/bench/python/torch_step.py`) with `--device cuda` for a GPU device.
//!
//! cargo run --release -p bench --features tch --example gpu_step -- --device libtorch:cuda
//!     [--dims 128,256] [--warmup 3] [--iters 20] [--points 1024] [--lines 128]
//!     [--python PATH | --no-python] [--json]
//! The interpreter defaults to $PL2MAP_TORCH_PYTHON. Each dimension runs in this
//! process in turn (the first dimension's first step pays the engine's start-up).

use bench::step::{TORCH_SCRIPT, TorchResult, synthetic_sample};
use model::burn::tensor::backend::AutodiffBackend;
use model::{Device, LossConfig, ModelConfig, Pl2MapBackend};
use serde::Serialize;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;
use train::step::{StepOptions, TrainState};

#[derive(Serialize)]
struct Row {
    device: String,
    dim: usize,
    /// Seconds from this program's start to the end of the first step.
    launch_to_first_step_s: f64,
    first_step_s: f64,
    median_step_s: f64,
    torch_device: Option<String>,
    torch_version: Option<String>,
    torch_first_step_s: Option<f64>,
    torch_median_step_s: Option<f64>,
    torch_note: Option<String>,
}

struct Settings {
    device: Device,
    dims: Vec<usize>,
    warmup: usize,
    iters: usize,
    points: usize,
    lines: usize,
    python: Option<PathBuf>,
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// (first step, median of the steps after the warm-up) on backend B.
fn burn_steps<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    s: &Settings,
    dim: usize,
    device: &B::Device,
    launch: Instant,
) -> Result<(f64, f64, f64), String> {
    kernels::alloc::keep_freed_memory();
    let cfg = ModelConfig::new(dim);
    let sample = synthetic_sample(&cfg, s.points, s.lines, 7);
    let mut state =
        TrainState::<B>::init(&cfg, LossConfig::indoor(), 7, device).map_err(|e| e.to_string())?;
    let mut times = Vec::new();
    let mut to_first = 0.0;
    for i in 0..1 + s.warmup + s.iters {
        let options = StepOptions {
            progress: 0.9,
            learning_rate: 1e-4,
            dropout_seed: i as u64,
        };
        let start = Instant::now();
        // The step reads its loss values back, which waits for the device.
        let report = state.step(&sample, &options).map_err(|e| e.to_string())?;
        times.push(start.elapsed().as_secs_f64());
        if i == 0 {
            to_first = launch.elapsed().as_secs_f64();
        }
        if !report.losses.total.is_finite() {
            return Err(format!("D = {dim}: non-finite loss at step {i}"));
        }
    }
    Ok((to_first, times[0], median(&times[1 + s.warmup..])))
}

fn torch_steps(s: &Settings, python: &PathBuf, dim: usize) -> Result<TorchResult, String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let script = dir.path().join("torch_step.py");
    std::fs::write(&script, TORCH_SCRIPT).map_err(|e| e.to_string())?;
    let torch_device = match s.device.gpu_index() {
        Some(i) => format!("cuda:{i}"),
        None => "cpu".into(),
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let out = Command::new(python)
        .arg(&script)
        .args(["--dim", &dim.to_string()])
        .args(["--points", &s.points.to_string()])
        .args(["--lines", &s.lines.to_string()])
        .args(["--threads", &threads.to_string()])
        // Every step timed, the first included: the warm-up is dropped here.
        .args(["--warmup", "0"])
        .args(["--iters", &(1 + s.warmup + s.iters).to_string()])
        .args(["--device", &torch_device])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(format!(
            "PyTorch failed: {}",
            err.lines().last().unwrap_or("no message")
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .unwrap_or("");
    serde_json::from_str(line).map_err(|e| format!("cannot parse PyTorch's result: {e}"))
}

fn run(s: &Settings, dim: usize, launch: Instant) -> Result<Row, String> {
    let d = s.device;
    let (to_first, first, med) = match d {
        Device::Cpu => {
            burn_steps::<model::CpuAutodiffBackend>(s, dim, &Default::default(), launch)?
        }
        #[cfg(feature = "cuda")]
        Device::Cuda(i) => {
            burn_steps::<model::CudaAutodiffBackend>(s, dim, &Device::cuda(i), launch)?
        }
        #[cfg(feature = "tch")]
        Device::LibTorchCpu | Device::LibTorchCuda(_) => {
            burn_steps::<model::LibTorchAutodiffBackend>(s, dim, &d.libtorch(), launch)?
        }
        #[allow(unreachable_patterns)]
        _ => return Err(d.not_built().to_string()),
    };
    let mut row = Row {
        device: d.to_string(),
        dim,
        launch_to_first_step_s: to_first,
        first_step_s: first,
        median_step_s: med,
        torch_device: None,
        torch_version: None,
        torch_first_step_s: None,
        torch_median_step_s: None,
        torch_note: None,
    };
    match &s.python {
        Some(py) => match torch_steps(s, py, dim) {
            Ok(t) => {
                row.torch_device = Some(match d.gpu_index() {
                    Some(i) => format!("cuda:{i}"),
                    None => "cpu".into(),
                });
                row.torch_version = Some(t.torch_version);
                row.torch_first_step_s = t.times_s.first().copied();
                row.torch_median_step_s =
                    Some(median(t.times_s.get(1 + s.warmup..).unwrap_or(&[])));
            }
            Err(e) => row.torch_note = Some(e),
        },
        None => row.torch_note = Some("skipped: no Python interpreter given".into()),
    }
    Ok(row)
}

fn main() {
    let launch = Instant::now();
    let mut s = Settings {
        device: Device::Cpu,
        dims: vec![128, 256],
        warmup: 3,
        iters: 20,
        points: 1024,
        lines: 128,
        python: std::env::var_os("PL2MAP_TORCH_PYTHON").map(PathBuf::from),
    };
    let mut json = false;
    let mut args = std::env::args().skip(1);
    let fail = |m: String| -> ! {
        eprintln!("error: {m}");
        std::process::exit(2)
    };
    while let Some(arg) = args.next() {
        let mut value = || {
            args.next()
                .unwrap_or_else(|| fail(format!("{arg} needs a value")))
        };
        let number = |v: String| {
            v.parse::<usize>()
                .unwrap_or_else(|_| fail(format!("not a number: {v}")))
        };
        match arg.as_str() {
            "--device" => s.device = value().parse().unwrap_or_else(|e: String| fail(e)),
            "--dims" => s.dims = value().split(',').map(|x| number(x.to_string())).collect(),
            "--warmup" => s.warmup = number(value()),
            "--iters" => s.iters = number(value()).max(1),
            "--points" => s.points = number(value()),
            "--lines" => s.lines = number(value()),
            "--python" => s.python = Some(PathBuf::from(value())),
            "--no-python" => s.python = None,
            "--json" => json = true,
            other => fail(format!("unknown argument {other}")),
        }
    }
    if let Err(e) = s.device.check_usable() {
        fail(e.to_string())
    }
    model::device::explain_gpu_panics(s.device);
    println!(
        "{:<18} {:>4} {:>12} {:>10} {:>10} {:>12} {:>10} {:>10}",
        "device", "D", "launch->1st", "1st step", "median", "torch dev", "torch 1st", "median"
    );
    for &dim in &s.dims {
        match run(&s, dim, launch) {
            Ok(r) => {
                let ms =
                    |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{:.1} ms", 1e3 * v));
                println!(
                    "{:<18} {:>4} {:>10.2} s {:>10} {:>10} {:>12} {:>10} {:>10}{}",
                    r.device,
                    r.dim,
                    r.launch_to_first_step_s,
                    ms(Some(r.first_step_s)),
                    ms(Some(r.median_step_s)),
                    r.torch_device.clone().unwrap_or_else(|| "-".into()),
                    ms(r.torch_first_step_s),
                    ms(r.torch_median_step_s),
                    r.torch_note
                        .as_ref()
                        .map_or(String::new(), |n| format!("  ({n})"))
                );
                if json {
                    println!("{}", serde_json::to_string(&r).unwrap_or_default());
                }
            }
            Err(e) => fail(format!("D = {dim}: {e}")),
        }
    }
}
