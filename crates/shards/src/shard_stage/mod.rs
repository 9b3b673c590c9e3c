//! The shard stage: frames table + label tables -> MCAP shards and their manifest
//! (docs/formats.md section 4), written by this crate's writer.
//!
//! Training frames go into `train-<k>.mcap` shards with their labels, the camera and
//! pose of the label tables (the ones the labels were made with). Test frames go, in
//! the same run, into separate `test-<k>.mcap` shards with the frames table's camera and
//! ground-truth pose and no labels: real datasets have no SfM labels for them, and the
//! score stage then reads its queries (image, camera, pose) from shards like the trainer
//! does, with the split of every frame recorded inside. A shard never mixes splits.
//!
//! One plan covers both: shards `0..T` are the training shards, `T..T+S` the test
//! shards (`frames_per_shard` frames each, the last of a split fewer). A work unit writes
//! a range of that plan (`--shards a..b`) and its manifest `manifest.<a>-<b>.json`; when
//! the unit manifests in the folder cover the whole plan they are merged into
//! `manifest.json` and `stage.json` is written, exactly as a single run over all shards
//! writes them. Image files go in byte for byte (their sha256 must still be the frames
//! table's content hash). A rerun whose record (or unit manifest) matches is skipped;
//! a killed run leaves only complete shard files, and a rerun rewrites the same bytes.
//!
//! When the inputs did change (frames added for a nightly warm start, new labels), each
//! shard is rewritten only if its own frames did: every written shard gets a source
//! digest file (`crate::SourceDigest`, over its frames' label messages and image hashes),
//! and a shard whose digest is unchanged and whose bytes are intact is kept.
//!
//! This file holds the stage's configuration, plan and run; what goes into a frame's
//! record is `source.rs`, the work units' manifests (checking and merging them) are
//! `units.rs`, and the stage's error and file names are `error.rs` and `names.rs`.

mod checked;
mod error;
mod names;
mod source;
mod units;

pub use checked::{checked_manifest, recorded_manifest};
pub use error::ShardStageError;
pub use names::{MANIFEST_FILE, STAGE, TEST_PREFIX, TRAIN_PREFIX};

use crate::{FrameRecord, Manifest, ShardConfig, ShardJob, ShardPlan, plan_shards, write_shards};
use fileio::IoError;
use serde::{Deserialize, Serialize};
use source::{Source, ranges_by_frame};
use stage::{Done, RecordCheck, Stage};
use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;
use std::path::Path;
use tables::frames::FRAMES_STAGE;
use tables::labels::{LABEL_FILES, LABEL_STAGES};
use tables::{FramesTable, LabelTables, Split};
use units::{finish_if_complete, load_manifest, save_record, unit_manifest_name, unit_up_to_date};

/// The shard stage's configuration: `[shard]` of a pipeline file and the flags of
/// `pl2map shard`, the only place its settings and defaults live.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct ShardStageConfig {
    /// Frames per shard file (the last shard of a split may hold fewer).
    #[arg(long, default_value_t = ShardStageConfig::default().frames_per_shard)]
    pub frames_per_shard: usize,
    /// Target uncompressed chunk size in bytes: a chunk is closed after the message
    /// that crosses it. Smaller chunks make seeking cheaper, larger ones compress better.
    #[arg(long, default_value_t = ShardStageConfig::default().chunk_size)]
    pub chunk_size: u64,
    /// zstd level of the chunks (1-22).
    #[arg(long, default_value_t = ShardStageConfig::default().zstd_level)]
    pub zstd_level: u32,
    /// Also write the test frames, into their own shards (see the module docs).
    #[arg(long, default_value_t = ShardStageConfig::default().include_test, action = clap::ArgAction::Set)]
    pub include_test: bool,
}

impl Default for ShardStageConfig {
    fn default() -> Self {
        let writer = ShardConfig::default();
        ShardStageConfig {
            frames_per_shard: writer.frames_per_shard,
            chunk_size: writer.chunk_size,
            zstd_level: writer.zstd_level,
            include_test: true,
        }
    }
}

impl ShardStageConfig {
    /// What the writer needs.
    pub fn writer(&self) -> ShardConfig {
        ShardConfig {
            frames_per_shard: self.frames_per_shard,
            chunk_size: self.chunk_size,
            zstd_level: self.zstd_level,
        }
    }

