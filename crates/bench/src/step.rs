//! Benchmark of one training step (forward + loss + backward + Adam) on the CPU backend,
//! optionally against the same step of an equivalent PyTorch module
//! (`crates/bench/python/torch_step.py`, embedded here and run with a given interpreter).
//!
//! Peak memory is the process's resident high-water mark (VmHWM), reset before each
//! configuration by writing 5 to /proc/self/clear_refs (Linux >= 4.0), so each row's
//! figure covers that configuration alone, plus whatever the process already held (shown
//! as the RSS before the configuration).

use crate::BenchError as E;
use model::burn::tensor::backend::AutodiffBackend;
use model::{LossConfig, ModelConfig, Pinhole, Pl2MapBackend, Sample};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;
use train::step::{StepOptions, TrainState};

/// The PyTorch side of the benchmark, run by the interpreter in `StepBenchConfig::python`.
pub const TORCH_SCRIPT: &str = include_str!("../python/torch_step.py");

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StepBenchConfig {
    /// Descriptor dimensions to run (one row each).
    pub dims: Vec<usize>,
    pub keypoints: usize,
    pub lines: usize,
    /// Steps run before timing.
    pub warmup: usize,
    /// Timed steps; the table reports their median.
    pub iterations: usize,
    /// Threads for both sides (rayon pool for burn, torch.set_num_threads for PyTorch).
    pub threads: usize,
    /// Training progress of the timed steps (>= 0.8 turns the reprojection term on).
    pub progress: f64,
    /// Which burn CPU backend runs the step.
    pub backend: BenchBackend,
    /// Python interpreter with torch installed; None skips the PyTorch side.
    pub python: Option<PathBuf>,
    pub seed: u64,
}

impl Default for StepBenchConfig {
    fn default() -> Self {
        StepBenchConfig {
            dims: vec![128, 256],
            keypoints: 1024,
            lines: 128,
            warmup: 2,
            iterations: 7,
            threads: 2,
            progress: 0.9,
            backend: BenchBackend::Flex,
            python: None,
            seed: 7,
        }
    }
}

/// The burn backends the benchmark can run on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BenchBackend {
    /// burn-flex (the default backend of this crate).
    Flex,
    /// burn-ndarray; needs the `ndarray` cargo feature.
    NdArray,
    /// burn-cuda on the default GPU; needs the `cuda` cargo feature. Step times include
    /// the device synchronisation of reading the loss values back.
    Cuda,
}

impl BenchBackend {
    pub fn label(&self) -> &'static str {
        match self {
            BenchBackend::Flex => "burn 0.21.0 Flex (CPU) + Autodiff",
            BenchBackend::NdArray => "burn 0.21.0 NdArray (CPU) + Autodiff",
            BenchBackend::Cuda => "burn 0.21.0 CUDA + Autodiff",
        }
    }
}

fn run_backend(cfg: &StepBenchConfig, dim: usize) -> Result<StepBenchRow, E> {
    match cfg.backend {
        BenchBackend::Flex => run_burn::<model::CpuAutodiffBackend>(cfg, dim),
        #[cfg(feature = "ndarray")]
        BenchBackend::NdArray => run_burn::<model::NdArrayAutodiffBackend>(cfg, dim),
        #[cfg(not(feature = "ndarray"))]
        BenchBackend::NdArray => Err(E::Bench(
            "the NdArray backend needs the `ndarray` cargo feature".into(),
        )),
        #[cfg(feature = "cuda")]
        BenchBackend::Cuda => run_burn::<model::CudaAutodiffBackend>(cfg, dim),
        #[cfg(not(feature = "cuda"))]
        BenchBackend::Cuda => Err(E::Bench(
            "the CUDA backend needs the `cuda` cargo feature".into(),
        )),
    }
}

