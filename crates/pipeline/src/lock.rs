//! Lock files of reproducible training sets (`manifests/*.toml`): the pipeline sections
//! that make the shards, the content hashes of the inputs (the synthetic scene's files,
//! by folder), of the stage outputs that do not depend on where the work folder is, and
//! every shard as the shard stage's `manifest.json` lists it.
//!
//! `verify` rebuilds synth -> ingest -> import -> (refine) -> shard in a temporary folder
//! and compares hash by hash. Frames and label tables are not locked: they hold
//! absolute paths (and the frames table's hash), so they differ between folders while
//! the shards made from them do not.

use crate::config::{Pipeline, PipelineFile, parse};
use crate::error::{PipelineError, Result};
use crate::run::{RunOptions, run};
use crate::stages::StageName;
use fileio::io_err;
use serde::{Deserialize, Serialize};
use shards::ManifestShard;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Stage outputs that are the same bytes wherever the work folder is.
const PORTABLE_OUTPUTS: [&str; 1] = ["refine/refine_report.json"];

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lock {
    /// pl2map version that wrote the lock (shown, not compared: a new version that
    /// writes the same shards still verifies).
    pub tool_version: String,
    pub shard_format_version: u32,
    pub planned_shards: usize,
    pub planned_frames: u64,
    /// The pipeline the shards are made from; `work` is replaced when verifying.
    pub pipeline: PipelineFile,
    /// Input group (a sequence folder, `sfm_gt/colmap` ...) -> hash of its files.
    pub inputs: BTreeMap<String, String>,
    /// `<stage>/<file>` -> sha256.
    pub outputs: BTreeMap<String, String>,
    pub shards: Vec<ManifestShard>,
}

impl Lock {
    /// Builds the lock of a pipeline whose stages ran up to `shard` in its work folder.
    pub fn collect(p: &Pipeline) -> Result<Lock> {
        let Some(synth) = p.synth() else {
            return Err(PipelineError::Config {
                path: p.origin.clone(),
                message: "only pipelines with [synth] can be locked (their inputs are \
                          rebuilt from the seed)"
                    .into(),
            });
        };
        let synth_dir = p.stage_dir(StageName::Synth);
        let mut groups: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for rel in synth::synth_stage::files_under(&synth_dir, &synth.name)
            .map_err(|e| crate::error::stage_err("synth")(&e))?
        {
            groups.entry(input_group(&rel)).or_default().push(rel);
        }
        let mut inputs = BTreeMap::new();
        for (g, files) in &groups {
            inputs.insert(
                g.clone(),
                stage::sha256_files(&synth_dir, files.iter().map(String::as_str))?,
            );
        }
        let mut outputs = BTreeMap::new();
        for rel in PORTABLE_OUTPUTS {
            let path = p.work.join(rel);
            if path.is_file() {
                outputs.insert(rel.to_string(), stage::sha256_file(&path)?);
            }
        }
        // The one manifest check of every reader (crates/shards/src/shard_stage/checked.rs).
        let manifest = shards::checked_manifest(&p.stage_dir(StageName::Shard)).map_err(|e| {
            PipelineError::Stage {
                stage: "shard",
                message: e.to_string(),
            }
        })?;
        let mut pipeline = p.file.clone();
        // Training and scoring do not make the shards: not part of the lock.
        pipeline.train = None;
        pipeline.score = None;
        Ok(Lock {
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
            shard_format_version: manifest.format_version,
            planned_shards: manifest.planned_shards,
            planned_frames: manifest.planned_frames,
            pipeline,
            inputs,
            outputs,
            shards: manifest.shards,
        })
    }

    pub fn read(path: &Path) -> Result<(Lock, String)> {
        let text = std::fs::read_to_string(path).map_err(io_err(path))?;
        Ok((parse::<Lock>(&text, path)?, text))
    }

    /// Writes the lock atomically, with a header saying where it came from.
    pub fn write(&self, path: &Path, source: &str) -> Result<()> {
        let body = toml::to_string(self).map_err(|e| PipelineError::Toml {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let text = format!(
            "# Lock file of {source}: written by `pl2map lock`, checked by `pl2map verify`\n\
             # (rebuilds synth -> ingest -> import -> refine -> shard in a temporary folder\n\
             # and compares every hash). Do not edit by hand.\n\n{body}"
        );
        stage::write_atomic(path, text.as_bytes())?;
        Ok(())
    }
}

/// Inputs are hashed by group so a difference names the folder it is in: the first
/// path component under the scene, two under `sfm_gt/`.
fn input_group(rel: &str) -> String {
    let parts: Vec<&str> = rel.split('/').skip(1).collect();
    match parts.as_slice() {
        [gt, sub, ..] if *gt == synth::gt::GT_DIR => format!("{gt}/{sub}"),
        [first, _, ..] => (*first).to_string(),
        [file] => (*file).to_string(),
        [] => String::new(),
    }
}

/// One compared value.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// input, output, shard or plan.
    pub kind: &'static str,
    pub name: String,
    pub expected: Option<String>,
    pub actual: Option<String>,
}

impl Row {
    pub fn matches(&self) -> bool {
        self.expected == self.actual
    }

    fn describe(&self) -> String {
        let v = |x: &Option<String>| x.clone().unwrap_or_else(|| "missing".into());
        format!(
            "{} {}: expected {}, got {}",
            self.kind,
            self.name,
            v(&self.expected),
            v(&self.actual)
        )
    }
}

#[derive(Clone, Debug)]
pub struct VerifyReport {
    pub manifest: PathBuf,
    pub rows: Vec<Row>,
    pub expected_version: String,
}

impl VerifyReport {
    pub fn differences(&self) -> Vec<String> {
        self.rows
            .iter()
            .filter(|r| !r.matches())
            .map(Row::describe)
            .collect()
    }

