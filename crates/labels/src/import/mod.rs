//! The import stage's steps: COLMAP model + LIMAP folder + frames table -> label tables.
//! The stage itself (its folder, record and skip) is [`crate::import_stage`].
//!
//! Per training frame (docs/method.md section 3):
//! - points: every keypoint of the image in the model (COLMAP points2D, COLMAP pixels),
//!   its point3D id and xyz, or no label;
//! - lines: every segment of LIMAP's `segments_<LIMAP image id>.txt` (times
//!   [`ImportConfig::segment_scale`]), the track that lists it among its supports and the
//!   track's 3D endpoints ordered to follow the segment ([`crate::align`]), or no label;
//! - the camera and pose the labels go with: the model's (default, as the reference
//!   implementation) or the frames table's ([`PoseSource`](tables::labels::PoseSource)).
//!
//! Images are joined by name through explicit [`NameMapping`](crate::NameMapping)s (one
//! for the model, one for LIMAP's image_list.txt). Inconsistent input is refused with
//! every problem listed ([`ImportProblem`]); the disagreement between SfM and dataset
//! poses is reported.

mod build;
mod config;
mod detected;
mod detector_report;
mod detectors;
mod error;
pub(crate) mod inputs;
mod join;
mod labelling;
pub(crate) mod make_labels;
mod problem_messages;
mod problems;
mod report;

pub use build::build;
pub use config::{ImportConfig, LineTrackSet};
pub use detected::{DETECTED_RADIUS_PX, DetectedLabelsReport, PointLabels, detected_rows};
pub use detector_report::DetectorCheckReport;
pub use detectors::{
    DetectorCheck, MATCH_RADIUS_PX, MIN_KEYPOINT_RATE, MIN_SEGMENT_RATE, MakeFrontEnd,
    SAMPLE_IMAGES, keypoints_near, matched_keypoints, matched_segments, sift_only,
};
pub use error::ImportError;
pub use problem_messages::{EXAMPLES_PER_KIND, summarize};
pub use problems::ImportProblem;
pub use report::{
    ImportReport, LimapCounts, LineCounts, ModelCounts, PointCounts, PoseDisagreement,
};
