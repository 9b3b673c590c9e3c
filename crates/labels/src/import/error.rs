//! The import stage's error.

use super::detector_report::DetectorCheckReport;
use super::problem_messages::summarize;
use super::problems::ImportProblem;
use std::path::PathBuf;
use tables::parquet::TableError;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum ImportError {
    /// The COLMAP crate's errors name the model's file (and line) already.
    #[error("COLMAP model: {source}")]
    Colmap {
        dir: PathBuf,
        #[source]
        source: colmap::ColmapError,
    },
    #[error("LIMAP folder: {0}")]
    Limap(#[from] limap::LimapError),
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("import configuration: {0}")]
    Config(String),
    /// The detector check says another detector made the model's keypoints or LIMAP's
    /// segments (`detector_check = "refuse"`).
    #[error("{}", report.refusal())]
    DetectorMismatch { report: Box<DetectorCheckReport> },
    #[error("{}", summarize(problems, hints))]
    Inconsistent {
        problems: Vec<ImportProblem>,
        hints: Vec<String>,
    },
}

impl ImportError {
    /// The problems of an inconsistent input (empty for other errors).
    pub fn problems(&self) -> &[ImportProblem] {
        match self {
            ImportError::Inconsistent { problems, .. } => problems,
            _ => &[],
        }
    }
}