    /// Ok when every row matches; otherwise the error lists each difference.
    pub fn check(&self) -> Result<()> {
        let differences = self.differences();
        if differences.is_empty() {
            return Ok(());
        }
        Err(PipelineError::Verify {
            manifest: self.manifest.clone(),
            count: differences.len(),
            differences,
        })
    }

    pub fn table(&self) -> String {
        // Hashes are shown by their first 16 hex digits (the error message has them
        // whole); other values in full.
        let short = |x: &Option<String>| match x {
            Some(s) if s.len() >= 64 && s[..64].bytes().all(|b| b.is_ascii_hexdigit()) => {
                s[..16].to_string()
            }
            Some(s) => s.clone(),
            None => "-".to_string(),
        };
        let cells: Vec<[String; 5]> = self
            .rows
            .iter()
            .map(|r| {
                [
                    r.kind.to_string(),
                    r.name.clone(),
                    short(&r.expected),
                    short(&r.actual),
                    if r.matches() { "ok" } else { "DIFFERS" }.to_string(),
                ]
            })
            .collect();
        let header = ["kind", "name", "locked", "rebuilt", "result"].map(String::from);
        let mut w = [0usize; 5];
        for row in std::iter::once(&header).chain(&cells) {
            for (k, c) in row.iter().enumerate() {
                w[k] = w[k].max(c.chars().count());
            }
        }
        let mut s = String::new();
        for row in std::iter::once(&header).chain(&cells) {
            let line: Vec<String> = row
                .iter()
                .enumerate()
                .map(|(k, c)| format!("{c:<width$}", width = w[k]))
                .collect();
            s.push_str(line.join("  ").trim_end());
            s.push('\n');
        }
        s
    }
}

/// Compares two locks value by value.
pub fn compare(manifest: &Path, expected: &Lock, actual: &Lock) -> VerifyReport {
    let mut rows = Vec::new();
    let mut maps =
        |kind: &'static str, e: &BTreeMap<String, String>, a: &BTreeMap<String, String>| {
            let keys: BTreeSet<&String> = e.keys().chain(a.keys()).collect();
            for k in keys {
                rows.push(Row {
                    kind,
                    name: k.clone(),
                    expected: e.get(k).cloned(),
                    actual: a.get(k).cloned(),
                });
            }
        };
    maps("input", &expected.inputs, &actual.inputs);
    maps("output", &expected.outputs, &actual.outputs);
    let plan = |l: &Lock| {
        format!(
            "format {}, {} shards, {} frames",
            l.shard_format_version, l.planned_shards, l.planned_frames
        )
    };
    rows.push(Row {
        kind: "plan",
        name: "shard plan".into(),
        expected: Some(plan(expected)),
        actual: Some(plan(actual)),
    });
    // Shards by file name; the sha256 covers the bytes, the row also carries the frame
    // range so a renumbered shard shows as a difference.
    let shard_map = |l: &Lock| -> BTreeMap<String, String> {
        l.shards
            .iter()
            .map(|s| {
                (
                    s.file.clone(),
                    format!(
                        "{} (#{}, frames {}..={}, {} frames, {} bytes)",
                        s.sha256, s.index, s.first_frame, s.last_frame, s.frame_count, s.bytes
                    ),
                )
            })
            .collect()
    };
    let (e, a) = (shard_map(expected), shard_map(actual));
    let keys: BTreeSet<&String> = e.keys().chain(a.keys()).collect();
    for k in keys {
        rows.push(Row {
            kind: "shard",
            name: k.clone(),
            expected: e.get(k).cloned(),
            actual: a.get(k).cloned(),
        });
    }
    VerifyReport {
        manifest: manifest.to_path_buf(),
        rows,
        expected_version: expected.tool_version.clone(),
    }
}

/// Rebuilds the lock's pipeline up to the shards in a temporary folder (or in `work`,
/// kept) and compares.
pub fn verify(manifest: &Path, work: Option<&Path>, progress: bool) -> Result<VerifyReport> {
    let (expected, text) = Lock::read(manifest)?;
    let temp;
    let work = match work {
        Some(w) => w.to_path_buf(),
        None => {
            temp = tempfile::Builder::new()
                .prefix("pl2map-verify-")
                .tempdir()
                .map_err(io_err(std::env::temp_dir()))?;
            temp.path().to_path_buf()
        }
    };
    let base = manifest.parent().unwrap_or(Path::new("."));
    let p = Pipeline::resolve(
        expected.pipeline.clone(),
        &text,
        manifest,
        base,
        Some(work),
        &["pipeline"],
    )?;
    run(
        &p,
        &RunOptions {
            until: Some(StageName::Shard),
            progress,
            ..RunOptions::default()
        },
    )?;
    let actual = Lock::collect(&p)?;
    Ok(compare(manifest, &expected, &actual))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups() {
        assert_eq!(
            input_group("synthroom/seq-01/frame-000000.color.png"),
            "seq-01"
        );
        assert_eq!(
            input_group("synthroom/sfm_gt/colmap/images.bin"),
            "sfm_gt/colmap"
        );
        assert_eq!(
            input_group("synthroom/sfm_gt/limap/finaltracks/track_0.txt"),
            "sfm_gt/limap"
        );
        assert_eq!(
            input_group("synthroom/sfm_gt/exact.json"),
            "sfm_gt/exact.json"
        );
        assert_eq!(input_group("synthroom/TrainSplit.txt"), "TrainSplit.txt");
    }
}
