use crate::{StageError, sha256_file, write_atomic};
use fileio::io_err;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `stage.json`: what a stage ran with and what it produced.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StageRecord {
    pub stage: String,
    /// pl2map version and results epoch that wrote it (`record_version`); another
    /// reruns the stage.
    pub version: String,
    pub config_hash: String,
    /// Input name -> content hash.
    pub inputs: BTreeMap<String, String>,
    /// Output path relative to the stage folder -> content hash.
    pub outputs: BTreeMap<String, String>,
}

/// Why a stage must run (or that it need not).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RecordCheck {
    UpToDate,
    Missing,
    Changed(String),
}

pub const RECORD_FILE: &str = "stage.json";

/// Bumped by every change that moves a stage's outputs for the same configuration and
/// inputs (the crate version stays 0.1.0 between releases): records of an older epoch
/// are out of date, so a work folder made by an older build is never taken as current.
/// 2: the front-end's dense descriptors and pytlsd's LSD (the synthetic ground truth).
pub const RESULTS_EPOCH: u32 = 2;

/// The version a record is written with and compared against: the crate version and
/// [`RESULTS_EPOCH`].
pub fn record_version() -> String {
    format!("{}+results.{RESULTS_EPOCH}", env!("CARGO_PKG_VERSION"))
}

impl StageRecord {
    pub fn new(stage: &str, config_hash: String, inputs: BTreeMap<String, String>) -> Self {
        StageRecord {
            stage: stage.to_string(),
            version: record_version(),
            config_hash,
            inputs,
            outputs: BTreeMap::new(),
        }
    }

    /// Hashes `rel` (relative to `dir`) into the outputs.
    pub fn add_output(&mut self, dir: &Path, rel: &str) -> Result<(), StageError> {
        let h = sha256_file(&dir.join(rel))?;
        self.outputs.insert(rel.to_string(), h);
        Ok(())
    }

    pub fn load(dir: &Path) -> Result<Option<StageRecord>, StageError> {
        let path = dir.join(RECORD_FILE);
        match std::fs::read(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes)
                .map(Some)
                .map_err(|source| StageError::Record { path, source }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(io_err(path)(e).into()),
        }
    }

    /// Written last, atomically: its presence means every output is complete.
    pub fn save(&self, dir: &Path) -> Result<(), StageError> {
        let mut json = serde_json::to_vec_pretty(self).map_err(StageError::Config)?;
        json.push(b'\n');
        write_atomic(dir.join(RECORD_FILE), &json)
    }

    /// Compares the record in `dir` with what the stage would run with now, and checks
    /// that every recorded output still has its recorded hash.
    pub fn check(
        dir: &Path,
        stage: &str,
        config_hash: &str,
        inputs: &BTreeMap<String, String>,
    ) -> Result<RecordCheck, StageError> {
        let Some(rec) = Self::load(dir)? else {
            return Ok(RecordCheck::Missing);
        };
        let changed = |why: String| Ok(RecordCheck::Changed(why));
        if rec.stage != stage {
            return changed(format!("record is for stage {}", rec.stage));
        }
        if rec.version != record_version() {
            return changed(format!("written by version {}", rec.version));
        }
        if rec.config_hash != config_hash {
            return changed("configuration changed".into());
        }
        if &rec.inputs != inputs {
            let names: Vec<&String> = inputs
                .iter()
                .filter(|(k, v)| rec.inputs.get(*k) != Some(v))
                .map(|(k, _)| k)
                .chain(rec.inputs.keys().filter(|k| !inputs.contains_key(*k)))
                .collect();
            return changed(format!("inputs changed: {names:?}"));
        }
        for (rel, h) in &rec.outputs {
            let p = dir.join(rel);
            if !p.exists() {
                return changed(format!("output {rel} is missing"));
            }
            if &sha256_file(&p)? != h {
                return changed(format!("output {rel} was modified"));
            }
        }
        Ok(RecordCheck::UpToDate)
    }
}

