//! The front-end of pl2map-rs: what turns an image into the network's input.
//!
//! - SIFT keypoints (OpenCV), top-K by response, and 128-d SIFT descriptors computed at
//!   GIVEN positions: at a fixed scale and upright orientation, the same way at training
//!   time (positions from the SfM model, which stores neither scale nor orientation) and
//!   at query time (positions from the detector). See docs/method.md section 1 (descriptor consistency).
//! - LSD line segments (OpenCV `createLineSegmentDetector`), longest first.
//! - T points sampled along each segment (endpoints included) with a descriptor at each,
//!   oriented along the segment.
//!
//! The [`FrontEnd`] trait (`frontend.rs`) is the one interface the trainer, the
//! predictor and `pl2map features` use; [`SiftFrontEnd`] implements it with the above,
//! and the `superpoint` crate adds the SuperPoint kind.
//!
//! Every coordinate this crate returns or takes follows COLMAP's convention (centre of
//! the top-left pixel at (0.5, 0.5)); OpenCV's integer-centre coordinates are converted
//! here, once, in `convert`.

mod config;
mod convert;
mod dense;
mod error;
mod extract;
mod frontend;
mod image_features;
mod kind;
mod lines;
mod lsd;
mod resize;
mod sift;

pub use config::{
    DescriptorConfig, DescriptorMethod, FrontEndConfig, LsdConfig, LsdImplementation,
    SUPERPOINT_WEIGHTS_ENV, SiftConfig, SuperPointConfig,
};
pub use convert::{decode_gray, gray_from_rgb, load_gray};
pub use dense::{DenseMap, OrientedGradients};
pub use error::FeatureError;
pub use extract::{describe_points_and_lines, extract, extract_batch, extract_per_call};
/// Reading image files within bounds and the pixel limit (`fileio::image`), for the
/// crates above this one that read images.
pub use fileio::image as image_file;
pub use frontend::{Described, FrontEnd, LabelledImage, SiftFrontEnd};
pub use image_features::{Detections, ImageFeatures};
pub use kind::{FrontEndKind, SUPERPOINT_DIM};
pub use lines::{describe_lines, sample_points};
pub use lsd::detect_segments;
pub use resize::{gray_f32, resize_area};
pub use sift::{Keypoint, describe_points, detect_keypoints};

/// SIFT descriptor dimension.
pub const SIFT_DIM: usize = 128;
