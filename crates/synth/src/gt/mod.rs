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

mod error;
mod frame;
mod lines;
pub mod noise;
mod points;
mod write;

pub use error::GtError;
pub use frame::{FrameObservations, KeypointObs, SegmentObs, observe_frame};
pub use lines::LineTrackGt;
pub use points::PointTrack;
pub use write::{EXACT_FILE, GT_DIR, write};

use super::generate::SynthDataset;

/// Tolerances of the labelling. The defaults are those the tests and the CLI use.
#[derive(Clone, Debug, PartialEq)]
pub struct GtConfig {
    /// Front-end settings: SIFT top-K (4096, the training configuration), the fixed
    /// descriptor scale and LSD.
    pub features: features::FrontEndConfig,
    /// Offset (pixels) of the four extra rays cast around a keypoint to detect depth
    /// discontinuities.
    pub discontinuity_offset_px: f64,
    /// A keypoint is kept when the four offset hits lie on its hit's plane (same normal,
    /// distance within this fraction of its depth: 1 mm at 2 m). A plane test rather than
    /// a depth comparison: slanted floors pass, creases, silhouettes and the 3 mm step of a
    /// poster's border fail.
    pub discontinuity_rel: f64,
    /// Surface points of two keypoints closer than this (metres) may form a track.
    pub point_tolerance_m: f64,
    /// L2 distance of unit-norm SIFT descriptors below which two keypoints may match.
    pub max_descriptor_distance: f32,
    /// Observations reprojecting farther than this (pixels) leave their track.
    pub max_reprojection_px: f64,
    /// Segment-edge association: maximum angle (degrees) ...
    pub max_line_angle_deg: f64,
    /// ... and perpendicular distance (pixels) of both segment endpoints to the
    /// projected edge.
    pub max_line_distance_px: f64,
    /// Line tracks need at least this many distinct images.
    pub min_line_images: usize,
    /// Standard deviation of the label noise, as RMS 3D error in centimetres (0 = exact).
    pub label_noise_cm: f64,
}

impl Default for GtConfig {
    fn default() -> Self {
        GtConfig {
            features: features::FrontEndConfig::default(),
            discontinuity_offset_px: 1.5,
            discontinuity_rel: 5e-4,
            point_tolerance_m: 0.01,
            max_descriptor_distance: 0.7,
            max_reprojection_px: 0.5,
            max_line_angle_deg: 2.0,
            max_line_distance_px: 1.5,
            min_line_images: 4,
            label_noise_cm: 0.0,
        }
    }
}

impl GtConfig {
    pub fn validate(&self) -> Result<(), GtError> {
        let bad = |m: &str| Err(GtError::Config(m.to_string()));
        self.features
            .validate()
            .map_err(|e| GtError::Config(e.to_string()))?;
        if !(self.label_noise_cm >= 0.0 && self.label_noise_cm.is_finite()) {
            return bad("label_noise_cm must be finite and >= 0");
        }
        if !(self.point_tolerance_m > 0.0 && self.point_tolerance_m.is_finite()) {
            return bad("point_tolerance_m must be finite and > 0");
        }
        if !(self.max_reprojection_px > 0.0
            && self.max_line_distance_px > 0.0
            && self.max_line_angle_deg > 0.0
            && self.discontinuity_offset_px > 0.0
            && self.discontinuity_rel > 0.0)
        {
            return bad("tolerances must be > 0");
        }
        if self.max_descriptor_distance.is_nan() || self.max_descriptor_distance <= 0.0 {
            return bad("max_descriptor_distance must be > 0");
        }
        if self.min_line_images < 2 {
            return bad("min_line_images must be >= 2");
        }
        Ok(())
    }
}

/// One training image of the model: COLMAP/LIMAP image id (1-based, training order),
/// its frame and name.
#[derive(Clone, Debug, PartialEq)]
pub struct GtImage {
    pub image_id: u32,
    /// Index into [`SynthDataset::frames`].
    pub frame: usize,
    pub name: String,
}

/// The exact labels of the training frames, before noise and writing.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    pub images: Vec<GtImage>,
    /// Per image (parallel to `images`): its keypoints and segments.
    pub observations: Vec<FrameObservations>,
    /// 3D point tracks; point3D id = position + 1.
    pub points: Vec<PointTrack>,
    /// Line tracks in edge order; track file index = position.
    pub lines: Vec<LineTrackGt>,
}

/// Counts printed by the CLI.
#[derive(Clone, Debug, PartialEq)]
pub struct GtSummary {
    pub images: usize,
    pub keypoints: usize,
    pub points3d: usize,
    pub observations: usize,
    pub mean_track_length: f64,
    pub segments: usize,
    pub line_tracks: usize,
    pub line_supports: usize,
}

impl GroundTruth {
    pub fn summary(&self) -> GtSummary {
        let observations: usize = self.points.iter().map(|p| p.track.len()).sum();
        GtSummary {
            images: self.images.len(),
            keypoints: self.observations.iter().map(|o| o.keypoints.len()).sum(),
            points3d: self.points.len(),
            observations,
            mean_track_length: if self.points.is_empty() {
                0.0
            } else {
                observations as f64 / self.points.len() as f64
            },
            segments: self.observations.iter().map(|o| o.segments.len()).sum(),
            line_tracks: self.lines.len(),
            line_supports: self.lines.iter().map(|l| l.supports.len()).sum(),
        }
    }
}

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
