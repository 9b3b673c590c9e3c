//! `pl2map run`: the stages in order into `<work>/<stage>/`. Each stage function checks
//! its own `stage.json` (configuration hash, content hashes of its inputs, intact
//! outputs) and skips itself when it matches, so a changed section reruns its stage, and
//! the stages after it rerun because their inputs' hashes changed.

use crate::config::{Pipeline, STAGES};
use crate::error::{PipelineError, Result, stage_err};
use crate::train_stage::WarmStart;
use crate::{synth_stage, train_stage};
use std::ops::Range;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    Ran,
    /// The record matched.
    Skipped,
    /// Not in this pipeline (no `[synth]`, `[refine]`, `[train]` ...), or after `until`.
    Off(String),
}

#[derive(Clone, Debug)]
pub struct StageReport {
    pub stage: &'static str,
    pub status: Status,
    pub seconds: f64,
    pub dir: PathBuf,
    /// One line on what the stage holds (frames, shards ...).
    pub note: String,
}

#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Last stage to run (one of [`STAGES`]); None: all.
    pub until: Option<String>,
    /// Progress bars (also hidden when stderr is not a terminal).
    pub progress: bool,
    /// Continue training from this model (`[warm_start]` says how long), when the
    /// training shards changed since the model in `<work>/train/` was made.
    pub warm_start: Option<PathBuf>,
    /// A work unit: only these shards of the shard stage's plan; the stages after it
    /// wait for the whole set (the unit that completes it writes `manifest.json`).
    pub shards: Option<Range<usize>>,
}

#[derive(Clone, Debug)]
pub struct RunReport {
    pub stages: Vec<StageReport>,
    /// The score stage's summary (both variants) when that stage ran or was up to date.
    pub score: Option<score::Summary>,
}

impl RunReport {
    pub fn status(&self, stage: &str) -> Option<&Status> {
        self.stages
            .iter()
            .find(|s| s.stage == stage)
            .map(|s| &s.status)
    }

    /// A table a person reads.
    pub fn table(&self) -> String {
        let mut s = format!(
            "{:<8} {:<14} {:>8}  {}\n",
            "stage", "status", "seconds", "notes"
        );
        for r in &self.stages {
            let (status, why) = match &r.status {
                Status::Ran => ("ran", r.note.clone()),
                Status::Skipped => ("up to date", r.note.clone()),
                Status::Off(why) => ("off", why.clone()),
            };
            s.push_str(&format!(
                "{:<8} {:<14} {:>8.1}  {}\n",
                r.stage, status, r.seconds, why
            ));
        }
        let total: f64 = self.stages.iter().map(|r| r.seconds).sum();
        s.push_str(&format!("{:<8} {:<14} {:>8.1}\n", "total", "", total));
        s
    }
}

fn status(skipped: bool) -> Status {
    if skipped {
        Status::Skipped
    } else {
        Status::Ran
    }
}

