//! The one check every reader of a shard folder goes through (the train stage, the score
//! stage, `pl2map lock`): the folder's `manifest.json` and the shards it lists are what
//! the shard stage recorded, and the manifest covers the whole plan. An edited manifest
//! (a shard dropped from the list), a shard file replaced after the stage ran, or the
//! files a refused run left behind are refused, naming the file and what to run.

use super::names::{MANIFEST_FILE, STAGE};
use crate::{Manifest, ShardError};
use rayon::prelude::*;
use std::path::Path;

/// The manifest of the shard stage's finished run in `dir`, checked (see the module
/// docs): the stage's `stage.json` lists `manifest.json` and every shard with the
/// content hash each file has now, and no planned shard or frame is missing.
pub fn checked_manifest(dir: &Path) -> Result<Manifest, ShardError> {
    let (manifest, record) = recorded_manifest_and_record(dir)?;
    // Every shard as recorded and as it is now, hashed in parallel; the first mismatch
    // in manifest order is reported, whatever the thread count.
    let problems: Vec<Option<String>> = manifest
        .shards
        .par_iter()
        .map(|s| -> Result<Option<String>, ShardError> {
            let file = dir.join(&s.file);
            Ok(match record.outputs.get(&s.file) {
                None => Some(format!("{}: not among the recorded outputs", s.file)),
                Some(recorded) if recorded != &s.sha256 => Some(format!(
                    "{}: the manifest says sha256 {}, the record {recorded}",
                    s.file, s.sha256
                )),
                Some(_) if !file.is_file() => Some(format!("{}: missing", s.file)),
                Some(recorded) => {
                    let now = stage::sha256_file(&file)?;
                    (&now != recorded).then(|| {
                        format!(
                            "{}: changed after the shard stage recorded it (sha256 {now}, \
                             recorded {recorded})",
                            s.file
                        )
                    })
                }
            })
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    if let Some(reason) = problems.into_iter().flatten().next() {
        return Err(stage::StageError::NotRecorded {
            path: dir.join(stage::RECORD_FILE),
            stages: STAGE.to_string(),
            reason,
        }
        .into());
    }
    Ok(manifest)
}

/// The manifest of the shard stage's finished run in `dir`, without reading the shards:
/// the record lists `manifest.json` with its current hash and no planned shard or frame
/// is missing. For a reader that takes the shards' hashes as its record's inputs before
/// it knows whether it will read them (the score stage's skip check); whoever reads the
/// shards goes through [`checked_manifest`].
pub fn recorded_manifest(dir: &Path) -> Result<Manifest, ShardError> {
    Ok(recorded_manifest_and_record(dir)?.0)
}

fn recorded_manifest_and_record(dir: &Path) -> Result<(Manifest, stage::StageRecord), ShardError> {
    let record = stage::recorded_outputs(dir, &[STAGE], &[MANIFEST_FILE])?;
    let path = dir.join(MANIFEST_FILE);
    let manifest = Manifest::load(&path)?;
    let listed: u64 = manifest.shards.iter().map(|s| s.frame_count).sum();
    if !manifest.is_complete() {
        return Err(ShardError::IncompleteManifest {
            path,
            reason: format!(
                "missing shard(s) {:?}, {listed} of {} planned frames listed",
                manifest.missing_shards(),
                manifest.planned_frames
            ),
        });
    }
    Ok((manifest, record))
}
