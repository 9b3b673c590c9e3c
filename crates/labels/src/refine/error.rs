//! The refine stage's error.

use crate::depth::DepthError;
use std::path::PathBuf;
use tables::parquet::TableError;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum RefineError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Depth(#[from] DepthError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("refine configuration: {0}")]
    Config(String),
    #[error("label tables: frame {frame_id} is not a training frame of the frames table")]
    UnknownFrame { frame_id: u32 },
    #[error("no training frame has a depth map (frames table depth source: {depth_source})")]
    NoDepth { depth_source: String },
    #[error("the frames table has depth maps but no depth_units_per_metre")]
    NoDepthUnits,
    #[error(
        "{}: the depth map of frame {frame_id} ({name}) changed since ingest (sha256 {actual}, \
         the frames table says {expected}): run the ingest again",
        path.display()
    )]
    DepthChanged {
        path: PathBuf,
        frame_id: u32,
        name: String,
        expected: String,
        actual: String,
    },
    #[error(
        "{}: frame {frame_id} ({name}) has a depth map but no depth hash (a frames table \
         written before depth maps were hashed): run the ingest again",
        frames.display()
    )]
    DepthUnhashed {
        frames: PathBuf,
        frame_id: u32,
        name: String,
    },
}