/// Runs the pipeline's stages in order (up to `options.until`).
pub fn run(p: &Pipeline, options: &RunOptions) -> Result<RunReport> {
    let last = match &options.until {
        Some(u) => STAGES
            .iter()
            .position(|s| s == u)
            .ok_or_else(|| PipelineError::Config {
                path: p.origin.clone(),
                message: format!(
                    "unknown stage {u:?} (expected one of {})",
                    STAGES.join(", ")
                ),
            })?,
        None => STAGES.len() - 1,
    };
    let frames = p.frames_path();
    let mut stages = Vec::new();
    // The score stage's summary, when it ran or was up to date.
    let mut score_summary = None;
    for (i, &stage) in STAGES.iter().enumerate() {
        let dir = p.stage_dir(stage);
        let t = Instant::now();
        let unit_done =
            options.shards.is_some() && i > STAGES.iter().position(|s| *s == "shard").unwrap_or(0);
        let (status, note) = if i > last {
            (
                Status::Off(format!("after --until {}", STAGES[last])),
                String::new(),
            )
        } else if unit_done {
            (
                Status::Off("a --shards work unit ends with its shards".into()),
                String::new(),
            )
        } else {
            match stage {
                "synth" => match &p.synth {
                    Some(s) => {
                        let skipped = synth_stage::run(s, &dir, options.progress)?;
                        let note = if s.tiny {
                            "tiny scene".to_string()
                        } else {
                            format!("{} frames", s.frames)
                        };
                        (status(skipped), format!("{note}, seed {}", s.seed))
                    }
                    None => (Status::Off("inputs from a dataset".into()), String::new()),
                },
                "ingest" => {
                    let out = datasets::ingest::run(&p.ingest, &dir)
                        .map_err(|e| stage_err("ingest")(&e))?;
                    let n = out.table.frames.len();
                    (status(out.skipped), format!("{n} frames"))
                }
                "import" => {
                    let out = labels::import::run(&p.import, &frames, &p.model, &p.limap, &dir)
                        .map_err(|e| stage_err("import")(&e))?;
                    (status(out.skipped), String::new())
                }
                "refine" => match &p.refine {
                    Some(c) => {
                        let out = labels::refine::run(c, &frames, &p.stage_dir("import"), &dir)
                            .map_err(|e| stage_err("refine")(&e))?;
                        (status(out.skipped), String::new())
                    }
                    None => (Status::Off("no [refine]".into()), String::new()),
                },
                "shard" => {
                    let range = options.shards.clone();
                    let out = labels::shard::run(&p.shard, &frames, &p.labels_dir(), &dir, range)
                        .map_err(|e| stage_err("shard")(&e))?;
                    let m = &out.manifest;
                    let mut note = format!(
                        "{} shards, {} frames",
                        m.shards.len(),
                        m.shards.iter().map(|s| s.frame_count).sum::<u64>()
                    );
                    if !out.reused.is_empty() {
                        note = format!(
                            "{note}; {} kept (frames unchanged), {} written",
                            out.reused.len(),
                            m.shards.len() - out.reused.len()
                        );
                    }
                    if let Some(r) = &options.shards {
                        let state = if out.complete {
                            "the set is complete"
                        } else {
                            "other units pending"
                        };
                        note = format!("unit {}..{}: {note}; {state}", r.start, r.end);
                    }
                    (status(out.skipped), note)
                }
                "train" => match &p.file.train {
                    Some(c) => {
                        let warm = options.warm_start.as_ref().map(|ckpt| WarmStart {
                            checkpoint: ckpt.clone(),
                            config: p
                                .file
                                .warm_start
                                .clone()
                                .unwrap_or_default()
                                .train_config(c),
                        });
                        let (skipped, _) = train_stage::train(
                            c,
                            &p.stage_dir("shard"),
                            &dir,
                            options.progress,
                            warm.as_ref(),
                        )?;
                        let note = match &warm {
                            Some(w) => format!(
                                "warm start from {}: {} iterations, seed {}",
                                w.checkpoint.display(),
                                w.config.iterations,
                                w.config.seed
                            ),
                            None => format!("{} iterations, seed {}", c.iterations, c.seed),
                        };
                        (status(skipped), note)
                    }
                    None => (Status::Off("no [train]".into()), String::new()),
                },
                "score" => match &p.file.score {
                    Some(s) => {
                        let model = p.stage_dir("train").join(train::checkpoint::MODEL_FILE);
                        let (skipped, summary) =
                            train_stage::score(s, &p.stage_dir("shard"), &model, &dir)?;
                        let note = train_stage::summary_line(&summary);
                        score_summary = Some(summary);
                        (status(skipped), note)
                    }
                    None => (Status::Off("no [score]".into()), String::new()),
                },
                _ => unreachable!("STAGES lists every stage handled here"),
            }
        };
        let seconds = if matches!(status, Status::Ran | Status::Skipped) {
            t.elapsed().as_secs_f64()
        } else {
            0.0
        };
        tracing::info!("{stage}: {status:?}");
        stages.push(StageReport {
            stage,
            status,
            seconds,
            dir,
            note,
        });
    }
    Ok(RunReport {
        stages,
        score: score_summary,
    })
}