/// The record of another stage's folder, for a stage that reads `files` from it: the
/// folder's `stage.json` must be there, be the record of one of `stages`, and list every
/// file of `files` with the content hash the file has now (each is hashed). A refused or
/// killed run removes its record first (crates/stage/src/runner.rs) but may leave the
/// outputs of an earlier run, and a file may be edited or copied over after its stage
/// ran: without this check a reader would take either for the stage's output. The
/// record's `outputs` then hold the hashes of `files`, ready to be the reader's inputs.
pub fn recorded_outputs(
    dir: &Path,
    stages: &[&str],
    files: &[&str],
) -> Result<StageRecord, StageError> {
    let record_path = dir.join(RECORD_FILE);
    let refuse = |path: PathBuf, stages: String, reason: String| StageError::NotRecorded {
        path,
        stages,
        reason,
    };
    let any = stages.join(" or ");
    let rec = match StageRecord::load(dir) {
        Ok(Some(rec)) => rec,
        Ok(None) => {
            let what = if files.is_empty() {
                "the folder".to_string()
            } else {
                files.join(", ")
            };
            return Err(refuse(
                record_path,
                any.clone(),
                format!(
                    "missing: {what} in {} are not the outputs of a finished {any} run (a \
                     refused or killed run leaves no record)",
                    dir.display()
                ),
            ));
        }
        Err(StageError::Record { path, source }) => {
            return Err(refuse(
                path,
                any.clone(),
                format!("not a readable stage record ({source})"),
            ));
        }
        Err(e) => return Err(e),
    };
    if !stages.contains(&rec.stage.as_str()) {
        return Err(refuse(
            record_path,
            any.clone(),
            format!(
                "the record of the {} stage, expected the {any} stage's",
                rec.stage
            ),
        ));
    }
    for rel in files {
        let path = dir.join(rel);
        let reason = match rec.outputs.get(*rel) {
            None => format!(
                "not among the outputs {} lists ({} stage)",
                record_path.display(),
                rec.stage
            ),
            Some(_) if !path.is_file() => format!(
                "missing, though {} lists it ({} stage)",
                record_path.display(),
                rec.stage
            ),
            Some(recorded) => {
                let now = sha256_file(&path)?;
                if &now == recorded {
                    continue;
                }
                format!(
                    "changed after the {} stage recorded it (sha256 {now}, {} says {recorded})",
                    rec.stage,
                    record_path.display()
                )
            }
        };
        return Err(refuse(path, rec.stage.clone(), reason));
    }
    Ok(rec)
}

