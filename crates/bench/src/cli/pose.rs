//! `pl2map bench pose`: our hybrid RANSAC against poselib 2.0.5 on the same random
//! correspondence sets, in the same run. Scenarios (pose::synthetic presets):
//! (a) 200 points, 40 % outliers, 1 px noise: `estimate_absolute_pose`;
//! (b) 8 points + 60 lines, 30 % bad lines, 1 px noise: `estimate_absolute_pose_pnpl`.
//! Both sides get the same options (thresholds 12 / 10 px, 1000 to 100000 iterations,
//! success probability 0.9999, Cauchy refinement). The problems go to a temporary JSON
//! file; one Python process solves them all and times each call itself.

use anyhow::{Context, bail};
use geometry::Pose;
use geometry::metrics::{median, pose_error};
use pose::synthetic::{SyntheticConfig, SyntheticProblem, generate_seeded};
use pose::{RansacOptions, estimate_pose};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Random problems per scenario.
    #[arg(long, default_value_t = 200)]
    problems: usize,
    /// Python interpreter with poselib 2.0.5 (default: $PL2MAP_PYTHON); without one,
    /// only our side runs.
    #[arg(long)]
    python: Option<PathBuf>,
    /// Seed of the problem generator (RANSAC seeds follow from it).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Solve every problem this many times on each side and keep the fastest time
    /// (the work is identical; the minimum filters out other processes' noise).
    #[arg(long, default_value_t = 5)]
    repeats: usize,
}

/// Solves each problem with poselib and prints one JSON object per line:
/// {"q": [w, x, y, z], "t": [...], "seconds": s, "iterations": n}.
const POSELIB_SCRIPT: &str = include_str!("../../python/pose_poselib.py");

struct Outcome {
    rot_deg: f64,
    trans_cm: f64,
    ms: f64,
    iterations: f64,
}

fn problem_json(pb: &SyntheticProblem, seed: u64) -> Value {
    let c = &pb.camera;
    json!({
        "camera": {"model": c.model.name(), "width": c.width, "height": c.height, "params": c.params},
        "points2D": pb.points.iter().map(|p| [p.pixel.x, p.pixel.y]).collect::<Vec<_>>(),
        "points3D": pb.points.iter().map(|p| [p.world.x, p.world.y, p.world.z]).collect::<Vec<_>>(),
        "lines2D": pb.lines.iter().map(|l| l.segment.to_array()).collect::<Vec<_>>(),
        "lines3D": pb.lines.iter().map(|l| {
            let (a, b) = (l.world.start, l.world.end);
            [a.x, a.y, a.z, b.x, b.y, b.z]
        }).collect::<Vec<_>>(),
        "seed": seed,
    })
}

fn ours(
    problems: &[(SyntheticProblem, u64)],
    opt: &RansacOptions,
    repeats: usize,
) -> anyhow::Result<Vec<Outcome>> {
    problems
        .iter()
        .map(|(pb, seed)| {
            let opt = RansacOptions {
                seed: *seed,
                ..opt.clone()
            };
            let mut ms = f64::INFINITY;
            let mut est = None;
            for _ in 0..repeats {
                let t0 = Instant::now();
                let e = estimate_pose(&pb.camera, &pb.points, &pb.lines, &opt)?;
                ms = ms.min(t0.elapsed().as_secs_f64() * 1e3);
                est = Some(e);
            }
            let est = est.context("no repeat ran")?;
            let e = pose_error(&pb.gt, &est.pose);
            Ok(Outcome {
                rot_deg: e.rotation_deg,
                trans_cm: e.translation_cm(),
                ms,
                iterations: est.iterations as f64,
            })
        })
        .collect()
}

fn poselib(
    python: &Path,
    dir: &Path,
    name: &str,
    problems: &[(SyntheticProblem, u64)],
    opt: &RansacOptions,
    repeats: usize,
) -> anyhow::Result<Vec<Outcome>> {
    let input = dir.join(format!("{name}.json"));
    let output = dir.join(format!("{name}.out.jsonl"));
    let script = dir.join("solve_poselib.py");
    std::fs::write(&script, POSELIB_SCRIPT)?;
    let doc = json!({
        "ransac": {
            "max_reproj_error": opt.point_threshold_px,
            "max_epipolar_error": opt.line_threshold_px,
            "min_iterations": opt.min_iterations,
            "max_iterations": opt.max_iterations,
            "success_prob": opt.success_probability,
            "dyn_num_trials_mult": opt.dynamic_trials_factor,
        },
        "bundle": {"loss_type": "CAUCHY", "loss_scale": opt.point_loss_scale_px, "max_iterations": opt.refine_iterations},
        "repeats": repeats,
        "problems": problems.iter().map(|(pb, s)| problem_json(pb, *s)).collect::<Vec<_>>(),
    });
    std::fs::write(&input, serde_json::to_vec(&doc)?)?;
    let status = Command::new(python)
        .arg(&script)
        .arg(&input)
        .arg(&output)
        .status()
        .with_context(|| format!("running {}", python.display()))?;
    if !status.success() {
        bail!(
            "{} {} failed ({status})",
            python.display(),
            script.display()
        );
    }
    let text = std::fs::read_to_string(&output)?;
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() != problems.len() {
        bail!(
            "poselib returned {} results for {} problems",
            lines.len(),
            problems.len()
        );
    }
    lines
        .iter()
        .zip(problems)
        .map(|(line, (pb, _))| {
            let v: Value = serde_json::from_str(line)?;
            let num = |x: &Value| x.as_f64().context("non-numeric poselib output");
            let q: Vec<f64> = v["q"]
                .as_array()
                .context("q")?
                .iter()
                .map(num)
                .collect::<Result<_, _>>()?;
            let t: Vec<f64> = v["t"]
                .as_array()
                .context("t")?
                .iter()
                .map(num)
                .collect::<Result<_, _>>()?;
            if q.len() != 4 || t.len() != 3 {
                bail!("malformed poselib pose: {line}");
            }
            let est = Pose::from_qvec_tvec([q[0], q[1], q[2], q[3]], [t[0], t[1], t[2]])?;
            let e = pose_error(&pb.gt, &est);
            Ok(Outcome {
                rot_deg: e.rotation_deg,
                trans_cm: e.translation_cm(),
                ms: num(&v["seconds"])? * 1e3,
                iterations: num(&v["iterations"])?,
            })
        })
        .collect()
}

