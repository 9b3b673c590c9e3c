use std::path::PathBuf;
use thiserror::Error;

/// Why the score stage stopped. A frame that could not be localised is not an error:
/// it is recorded as a failure with its reason (see [`crate::FrameResult`]).
#[derive(Debug, Error)]
pub enum ScoreError {
    #[error("invalid score option: {0}")]
    Config(String),
    #[error("{}: cannot read the shard manifest: {reason}", path.display())]
    Manifest { path: PathBuf, reason: String },
    #[error(
        "{}: the manifest is incomplete (missing shard(s) {missing:?}): run the shard stage to the end",
        path.display()
    )]
    IncompleteManifest { path: PathBuf, missing: Vec<usize> },
    #[error("{}: no {split} shards in the manifest ({reason})", dir.display())]
    NoFrames {
        dir: PathBuf,
        split: &'static str,
        reason: &'static str,
    },
    #[error("shards in {}: {source}", dir.display())]
    Shards {
        dir: PathBuf,
        #[source]
        source: shards::ShardError,
    },
    #[error("frame {frame_id} ({name}) is a {found} frame but was read from a {expected} shard")]
    WrongSplit {
        frame_id: u64,
        name: String,
        found: &'static str,
        expected: &'static str,
    },
    #[error("frame {frame_id} ({name}): {reason}")]
    Frame {
        frame_id: u64,
        name: String,
        reason: String,
    },
    #[error(
        "frame {frame_id}: image name {name:?} contains whitespace, which the hloc result format \
         (`name qw qx qy qz tx ty tz`) cannot hold"
    )]
    NameWithSpace { frame_id: u64, name: String },
    #[error("network {}: {reason}", checkpoint.display())]
    Network { checkpoint: PathBuf, reason: String },
    /// The query segments folder (`query_segments`) cannot be read.
    #[error("query segments {}: {reason}", dir.display())]
    QuerySegments { dir: PathBuf, reason: String },
    /// A checkpoint that does not load (the reason names the file).
    #[error("network: {reason}")]
    Model { reason: String },
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("{}: not a score summary: {reason}", path.display())]
    Summary { path: PathBuf, reason: String },
    #[error("{}: parquet: {source}", path.display())]
    Parquet {
        path: PathBuf,
        #[source]
        source: tables::parquet::polars::error::PolarsError,
    },
    #[error(transparent)]
    Table(#[from] tables::TableError),
    #[error("{}: PNG: {source}", path.display())]
    Png {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{}: line {line}: {reason}", path.display())]
    HlocFormat {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error("{}: line {line}: {reason}", path.display())]
    QueryList {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error("{}: visual MCAP: {reason}", path.display())]
    Visual { path: PathBuf, reason: String },
}
