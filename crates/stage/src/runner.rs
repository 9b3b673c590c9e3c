//! The one ending every stage shares (ARCHITECTURE.md, "The stage folder"):
//!
//! 1. [`Stage::new`]: the stage's name, its folder, the hash of its configuration and
//!    the content hashes of its inputs;
//! 2. [`Stage::run`]: when the folder's `stage.json` matches (same stage, version,
//!    configuration, inputs, and every recorded output still has its recorded hash)
//!    nothing runs and `load` reads the existing outputs back; otherwise the old record
//!    is removed first (from then on the folder does not claim to be complete) and the
//!    outputs it listed with it, `work` writes the outputs through [`Outputs`] (each
//!    file atomically, under a temp name and renamed), and the new record is written
//!    last, atomically;
//! 3. [`Done`]: the output, whether the stage was skipped, how long it took, and the
//!    report line a person reads (`<stage>: ran in 1.2 s: 300 frames`).
//!
//! A record that cannot be parsed (a crash of another tool, a hand edit) counts as no
//! record: the stage runs again. A folder whose record names another stage is refused
//! before anything in it is touched (a stage run with another stage's folder as its
//! output would otherwise replace that stage's record), and so is a path that is a file.
//! A stage that reads another stage's outputs takes them through
//! [`crate::recorded_outputs`]. Stages whose outputs are produced in several runs
//! (the shard stage's work units) use [`Stage::check`] and [`Outputs::finish`]
//! directly.

use crate::{
    AtomicFile, FolderGuard, GuardMode, RECORD_FILE, RecordCheck, StageError, StageRecord,
    hash_config, sha256_file, write_atomic,
};
use fileio::io_err;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// One run of a stage in its folder, holding the folder's guard (`crate::FolderGuard`)
/// for as long as it lives.
#[derive(Clone, Debug)]
pub struct Stage {
    name: &'static str,
    dir: PathBuf,
    config_hash: String,
    inputs: BTreeMap<String, String>,
    /// Held, not read: released when the last clone of the stage is dropped.
    _guard: Arc<FolderGuard>,
}

/// What a stage gives back: its output, and whether it was up to date.
#[derive(Clone, Debug)]
pub struct Done<T> {
    pub output: T,
    /// The record matched: nothing was recomputed.
    pub skipped: bool,
    pub seconds: f64,
}

/// A one-line description of a stage's output for the run table and the report line
/// (`300 frames`, `2 shards, 32 frames`).
pub trait Note {
    fn note(&self) -> String;
}

impl<T: Note> Done<T> {
    /// `<stage>: ran in 1.2 s: <note>` or `<stage>: up to date: <note>`.
    pub fn line(&self, stage: &str) -> String {
        let note = self.output.note();
        let state = if self.skipped {
            "up to date".to_string()
        } else {
            format!("ran in {:.1} s", self.seconds)
        };
        if note.is_empty() {
            format!("{stage}: {state}")
        } else {
            format!("{stage}: {state}: {note}")
        }
    }
}

impl Stage {
    /// `config` is hashed (its JSON serialisation); `inputs` maps input names to content
    /// hashes. Guards the folder (created if needed) for this stage alone.
    pub fn new<C: Serialize>(
        name: &'static str,
        dir: impl Into<PathBuf>,
        config: &C,
        inputs: BTreeMap<String, String>,
    ) -> Result<Self, StageError> {
        Stage::with_guard(name, dir, config, inputs, GuardMode::Exclusive)
    }

    /// As [`Stage::new`], sharing the folder with other holders of a shared guard (the
    /// shard stage's work units, which write disjoint files).
    pub fn with_guard<C: Serialize>(
        name: &'static str,
        dir: impl Into<PathBuf>,
        config: &C,
        inputs: BTreeMap<String, String>,
        mode: GuardMode,
    ) -> Result<Self, StageError> {
        let dir = dir.into();
        let config_hash = hash_config(config)?;
        // Before anything is created or removed: the folder is a folder, and not the
        // folder of another stage (whose record this run would remove).
        require_folder(&dir)?;
        if let Ok(Some(rec)) = StageRecord::load(&dir)
            && rec.stage != name
        {
            return Err(StageError::OtherStage {
                dir,
                found: rec.stage,
                stage: name.to_string(),
            });
        }
        let guard = Arc::new(FolderGuard::acquire(&dir, mode)?);
        // Held alone, the folder has no other writer: what killed runs left there goes
        // now, whether or not this run rewrites anything.
        if mode == GuardMode::Exclusive {
            remove_leftovers(&dir)?;
        }
        Ok(Stage {
            name,
            dir,
            config_hash,
            inputs,
            _guard: guard,
        })
    }

