//! `pl2map bench colmap`: reading a large binary model, ours against pycolmap.
//!
//! Writes a synthetic model with our writer to a temporary directory, times our reader
//! (best of N) and, when a Python with pycolmap is given (`--python` or PL2MAP_PYTHON),
//! `pycolmap.Reconstruction(dir)` on the same files in the same run (best of N, timed
//! inside Python so interpreter start-up is not counted).
use anyhow::{Context, bail};
use colmap::synthetic::{SyntheticSpec, large_model};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Number of 3D points.
    #[arg(long, default_value_t = 1_000_000)]
    points: usize,
    /// Number of (registered) images.
    #[arg(long, default_value_t = 5_000)]
    images: usize,
    /// Number of observations (total track length).
    #[arg(long, default_value_t = 5_000_000)]
    obs: usize,
    /// 2D points without a 3D point, per image.
    #[arg(long, default_value_t = 1_000)]
    unmatched: usize,
    /// Timed repetitions; the best one counts.
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Python interpreter with pycolmap (default: $PL2MAP_PYTHON).
    #[arg(long)]
    python: Option<PathBuf>,
    /// Seed of the synthetic model.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

const PY_SCRIPT: &str = include_str!("../../python/colmap_pycolmap.py");

struct PyResult {
    seconds: f64,
    cpu_seconds: f64,
    points: usize,
    images: usize,
    observations: usize,
    version: String,
}

fn run_pycolmap(python: &Path, dir: &Path, repeats: usize) -> anyhow::Result<PyResult> {
    let out = Command::new(python)
        .args(["-c", PY_SCRIPT])
        .arg(dir)
        .arg(repeats.to_string())
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    if !out.status.success() {
        bail!(
            "{} failed: {}",
            python.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8(out.stdout)?;
    let f: Vec<&str> = text.split_whitespace().collect();
    if f.len() != 6 {
        bail!("unexpected output from pycolmap script: {text:?}");
    }
    Ok(PyResult {
        seconds: f[0].parse()?,
        cpu_seconds: f[1].parse()?,
        points: f[2].parse()?,
        images: f[3].parse()?,
        observations: f[4].parse()?,
        version: f[5].to_string(),
    })
}

/// A scratch directory removed on drop (the CLI has no tempfile dependency).
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> anyhow::Result<Self> {
        let dir = std::env::temp_dir().join(format!("pl2map-bench-colmap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(TempDir(dir))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// CPU time (user + system, all threads) of this process so far, from /proc (Linux);
/// None elsewhere. Reported next to wall time because the benchmark may share the
/// machine with other work.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses and may contain spaces).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

fn dir_size(dir: &Path) -> anyhow::Result<u64> {
    let mut total = 0;
    for e in std::fs::read_dir(dir)? {
        total += e?.metadata()?.len();
    }
    Ok(total)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let repeats = args.repeats.max(1);
    let spec = SyntheticSpec {
        num_points3d: args.points,
        num_images: args.images,
        num_observations: args.obs,
        unmatched_per_image: args.unmatched,
        images_per_camera: 10,
        seed: args.seed,
    };
    if args.images == 0 || (args.points > 0 && args.obs.div_ceil(args.points) > args.images) {
        bail!("tracks would be longer than the number of images");
    }
    let t = Instant::now();
    let rec = large_model(&spec);
    let gen_s = t.elapsed().as_secs_f64();
    let tmp = TempDir::new()?;
    let dir = tmp.0.as_path();
    let t = Instant::now();
    rec.write_binary(dir)?;
    let write_s = t.elapsed().as_secs_f64();
    let bytes = dir_size(dir)?;
    let (n_points, n_images, n_obs, n_2d) = (
        rec.points3d.len(),
        rec.images.len(),
        rec.num_observations(),
        rec.num_points2d(),
    );
    drop(rec);
    stage::outln!(
        "model: {n_points} points3D, {n_images} images, {n_obs} observations, {n_2d} points2D; \
         {:.1} MB of .bin files (generated in {gen_s:.2} s, written in {write_s:.2} s)",
        bytes as f64 / 1e6
    );

    let mut ours = f64::INFINITY;
    let mut ours_cpu: Option<f64> = None;
    for _ in 0..repeats {
        let c = process_cpu_seconds();
        let t = Instant::now();
        let r = colmap::read_binary(dir)?;
        ours = ours.min(t.elapsed().as_secs_f64());
        if let (Some(c0), Some(c1)) = (c, process_cpu_seconds()) {
            ours_cpu = Some(ours_cpu.map_or(c1 - c0, |b: f64| b.min(c1 - c0)));
        }
        if r.points3d.len() != n_points || r.num_observations() != n_obs {
            bail!("read back a different model");
        }
        drop(r);
    }

    let python = args
        .python
        .or_else(|| std::env::var_os("PL2MAP_PYTHON").map(PathBuf::from));
    let py = match &python {
        None => Err(anyhow::anyhow!("no --python and PL2MAP_PYTHON unset")),
        Some(p) => run_pycolmap(p, dir, repeats),
    };

    let mbps = |s: f64| bytes as f64 / 1e6 / s;
    stage::outln!();
    let cpu = |c: Option<f64>| c.map_or("-".to_string(), |c| format!("{c:.2}"));
    stage::outln!("| reader | wall, best of {repeats} (s) | MB/s | CPU, best of {repeats} (s) |");
    stage::outln!("|---|---:|---:|---:|");
    stage::outln!(
        "| pl2map colmap::read_binary | {ours:.3} | {:.0} | {} |",
        mbps(ours),
        cpu(ours_cpu)
    );
    match py {
        Ok(p) => {
            if (p.points, p.images, p.observations) != (n_points, n_images, n_obs) {
                bail!(
                    "pycolmap read {} points, {} images, {} observations",
                    p.points,
                    p.images,
                    p.observations
                );
            }
            stage::outln!(
                "| pycolmap {} Reconstruction(dir) | {:.3} | {:.0} | {:.2} |",
                p.version,
                p.seconds,
                mbps(p.seconds),
                p.cpu_seconds
            );
            stage::outln!();
            stage::outln!(
                "ratio ours / pycolmap: wall {:.2}x, CPU {} (goal <= 1.0x)",
                ours / p.seconds,
                ours_cpu.map_or("-".to_string(), |c| format!("{:.2}x", c / p.cpu_seconds))
            );
        }
        Err(e) => stage::outln!("\npycolmap: skipped ({e:#})"),
    }
    Ok(())
}
