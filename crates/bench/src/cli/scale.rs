//! `pl2map bench scale`: the pipeline at several scene sizes, one table: each stage's
//! seconds and peak memory, and the training step's seconds and data wait.
//!
//! For each frame count the synthetic scene of a base pipeline file (default
//! `pipeline/synthetic.toml`) is built with `[synth] frames` set to it, in
//! `<work>/<frames>/`, by this same binary as child processes: `pl2map run --until
//! <stage>` stage by stage, then `pl2map train` for a few hundred steps of the file's
//! `[train]` (or with `--max-keypoints`, the paper recipe's limit), then optionally
//! `score`. Each child's peak resident memory comes from the kernel (`wait4`'s
//! `ru_maxrss`), so every figure is one process's. A stage already done in the work
//! folder is skipped by `pl2map run` (seconds near 0): use a fresh `--work` to time
//! the data stages. The step figures are medians over the steps after the first 20
//! (`metrics.csv`: `seconds`, `data_seconds`).

use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Frame counts of the synthetic scene (two thirds of each train, a third test).
    #[arg(long, value_delimiter = ',', default_values_t = [300usize, 3000, 10500])]
    frames: Vec<usize>,
    /// Training steps at each size.
    #[arg(long, default_value_t = 300)]
    steps: u64,
    /// The base pipeline file (its `[synth]`, data stages and `[train]`).
    #[arg(long, default_value = "pipeline/synthetic.toml")]
    pipeline: PathBuf,
    /// Where the scenes are built (kept: a second run reuses the data stages).
    #[arg(long)]
    work: PathBuf,
    /// `[train.limits] max_keypoints` for the training run (the paper recipe's 2048).
    #[arg(long)]
    max_keypoints: Option<usize>,
    /// Also score the few-hundred-step model on the test shards (its memory and time).
    #[arg(long)]
    score: bool,
    /// Stages to run again in a reused work folder (their folders are removed first),
    /// e.g. `--rerun import,refine,shard` to measure a new binary without rendering the
    /// scenes again. The other stages' rows then show a skip, not a run.
    #[arg(long, value_delimiter = ',')]
    rerun: Vec<String>,
}

struct Row {
    frames: usize,
    what: String,
    seconds: f64,
    peak_mb: f64,
    step_s: Option<f64>,
    wait_s: Option<f64>,
}

const STAGES: [&str; 5] = ["synth", "ingest", "import", "refine", "shard"];

pub fn run(a: Args) -> anyhow::Result<()> {
    let exe = std::env::current_exe().context("finding the pl2map binary")?;
    let base = std::fs::read_to_string(&a.pipeline)
        .with_context(|| format!("reading {}", a.pipeline.display()))?;
    let base: toml::Table =
        toml::from_str(&base).with_context(|| format!("parsing {}", a.pipeline.display()))?;
    if let Some(bad) = a.rerun.iter().find(|s| !STAGES.contains(&s.as_str())) {
        bail!("--rerun {bad}: expected stages among {}", STAGES.join(", "));
    }
    std::fs::create_dir_all(&a.work)?;
    let work = a.work.canonicalize()?;
    let mut rows = Vec::new();
    for &frames in &a.frames {
        let dir = work.join(frames.to_string());
        std::fs::create_dir_all(&dir)?;
        let pipeline = write_pipeline(&base, frames, &dir)?;
        for stage in &a.rerun {
            let folder = dir.join("work").join(stage);
            if folder.exists() {
                std::fs::remove_dir_all(&folder)
                    .with_context(|| format!("removing {}", folder.display()))?;
            }
        }
        for stage in STAGES {
            let (seconds, peak) = child(
                Command::new(&exe)
                    .args(["--quiet", "run"])
                    .arg(&pipeline)
                    .args(["--until", stage]),
                &dir.join(format!("{stage}.log")),
            )?;
            let log = std::fs::read_to_string(dir.join(format!("{stage}.log")))?;
            let what = if was_skipped(&log, stage) {
                format!("{stage} (kept)")
            } else {
                stage.to_string()
            };
            rows.push(row(frames, &what, seconds, peak));
            eprintln!(
                "{frames} frames: {stage} {seconds:.1} s, {:.0} MB",
                peak / 1e6
            );
        }
        let config = write_train_config(&base, a.steps, a.max_keypoints, &dir)?;
        let out = dir.join("train-bench");
        let _ = std::fs::remove_dir_all(&out);
        let (seconds, peak) = child(
            Command::new(&exe)
                .args(["--quiet", "train", "--shards"])
                .arg(dir.join("work/shard"))
                .arg("--out")
                .arg(&out)
                .arg("--config")
                .arg(&config),
            &dir.join("train.log"),
        )?;
        let (step, wait) = step_medians(&out.join("metrics.csv"))?;
        rows.push(Row {
            step_s: Some(step),
            wait_s: Some(wait),
            ..row(frames, &format!("train ({} steps)", a.steps), seconds, peak)
        });
        eprintln!("{frames} frames: train {seconds:.1} s, step {step:.4} s, wait {wait:.4} s");
        if a.score {
            let (seconds, peak) = child(
                Command::new(&exe)
                    .args(["--quiet", "score", "--shards"])
                    .arg(dir.join("work/shard"))
                    .arg("--checkpoint")
                    .arg(out.join("model.ckpt"))
                    .arg("--out")
                    .arg(dir.join("score-bench")),
                &dir.join("score.log"),
            )?;
            rows.push(row(frames, "score", seconds, peak));
        }
    }
    print_table(&rows, &a);
    Ok(())
}