    pub fn name(&self) -> &'static str {
        self.name
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn config_hash(&self) -> &str {
        &self.config_hash
    }

    pub fn inputs(&self) -> &BTreeMap<String, String> {
        &self.inputs
    }

    /// Adds an input (e.g. a model hashed after the others).
    pub fn add_input(&mut self, name: impl Into<String>, sha256: impl Into<String>) {
        self.inputs.insert(name.into(), sha256.into());
    }

    /// The record now in the folder, if any and readable.
    pub fn previous(&self) -> Option<StageRecord> {
        StageRecord::load(&self.dir).ok().flatten()
    }

    /// Compares the folder's record with this run. An unreadable record counts as none.
    pub fn check(&self) -> Result<RecordCheck, StageError> {
        match StageRecord::check(&self.dir, self.name, &self.config_hash, &self.inputs) {
            Err(StageError::Record { .. }) => Ok(RecordCheck::Missing),
            other => other,
        }
    }

    /// Starts writing: creates the folder and removes the old record, so that from now
    /// until [`Outputs::finish`] the folder does not claim to be complete.
    pub fn begin(&self) -> Result<Outputs, StageError> {
        std::fs::create_dir_all(&self.dir).map_err(io_err(&self.dir))?;
        let record = self.dir.join(RECORD_FILE);
        match std::fs::remove_file(&record) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err(&record)(e).into()),
        }
        Ok(Outputs {
            record: StageRecord::new(self.name, self.config_hash.clone(), self.inputs.clone()),
            dir: self.dir.clone(),
            pending: Vec::new(),
        })
    }

    /// Skips when up to date (`load` reads the outputs back), else runs `work` and
    /// records what it wrote.
    pub fn run<T, E>(
        self,
        load: impl FnOnce(&Path) -> Result<T, E>,
        work: impl FnOnce(&mut Outputs) -> Result<T, E>,
    ) -> Result<Done<T>, E>
    where
        E: From<StageError>,
    {
        let start = Instant::now();
        match self.check()? {
            RecordCheck::UpToDate => {
                tracing::info!("{}: {} is up to date", self.name, self.dir.display());
                let output = load(&self.dir)?;
                return Ok(Done {
                    output,
                    skipped: true,
                    seconds: start.elapsed().as_secs_f64(),
                });
            }
            RecordCheck::Missing => {}
            RecordCheck::Changed(why) => tracing::info!("{}: rerunning ({why})", self.name),
        }
        let previous = self.previous().filter(|r| r.stage == self.name);
        let mut outputs = self.begin()?;
        // The outputs of the earlier run go with its record: a run refused from here on
        // leaves neither, so nothing of the earlier run is taken for this one's.
        if let Some(rec) = previous {
            remove_outputs(&self.dir, &rec)?;
        }
        let output = work(&mut outputs)?;
        outputs.finish()?;
        Ok(Done {
            output,
            skipped: false,
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}

/// Refuses a path that is a file, or that has a file where a folder above it should be
/// (creating the folder would fail with "File exists" or "Not a directory"), naming it.
pub fn require_folder(dir: &Path) -> Result<(), StageError> {
    for a in dir.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => {
                return Err(StageError::NotAFolder {
                    path: a.to_path_buf(),
                    within: dir.to_path_buf(),
                });
            }
            // Not there (yet): the folder above decides. Any other error is reported by
            // whatever then touches the path.
            Err(_) => continue,
        }
    }
    Ok(())
}

/// Removes the files a record lists (those inside `dir`), and the folders they leave
/// empty under `dir`.
fn remove_outputs(dir: &Path, rec: &StageRecord) -> Result<(), StageError> {
    let mut folders = std::collections::BTreeSet::new();
    for rel in rec.outputs.keys() {
        let rel_path = Path::new(rel);
        // A hand-edited record names nothing outside the folder.
        if !rel_path
            .components()
            .all(|c| matches!(c, std::path::Component::Normal(_)))
        {
            continue;
        }
        let path = dir.join(rel_path);
        match std::fs::remove_file(&path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err(&path)(e).into()),
        }
        folders.extend(
            path.ancestors()
                .skip(1)
                .take_while(|a| a.starts_with(dir) && *a != dir)
                .map(Path::to_path_buf),
        );
    }
    // Deepest first; a folder holding anything else stays (remove_dir refuses it).
    for folder in folders.iter().rev() {
        let _ = std::fs::remove_dir(folder);
    }
    Ok(())
}

