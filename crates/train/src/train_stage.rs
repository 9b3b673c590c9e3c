//! The train stage: trains on the training shards of a shard folder into a stage folder
//! through the stage runner, so `pl2map train` alone and `pl2map run` record the same
//! `stage.json` and skip the same way.
//!
//! Inputs (hashed into the record): every training shard listed by the shard folder's
//! manifest (`shard/<file>` -> sha256) and, for a run that starts from another model
//! ([`TrainStageOptions::init`]), that model (`init`). The configuration hash covers the
//! [`TrainConfig`] after `--iterations`.
//!
//! A folder that is not up to date may hold files of an earlier run:
//! - `checkpoint.ckpt` of an interrupted run of the same configuration and inputs (its
//!   `.train-run.json` says so) is resumed: the resumed run gives the same model, bit for
//!   bit, as an uninterrupted one (trainer tests);
//! - files an earlier recorded run or an earlier interrupted run of this stage wrote
//!   (its `stage.json` or `.train-run.json` names them) are replaced;
//! - a checkpoint nothing here accounts for is refused, naming it (`--resume` continues
//!   it instead).

use crate::checkpoint::{CHECKPOINT_FILE, MODEL_FILE};
use crate::config::TrainConfig;
use crate::error::{TrainError, io_err};
use crate::metrics::METRICS_FILE;
use crate::plot::PLOT_FILE;
use crate::trainer::{CONFIG_FILE, RunOptions, TrainSummary, train};
use serde::{Deserialize, Serialize};
use shards::Split;
use stage::{Done, RecordCheck, Stage, StageRecord};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub const STAGE: &str = "train";
/// The copy of the model a run started from, kept next to what it became (the given
/// file may be `<dir>/model.ckpt` itself, which the run replaces).
pub const INIT_FILE: &str = "warm-start.ckpt";
/// What an unfinished run is: written before the first step, so a rerun recognises its
/// checkpoint (and resumes it) or knows it may replace it.
pub const RUN_FILE: &str = ".train-run.json";
/// A warm-started model the promotion gate did not keep: the folder's `model.ckpt` is
/// then the model the run started from (`pl2map run --warm-start`, docs/operations.md).
pub const REJECTED_FILE: &str = "model.rejected.ckpt";

/// The promotion gate of a warm start: `(new model, model it started from)` -> whether
/// the new one replaces the old. Called after the run, before the stage is recorded.
#[derive(Clone)]
pub struct Gate(pub Arc<GateFn>);

/// `(new model, previous model) -> keep the new one?`, or why it could not decide.
pub type GateFn = dyn Fn(&Path, &Path) -> Result<bool, String> + Send + Sync;

impl std::fmt::Debug for Gate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Gate")
    }
}

/// How to run (what is not part of the configuration).
#[derive(Clone, Debug, Default)]
pub struct TrainStageOptions {
    /// Start from this model's weights (same network; fresh optimiser, the model's
    /// coordinate centre).
    pub init: Option<PathBuf>,
    /// With `init`: do nothing when the model in the folder was trained on exactly the
    /// current training shards (nightly retraining with nothing new).
    pub only_if_new_shards: bool,
    /// Continue the folder's `checkpoint.ckpt` whatever run wrote it.
    pub resume: bool,
    /// Replaces the configuration's iteration count.
    pub iterations: Option<u64>,
    pub progress: bool,
    /// With `init`: decides whether the new model replaces the one it started from; a
    /// model it refuses is kept as [`REJECTED_FILE`] and `model.ckpt` is the old one.
    pub gate: Option<Gate>,
}

/// What the stage holds.
#[derive(Clone, Debug)]
pub struct TrainOutput {
    /// `<dir>/model.ckpt`.
    pub model: PathBuf,
    pub config: TrainConfig,
    pub init: Option<PathBuf>,
    /// The run's summary when it ran (None when it was up to date).
    pub summary: Option<TrainSummary>,
}

impl stage::Note for TrainOutput {
    fn note(&self) -> String {
        let c = &self.config;
        match &self.init {
            Some(i) => format!(
                "warm start from {}: {} iterations, seed {}",
                i.display(),
                c.iterations,
                c.seed
            ),
            None => format!("{} iterations, seed {}", c.iterations, c.seed),
        }
    }
}

