//! The one stage runner (ARCHITECTURE.md, "The stage folder"):
//! - [`Stage`]: a stage's folder, configuration hash and input hashes; it skips the
//!   stage when the folder's record matches, else runs it and records what it wrote
//!   ([`Outputs`]), and gives back a [`Done`] with the report line;
//! - outputs are written to a temp file in the destination folder and renamed, so a
//!   killed stage never leaves a partial file under the final name ([`AtomicFile`]);
//! - content hashes (sha256, hex) of inputs, outputs and configurations;
//! - `stage.json` ([`RECORD_FILE`], [`StageRecord`]): what a stage ran with and what it
//!   wrote;
//! - progress bars, hidden when stderr is not a terminal or when asked to be quiet;
//! - one writer per folder ([`FolderGuard`]);
//! - a stage reads another stage's outputs only while that stage's record vouches for
//!   them ([`recorded_outputs`]), and never writes into another stage's folder.
//!
//! Every stage crate depends on this one and on no other stage crate for it.

mod atomic;
mod guard;
mod hash;
pub mod out;
mod progress;
mod record;
mod runner;

pub use atomic::{AtomicFile, write_atomic};
pub use guard::{FolderGuard, GUARD_FILE, GuardMode, set_wait};
pub use hash::{hash_config, sha256_bytes, sha256_file, sha256_files};
pub use progress::{progress_bar, set_quiet};
pub use record::{RECORD_FILE, RecordCheck, StageRecord, recorded_file, recorded_outputs};
pub use runner::{Done, Note, Outputs, Stage, require_folder};

use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum StageError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("{path}: invalid stage record: {source}")]
    Record {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("cannot hash configuration: {0}")]
    Config(#[source] serde_json::Error),
    #[error("{}: the path is not valid UTF-8", path.display())]
    Path { path: PathBuf },
    #[error(
        "{} is in use by {holder}: pass --wait to wait for it, or use another folder",
        dir.display()
    )]
    Busy { dir: PathBuf, holder: String },
    /// A stage folder (or a folder above it) that is a file.
    #[error("{} is a file, not a folder{}: choose another folder", path.display(), within_note(path, within))]
    NotAFolder { path: PathBuf, within: PathBuf },
    /// A stage asked to write into the folder of another stage (`pl2map score --out
    /// <work>/train`): refused before anything there is touched.
    #[error(
        "{} belongs to the {found} stage (its {RECORD_FILE} says so): the {stage} stage does not \
         write into another stage's folder; choose another folder",
        dir.display()
    )]
    OtherStage {
        dir: PathBuf,
        found: String,
        stage: String,
    },
    /// Files a reader takes from another stage's folder that the folder's record does not
    /// vouch for (no record, another stage's record, a file changed after it was
    /// recorded): [`recorded_outputs`].
    #[error("{}: {reason}: run the {stages} stage again", path.display())]
    NotRecorded {
        path: PathBuf,
        /// The stage(s) that write these files (`import or refine`).
        stages: String,
        reason: String,
    },
}

/// ` (in <within>)` when the file is a folder above the one asked for.
fn within_note(path: &std::path::Path, within: &std::path::Path) -> String {
    if path == within {
        String::new()
    } else {
        format!(" (in {})", within.display())
    }
}
