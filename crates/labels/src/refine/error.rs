//! The refine stage's error.

use crate::depth::DepthError;
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
}
