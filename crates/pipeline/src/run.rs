//! `pl2map run`: the stages of [`StageName::ALL`] in order into `<work>/<stage>/`. Each
//! stage function runs through the stage runner (`stage::Stage`): it checks its own
//! `stage.json` (configuration hash, content hashes of its inputs, intact outputs) and
//! skips itself when it matches, so a changed section reruns its stage, and the stages
//! after it rerun because their inputs' hashes changed.

use crate::config::Pipeline;
use crate::error::{PipelineError, Result, stage_err};
use crate::promotion::{self, Kept, PREVIOUS_SCORE_DIR, Promotion};
use crate::stages::StageName;
use stage::{Done, Note};
use std::ops::Range;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

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
    pub stage: StageName,
    pub status: Status,
    pub seconds: f64,
    pub dir: PathBuf,
    /// One line on what the stage holds (frames, shards ...).
    pub note: String,
}

impl StageReport {
    /// The status as the table says it, and its notes (why it is off, else the stage's
    /// own note).
    fn status_and_notes(&self) -> (&'static str, String) {
        match &self.status {
            Status::Ran => ("ran", self.note.clone()),
            Status::Skipped => ("up to date", self.note.clone()),
            Status::Off(why) => ("off", why.clone()),
        }
    }

    fn done<T: Note>(stage: StageName, dir: PathBuf, done: &Done<T>) -> Self {
        StageReport {
            stage,
            status: if done.skipped {
                Status::Skipped
            } else {
                Status::Ran
            },
            seconds: done.seconds,
            dir,
            note: done.output.note(),
        }
    }

