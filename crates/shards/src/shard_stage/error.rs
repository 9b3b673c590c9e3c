//! The shard stage's error. Its own file because the stage (`mod.rs`), its frame source
//! (`source.rs`) and its work units (`units.rs`) all return it.

use crate::ShardError;
use std::path::PathBuf;
use tables::TableError;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum ShardStageError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Shards(#[from] ShardError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error(
        "the label tables do not cover the training frames: {} training frame(s) without labels \
         (first {:?}), {} labelled frame(s) that are not training frames (first {:?})",
        missing.len(), missing.first(), extra.len(), extra.first()
    )]
    LabelsDontMatch { missing: Vec<u32>, extra: Vec<u32> },
    #[error("shard range {start}..{end} is outside the plan's {count} shards")]
    Range {
        start: usize,
        end: usize,
        count: usize,
    },
    #[error("{}: cannot read the manifest: {reason}", path.display())]
    Manifest { path: PathBuf, reason: String },
    #[error("shard configuration: {0}")]
    Config(String),
}
