//! The mechanics every stage shares (DESIGN.md "Data flow"):
//! - outputs are written to a temp file in the destination folder and renamed, so a
//!   killed stage never leaves a partial file under the final name;
//! - content hashes (sha256, hex) of inputs, outputs and configurations;
//! - `stage.json`: what a stage ran with and what it wrote; a stage whose record
//!   matches its current inputs and config, and whose outputs are intact, is skipped;
//! - progress bars, hidden when stderr is not a terminal or when asked to be quiet.
//!
//! A separate crate (DESIGN.md lists one crate per concern and none for this) because
//! every stage crate needs it and none of them should depend on another for it.

mod atomic;
mod hash;
mod progress;
mod record;

pub use atomic::{AtomicFile, write_atomic};
pub use hash::{hash_config, sha256_bytes, sha256_file, sha256_files};
pub use progress::{progress_bar, set_quiet};
pub use record::{RecordCheck, StageRecord};

use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum StageError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: invalid stage record: {source}")]
    Record {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("cannot hash configuration: {0}")]
    Config(#[source] serde_json::Error),
}

pub(crate) fn io_err(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> StageError {
    let path = path.into();
    move |source| StageError::Io { path, source }
}
