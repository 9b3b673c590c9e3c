//! Errors of the trainer, each naming the file (and where useful the frame) it is about.

use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum TrainError {
    #[error("invalid training configuration: {0}")]
    Config(String),
    #[error("reading the configuration {path}: {reason}")]
    ConfigFile { path: PathBuf, reason: String },
    #[error(transparent)]
    Shard(#[from] shards::ShardError),
    #[error("no training frames in the given shards")]
    NoFrames,
    #[error("frame {frame_id} ({name}): {reason}")]
    Frame {
        frame_id: u64,
        name: String,
        reason: String,
    },
    #[error("front-end: {0}")]
    Features(#[from] features::FeatureError),
    #[error("front-end: {0}")]
    SuperPoint(#[from] superpoint::SuperPointError),
    /// A reference checkpoint (`import_reference`): unreadable, a missing key or a
    /// wrong shape; the error names the file and the key.
    #[error("reference checkpoint {0}")]
    Reference(superpoint::SuperPointError),
    #[error("model: {0}")]
    Model(#[from] model::ModelError),
    #[error("checkpoint {path}: {reason}")]
    Checkpoint { path: PathBuf, reason: String },
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("the frame stream's background thread stopped: {0}")]
    Stream(String),
    #[error("image: {0}")]
    Image(String),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
}

/// `.map_err(io_err(&path))?` (the workspace's one IO error, crates/fileio).
pub(crate) use fileio::io_err;
