//! Errors of the limap crate.
//!
//! Parsers of a single file return [`ParseError`] (the place inside the text and what was
//! expected there); the file-level readers wrap it with the path in [`LimapError::Parse`].

use std::path::PathBuf;

use thiserror::Error;

use crate::problem::Problem;

/// A malformed LIMAP text file: where (1-based line and byte column) and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("line {line}, column {column}: expected {expected}, found {found}")]
pub struct ParseError {
    pub line: usize,
    pub column: usize,
    pub expected: String,
    /// The offending token (quoted, shortened when long) or `end of file`.
    pub found: String,
}

/// A malformed binary structure file: the byte offset of the value that could not be
/// read, the record it belongs to and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("byte {offset}{}: {problem}", record.as_ref().map(|r| format!(", {r}")).unwrap_or_default())]
pub struct BinaryError {
    pub offset: usize,
    /// The record, e.g. `record 3 (image 12)`; `None` for the header.
    pub record: Option<String>,
    pub problem: String,
}

/// Everything that can go wrong reading, checking or writing LIMAP outputs.
#[derive(Debug, Error)]
pub enum LimapError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("{}: {source}", path.display())]
    Parse {
        path: PathBuf,
        #[source]
        source: ParseError,
    },
    #[error("{}: not valid UTF-8 (first invalid byte at offset {offset})", path.display())]
    NotUtf8 { path: PathBuf, offset: usize },
    #[error(
        "{}: holds {count} files named track*.txt, so LIMAP reads track_0.txt .. track_{last}.txt, \
         but track_{missing}.txt is missing",
        dir.display(),
        last = count.saturating_sub(1)
    )]
    MissingTrack {
        dir: PathBuf,
        count: usize,
        missing: usize,
    },
    #[error(
        "{}: LIMAP counts every track*.txt file as a track, but {name:?} is not named track_<index>.txt",
        dir.display()
    )]
    StrayTrackFile { dir: PathBuf, name: String },
    #[error(
        "{}: expected segments_<image id>.txt with a non-negative integer id, found {name:?}",
        dir.display()
    )]
    BadSegmentsFileName { dir: PathBuf, name: String },
    #[error(
        "{}: no segments folder found (looked for {}); pass the folder explicitly",
        root.display(),
        looked_for
    )]
    SegmentsNotFound { root: PathBuf, looked_for: String },
    #[error(
        "{}: {} candidate segments folders ({}); pass the one used for triangulation explicitly",
        root.display(),
        candidates.len(),
        candidates.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    SegmentsAmbiguous {
        root: PathBuf,
        candidates: Vec<PathBuf>,
    },
    #[error("{}: not a directory", path.display())]
    NotADirectory { path: PathBuf },
    #[error(
        "{}: not a LIMAP output folder: no image_list.txt (LIMAP 1.x) and no \
         final_model/structures/ (LIMAP 2.0; or pass final_model/ itself)",
        root.display()
    )]
    UnknownLayout { root: PathBuf },
    /// A malformed LIMAP 2.0 binary structure file.
    #[error("{}: {source}", path.display())]
    Binary {
        path: PathBuf,
        #[source]
        source: BinaryError,
    },
    /// A LIMAP 2.0 record that parses but refers to something the folder lacks.
    #[error("{}: {record}: {problem}", path.display())]
    Record {
        path: PathBuf,
        record: String,
        problem: String,
    },
    /// The COLMAP model of a LIMAP 2.0 folder (`final_model/`).
    #[error("LIMAP 2.0 model {}: {source}", dir.display())]
    Colmap {
        dir: PathBuf,
        #[source]
        source: Box<colmap::ColmapError>,
    },
    /// Options that do not apply to the folder.
    #[error("{0}")]
    Options(String),
    /// A value handed to a writer that the format cannot hold or LIMAP could not read back.
    #[error("cannot write {what}: {reason}")]
    InvalidData { what: String, reason: String },
    /// A folder whose files parse but disagree with each other (see [`crate::check`]).
    #[error("{}: {} consistency error(s); first: {}", root.display(), problems.len(),
        problems.first().map(|p| p.to_string()).unwrap_or_default())]
    Inconsistent {
        root: PathBuf,
        problems: Vec<Problem>,
    },
}

impl LimapError {
    pub(crate) fn invalid_option(message: String) -> Self {
        LimapError::Options(message)
    }

    pub(crate) fn invalid(what: impl Into<String>, reason: impl Into<String>) -> Self {
        LimapError::InvalidData {
            what: what.into(),
            reason: reason.into(),
        }
    }
}
