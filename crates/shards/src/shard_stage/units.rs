//! The shard stage's work units: a unit (`--shards a..b`) records its shards in its own
//! manifest, `manifest.<a>-<b>.json`; a unit manifest counts only when it was made by
//! this run (configuration, inputs, plan) and its shards are intact, and the intact ones
//! are merged into `manifest.json` and the stage record once they cover the whole plan.

use super::error::ShardStageError;
use super::names::MANIFEST_FILE;
use crate::Manifest;
use fileio::IoResultExt;
use stage::{FolderGuard, GuardMode, Stage};
use std::ops::Range;
use std::path::Path;

pub(super) fn unit_manifest_name(range: &Range<usize>) -> String {
    format!("manifest.{}-{}.json", range.start, range.end)
}

pub(super) fn load_manifest(path: &Path) -> Result<Option<Manifest>, ShardStageError> {
    if !path.is_file() {
        return Ok(None);
    }
    Manifest::load(path)
        .map(Some)
        .map_err(|e| ShardStageError::Manifest {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
}

/// Whether a unit manifest describes this run and its shards are intact.
pub(super) fn unit_up_to_date(
    m: &Manifest,
    dir: &Path,
    expected: &Manifest,
) -> Result<bool, ShardStageError> {
    if (
        &m.config_hash,
        &m.inputs,
        &m.tool_version,
        m.format_version,
        m.planned_shards,
        m.planned_frames,
    ) != (
        &expected.config_hash,
        &expected.inputs,
        &expected.tool_version,
        expected.format_version,
        expected.planned_shards,
        expected.planned_frames,
    ) {
        return Ok(false);
    }
    for s in &m.shards {
        let p = dir.join(&s.file);
        if !p.is_file() || stage::sha256_file(&p)? != s.sha256 {
            return Ok(false);
        }
    }
    Ok(true)
}

pub(super) fn save_record(stage: &Stage, manifest: &Manifest) -> Result<(), ShardStageError> {
    let mut outputs = stage.begin()?;
    // The writer hashed every shard as it wrote it.
    for s in &manifest.shards {
        outputs.add_hashed(&s.file, &s.sha256);
    }
    outputs.path(MANIFEST_FILE);
    outputs.finish()?;
    Ok(())
}

/// Merges the unit manifests of this run found in `out`; when they cover the whole
/// plan, writes `manifest.json` and `stage.json`.
/// The lock of the merge step (work units finish side by side).
const MERGE_LOCK_FILE: &str = ".merge.lock";

pub(super) fn finish_if_complete(
    stage: &Stage,
    expected: &Manifest,
) -> Result<bool, ShardStageError> {
    let out = stage.dir();
    // One unit at a time merges the unit manifests and writes the record.
    let _merge = FolderGuard::wait_named(out, MERGE_LOCK_FILE, GuardMode::Exclusive)?;
    let mut names = Vec::new();
    for entry in std::fs::read_dir(out).at(out)? {
        let name = entry.at(out)?.file_name().to_string_lossy().into_owned();
        if name.starts_with("manifest.") && name.ends_with(".json") && name != MANIFEST_FILE {
            names.push(name);
        }
    }
    names.sort();
    let mut units = Vec::new();
    for name in names {
        if let Some(m) = load_manifest(&out.join(&name))?
            && unit_up_to_date(&m, out, expected)?
        {
            units.push(m);
        }
    }
    if units.is_empty() {
        return Ok(false);
    }
    let merged = Manifest::merge(&units)?;
    if !merged.is_complete() {
        return Ok(false);
    }
    merged.save(out.join(MANIFEST_FILE))?;
    save_record(stage, &merged)?;
    Ok(true)
}