/// Removes what killed runs left in `dir`: temp files `.<name>.*tmp` and staging folders
/// `.<name>.partial-<pid>`. Only called with the folder's exclusive guard held, so their
/// writers are gone; only hidden names of those two shapes, nothing a user keeps.
fn remove_leftovers(dir: &Path) -> Result<(), StageError> {
    for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
        let entry = entry.map_err(io_err(dir))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let path = entry.path();
        let temp = name.starts_with('.') && name.ends_with(".tmp");
        let staging = name.starts_with('.') && name.contains(".partial-");
        let result = if temp && path.is_file() {
            std::fs::remove_file(&path)
        } else if staging && path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            continue;
        };
        match result {
            Ok(()) => tracing::info!("removed {}, left by a killed run", path.display()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err(&path)(e).into()),
        }
    }
    Ok(())
}

/// The outputs of a stage being written: every file goes in through a temp name and a
/// rename, and is listed (with its content hash) in the record [`Outputs::finish`]
/// writes last.
pub struct Outputs {
    record: StageRecord,
    dir: PathBuf,
    /// Outputs to hash at `finish` (written by the stage itself, atomically).
    pending: Vec<String>,
}

impl Outputs {
    /// The stage folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// `dir/rel`, recorded as an output: the stage writes it (atomically) before
    /// `finish`, which hashes it.
    pub fn path(&mut self, rel: &str) -> PathBuf {
        self.pending.push(rel.to_string());
        self.dir.join(rel)
    }

    /// Records a file the stage wrote, given as a path inside the stage folder.
    pub fn add(&mut self, path: &Path) -> Result<(), StageError> {
        let rel = path.strip_prefix(&self.dir).unwrap_or(path);
        let rel = rel.to_str().ok_or_else(|| StageError::Path {
            path: path.to_path_buf(),
        })?;
        let rel = rel.replace(std::path::MAIN_SEPARATOR, "/");
        self.pending.push(rel);
        Ok(())
    }

    /// Records an output whose hash the stage already has (it hashed it while writing).
    pub fn add_hashed(&mut self, rel: &str, sha256: &str) {
        self.record
            .outputs
            .insert(rel.to_string(), sha256.to_string());
    }

    /// Writes `bytes` to `dir/rel` atomically and records it.
    pub fn write(&mut self, rel: &str, bytes: &[u8]) -> Result<(), StageError> {
        let path = self.dir.join(rel);
        write_atomic(&path, bytes)?;
        self.add_hashed(rel, &crate::sha256_bytes(bytes));
        Ok(())
    }

    /// A file to write to `dir/rel` atomically; [`AtomicFile::commit`] it, then it is
    /// hashed and recorded at `finish`.
    pub fn create(&mut self, rel: &str) -> Result<AtomicFile, StageError> {
        let path = self.path(rel);
        AtomicFile::create(path)
    }

    /// Hashes the outputs written by path and writes `stage.json`, atomically: the
    /// folder is complete from now on.
    pub fn finish(mut self) -> Result<StageRecord, StageError> {
        for rel in std::mem::take(&mut self.pending) {
            let h = sha256_file(&self.dir.join(&rel))?;
            self.record.outputs.insert(rel, h);
        }
        self.record.save(&self.dir)?;
        Ok(self.record)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    struct E(String);
    impl From<StageError> for E {
        fn from(e: StageError) -> Self {
            E(e.to_string())
        }
    }

    fn run_once(dir: &Path, config: u32, input: &str, calls: &mut u32) -> Done<String> {
        let inputs = BTreeMap::from([("in".to_string(), input.to_string())]);
        Stage::new("demo", dir, &config, inputs)
            .unwrap()
            .run(
                |d| Ok::<_, E>(std::fs::read_to_string(d.join("out.txt")).unwrap()),
                |out| {
                    *calls += 1;
                    out.write("out.txt", format!("{config} {input}").as_bytes())?;
                    let mut f = out.create("sub/more.txt")?;
                    std::io::Write::write_all(&mut f, b"more").unwrap();
                    f.commit()?;
                    Ok(format!("{config} {input}"))
                },
            )
            .unwrap()
    }

    #[test]
    fn runs_records_and_skips() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("stage");
        let mut calls = 0;
        let a = run_once(&d, 1, "x", &mut calls);
        assert!(!a.skipped);
        assert_eq!(a.output, "1 x");
        let rec = StageRecord::load(&d).unwrap().unwrap();
        assert_eq!(
            rec.outputs.keys().collect::<Vec<_>>(),
            ["out.txt", "sub/more.txt"]
        );
        let b = run_once(&d, 1, "x", &mut calls);
        assert!(b.skipped && b.output == "1 x" && calls == 1);
        // Another configuration, another input, a touched output: each reruns.
        run_once(&d, 2, "x", &mut calls);
        run_once(&d, 2, "y", &mut calls);
        std::fs::write(d.join("sub/more.txt"), b"edited").unwrap();
        run_once(&d, 2, "y", &mut calls);
        assert_eq!(calls, 4);
        // A garbage record is no record.
        std::fs::write(d.join(RECORD_FILE), b"{not json").unwrap();
        assert!(!run_once(&d, 2, "y", &mut calls).skipped);
        assert_eq!(calls, 5);
    }