    fn off(stage: StageName, dir: PathBuf, why: impl Into<String>) -> Self {
        StageReport {
            stage,
            status: Status::Off(why.into()),
            seconds: 0.0,
            dir,
            note: String::new(),
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Last stage to run; None: all.
    pub until: Option<StageName>,
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
    /// The promotion gate's decision, when a warm start trained a new model.
    pub promotion: Option<Promotion>,
}

impl RunReport {
    pub fn status(&self, stage: StageName) -> Option<&Status> {
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
            let (status, why) = r.status_and_notes();
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

/// Runs the pipeline's stages in order (up to `options.until`).
pub fn run(p: &Pipeline, options: &RunOptions) -> Result<RunReport> {
    // One run per work folder (work units of the shard stage share it).
    let mode = if options.shards.is_some() {
        stage::GuardMode::Shared
    } else {
        stage::GuardMode::Exclusive
    };
    let _guard = stage::FolderGuard::acquire(&p.work, mode)?;
    if let Some(ckpt) = &options.warm_start
        && !ckpt.is_file()
    {
        return Err(PipelineError::Config {
            path: p.origin.clone(),
            message: format!("--warm-start {}: no such file", ckpt.display()),
        });
    }
    let last = options.until.unwrap_or(StageName::Score);
    let mut stages = Vec::new();
    // The score stage's summary, when it ran or was up to date.
    let mut score_summary = None;
    let decision: Arc<Mutex<Option<Promotion>>> = Arc::default();
    for stage in StageName::ALL {
        let dir = p.stage_dir(stage);
        let report = if stage > last {
            StageReport::off(stage, dir, format!("after --until {last}"))
        } else if options.shards.is_some() && stage > StageName::Shard {
            StageReport::off(stage, dir, "a --shards work unit ends with its shards")
        } else {
            let r = run_stage(p, stage, dir, options, &mut score_summary, &decision)?;
            let (status, notes) = r.status_and_notes();
            tracing::info!("{stage}: {status}, {notes}");
            r
        };
        stages.push(report);
    }
    let promotion = decision.lock().unwrap_or_else(|p| p.into_inner()).take();
    if let Some(d) = &promotion {
        tracing::info!("{}", d.verdict());
    }
    Ok(RunReport {
        stages,
        score: score_summary,
        promotion,
    })
}

/// The promotion gate of a warm start (None without `[score]`): scores the new model
/// into `<work>/score` and the previous one into `<work>/score-previous` with the
/// pipeline's `[score]`, decides (`promotion::decide`) and leaves the decision in
/// `decision` for the run's report.
fn gate(p: &Pipeline, decision: &Arc<Mutex<Option<Promotion>>>) -> Option<train::Gate> {
    let Some(config) = p.file.score.clone() else {
        tracing::warn!("--warm-start without [score]: no promotion gate, the new model is kept");
        return None;
    };
    let shards = p.stage_dir(StageName::Shard);
    let (new_dir, previous_dir) = (
        p.stage_dir(StageName::Score),
        p.work.join(PREVIOUS_SCORE_DIR),
    );
    let decision = Arc::clone(decision);
    Some(train::Gate(Arc::new(move |new, previous| {
        let score = |model: &std::path::Path, out: &std::path::Path| {
            score::score_stage::run(
                &config,
                &shards,
                &score::Source::Network(model.to_path_buf()),
                out,
            )
            .map(|d| d.output.summary)
            .map_err(|e| format!("scoring {}: {e}", model.display()))
        };
        let new = score(new, &new_dir)?;
        let previous = score(previous, &previous_dir)?;
        let (kept, reason) = promotion::decide(&new, &previous);
        let keep_new = kept == Kept::New;
        *decision.lock().unwrap_or_else(|p| p.into_inner()) = Some(Promotion {
            new,
            previous,
            kept,
            reason,
        });
        Ok(keep_new)
    })))
}

/// One stage of `p` into `dir`.
fn run_stage(
    p: &Pipeline,
    stage: StageName,
    dir: PathBuf,
    options: &RunOptions,
    score_summary: &mut Option<score::Summary>,
    decision: &Arc<Mutex<Option<Promotion>>>,
) -> Result<StageReport> {
    let name = stage.as_str();
    let frames = p.frames_path();
    Ok(match stage {
        StageName::Synth => match p.synth() {
            Some(s) => {
                let done = synth::synth_stage::run(s, &dir, options.progress, false)
                    .map_err(|e| stage_err(name)(&e))?;
                StageReport::done(stage, dir, &done)
            }
            None => StageReport::off(stage, dir, "inputs from a dataset"),
        },
        StageName::Ingest => {
            let done =
                datasets::ingest_stage::run(&p.ingest, &dir).map_err(|e| stage_err(name)(&e))?;
            StageReport::done(stage, dir, &done)
        }
        StageName::Import => {
            let done = labels::import_stage::run(&p.import, &frames, &dir, &|c| {
                frontends::build(c).map_err(|e| e.to_string())
            })
            .map_err(|e| stage_err(name)(&e))?;
            StageReport::done(stage, dir, &done)
        }
        StageName::Refine => match p.refine() {
            Some(c) => {
                let done =
                    labels::refine_stage::run(c, &frames, &p.stage_dir(StageName::Import), &dir)
                        .map_err(|e| stage_err(name)(&e))?;
                StageReport::done(stage, dir, &done)
            }
            None => StageReport::off(stage, dir, "no [refine]"),
        },
        StageName::Shard => {
            let done = shards::shard_stage::run(
                p.shard(),
                &frames,
                &p.labels_dir(),
                &dir,
                options.shards.clone(),
            )
            .map_err(|e| stage_err(name)(&e))?;
            StageReport::done(stage, dir, &done)
        }
        StageName::Train => match &p.file.train {
            Some(c) => {
                let (config, init) = match &options.warm_start {
                    Some(ckpt) => (
                        p.file
                            .warm_start
                            .clone()
                            .unwrap_or_default()
                            .train_config(c),
                        Some(ckpt.clone()),
                    ),
                    None => (c.clone(), None),
                };
                let gate = init.as_ref().and_then(|_| gate(p, decision));
                let opts = train::TrainStageOptions {
                    only_if_new_shards: init.is_some(),
                    init,
                    progress: options.progress,
                    gate,
                    ..Default::default()
                };
                let done =
                    train::train_stage::run(&config, &p.stage_dir(StageName::Shard), &dir, &opts)
                        .map_err(|e| stage_err(name)(&e))?;
                StageReport::done(stage, dir, &done)
            }
            None => StageReport::off(stage, dir, "no [train]"),
        },
        StageName::Score => match &p.file.score {
            Some(s) => {
                let model = p
                    .stage_dir(StageName::Train)
                    .join(train::checkpoint::MODEL_FILE);
                let done = score::score_stage::run(
                    s,
                    &p.stage_dir(StageName::Shard),
                    &score::Source::Network(model),
                    &dir,
                )
                .map_err(|e| stage_err(name)(&e))?;
                *score_summary = Some(done.output.summary.clone());
                StageReport::done(stage, dir, &done)
            }
            None => StageReport::off(stage, dir, "no [score]"),
        },
    })
}