/// One PyTorch measurement, as the script prints it (one JSON object).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TorchResult {
    pub torch_version: String,
    pub params: usize,
    pub times_s: Vec<f64>,
    pub median_s: f64,
    /// Median process CPU time per step (PyTorch's OpenMP threads spin while waiting, so
    /// this overstates the work on a busy machine).
    pub cpu_median_s: Option<f64>,
    pub rss_before_bytes: Option<u64>,
    pub peak_rss_bytes: Option<u64>,
    /// Whether the script ran its line encoder on token 0 only, like this crate.
    pub token0_only: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StepBenchRow {
    pub dim: usize,
    pub params: usize,
    pub times_s: Vec<f64>,
    pub median_s: f64,
    /// Median CPU time per step (all threads); on a machine shared with other work this
    /// says more than the wall time (10 ms resolution).
    pub cpu_median_s: Option<f64>,
    pub rss_before_bytes: Option<u64>,
    pub peak_rss_bytes: Option<u64>,
    /// PyTorch running the reference computation (line encoder on all T tokens).
    pub torch_full: Option<TorchResult>,
    /// PyTorch with the same token-0 shortcut as this crate.
    pub torch_token0: Option<TorchResult>,
    /// Why the PyTorch side is missing, if it is.
    pub torch_note: Option<String>,
}

impl StepBenchRow {
    /// burn time / PyTorch time (reference computation).
    pub fn ratio_full(&self) -> Option<f64> {
        self.torch_full.as_ref().map(|t| self.median_s / t.median_s)
    }

    pub fn ratio_token0(&self) -> Option<f64> {
        self.torch_token0
            .as_ref()
            .map(|t| self.median_s / t.median_s)
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StepBenchTable {
    pub backend: String,
    pub threads: usize,
    pub keypoints: usize,
    pub lines: usize,
    pub line_tokens: usize,
    pub iterations: usize,
    pub load_average_before: Option<String>,
    pub load_average_after: Option<String>,
    pub rows: Vec<StepBenchRow>,
}

fn mib(b: Option<u64>) -> String {
    b.map_or("-".into(), |b| {
        format!("{:.0}", b as f64 / (1024.0 * 1024.0))
    })
}

impl fmt::Display for StepBenchTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "training step (forward + loss + backward + Adam), {} keypoints, {} lines x {} tokens, {} threads, median of {}",
            self.keypoints, self.lines, self.line_tokens, self.threads, self.iterations
        )?;
        writeln!(
            f,
            "load average before: {}   after: {}",
            self.load_average_before.as_deref().unwrap_or("?"),
            self.load_average_after.as_deref().unwrap_or("?")
        )?;
        writeln!(
            f,
            "{:>4} {:>8} | {:>7} {:>6} {:>6} {:>6} | {:>7} {:>6} {:>6} {:>6} | {:>7} {:>6} {:>6}",
            "D",
            "params",
            "burn s",
            "cpu s",
            "RSS0",
            "peak",
            "torch s",
            "cpu s",
            "peak",
            "ratio",
            "t0 s",
            "cpu s",
            "ratio"
        )?;
        for r in &self.rows {
            let t = |x: &Option<TorchResult>| {
                x.as_ref()
                    .map_or("-".to_string(), |t| format!("{:.3}", t.median_s))
            };
            let ratio = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.2}x"));
            let c = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.2}"));
            let tc = |x: &Option<TorchResult>| c(x.as_ref().and_then(|t| t.cpu_median_s));
            writeln!(
                f,
                "{:>4} {:>8} | {:>7.3} {:>6} {:>6} {:>6} | {:>7} {:>6} {:>6} {:>6} | {:>7} {:>6} {:>6}",
                r.dim,
                r.params,
                r.median_s,
                c(r.cpu_median_s),
                mib(r.rss_before_bytes),
                mib(r.peak_rss_bytes),
                t(&r.torch_full),
                tc(&r.torch_full),
                mib(r.torch_full.as_ref().and_then(|t| t.peak_rss_bytes)),
                ratio(r.ratio_full()),
                t(&r.torch_token0),
                tc(&r.torch_token0),
                ratio(r.ratio_token0()),
            )?;
            if let Some(note) = &r.torch_note {
                writeln!(f, "     PyTorch: {note}")?;
            }
        }
        writeln!(
            f,
            "backend: {}; s = median wall seconds per step, cpu s = median CPU seconds (all threads), RSS0/peak = MiB resident before / at peak",
            self.backend
        )?;
        writeln!(
            f,
            "torch = PyTorch running the reference computation (line encoder on all tokens); t0 = PyTorch with this crate's token-0 shortcut; ratio = burn s / torch s"
        )
    }
}

