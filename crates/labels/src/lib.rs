//! Labels of training images (docs/method.md section 3) and the stages that make them
//! (ARCHITECTURE.md, "Data flow"):
//!
//! - [`import_stage`] (steps in [`import`]): joins a COLMAP model and a LIMAP folder to
//!   the frames table by image name (an explicit [`NameMapping`], never a guess),
//!   refuses inconsistent input with every problem listed, and writes the label tables.
//! - [`refine_stage`] (optional, steps in [`refine`]): moves point and line labels onto
//!   the depth maps and reports what moved and what was dropped.
//! - [`label_error`]: the 3D error of labels against exact ones (the synthetic scene's).
//!
//! Label tables (parquet, one folder per stage, see `tables::labels`):
//! `points.parquet` (one row per keypoint), `lines.parquet` (one row per 2D segment),
//! `poses.parquet` (the camera and world-to-camera pose every label was computed with).
//! Rows are sorted by frame id, then keypoint / segment index, so the same inputs give
//! the same bytes.

pub mod align;
pub mod depth;
pub mod import;
pub mod import_stage;
pub mod label_error;
mod label_folder;
pub mod names;
pub mod refine;
pub mod refine_stage;
mod stats;

pub use names::NameMapping;
pub use stats::Spread;
pub use tables::{LabelSource, LabelTables, LineRow, PointRow, PoseRow, PoseSource, TableError};
