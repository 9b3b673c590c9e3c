use std::path::PathBuf;
use thiserror::Error;

/// Errors of the ground-truth labelling.
#[derive(Debug, Error)]
pub enum GtError {
    #[error("invalid ground-truth configuration: {0}")]
    Config(String),
    #[error("frame index {index} out of range (the dataset has {count} frames)")]
    FrameIndex { index: usize, count: usize },
    #[error("front-end failed on frame {frame}: {source}")]
    Features {
        frame: usize,
        #[source]
        source: features::FeatureError,
    },
    #[error("COLMAP model {path}: {source}")]
    Colmap {
        path: PathBuf,
        #[source]
        source: colmap::ColmapError,
    },
    #[error("LIMAP folder {path}: {source}")]
    Limap {
        path: PathBuf,
        #[source]
        source: limap::LimapError,
    },
    /// `fileio::IoError` displays `<path>: <source>`: the message stays
    /// "I/O error on <path>: <source>".
    #[error("I/O error on {0}")]
    Io(#[from] fileio::IoError),
    #[error("could not serialise {path}: {source}")]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
}
