//! Writing a range of planned shards (one work unit, `--shards a..b`) in parallel, each
//! shard kept when its source digest (`digest.rs`) says it is unchanged.

use crate::digest;
use crate::error::ShardError;
use crate::manifest::{Manifest, ManifestShard};
use crate::plan::ShardPlan;
use crate::record::FrameRecord;
use crate::writer::{SHARD_FORMAT_VERSION, ShardConfig, ShardInfo, write_frames};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

/// Where the writer gets a frame from (the shard stage reads label tables and image
/// files). Called from several threads, once per frame, in increasing frame id order
/// within a shard.
pub trait FrameSource: Sync {
    fn load(&self, frame_id: u64) -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>>;
}

impl<F> FrameSource for F
where
    F: Fn(u64) -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> + Sync,
{
    fn load(&self, frame_id: u64) -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        self(frame_id)
    }
}

/// What a run of the shard stage writes with; the same for every work unit of a run.
#[derive(Clone, Debug)]
pub struct ShardJob<'a> {
    /// Folder of the shard files.
    pub out_dir: &'a Path,
    /// The whole run's plan ([`crate::plan_shards`]).
    pub plans: &'a [ShardPlan],
    pub config: &'a ShardConfig,
    /// Hash of the stage's configuration (e.g. `stage::hash_config`), recorded in the
    /// manifest.
    pub config_hash: String,
    /// Input name -> content hash, recorded in the manifest.
    pub inputs: BTreeMap<String, String>,
    /// Source digest of every planned shard (`digest.rs`), in plan order: a shard whose
    /// digest file under `out_dir` names the same digest, and is intact, is kept as it
    /// is; written shards get their digest file. None: write every shard, no digests.
    pub digests: Option<&'a [String]>,
}

/// What [`write_shards`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WriteOutcome {
    pub manifest: Manifest,
    /// Plan indexes of the shards kept from an earlier run (same source digest).
    pub reused: Vec<usize>,
}

/// Writes shards `range` of the plan (one work unit), in parallel on the current
/// rayon pool, each shard streamed from `source` frame by frame. Each file depends
/// only on its frames and the config, so the bytes are the same for any thread
/// count; the manifest lists the shards by index. With digests, unchanged shards are
/// kept (see [`ShardJob::digests`]).
pub fn write_shards(
    job: &ShardJob<'_>,
    range: Range<usize>,
    source: &impl FrameSource,
) -> Result<WriteOutcome, ShardError> {
    let count = job.plans.len();
    let plans = job.plans.get(range.clone()).ok_or(ShardError::ShardRange {
        start: range.start,
        end: range.end,
        count,
    })?;
    if let Some(d) = job.digests
        && d.len() != count
    {
        return Err(ShardError::DigestCount {
            digests: d.len(),
            shards: count,
        });
    }
    let frames_in_range: u64 = plans.iter().map(|p| p.frame_ids.len() as u64).sum();
    let bar = stage::progress_bar(frames_in_range, "shard");
    let digest_of = |plan: &ShardPlan| {
        job.digests
            .and_then(|d| d.get(plan.index))
            .map(String::as_str)
    };
    let written: Vec<(ManifestShard, bool)> = plans
        .par_iter()
        .map(|plan| -> Result<(ManifestShard, bool), ShardError> {
            let digest = digest_of(plan);
            if let Some(d) = digest
                && let Some(kept) = digest::reusable(job.out_dir, plan, d)?
            {
                bar.inc(plan.frame_ids.len() as u64);
                return Ok((kept, true));
            }
            let frames = plan.frame_ids.iter().map(|&id| {
                let f = source.load(id).map_err(|source| ShardError::Source {
                    frame_id: id,
                    source,
                })?;
                if f.frame_id != id {
                    return Err(ShardError::SourceMismatch {
                        expected: id,
                        got: f.frame_id,
                    });
                }
                bar.inc(1);
                Ok(f)
            });
            let info = write_frames(&job.out_dir.join(&plan.file_name), frames, job.config)?;
            let shard = manifest_shard(plan, info);
            if let Some(d) = digest {
                digest::save(job.out_dir, &shard, d)?;
            }
            Ok((shard, false))
        })
        .collect::<Result<_, _>>()?;
    bar.finish_and_clear();
    let reused = written
        .iter()
        .filter(|(_, kept)| *kept)
        .map(|(s, _)| s.index)
        .collect();
    let manifest = Manifest {
        format_version: SHARD_FORMAT_VERSION,
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        config_hash: job.config_hash.clone(),
        inputs: job.inputs.clone(),
        line_tracks: None,
        planned_shards: count,
        planned_frames: job.plans.iter().map(|p| p.frame_ids.len() as u64).sum(),
        shards: written.into_iter().map(|(s, _)| s).collect(),
    };
    Ok(WriteOutcome { manifest, reused })
}

fn manifest_shard(plan: &ShardPlan, info: ShardInfo) -> ManifestShard {
    ManifestShard {
        index: plan.index,
        file: plan.file_name.clone(),
        first_frame: info.first_frame,
        last_frame: info.last_frame,
        frame_count: info.frame_count,
        sha256: info.sha256,
        bytes: info.bytes,
    }
}