fn medians(o: &[Outcome]) -> [f64; 4] {
    let m = |f: fn(&Outcome) -> f64| median(&o.iter().map(f).collect::<Vec<_>>());
    [
        m(|o| o.rot_deg),
        m(|o| o.trans_cm),
        m(|o| o.ms),
        m(|o| o.iterations),
    ]
}

fn python_path(arg: Option<PathBuf>) -> Option<PathBuf> {
    arg.or_else(|| std::env::var_os("PL2MAP_PYTHON").map(PathBuf::from))
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.problems == 0 || args.repeats == 0 {
        bail!("--problems and --repeats must be at least 1");
    }
    let opt = RansacOptions::default();
    let scenarios = [
        (
            "a",
            "(a) 200 points, 40 % outliers",
            SyntheticConfig::bench_points(),
        ),
        (
            "b",
            "(b) 8 points + 60 lines, 30 % bad lines",
            SyntheticConfig::bench_points_lines(),
        ),
    ];
    let python = python_path(args.python);
    let dir = std::env::temp_dir().join(format!("pl2map-bench-pose-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    stage::outln!(
        "pose benchmark: {} problems per scenario, 1 px noise, 640x480 f=525 camera, seed {}; \
         time = fastest of {} runs per problem, then the median over problems",
        args.problems,
        args.seed,
        args.repeats
    );
    stage::outln!(
        "options: thresholds {} / {} px, iterations {}..{}, success {}, Cauchy {} px (points) / {} px (lines)",
        opt.point_threshold_px,
        opt.line_threshold_px,
        opt.min_iterations,
        opt.max_iterations,
        opt.success_probability,
        opt.point_loss_scale_px,
        opt.line_loss_scale_px
    );
    stage::outln!(
        "medians over problems; ratio = pl2map / poselib (below 1: pl2map more accurate or faster)"
    );
    stage::outln!(
        "{:<42} {:<8} {:>10} {:>10} {:>10} {:>8}",
        "scenario",
        "side",
        "rot deg",
        "trans cm",
        "time ms",
        "iters"
    );
    let result = (|| -> anyhow::Result<()> {
        for (si, (key, title, cfg)) in scenarios.iter().enumerate() {
            let problems: Vec<(SyntheticProblem, u64)> = (0..args.problems as u64)
                .map(|i| {
                    let seed = args
                        .seed
                        .wrapping_mul(1_000_003)
                        .wrapping_add(i + 1_000_000 * si as u64);
                    (generate_seeded(cfg, seed), seed)
                })
                .collect();
            // Warm-up so that the first timed call does not pay for page faults.
            let _ = ours(&problems[..1], &opt, 1)?;
            let a = medians(&ours(&problems, &opt, args.repeats)?);
            let row = |side: &str, m: &[f64; 4]| {
                stage::outln!(
                    "{:<42} {:<8} {:>10.4} {:>10.4} {:>10.3} {:>8.0}",
                    if side == "pl2map" { *title } else { "" },
                    side,
                    m[0],
                    m[1],
                    m[2],
                    m[3]
                )
            };
            row("pl2map", &a);
            match &python {
                None => stage::outln!(
                    "{:<42} poselib skipped: no --python and no PL2MAP_PYTHON",
                    ""
                ),
                Some(py) => match poselib(py, &dir, key, &problems, &opt, args.repeats) {
                    Ok(p) => {
                        let b = medians(&p);
                        row("poselib", &b);
                        stage::outln!(
                            "{:<42} {:<8} {:>10.3} {:>10.3} {:>10.3} {:>8.3}",
                            "",
                            "ratio",
                            a[0] / b[0],
                            a[1] / b[1],
                            a[2] / b[2],
                            a[3] / b[3]
                        );
                    }
                    Err(e) => stage::outln!("{:<42} poselib skipped: {e:#}", ""),
                },
            }
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&dir);
    result
}
