//! The score stage as a recorded stage: [`run`] scores a shard folder into a stage
//! folder through the stage runner, so `pl2map score` alone and `pl2map run` record the
//! same `stage.json` and skip the same way.
//!
//! Inputs (hashed into the record): the shards the localiser reads (`shard/<file>` ->
//! sha256, from the shard folder's manifest) and the model (`model`), or `oracle` for
//! the label correspondences. The configuration hash covers the resolved
//! [`ScoreConfig`] (every RANSAC setting), so a changed default reruns the stage.

use crate::error::ScoreError;
use crate::evaluate::ScoreConfig;
use crate::localiser::Localiser;
use crate::oracle::OracleLocaliser;
use crate::scoring::{SUMMARY_JSON_FILE, score_shards_with_visual};
use crate::summary::Summary;
use serde::{Deserialize, Serialize};
use shards::Split;
use stage::{Done, Stage};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const STAGE: &str = "score";

/// The score stage's settings: `[score]` of a pipeline file and the flags of
/// `pl2map score`. Defaults: the reference evaluation's (docs/method.md section 6), taken
/// from [`ScoreConfig::default`] and `pose::RansacOptions::default`, where they live.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct ScoreStageConfig {
    /// Keep points predicted with at least this reliability.
    #[arg(long, default_value_t = ScoreStageConfig::default().min_point_reliability)]
    pub min_point_reliability: f64,
    /// Keep lines predicted with at least this reliability.
    #[arg(long, default_value_t = ScoreStageConfig::default().min_line_reliability)]
    pub min_line_reliability: f64,
    /// RANSAC inlier threshold on point reprojection errors, pixels.
    #[arg(long, default_value_t = ScoreStageConfig::default().point_threshold_px)]
    pub point_threshold_px: f64,
    /// RANSAC inlier threshold on line errors (the sum of both endpoint distances),
    /// pixels.
    #[arg(long, default_value_t = ScoreStageConfig::default().line_threshold_px)]
    pub line_threshold_px: f64,
    /// RANSAC seed (mixed with each frame id: same inputs and seed, same poses).
    #[arg(long, default_value_t = ScoreStageConfig::default().seed)]
    pub seed: u64,
    /// RANSAC iterations at most (None: PoseLib's default, 100000). A weak model leaves
    /// few inliers and RANSAC runs to this cap: lower it for quick looks.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[arg(long)]
    pub max_iterations: Option<usize>,
    /// Also write `visual.mcap` (every test frame's image, estimated and ground-truth
    /// cameras, predicted points and lines, for Foxglove). Off by default: the other
    /// outputs and the record are the same either way.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    #[arg(long)]
    pub visual: bool,
    /// Test images' segments from a LIMAP-format folder (`image_list.txt` and
    /// `segments_<id>.txt`: the map's line detector run on the queries) instead of the
    /// front-end's line detector (query_lines.rs).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[arg(long)]
    pub query_segments: Option<PathBuf>,
    /// `query_segments` coordinates times this are pixels (LIMAP detects on images
    /// resized to `max_image_dim`).
    #[serde(skip_serializing_if = "is_default_scale")]
    #[arg(long, default_value_t = ScoreStageConfig::default().query_segment_scale)]
    pub query_segment_scale: f64,
    /// Where the network runs: `cpu`, `cuda` or `cuda:N` (builds with the `cuda`
    /// feature), whatever device trained it (SuperPoint too; SIFT, LSD and RANSAC run on
    /// the CPU).
    #[cfg(feature = "network")]
    #[serde(skip_serializing_if = "train::Device::is_cpu")]
    #[arg(long, default_value_t = ScoreStageConfig::default().device)]
    pub device: train::Device,
}

/// The default scale is left out of the record: a stage run without the option records
/// the same hash as before it existed.
fn is_default_scale(v: &f64) -> bool {
    *v == ScoreStageConfig::default().query_segment_scale
}

impl Default for ScoreStageConfig {
    /// The evaluation's settings are [`ScoreConfig::default`]'s (the reliability
    /// filters) and `pose::RansacOptions::default`'s (thresholds, seed, iterations).
    fn default() -> Self {
        let score = ScoreConfig::default();
        ScoreStageConfig {
            min_point_reliability: score.min_point_reliability,
            min_line_reliability: score.min_line_reliability,
            point_threshold_px: score.ransac.point_threshold_px,
            line_threshold_px: score.ransac.line_threshold_px,
            seed: score.ransac.seed,
            max_iterations: None,
            visual: false,
            query_segments: None,
            query_segment_scale: 1.0,
            #[cfg(feature = "network")]
            device: train::Device::Cpu,
        }
    }
}

impl ScoreStageConfig {
    /// The resolved configuration of every frame's evaluation.
    pub fn resolve(&self) -> ScoreConfig {
        ScoreConfig::with_ransac(
            self.min_point_reliability,
            self.min_line_reliability,
            self.point_threshold_px,
            self.line_threshold_px,
            self.seed,
            self.max_iterations,
        )
    }
}

