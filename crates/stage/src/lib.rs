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
//! - one writer per folder ([`FolderGuard`]).
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
pub use record::{RECORD_FILE, RecordCheck, StageRecord};
pub use runner::{Done, Note, Outputs, Stage};

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
}
