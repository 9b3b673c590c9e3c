//! The trainer of pl2map-rs (`pl2map train`) and the predictor of trained networks.
//!
//! - [`stream`]: frames from shard files, seeded shuffle buffer across shards, prefetched
//!   on a background thread; the order is a pure function of the seed and the epoch.
//! - [`augment`]: brightness, contrast, scale, rotation about the principal point; the
//!   keypoints, segments, intrinsics and pose follow the image (docs/method.md section 5).
//! - [`sample`]: shard frame (+ augmentation) -> [`model::Sample`], descriptors re-sampled
//!   on the augmented image, per-sample limits.
//! - [`step`]: one training step (forward, loss, backward, the fused Adam), its gradient
//!   groups side by side on the CPU's cores.
//! - [`trainer`]: the loop (Adam, learning rate halved k times), atomic checkpoints with an
//!   exact `--resume`, `--init` warm starts, metrics CSV, progress bar, loss plot.
//! - [`predict`]: [`Predictor`], the front-end + network on one query image.

pub mod augment;
pub mod checkpoint;
pub mod config;
pub mod descriptor_cache;
pub mod descriptor_spill;
pub mod error;
pub mod import_reference;
pub mod metrics;
pub mod plot;
pub mod predict;
pub mod sample;
pub mod seeds;
pub mod step;
pub mod stream;
#[cfg(test)]
mod testutil;
pub mod train_stage;
pub mod trainer;

pub use config::{Limits, LrSchedule, TrainConfig};
pub use error::TrainError;
/// Where a run trains or predicts (`--device cpu|cuda[:N]`).
pub use model::Device;
pub use predict::{ImagePrediction, PredictedLine, PredictedPoint, Predictor};
pub use train_stage::{Gate, TrainOutput, TrainStageOptions};
pub use trainer::{MeanLosses, RunOptions, TrainSummary, train, train_on};
