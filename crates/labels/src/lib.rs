//! Labels of training images (specs/pl2map.md section 3) and the stages that make and
//! ship them (DESIGN.md "Data flow"):
//!
//! - [`import`]: joins a COLMAP model and a LIMAP folder to the frames table by image
//!   name (an explicit [`NameMapping`], never a guess), refuses inconsistent input with
//!   every problem listed, and writes the label tables.
//! - [`refine`] (optional): moves point and line labels onto the depth maps and reports
//!   what moved and what was dropped.
//! - [`shard`]: streams frames, images and labels into MCAP shards (`shards` crate).
//!
//! Label tables (parquet, one folder per stage, see [`tables`]):
//! `points.parquet` (one row per keypoint), `lines.parquet` (one row per 2D segment),
//! `poses.parquet` (the camera and world-to-camera pose every label was computed with).
//! Rows are sorted by frame id, then keypoint / segment index, so the same inputs give
//! the same bytes.

pub mod ablation;
pub mod align;
pub mod depth;
pub mod import;
pub mod names;
mod parquet;
pub mod refine;
pub mod shard;
mod stats;
pub mod tables;

pub use names::NameMapping;
pub use parquet::TableError;
pub use stats::Spread;
pub use tables::{LabelSource, LabelTables, LineRow, PointRow, PoseRow, PoseSource};