/// The shards of one split listed in a shard folder's manifest, as paths and as record
/// inputs (`shard/<file>` -> sha256).
pub fn split_shards(
    shard_dir: &Path,
    split: Split,
) -> Result<(Vec<PathBuf>, BTreeMap<String, String>), TrainError> {
    // The one manifest check of every reader (crates/shards/src/shard_stage/checked.rs).
    let manifest = shards::checked_manifest(shard_dir)?;
    let list = shards::shards_of_split(&manifest, split);
    let paths = list.iter().map(|s| shard_dir.join(&s.file)).collect();
    let inputs = list
        .iter()
        .map(|s| (format!("shard/{}", s.file), s.sha256.clone()))
        .collect();
    Ok((paths, inputs))
}

/// The identity of a run, written to [`RUN_FILE`] before it starts.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct RunIdentity {
    config_hash: String,
    inputs: BTreeMap<String, String>,
}

/// Trains on the training shards of `shard_dir` into `dir` unless its record matches.
pub fn run(
    config: &TrainConfig,
    shard_dir: &Path,
    dir: &Path,
    options: &TrainStageOptions,
) -> Result<Done<TrainOutput>, TrainError> {
    let mut config = config.clone();
    if let Some(n) = options.iterations {
        config.iterations = n;
    }
    // The whole configuration (a CUDA device in a CPU build among it) before anything
    // is read or written.
    config.validate()?;
    // The machine too (driver, GPU index), before anything is written.
    config.device.check_usable()?;
    model::device::explain_gpu_panics(config.device);
    if options.resume {
        // Refused before the folder's record is touched: a resume under another
        // configuration must not cost the finished run its record.
        let ckpt = dir.join(CHECKPOINT_FILE);
        let ck = crate::checkpoint::CheckpointFile::read(&ckpt)?;
        crate::trainer::resumed_config(&ck.header.config, config.clone(), &ckpt)?;
    }
    let (paths, shard_inputs) = split_shards(shard_dir, Split::Train)?;
    let model = dir.join(MODEL_FILE);
    let output = |summary| TrainOutput {
        model: model.clone(),
        config: config.clone(),
        init: options.init.clone(),
        summary,
    };
    let start = std::time::Instant::now();
    if options.init.is_some()
        && options.only_if_new_shards
        && trained_on_these_shards(dir, &shard_inputs)
    {
        return Ok(Done {
            output: output(None),
            skipped: true,
            seconds: start.elapsed().as_secs_f64(),
        });
    }
    let mut inputs = shard_inputs;
    let init_bytes = match &options.init {
        Some(p) => {
            // Checked before anything is written, so that an error names the file the
            // user gave, not the copy the stage keeps.
            crate::trainer::init_checkpoint(p, &config)?;
            let bytes = std::fs::read(p).map_err(io_err(p))?;
            inputs.insert("init".into(), stage::sha256_bytes(&bytes));
            Some(bytes)
        }
        None => None,
    };
    // The SuperPoint weights are an input like the shards: another file under the same
    // path trains again.
    if let Some(sha256) = superpoint::weights_sha256(&config.front_end)? {
        inputs.insert("superpoint_weights".into(), sha256);
    }
    let stage = Stage::new(STAGE, dir, &config.for_record(), inputs)?;
    match stage.check()? {
        RecordCheck::UpToDate => {
            return Ok(Done {
                output: output(None),
                skipped: true,
                seconds: start.elapsed().as_secs_f64(),
            });
        }
        RecordCheck::Missing => {}
        RecordCheck::Changed(why) => tracing::info!("train: rerunning ({why})"),
    }
    if paths.is_empty() {
        return Err(TrainError::Config(format!(
            "{} lists no training shards",
            shard_dir.join(shards::MANIFEST_FILE).display()
        )));
    }
    let identity = RunIdentity {
        config_hash: stage.config_hash().to_string(),
        inputs: stage.inputs().clone(),
    };
    let resume = options.resume || clear_earlier_run(&stage, &identity)?;
    let mut outputs = stage.begin()?;
    let run_file = dir.join(RUN_FILE);
    let identity_json = serde_json::to_vec_pretty(&identity)
        .map_err(|e| TrainError::Config(format!("encoding {}: {e}", run_file.display())))?;
    stage::write_atomic(&run_file, &identity_json)?;
    let init = match init_bytes {
        Some(bytes) => {
            outputs.write(INIT_FILE, &bytes)?;
            Some(dir.join(INIT_FILE))
        }
        None => None,
    };
    let run_options = RunOptions {
        out_dir: dir.to_path_buf(),
        resume,
        init: if resume { None } else { init },
        iterations: None,
        progress: options.progress,
        stop_after: None,
    };
    let summary = match train(config.clone(), &paths, &run_options) {
        Ok(s) => s,
        Err(e) => {
            // The copy of the starting model belongs to this run only: a failed run
            // leaves no copy a later run could take for its own.
            if run_options.init.is_some() {
                remove_if_exists(&dir.join(INIT_FILE))?;
            }
            return Err(e);
        }
    };
    if summary.model.is_none() {
        return Err(TrainError::Config(format!(
            "the run in {} wrote no model",
            dir.display()
        )));
    }
    if let (Some(gate), Some(_)) = (&options.gate, &options.init)
        && !promote(gate, dir)?
    {
        outputs.path(REJECTED_FILE);
    }
    for f in [MODEL_FILE, CHECKPOINT_FILE, METRICS_FILE, CONFIG_FILE] {
        outputs.path(f);
    }
    if summary.plot.is_some() {
        outputs.path(PLOT_FILE);
    }
    outputs.finish()?;
    remove_if_exists(&run_file)?;
    Ok(Done {
        output: output(Some(summary)),
        skipped: false,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Runs the gate on the folder's new model and the copy of the model it started from;
/// when the gate keeps the old one, the new one becomes [`REJECTED_FILE`] and the old one
/// `model.ckpt` again. Returns whether the new one was kept.
fn promote(gate: &Gate, dir: &Path) -> Result<bool, TrainError> {
    let (model, previous) = (dir.join(MODEL_FILE), dir.join(INIT_FILE));
    let keep_new = (gate.0)(&model, &previous)
        .map_err(|e| TrainError::Config(format!("promotion gate: {e}")))?;
    remove_if_exists(&dir.join(REJECTED_FILE))?;
    if !keep_new {
        let rejected = dir.join(REJECTED_FILE);
        std::fs::rename(&model, &rejected).map_err(io_err(&rejected))?;
        let bytes = std::fs::read(&previous).map_err(io_err(&previous))?;
        stage::write_atomic(&model, &bytes)?;
    }
    Ok(keep_new)
}

/// Decides what to do with the files of an earlier run before a fresh one; returns
/// whether the folder's checkpoint is an interrupted run of this very run (resume it).
fn clear_earlier_run(stage: &Stage, identity: &RunIdentity) -> Result<bool, TrainError> {
    let dir = stage.dir();
    let checkpoint = dir.join(CHECKPOINT_FILE);
    let earlier: Option<RunIdentity> = std::fs::read(dir.join(RUN_FILE))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok());
    if checkpoint.is_file() && earlier.as_ref() == Some(identity) {
        tracing::info!("train: resuming the interrupted run in {}", dir.display());
        return Ok(true);
    }
    // Files this stage wrote before (recorded, or of an interrupted run of this stage).
    let recorded = stage.previous().filter(|r| r.stage == STAGE);
    let ours =
        |f: &str| earlier.is_some() || recorded.as_ref().is_some_and(|r| r.outputs.contains_key(f));
    for f in [CHECKPOINT_FILE, MODEL_FILE] {
        let p = dir.join(f);
        if !p.exists() {
            continue;
        }
        if ours(f) {
            remove_if_exists(&p)?;
        } else {
            return Err(TrainError::Config(format!(
                "{} exists and no record of this folder says which run wrote it: pass \
                 --resume to continue it, or use another folder",
                p.display()
            )));
        }
    }
    Ok(false)
}

/// Whether `dir` holds an intact trained model whose record lists exactly these
/// training shards (whatever its configuration or starting model was).
fn trained_on_these_shards(dir: &Path, shards: &BTreeMap<String, String>) -> bool {
    let Ok(Some(rec)) = StageRecord::load(dir) else {
        return false;
    };
    let recorded: BTreeMap<String, String> = rec
        .inputs
        .iter()
        .filter(|(k, _)| k.starts_with("shard/"))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    if &recorded != shards {
        return false;
    }
    let check = StageRecord::check(dir, STAGE, &rec.config_hash, &rec.inputs);
    matches!(check, Ok(RecordCheck::UpToDate))
}

fn remove_if_exists(path: &Path) -> Result<(), TrainError> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(io_err(path)(e).into()),
    }
}