/// [`recorded_outputs`] for one file given by its path (a frames table): its content
/// hash, as recorded and as it is now.
pub fn recorded_file(path: &Path, stages: &[&str]) -> Result<String, StageError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| StageError::Path {
            path: path.to_path_buf(),
        })?;
    let mut rec = recorded_outputs(dir, stages, &[name])?;
    Ok(rec.outputs.remove(name).unwrap_or_default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_lifecycle() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let inputs: BTreeMap<_, _> = [("frames".to_string(), "abc".to_string())].into();
        assert_eq!(
            StageRecord::check(d, "shard", "c1", &inputs).unwrap(),
            RecordCheck::Missing
        );
        write_atomic(d.join("out.bin"), b"data").unwrap();
        let mut rec = StageRecord::new("shard", "c1".into(), inputs.clone());
        rec.add_output(d, "out.bin").unwrap();
        rec.save(d).unwrap();
        assert_eq!(
            StageRecord::check(d, "shard", "c1", &inputs).unwrap(),
            RecordCheck::UpToDate
        );
        assert!(matches!(
            StageRecord::check(d, "shard", "c2", &inputs).unwrap(),
            RecordCheck::Changed(_)
        ));
        let other: BTreeMap<_, _> = [("frames".to_string(), "def".to_string())].into();
        assert!(matches!(
            StageRecord::check(d, "shard", "c1", &other).unwrap(),
            RecordCheck::Changed(_)
        ));
        std::fs::write(d.join("out.bin"), b"tampered").unwrap();
        assert!(matches!(
            StageRecord::check(d, "shard", "c1", &inputs).unwrap(),
            RecordCheck::Changed(_)
        ));
    }

    /// A record written by a build of an earlier results epoch (same crate version) is
    /// out of date, and the reason names the version it was written by.
    #[test]
    fn an_earlier_results_epoch_reruns_the_stage() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let inputs = BTreeMap::new();
        let mut rec = StageRecord::new("synth", "c1".into(), inputs.clone());
        rec.save(d).unwrap();
        assert_eq!(
            StageRecord::check(d, "synth", "c1", &inputs).unwrap(),
            RecordCheck::UpToDate
        );
        rec.version = env!("CARGO_PKG_VERSION").to_string();
        rec.save(d).unwrap();
        match StageRecord::check(d, "synth", "c1", &inputs).unwrap() {
            RecordCheck::Changed(why) => assert!(why.contains("written by version 0.1.0"), "{why}"),
            other => panic!("{other:?}"),
        }
    }

    fn recorded(d: &Path, stage: &str, files: &[(&str, &[u8])]) {
        let mut rec = StageRecord::new(stage, "c".into(), BTreeMap::new());
        for (rel, bytes) in files {
            write_atomic(d.join(rel), bytes).unwrap();
            rec.add_output(d, rel).unwrap();
        }
        rec.save(d).unwrap();
    }

    /// A reader takes another stage's files only while that stage's record vouches for
    /// them: no record, another stage's record, a file the record does not list, a
    /// missing or changed file are each refused, naming the file and the stage to run.
    #[test]
    fn readers_take_only_recorded_outputs() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let files = ["points.parquet", "poses.parquet"];
        recorded(
            d,
            "import",
            &[("points.parquet", b"p"), ("poses.parquet", b"q")],
        );
        let rec = recorded_outputs(d, &["import", "refine"], &files).unwrap();
        assert_eq!(rec.outputs["points.parquet"], crate::sha256_bytes(b"p"));

        // A refused rerun removed the record and left the tables.
        std::fs::remove_file(d.join(RECORD_FILE)).unwrap();
        let e = recorded_outputs(d, &["import", "refine"], &files).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains(&d.join(RECORD_FILE).display().to_string())
                && msg.contains("missing: points.parquet, poses.parquet")
                && msg.contains("run the import or refine stage again"),
            "{msg}"
        );

        recorded(d, "shard", &[("points.parquet", b"p")]);
        let msg = recorded_outputs(d, &["import", "refine"], &files)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("the record of the shard stage, expected the import or refine"),
            "{msg}"
        );

        recorded(d, "refine", &[("points.parquet", b"p")]);
        let msg = recorded_outputs(d, &["import", "refine"], &files)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("poses.parquet: not among the outputs")
                && msg.contains("run the refine stage again"),
            "{msg}"
        );

        recorded(
            d,
            "import",
            &[("points.parquet", b"p"), ("poses.parquet", b"q")],
        );
        std::fs::write(d.join("poses.parquet"), b"stale").unwrap();
        let msg = recorded_outputs(d, &["import"], &files)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("poses.parquet: changed after the import stage recorded it")
                && msg.contains(&crate::sha256_bytes(b"stale")),
            "{msg}"
        );
        std::fs::remove_file(d.join("poses.parquet")).unwrap();
        let msg = recorded_outputs(d, &["import"], &files)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("poses.parquet: missing, though"), "{msg}");

        std::fs::write(d.join(RECORD_FILE), b"{").unwrap();
        let msg = recorded_outputs(d, &["import"], &files)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("not a readable stage record"), "{msg}");
    }
}
