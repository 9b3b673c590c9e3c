//! Training and scoring as recorded stages. `train::train` and `score::run` keep no
//! `stage.json` of their own (`pl2map train` / `pl2map score` are one-off commands), so
//! the pipeline keeps one in `<work>/train/` and `<work>/score/`: the configuration's
//! hash and the content hashes of what they read (the shards, by the shard manifest's
//! sha256, and the model), so a second run skips them and a change retrains / rescores.

use crate::error::{PipelineError, Result, io_err, stage_err};
use datasets::frames::Split;
use serde::{Deserialize, Serialize};
use stage::{RecordCheck, StageRecord};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `stage::record::RECORD_FILE` (not exported by the stage crate).
const RECORD_FILE: &str = "stage.json";

/// `pl2map score` options (the network localiser on the test shards).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScoreSection {
    pub min_point_reliability: f64,
    pub min_line_reliability: f64,
    /// RANSAC inlier thresholds, pixels (points: reprojection error; lines: the sum of
    /// both endpoint distances).
    pub point_threshold_px: f64,
    pub line_threshold_px: f64,
    pub seed: u64,
    /// RANSAC iteration cap (None: the localiser's default). A weak model makes every
    /// frame run to it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_iterations: Option<usize>,
}

impl Default for ScoreSection {
    fn default() -> Self {
        let c = score::ScoreConfig::default();
        ScoreSection {
            min_point_reliability: c.min_point_reliability,
            min_line_reliability: c.min_line_reliability,
            point_threshold_px: c.ransac.point_threshold_px,
            line_threshold_px: c.ransac.line_threshold_px,
            seed: c.ransac.seed,
            max_iterations: None,
        }
    }
}

impl ScoreSection {
    /// The same configuration `pl2map score` builds from its flags.
    pub fn config(&self) -> score::ScoreConfig {
        score::ScoreConfig::with_ransac(
            self.min_point_reliability,
            self.min_line_reliability,
            self.point_threshold_px,
            self.line_threshold_px,
            self.seed,
            self.max_iterations,
        )
    }
}

/// The shards of one split, as paths and as record inputs (`shard/<file>` -> sha256).
fn split_shards(
    shard_dir: &Path,
    split: Split,
) -> Result<(Vec<PathBuf>, BTreeMap<String, String>)> {
    let path = shard_dir.join(labels::shard::MANIFEST_FILE);
    let manifest = shards::Manifest::load(&path).map_err(|e| PipelineError::Stage {
        stage: "shard",
        message: format!("{}: {e}", path.display()),
    })?;
    let list = labels::shard::shards_of_split(&manifest, split);
    let paths = list.iter().map(|s| shard_dir.join(&s.file)).collect();
    let inputs = list
        .iter()
        .map(|s| (format!("shard/{}", s.file), s.sha256.clone()))
        .collect();
    Ok((paths, inputs))
}

/// Whether `dir`'s record matches; removes a stale record (and `stale` files) if not.
fn up_to_date(
    stage_name: &str,
    dir: &Path,
    config_hash: &str,
    inputs: &BTreeMap<String, String>,
    stale: &[&str],
) -> Result<bool> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let check = match StageRecord::check(dir, stage_name, config_hash, inputs) {
        Err(stage::StageError::Record { .. }) => RecordCheck::Missing,
        other => other?,
    };
    match check {
        RecordCheck::UpToDate => return Ok(true),
        RecordCheck::Missing => {}
        RecordCheck::Changed(why) => tracing::info!("{stage_name}: rerunning ({why})"),
    }
    for f in std::iter::once(RECORD_FILE).chain(stale.iter().copied()) {
        let p = dir.join(f);
        match std::fs::remove_file(&p) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err(&p)(e)),
        }
    }
    Ok(false)
}

fn record(
    stage_name: &str,
    dir: &Path,
    config_hash: String,
    inputs: BTreeMap<String, String>,
    files: &[PathBuf],
) -> Result<()> {
    let mut rec = StageRecord::new(stage_name, config_hash, inputs);
    for f in files {
        let rel = f.strip_prefix(dir).unwrap_or(f);
        if let Some(rel) = rel.to_str() {
            rec.add_output(dir, rel)?;
        }
    }
    rec.save(dir)?;
    Ok(())
}

/// A warm start: the model to continue from and the run's configuration.
#[derive(Clone, Debug)]
pub struct WarmStart {
    pub checkpoint: PathBuf,
    pub config: train::TrainConfig,
}

/// The pipeline's copy of the warm start's model, kept next to what it became (the
/// given file may be `<work>/train/model.ckpt` itself, which the run replaces).
pub const WARM_START_FILE: &str = "warm-start.ckpt";