/// Whether `pl2map run`'s summary (its log) says the stage was up to date, not run.
fn was_skipped(log: &str, stage: &str) -> bool {
    log.lines().any(|l| {
        l.strip_prefix(stage).is_some_and(|rest| {
            rest.starts_with(' ') && rest.trim_start().starts_with("up to date")
        })
    })
}

fn row(frames: usize, what: &str, seconds: f64, peak: f64) -> Row {
    Row {
        frames,
        what: what.to_string(),
        seconds,
        peak_mb: peak / 1e6,
        step_s: None,
        wait_s: None,
    }
}

/// The base file with `[synth] frames` set and the work folder in `dir`.
fn write_pipeline(base: &toml::Table, frames: usize, dir: &Path) -> anyhow::Result<PathBuf> {
    let mut t = base.clone();
    t.insert("work".into(), toml::Value::String("work".into()));
    let synth = t
        .entry("synth")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let Some(synth) = synth.as_table_mut() else {
        bail!("the base pipeline's [synth] is not a table");
    };
    synth.remove("tiny");
    synth.insert("frames".into(), toml::Value::Integer(frames as i64));
    let path = dir.join("pipeline.toml");
    std::fs::write(&path, toml::to_string(&t)?)?;
    Ok(path)
}

/// The base file's `[train]` with `steps` iterations (and the keypoint limit).
fn write_train_config(
    base: &toml::Table,
    steps: u64,
    max_keypoints: Option<usize>,
    dir: &Path,
) -> anyhow::Result<PathBuf> {
    let mut train = match base.get("train") {
        Some(toml::Value::Table(t)) => t.clone(),
        _ => bail!("the base pipeline has no [train]"),
    };
    train.insert("iterations".into(), toml::Value::Integer(steps as i64));
    train.insert(
        "checkpoint_every".into(),
        toml::Value::Integer(steps as i64),
    );
    if let Some(k) = max_keypoints {
        let limits = train
            .entry("limits")
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        if let Some(l) = limits.as_table_mut() {
            l.insert("max_keypoints".into(), toml::Value::Integer(k as i64));
        }
    }
    let path = dir.join("train-bench.toml");
    let mut doc = toml::Table::new();
    doc.insert("train".into(), toml::Value::Table(train));
    std::fs::write(&path, toml::to_string(&doc)?)?;
    Ok(path)
}

