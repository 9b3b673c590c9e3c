//! MCAP label shards (docs/formats.md section 4) and the shard stage that writes
//! them from the frames and label tables ([`shard_stage`]).
//!
//! A shard is one MCAP file holding up to `frames_per_shard` consecutive frames of a
//! run, with zstd chunks and the full index (chunk indexes, message indexes,
//! statistics, metadata index, summary offsets). Each frame is one log time
//! (`frame_id * 100 ms`, see [`FRAME_PERIOD_NS`]) and these channels, all protobuf
//! with their schema (a binary FileDescriptorSet) embedded:
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/camera/calibration` | foxglove.CameraCalibration | K, distortion, P = [K\|0] |
//! | `/tf` | foxglove.FrameTransform | the camera's pose in `world` |
//! | `/camera/image` | foxglove.CompressedImage | the original image file's bytes |
//! | `/labels` | pl2map.FrameLabels | everything the trainer needs but the image |
//! | `/labels/points` | foxglove.PointCloud | valid 3D point labels (float32 x y z) |
//! | `/labels/lines` | foxglove.SceneUpdate | valid 3D line labels (LINE_LIST) |
//!
//! So any MCAP reader (Python's `mcap` + `mcap-protobuf-support`, Foxglove) decodes a
//! shard without this crate. [`write_shard`] writes one file; [`plan_shards`] and
//! [`write_shards`] split a run into shards and write a range of them in parallel,
//! returning a [`Manifest`] (and, given [`SourceDigest`]s, keeping the shards whose
//! frames did not change); [`ShardReader`] streams frames back, seeks by frame id
//! and reads any subset of shards.

mod digest;
mod error;
mod manifest;
mod plan;
mod reader;
mod record;
pub mod schema;
pub mod shard_stage;
mod visual;
mod write_shards;
mod writer;

pub use digest::{SOURCE_SUFFIX, SourceDigest};
pub use error::ShardError;
pub use manifest::{Manifest, ManifestShard};
pub use plan::{ShardPlan, plan_shards, shard_file_name};
pub use reader::{ReaderOptions, ShardFile, ShardReader};
pub use record::{FrameRecord, ImageFormat, LabelSource, Split};
pub use shard_stage::{MANIFEST_FILE, checked_manifest, recorded_manifest, shards_of_split};
pub use visual::{
    CAMERA_FRAME, LINES_ENTITY_ID, WORLD_FRAME, camera_calibration, camera_transform,
    foxglove_distortion, identity_pose,
};
pub use write_shards::{FrameSource, ShardJob, WriteOutcome, write_shards};
pub use writer::{
    FRAME_PERIOD_NS, LIBRARY, SHARD_FORMAT_VERSION, SHARD_METADATA_NAME, ShardConfig, ShardInfo,
    TOPIC_CALIBRATION, TOPIC_IMAGE, TOPIC_LABELS, TOPIC_LINES, TOPIC_POINTS, TOPIC_TF,
    frame_id_of_log_time, frame_log_time, write_shard,
};