    /// Refuses values no shard can be written with, before anything is read.
    pub fn validate(&self) -> Result<(), ShardStageError> {
        if self.frames_per_shard == 0 {
            return Err(ShardStageError::Config(
                "frames_per_shard must be at least 1".into(),
            ));
        }
        if !(1..=22).contains(&self.zstd_level) {
            return Err(ShardStageError::Config(format!(
                "zstd_level must be in 1..=22, got {}",
                self.zstd_level
            )));
        }
        if self.chunk_size == 0 {
            return Err(ShardStageError::Config(
                "chunk_size must be at least 1".into(),
            ));
        }
        Ok(())
    }
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct ShardOutput {
    /// The manifest of the shards this run covers (the whole run's when complete).
    pub manifest: Manifest,
    /// Whether `manifest.json` (all planned shards) exists after this run.
    pub complete: bool,
    /// The work unit this run wrote (`--shards a..b`), None for the whole plan.
    pub range: Option<Range<usize>>,
    /// Plan indexes of the shards kept as they were: their source digest (the frames,
    /// labels and images they are made of) did not change since they were written.
    pub reused: Vec<usize>,
}

impl stage::Note for ShardOutput {
    fn note(&self) -> String {
        let m = &self.manifest;
        let mut note = format!(
            "{} shards, {} frames",
            m.shards.len(),
            m.shards.iter().map(|s| s.frame_count).sum::<u64>()
        );
        if !self.reused.is_empty() {
            note = format!(
                "{note}; {} kept (frames unchanged), {} written",
                self.reused.len(),
                m.shards.len() - self.reused.len()
            );
        }
        if let Some(r) = &self.range {
            let state = if self.complete {
                "the set is complete"
            } else {
                "other units pending"
            };
            note = format!("unit {}..{}: {note}; {state}", r.start, r.end);
        }
        note
    }
}

/// The whole run's plan: training shards, then test shards.
pub fn plan(
    frames: &FramesTable,
    config: &ShardStageConfig,
) -> Result<Vec<ShardPlan>, ShardStageError> {
    let ids = |split| -> Vec<u64> {
        frames
            .frames
            .iter()
            .filter(|f| f.split == split)
            .map(|f| u64::from(f.id))
            .collect()
    };
    let fps = config.frames_per_shard;
    let mut out: Vec<ShardPlan> = plan_shards(&ids(Split::Train), fps)?
        .into_iter()
        .map(|mut p| {
            p.file_name = format!("{TRAIN_PREFIX}{:05}.mcap", p.index);
            p
        })
        .collect();
    if config.include_test {
        let offset = out.len();
        out.extend(
            plan_shards(&ids(Split::Test), fps)?
                .into_iter()
                .map(|mut p| {
                    p.file_name = format!("{TEST_PREFIX}{:05}.mcap", p.index);
                    p.index += offset;
                    p
                }),
        );
    }
    Ok(out)
}

/// The shards of a manifest that hold one split (by file name, see the module docs).
pub fn shards_of_split(manifest: &Manifest, split: Split) -> Vec<&crate::ManifestShard> {
    let prefix = match split {
        Split::Train => TRAIN_PREFIX,
        Split::Test => TEST_PREFIX,
    };
    manifest
        .shards
        .iter()
        .filter(|s| s.file.starts_with(prefix))
        .collect()
}

/// Writes shards `range` of the run's plan (None: all) into `out`.
pub fn run(
    config: &ShardStageConfig,
    frames_path: &Path,
    labels_dir: &Path,
    out: &Path,
    range: Option<Range<usize>>,
) -> Result<Done<ShardOutput>, ShardStageError> {
    let start = std::time::Instant::now();
    let (output, skipped) = run_unit(config, frames_path, labels_dir, out, range)?;
    Ok(Done {
        output,
        skipped,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn run_unit(
    config: &ShardStageConfig,
    frames_path: &Path,
    labels_dir: &Path,
    out: &Path,
    range: Option<Range<usize>>,
) -> Result<(ShardOutput, bool), ShardStageError> {
    config.validate()?;
    // The tables only as their stages recorded them: not what a refused or killed run
    // left, nor a file changed afterwards (crates/stage/src/record.rs).
    let frames_sha256 = stage::recorded_file(frames_path, &[FRAMES_STAGE])?;
    let label_record = stage::recorded_outputs(labels_dir, &LABEL_STAGES, &LABEL_FILES)?;
    let frames = FramesTable::read_parquet(frames_path)?;
    let labels = LabelTables::read(labels_dir)?;
    labels.require_frames(frames_path, &frames_sha256)?;
    let train_ids: BTreeSet<u32> = frames
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .map(|f| f.id)
        .collect();
    let labelled: BTreeSet<u32> = labels.poses.iter().map(|p| p.frame_id).collect();
    if train_ids != labelled {
        return Err(ShardStageError::LabelsDontMatch {
            missing: train_ids.difference(&labelled).copied().collect(),
            extra: labelled.difference(&train_ids).copied().collect(),
        });
    }

    let plans = plan(&frames, config)?;
    let count = plans.len();
    let range = range.unwrap_or(0..count);
    if range.start > range.end || range.end > count {
        return Err(ShardStageError::Range {
            start: range.start,
            end: range.end,
            count,
        });
    }
    let full = range == (0..count);
    let unit = (!full).then(|| range.clone());
    let mut inputs = BTreeMap::from([("frames".to_string(), frames_sha256)]);
    // Checked by `recorded_outputs`: the record lists each table with its hash now.
    for f in LABEL_FILES {
        inputs.insert(format!("labels/{f}"), label_record.outputs[f].clone());
    }
    // Work units write disjoint shards of one folder side by side: they share it, and
    // a whole run waits for them (and they for it).
    let mode = if full {
        stage::GuardMode::Exclusive
    } else {
        stage::GuardMode::Shared
    };
    let stage = Stage::with_guard(STAGE, out, config, inputs.clone(), mode)?;
    let config_hash = stage.config_hash().to_string();
    let expected = Manifest {
        format_version: crate::SHARD_FORMAT_VERSION,
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        config_hash: config_hash.clone(),
        inputs: inputs.clone(),
        line_tracks: labels.line_tracks.clone(),
        planned_shards: count,
        planned_frames: plans.iter().map(|p| p.frame_ids.len() as u64).sum(),
        shards: Vec::new(),
    };

    // Skip when this unit (or the whole run) is recorded and intact.
    if stage.check()? == RecordCheck::UpToDate
        && let Some(whole) = load_manifest(&out.join(MANIFEST_FILE))?
    {
        let shards = whole
            .shards
            .iter()
            .filter(|s| range.contains(&s.index))
            .cloned()
            .collect();
        return Ok((
            ShardOutput {
                manifest: Manifest { shards, ..whole },
                complete: true,
                range: unit.clone(),
                reused: Vec::new(),
            },
            true,
        ));
    }
    if !full
        && let Some(m) = load_manifest(&out.join(unit_manifest_name(&range)))?
        && unit_up_to_date(&m, out, &expected)?
    {
        let complete = finish_if_complete(&stage, &expected)?;
        return Ok((
            ShardOutput {
                manifest: m,
                complete,
                range: unit.clone(),
                reused: Vec::new(),
            },
            true,
        ));
    }

    // From here on the folder claims nothing: no record, no whole-run manifest.
    drop(stage.begin()?);
    remove_file(&out.join(MANIFEST_FILE))?;

    let point_ranges = ranges_by_frame(labels.points.iter().map(|r| r.frame_id));
    let line_ranges = ranges_by_frame(labels.lines.iter().map(|r| r.frame_id));
    let source = Source {
        frames: frames.frames.iter().map(|f| (u64::from(f.id), f)).collect(),
        labels: &labels,
        train: labels
            .poses
            .iter()
            .enumerate()
            .map(|(i, p)| {
                (
                    u64::from(p.frame_id),
                    (
                        i,
                        point_ranges.get(&p.frame_id).cloned().unwrap_or(0..0),
                        line_ranges.get(&p.frame_id).cloned().unwrap_or(0..0),
                    ),
                )
            })
            .collect(),
    };
    let writer = config.writer();
    let digests = source.digests(&plans, &writer)?;
    let job = ShardJob {
        out_dir: out,
        plans: &plans,
        config: &writer,
        config_hash: config_hash.clone(),
        inputs: inputs.clone(),
        digests: Some(&digests),
    };
    let load = |id: u64| -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        source.load(id).map_err(|e| Box::new(e) as _)
    };
    let crate::WriteOutcome {
        mut manifest,
        reused,
    } = write_shards(&job, range.clone(), &load)?;
    manifest.line_tracks = labels.line_tracks.clone();
    let complete = if full {
        manifest.save(out.join(MANIFEST_FILE))?;
        save_record(&stage, &manifest)?;
        true
    } else {
        manifest.save(out.join(unit_manifest_name(&range)))?;
        finish_if_complete(&stage, &expected)?
    };
    Ok((
        ShardOutput {
            manifest,
            complete,
            range: unit,
            reused,
        },
        false,
    ))
}

fn remove_file(path: &Path) -> Result<(), ShardStageError> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(IoError::new(path, source).into()),
    }
}