/// Where the correspondences come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Source {
    /// A trained network (`model.ckpt` of the train stage): scores the test frames.
    Network(PathBuf),
    /// The shard labels: scores the training frames (an upper bound, a check of the
    /// solvers).
    Oracle,
}

/// What the stage holds.
#[derive(Clone, Debug)]
pub struct ScoreStageOutput {
    pub summary: Summary,
    /// The run's output when it ran (None when it was up to date).
    pub run: Option<crate::scoring::ScoreOutput>,
}

impl stage::Note for ScoreStageOutput {
    fn note(&self) -> String {
        self.summary.line()
    }
}

/// The shards of `split` listed in the folder's manifest, as record inputs
/// (`shard/<file>` -> sha256). The manifest is the one the shard stage recorded; the
/// shards themselves are hashed once, by [`crate::scoring::shard_paths`], when the
/// stage reads them.
fn shard_inputs(shards_dir: &Path, split: Split) -> Result<BTreeMap<String, String>, ScoreError> {
    let path = shards_dir.join(shards::MANIFEST_FILE);
    let manifest = shards::recorded_manifest(shards_dir).map_err(|e| ScoreError::Manifest {
        path: path.clone(),
        reason: e.to_string(),
    })?;
    Ok(shards::shards_of_split(&manifest, split)
        .into_iter()
        .map(|s| (format!("shard/{}", s.file), s.sha256.clone()))
        .collect())
}

/// Scores the shards of `shards_dir` into `out` unless its record matches.
pub fn run(
    config: &ScoreStageConfig,
    shards_dir: &Path,
    source: &Source,
    out: &Path,
) -> Result<Done<ScoreStageOutput>, ScoreError> {
    let resolved = config.resolve();
    resolved.validate()?;
    // Before anything is read or written.
    #[cfg(feature = "network")]
    config
        .device
        .check_usable()
        .map_err(|e| ScoreError::Model {
            reason: e.to_string(),
        })?;
    let (split, source_hash) = match source {
        Source::Network(model) => (Split::Test, stage::sha256_file(model)?),
        Source::Oracle => (Split::Train, "oracle".to_string()),
    };
    let mut inputs = shard_inputs(shards_dir, split)?;
    inputs.insert("model".into(), source_hash);
    // Read before the record check: the segments' content is an input of the record.
    let query_segments = match &config.query_segments {
        Some(dir) => {
            let q = crate::query_lines::QuerySegments::load(dir, config.query_segment_scale)?;
            inputs.insert("query_segments".into(), q.sha256.clone());
            Some(q)
        }
        None => None,
    };
    // The record's configuration is the resolved one, with `visual` only when on and
    // the device only when not the CPU: a stage run without them records the same hash
    // as before the options existed.
    #[derive(Serialize)]
    struct Recorded<'a> {
        #[serde(flatten)]
        config: &'a ScoreConfig,
        #[serde(skip_serializing_if = "std::ops::Not::not")]
        visual: bool,
        #[serde(skip_serializing_if = "Option::is_none")]
        device: Option<String>,
    }
    #[cfg(feature = "network")]
    let device = (!config.device.is_cpu()).then(|| config.device.to_string());
    #[cfg(not(feature = "network"))]
    let device = None;
    let stage = if config.visual || device.is_some() {
        Stage::new(
            STAGE,
            out,
            &Recorded {
                config: &resolved,
                visual: config.visual,
                device,
            },
            inputs,
        )?
    } else {
        Stage::new(STAGE, out, &resolved, inputs)?
    };
    stage.run(
        |dir| {
            let summary = Summary::read_json(&dir.join(SUMMARY_JSON_FILE))?;
            Ok(ScoreStageOutput { summary, run: None })
        },
        |outputs| {
            let mut localiser: Box<dyn Localiser> = match source {
                #[cfg(feature = "network")]
                Source::Network(model) => {
                    let mut l = crate::NetworkLocaliser::load_on(model, config.device)?;
                    if let Some(q) = query_segments.clone() {
                        l = l.with_query_segments(q);
                    }
                    Box::new(l)
                }
                #[cfg(not(feature = "network"))]
                Source::Network(model) => {
                    return Err(ScoreError::Network {
                        checkpoint: model.clone(),
                        reason: "this build of the score crate has no network (feature \
                                 `network`)"
                            .into(),
                    });
                }
                Source::Oracle => Box::new(OracleLocaliser),
            };
            let result = score_shards_with_visual(
                shards_dir,
                outputs.dir(),
                localiser.as_mut(),
                &resolved,
                config.visual,
            )?;
            for f in &result.files {
                outputs.add(f)?;
            }
            Ok(ScoreStageOutput {
                summary: result.summary.clone(),
                run: Some(result),
            })
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stage's defaults are the evaluation's and RANSAC's, taken from where they
    /// live: a stage run with no settings scores as `ScoreConfig::default()`.
    #[test]
    fn defaults_resolve_to_the_evaluations() {
        assert_eq!(
            ScoreStageConfig::default().resolve(),
            ScoreConfig::default()
        );
    }
}
