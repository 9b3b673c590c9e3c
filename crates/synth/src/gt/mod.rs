//! Ground truth of the synthetic room in the formats hloc and LIMAP write: a COLMAP model
//! of the training frames (every SIFT keypoint, 3D points with tracks) and a LIMAP output
//! folder (LSD segments of every training frame, line tracks on the room's exact edges).
//!
//! Labels come from the exact geometry, not from a reconstruction:
//! - a keypoint's 3D point is the ray cast through it; keypoints of different images
//!   join a track when their surface points agree within [`GtConfig::point_tolerance_m`]
//!   and their SIFT descriptors within [`GtConfig::max_descriptor_distance`];
//! - a segment joins the track of the analytic 3D edge it lies on.
//!
//! Work is split as the generator splits it: [`observe_frame`] runs on one rendered
//! training frame (parallel over frames), [`build`] merges the frames in image order
//! (sequential), [`write`] writes `<scene>/sfm_gt/`. The result is a pure function of the
//! dataset and the configuration, whatever the number of threads.
//!
//! Files under `sfm_gt/`:
//! - `colmap/{cameras,images,points3D,rigs,frames}.bin` (hloc writes binary models);
//! - `limap/` (image_list.txt, line_detections/lsd/segments/segments_<id>.txt,
//!   finaltracks/track_<i>.txt, alltracks.txt);
//! - `exact.json`: the noise-free 3D points and line endpoints (see [`noise`]).

mod config;
mod error;
mod frame;
mod ground_truth;
mod lines;
pub mod noise;
mod observations;
mod points;
mod write;

pub use config::GtConfig;
pub use error::GtError;
pub use frame::observe_frame;
pub use ground_truth::{GroundTruth, GtImage, GtSummary};
pub use lines::LineTrackGt;
pub use observations::{FrameObservations, KeypointObs, SegmentObs};
pub use points::PointTrack;
pub use write::{EXACT_FILE, GT_DIR, write};

use crate::dataset::SynthDataset;

/// Merges the per-frame observations (`obs[k]` belongs to `images[k]`, in image order)
/// into point and line tracks. Sequential and ordered: the result does not depend on how
/// the observations were computed in parallel.
pub fn build(
    dataset: &SynthDataset,
    images: Vec<GtImage>,
    observations: Vec<FrameObservations>,
    cfg: &GtConfig,
) -> Result<GroundTruth, GtError> {
    cfg.validate()?;
    if images.len() != observations.len() {
        return Err(GtError::Config(format!(
            "{} images but {} observation sets",
            images.len(),
            observations.len()
        )));
    }
    let poses = images
        .iter()
        .map(|im| {
            dataset
                .frames
                .get(im.frame)
                .map(|f| f.pose)
                .ok_or(GtError::FrameIndex {
                    index: im.frame,
                    count: dataset.frames.len(),
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let points = points::build_tracks(dataset, &poses, &observations, cfg);
    let lines = lines::build_tracks(dataset, &poses, &observations, cfg);
    Ok(GroundTruth {
        images,
        observations,
        points,
        lines,
    })
}