/// A deterministic synthetic image: unit-norm random descriptors, keypoints and segments
/// spread over a 640 x 480 image, 80 % of them labelled with back-projections at 1-6 m.
pub fn synthetic_sample(config: &ModelConfig, n: usize, m: usize, seed: u64) -> Sample {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = config.descriptor_dim;
    let t = config.line_tokens;
    let mut unit_rows = |rows: usize| -> Vec<f32> {
        let mut v = Vec::with_capacity(rows * d);
        for _ in 0..rows {
            let row: Vec<f32> = (0..d).map(|_| rng.random::<f32>() - 0.5).collect();
            let norm = row.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-6);
            v.extend(row.iter().map(|x| x / norm));
        }
        v
    };
    let point_descriptors = unit_rows(n);
    let line_descriptors = unit_rows(m * t);
    let camera = Pinhole {
        fx: 525.0,
        fy: 525.0,
        cx: 320.0,
        cy: 240.0,
    };
    let back = |u: f32, v: f32, z: f32| {
        [
            (u - camera.cx as f32) / camera.fx as f32 * z,
            (v - camera.cy as f32) / camera.fy as f32 * z,
            z,
        ]
    };
    let mut keypoints = Vec::with_capacity(n);
    let mut point_labels = Vec::with_capacity(n);
    let mut point_valid = Vec::with_capacity(n);
    for _ in 0..n {
        let (u, v) = (rng.random::<f32>() * 640.0, rng.random::<f32>() * 480.0);
        keypoints.push([u, v]);
        point_labels.push(back(u, v, 1.0 + 5.0 * rng.random::<f32>()));
        point_valid.push(rng.random::<f32>() < 0.8);
    }
    let mut segments = Vec::with_capacity(m);
    let mut line_labels = Vec::with_capacity(m);
    let mut line_valid = Vec::with_capacity(m);
    for _ in 0..m {
        let (u1, v1) = (rng.random::<f32>() * 640.0, rng.random::<f32>() * 480.0);
        let (u2, v2) = (rng.random::<f32>() * 640.0, rng.random::<f32>() * 480.0);
        segments.push([u1, v1, u2, v2]);
        let a = back(u1, v1, 1.0 + 5.0 * rng.random::<f32>());
        let b = back(u2, v2, 1.0 + 5.0 * rng.random::<f32>());
        line_labels.push([a[0], a[1], a[2], b[0], b[1], b[2]]);
        line_valid.push(rng.random::<f32>() < 0.8);
    }
    Sample {
        point_descriptors,
        line_descriptors,
        keypoints,
        segments,
        point_labels,
        point_valid,
        line_labels,
        line_valid,
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0; 3],
        camera,
    }
}

/// CPU time (user + system, all threads) of this process in seconds; /proc reports it in
/// USER_HZ ticks, which Linux fixes at 100 per second for userspace.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) may hold spaces; the fields after it follow its ')'.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 after ')'.
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

fn status_kib(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Resets VmHWM to the current RSS; false where the kernel does not allow it.
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn load_average() -> Option<String> {
    let s = std::fs::read_to_string("/proc/loadavg").ok()?;
    Some(s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
}

fn median(times: &[f64]) -> f64 {
    let mut t = times.to_vec();
    t.sort_by(f64::total_cmp);
    match t.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => t[n / 2],
        n => 0.5 * (t[n / 2 - 1] + t[n / 2]),
    }
}

fn run_burn<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    cfg: &StepBenchConfig,
    dim: usize,
) -> Result<StepBenchRow, E> {
    // The trainer's allocator settings (alloc.rs), so the step is measured as it trains.
    kernels::alloc::keep_freed_memory();
    let model_config = ModelConfig::new(dim);
    let sample = synthetic_sample(&model_config, cfg.keypoints, cfg.lines, cfg.seed);
    let rss_before = status_kib("VmRSS:");
    let peak_ok = reset_peak_rss();
    let device = Default::default();
    let mut state = TrainState::<B>::init(&model_config, LossConfig::indoor(), cfg.seed, &device)?;
    let params = state.model().parameter_counts().total();
    let mut times = Vec::with_capacity(cfg.iterations);
    let mut cpu = Vec::with_capacity(cfg.iterations);
    for i in 0..cfg.warmup + cfg.iterations {
        let options = StepOptions {
            progress: cfg.progress,
            learning_rate: 1e-4,
            dropout_seed: cfg.seed.wrapping_add(i as u64),
        };
        let cpu_start = process_cpu_seconds();
        let start = Instant::now();
        let report = state.step(&sample, &options)?;
        let elapsed = start.elapsed().as_secs_f64();
        let cpu_used = cpu_start.zip(process_cpu_seconds()).map(|(a, b)| b - a);
        if !report.losses.total.is_finite() {
            return Err(E::Bench(format!(
                "D = {dim}: non-finite loss at step {i}: {:?}",
                report.losses
            )));
        }
        if i >= cfg.warmup {
            times.push(elapsed);
            if let Some(c) = cpu_used {
                cpu.push(c);
            }
        }
    }
    let peak = if peak_ok { status_kib("VmHWM:") } else { None };
    Ok(StepBenchRow {
        dim,
        params,
        median_s: median(&times),
        times_s: times,
        cpu_median_s: (!cpu.is_empty()).then(|| median(&cpu)),
        rss_before_bytes: rss_before,
        peak_rss_bytes: peak,
        torch_full: None,
        torch_token0: None,
        torch_note: None,
    })
}