/// Runs `cmd` (output into `log`), returning its wall seconds and peak resident bytes.
fn child(cmd: &mut Command, log: &Path) -> anyhow::Result<(f64, f64)> {
    let out = std::fs::File::create(log)?;
    let err = out.try_clone()?;
    let t = Instant::now();
    let child = cmd
        .stdout(out)
        .stderr(err)
        .spawn()
        .context("starting pl2map")?;
    let (status, peak) = wait_with_peak(child.id() as libc::pid_t)?;
    let seconds = t.elapsed().as_secs_f64();
    if status != 0 {
        bail!(
            "{cmd:?} failed (status {status}); its output is in {}",
            log.display()
        );
    }
    Ok((seconds, peak))
}

/// `wait4` on the child: its exit status and peak resident set (bytes).
fn wait_with_peak(pid: libc::pid_t) -> anyhow::Result<(i32, f64)> {
    let mut status = 0;
    // SAFETY: rusage is plain data that wait4 fills in; a zeroed one is a valid value.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not yet waited for; both pointers are valid.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    if r != pid {
        bail!(
            "waiting for process {pid}: {}",
            std::io::Error::last_os_error()
        );
    }
    let code = if libc::WIFEXITED(status) {
        libc::WEXITSTATUS(status)
    } else {
        -1
    };
    // Linux reports ru_maxrss in KiB.
    Ok((code, usage.ru_maxrss as f64 * 1024.0))
}

/// Median step seconds and data wait over the rows after the first 20.
fn step_medians(metrics: &Path) -> anyhow::Result<(f64, f64)> {
    let text = std::fs::read_to_string(metrics)
        .with_context(|| format!("reading {}", metrics.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (Some(s), Some(d)) = (col("seconds"), col("data_seconds")) else {
        bail!("{}: no seconds / data_seconds columns", metrics.display());
    };
    let mut steps = Vec::new();
    let mut waits = Vec::new();
    for line in lines.skip(20) {
        let f: Vec<&str> = line.split(',').collect();
        steps.push(
            f.get(s)
                .and_then(|v| v.parse::<f64>().ok())
                .unwrap_or(f64::NAN),
        );
        waits.push(
            f.get(d)
                .and_then(|v| v.parse::<f64>().ok())
                .unwrap_or(f64::NAN),
        );
    }
    if steps.is_empty() {
        bail!("{}: fewer than 21 steps", metrics.display());
    }
    Ok((median(&mut steps), median(&mut waits)))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn print_table(rows: &[Row], a: &Args) {
    println!(
        "pl2map bench scale: {} ({} steps{}); machine: {} cores",
        a.pipeline.display(),
        a.steps,
        a.max_keypoints
            .map(|k| format!(", max_keypoints {k}"))
            .unwrap_or_default(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    println!(
        "{:>7} {:<18} {:>9} {:>9} {:>9} {:>9} {:>10}",
        "frames", "stage", "seconds", "peak MB", "step s", "wait s", "step ratio"
    );
    let first_step = rows.iter().find_map(|r| r.step_s);
    for r in rows {
        let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.4}"));
        let ratio = match (r.step_s, first_step) {
            (Some(s), Some(f)) if f > 0.0 => format!("{:.2}x", s / f),
            _ => "-".to_string(),
        };
        println!(
            "{:>7} {:<18} {:>9.1} {:>9.0} {:>9} {:>9} {:>10}",
            r.frames,
            r.what,
            r.seconds,
            r.peak_mb,
            opt(r.step_s),
            opt(r.wait_s),
            ratio
        );
    }
}

#[cfg(test)]
mod tests {
    use super::was_skipped;

    /// The summary `pl2map run` prints (crates/pipeline's stage table).
    #[test]
    fn a_kept_stage_is_told_from_a_run_one() {
        let log = "stage    status          seconds  notes\n\
                   synth    up to date          5.2  10500 frames, seed 0\n\
                   refine   ran                39.4  6936588 of 6936588 point labels kept\n";
        assert!(was_skipped(log, "synth"));
        assert!(!was_skipped(log, "refine"));
        assert!(!was_skipped(log, "shard"));
    }
}
