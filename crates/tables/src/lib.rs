//! The tables the data stages hand to each other, stored as parquet (polars):
//!
//! - [`frames`]: the frames table the ingest stage writes (one row per image: name,
//!   split, camera, world-to-camera pose, depth, content hash) with its [`IngestMeta`];
//! - [`labels`]: the label tables the import and refine stages write (`points.parquet`,
//!   `lines.parquet`, `poses.parquet`) and the shard stage reads;
//! - [`Split`] and [`LabelSource`], shared by every crate that names a split or a label
//!   origin (the shards' protobuf schema maps onto them);
//! - [`image_file`]: whether a frame's PNG or JPEG file is whole (not truncated);
//! - [`parquet`]: the one parquet helper (atomic, deterministic writes; checked column
//!   access whose errors name the file, column and row).
//!
//! A crate of the formats layer (ARCHITECTURE.md): the adapters (`datasets`), the label
//! stages (`labels`), the shard stage (`shards`) and the score stage read and write these
//! files without depending on each other.

pub mod frames;
pub mod image_file;
pub mod labels;
pub mod parquet;

pub use frames::{ExcludedFrame, Frame, FramesTable, IngestMeta, Split};
pub use labels::{LabelSource, LabelTables, LineRow, PointRow, PoseRow, PoseSource};
pub use parquet::TableError;