fn run_torch(
    cfg: &StepBenchConfig,
    python: &PathBuf,
    script: &std::path::Path,
    dim: usize,
    token0_only: bool,
) -> Result<TorchResult, String> {
    let mut cmd = Command::new(python);
    cmd.arg(script)
        .args(["--dim", &dim.to_string()])
        .args(["--points", &cfg.keypoints.to_string()])
        .args(["--lines", &cfg.lines.to_string()])
        .args(["--threads", &cfg.threads.to_string()])
        .args(["--warmup", &cfg.warmup.to_string()])
        .args(["--iters", &cfg.iterations.to_string()])
        .args(["--progress", &cfg.progress.to_string()])
        .args(["--seed", &cfg.seed.to_string()]);
    if token0_only {
        cmd.arg("--token0-only");
    }
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("").to_string();
        return Err(format!(
            "{} exited with {}: {last}",
            python.display(),
            out.status
        ));
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .ok_or_else(|| "the PyTorch script printed no result".to_string())?;
    serde_json::from_str(line).map_err(|e| format!("cannot parse the PyTorch result: {e}"))
}

/// Runs the benchmark; each configuration is timed on burn first, then (with a Python
/// interpreter) on PyTorch in a fresh process, twice: the reference computation and the
/// token-0 variant.
pub fn run_step_benchmark(cfg: &StepBenchConfig) -> Result<StepBenchTable, E> {
    if cfg.iterations == 0 || cfg.threads == 0 {
        return Err(E::Bench("iterations and threads must be positive".into()));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads)
        .build()
        .map_err(|e| E::Bench(format!("cannot build a thread pool: {e}")))?;
    let load_before = load_average();

    let script_dir = match &cfg.python {
        Some(_) => Some(tempfile::tempdir().map_err(fileio::io_err("temporary directory"))?),
        None => None,
    };
    let script = match &script_dir {
        Some(dir) => {
            let path = dir.path().join("torch_step.py");
            std::fs::write(&path, TORCH_SCRIPT).map_err(fileio::io_err(&path))?;
            Some(path)
        }
        None => None,
    };

    let mut rows = Vec::new();
    for &dim in &cfg.dims {
        let mut row = pool.install(|| run_backend(cfg, dim))?;
        match (&cfg.python, &script) {
            (Some(python), Some(script)) => {
                let full = run_torch(cfg, python, script, dim, false);
                let t0 = run_torch(cfg, python, script, dim, true);
                let mut notes = Vec::new();
                match full {
                    Ok(r) => row.torch_full = Some(r),
                    Err(e) => notes.push(e),
                }
                match t0 {
                    Ok(r) => row.torch_token0 = Some(r),
                    Err(e) => notes.push(e),
                }
                if !notes.is_empty() {
                    row.torch_note = Some(notes.join("; "));
                }
            }
            _ => row.torch_note = Some("skipped: no Python interpreter given".into()),
        }
        rows.push(row);
    }
    Ok(StepBenchTable {
        backend: cfg.backend.label().into(),
        threads: cfg.threads,
        keypoints: cfg.keypoints,
        lines: cfg.lines,
        line_tokens: ModelConfig::new(cfg.dims.first().copied().unwrap_or(128)).line_tokens,
        iterations: cfg.iterations,
        load_average_before: load_before,
        load_average_after: load_average(),
        rows,
    })
}