/// Trains on the training shards of `shard_dir` into `dir` unless the record matches.
/// With `warm`, training starts from its model and runs its configuration, and only
/// when the training shards differ from those the current model in `dir` was trained
/// on (nothing new: nothing to do). Returns (skipped, the model file).
pub fn train(
    config: &train::TrainConfig,
    shard_dir: &Path,
    dir: &Path,
    progress: bool,
    warm: Option<&WarmStart>,
) -> Result<(bool, PathBuf)> {
    let model = dir.join(train::checkpoint::MODEL_FILE);
    let (paths, mut inputs) = split_shards(shard_dir, Split::Train)?;
    let config = warm.map_or(config, |w| &w.config);
    let config_hash = stage::hash_config(config)?;
    // A fresh run refuses a folder holding a checkpoint (it would be another run's).
    let stale = [
        train::checkpoint::CHECKPOINT_FILE,
        train::checkpoint::MODEL_FILE,
    ];
    let mut init = None;
    if let Some(w) = warm {
        if trained_on_these_shards(dir, &inputs)? {
            return Ok((true, model));
        }
        let bytes = std::fs::read(&w.checkpoint).map_err(io_err(&w.checkpoint))?;
        let copy = dir.join(WARM_START_FILE);
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        stage::write_atomic(&copy, &bytes)?;
        inputs.insert("warm_start".into(), stage::sha256_bytes(&bytes));
        init = Some(copy);
    }
    if up_to_date("train", dir, &config_hash, &inputs, &stale)? {
        return Ok((true, model));
    }
    if paths.is_empty() {
        return Err(PipelineError::Stage {
            stage: "train",
            message: format!("{} lists no training shards", shard_dir.display()),
        });
    }
    let options = train::RunOptions {
        out_dir: dir.to_path_buf(),
        progress,
        init: init.clone(),
        ..train::RunOptions::default()
    };
    let s = train::train(config.clone(), &paths, &options).map_err(|e| stage_err("train")(&e))?;
    let Some(model_path) = s.model.clone() else {
        return Err(PipelineError::Stage {
            stage: "train",
            message: format!("the run in {} wrote no model", dir.display()),
        });
    };
    let mut files = vec![model_path, s.checkpoint.clone(), s.metrics.clone()];
    files.extend(s.plot.clone());
    files.extend(init);
    record("train", dir, config_hash, inputs, &files)?;
    Ok((false, model))
}

/// Whether `dir` holds an intact trained model whose record lists exactly these
/// training shards (whatever its configuration or warm start was).
fn trained_on_these_shards(dir: &Path, shards: &BTreeMap<String, String>) -> Result<bool> {
    let Ok(Some(rec)) = StageRecord::load(dir) else {
        return Ok(false);
    };
    let recorded: BTreeMap<String, String> = rec
        .inputs
        .iter()
        .filter(|(k, _)| k.starts_with("shard/"))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    if &recorded != shards {
        return Ok(false);
    }
    let check = StageRecord::check(dir, "train", &rec.config_hash, &rec.inputs);
    Ok(matches!(check, Ok(RecordCheck::UpToDate)))
}

/// Scores `model` on the test shards of `shard_dir` into `dir` unless the record
/// matches. Returns (skipped, summary).
pub fn score(
    section: &ScoreSection,
    shard_dir: &Path,
    model: &Path,
    dir: &Path,
) -> Result<(bool, score::Summary)> {
    let config = section.config();
    let (_, mut inputs) = split_shards(shard_dir, Split::Test)?;
    inputs.insert("model".into(), stage::sha256_file(model)?);
    let config_hash = stage::hash_config(&config)?;
    if up_to_date("score", dir, &config_hash, &inputs, &[])? {
        let path = dir.join(score::run::SUMMARY_JSON_FILE);
        let summary = score::Summary::read_json(&path).map_err(|e| stage_err("score")(&e))?;
        return Ok((true, summary));
    }
    let mut localiser = score::NetworkLocaliser::load(model).map_err(|e| stage_err("score")(&e))?;
    let out =
        score::run(shard_dir, dir, &mut localiser, &config).map_err(|e| stage_err("score")(&e))?;
    record("score", dir, config_hash, inputs, &out.files)?;
    Ok((false, out.summary))
}

/// "points: median .. cm, x % under 5 cm / 5 deg; points + lines: ..." for the run table.
pub(crate) fn summary_line(s: &score::Summary) -> String {
    s.variants
        .iter()
        .map(|v| {
            let acc = v
                .accuracy
                .iter()
                .find(|a| a.cm == 5.0 && a.deg == 5.0)
                .or(v.accuracy.last())
                .map(|a| {
                    format!(
                        "{:.1} % under {} cm / {} deg",
                        100.0 * a.fraction,
                        a.cm,
                        a.deg
                    )
                })
                .unwrap_or_default();
            format!("{}: median {:.1} cm, {acc}", v.variant.label(), v.median_cm)
        })
        .collect::<Vec<_>>()
        .join("; ")
}
