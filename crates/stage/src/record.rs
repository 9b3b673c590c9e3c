use crate::{StageError, sha256_file, write_atomic};
use fileio::io_err;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

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
}