    #[test]
    fn a_failed_run_leaves_no_record() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut calls = 0;
        run_once(d, 1, "x", &mut calls);
        let r = Stage::new("demo", d, &2u32, BTreeMap::new())
            .unwrap()
            .run(|_| Ok::<(), E>(()), |_| Err(E("failed".into())));
        assert_eq!(r.unwrap_err().0, "failed");
        assert!(!d.join(RECORD_FILE).exists());
    }

    /// A stage never writes into another stage's folder: refused before anything there
    /// changes, naming the folder and the stage it belongs to.
    #[test]
    fn refuses_the_folder_of_another_stage() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("train");
        let mut calls = 0;
        run_once(&d, 1, "x", &mut calls);
        let before = std::fs::read(d.join(RECORD_FILE)).unwrap();
        let listing = |d: &Path| {
            let mut v: Vec<_> = std::fs::read_dir(d)
                .unwrap()
                .map(|e| e.unwrap().file_name())
                .collect();
            v.sort();
            v
        };
        let files = listing(&d);
        let e = Stage::new("score", &d, &1u32, BTreeMap::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{} belongs to the demo stage (its stage.json says so): the score stage does \
                 not write into another stage's folder; choose another folder",
                d.display()
            )
        );
        assert_eq!(std::fs::read(d.join(RECORD_FILE)).unwrap(), before);
        assert_eq!(listing(&d), files);
    }

    /// A stage folder that is a file, or under one, is named as such (not "File exists").
    #[test]
    fn refuses_a_file_as_the_stage_folder() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("w");
        std::fs::write(&f, b"a file").unwrap();
        let e = Stage::new("demo", &f, &1u32, BTreeMap::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{} is a file, not a folder: choose another folder",
                f.display()
            )
        );
        let below = f.join("ingest");
        let e = Stage::new("demo", &below, &1u32, BTreeMap::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{} is a file, not a folder (in {}): choose another folder",
                f.display(),
                below.display()
            )
        );
        assert_eq!(std::fs::read(&f).unwrap(), b"a file");
    }

    /// A rerun removes the earlier run's outputs with its record: refused, it leaves
    /// neither (a reader could otherwise take them for its own outputs).
    #[test]
    fn a_refused_rerun_leaves_no_earlier_outputs() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut calls = 0;
        run_once(d, 1, "x", &mut calls);
        std::fs::write(d.join("notes.txt"), b"mine").unwrap();
        let r = Stage::new("demo", d, &2u32, BTreeMap::new())
            .unwrap()
            .run(|_| Ok::<(), E>(()), |_| Err(E("refused".into())));
        assert_eq!(r.unwrap_err().0, "refused");
        assert!(!d.join(RECORD_FILE).exists());
        assert!(!d.join("out.txt").exists());
        assert!(!d.join("sub").exists());
        assert_eq!(std::fs::read(d.join("notes.txt")).unwrap(), b"mine");
    }

    #[test]
    fn report_lines() {
        struct N;
        impl Note for N {
            fn note(&self) -> String {
                "3 frames".into()
            }
        }
        let ran = Done {
            output: N,
            skipped: false,
            seconds: 1.25,
        };
        assert_eq!(ran.line("ingest"), "ingest: ran in 1.2 s: 3 frames");
        let up = Done {
            output: N,
            skipped: true,
            seconds: 0.0,
        };
        assert_eq!(up.line("ingest"), "ingest: up to date: 3 frames");
    }
}
