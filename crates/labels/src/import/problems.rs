//! Everything that makes import input inconsistent. The import collects all of them
//! before refusing, so one run shows every problem of its inputs (their text is in
//! crates/labels/src/import/problem_messages.rs).

use serde::Serialize;

/// One disagreement between the frames table, the COLMAP model and the LIMAP folder.
/// Tracks are LIMAP finaltracks indices (`track_<i>.txt`), LIMAP ids are the ids of
/// `image_list.txt`, model ids COLMAP image ids.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ImportProblem {
    NoTrainingFrames,
    ModelNameUnmappable {
        image_id: u32,
        name: String,
        reason: String,
    },
    ModelImageNotInDataset {
        image_id: u32,
        name: String,
        mapped: String,
    },
    ModelImageIsTestFrame {
        image_id: u32,
        name: String,
        frame_id: u32,
    },
    DuplicateModelName {
        mapped: String,
        first_image_id: u32,
        second_image_id: u32,
    },
    TrainFrameNotInModel {
        frame_id: u32,
        name: String,
    },
    UnknownCamera {
        image_id: u32,
        camera_id: u32,
    },
    InvalidModelPose {
        image_id: u32,
        reason: String,
    },
    UnknownPoint3d {
        image_id: u32,
        kp_index: usize,
        point3d_id: u64,
    },
    CameraSizeMismatch {
        frame_id: u32,
        name: String,
        model: (u64, u64),
        frame: (u32, u32),
    },
    KeypointsOutsideImage {
        frame_id: u32,
        name: String,
        count: usize,
        first_index: usize,
        first: [f64; 2],
        size: (u64, u64),
    },
    LimapNameUnmappable {
        limap_image_id: u32,
        name: String,
        reason: String,
    },
    LimapImageNotInDataset {
        limap_image_id: u32,
        name: String,
        mapped: String,
    },
    LimapImageIsTestFrame {
        limap_image_id: u32,
        name: String,
        frame_id: u32,
    },
    DuplicateLimapName {
        mapped: String,
        first_limap_image_id: u32,
        second_limap_image_id: u32,
    },
    TrainFrameNotInLimap {
        frame_id: u32,
        name: String,
    },
    TrainFrameWithoutSegments {
        frame_id: u32,
        name: String,
        limap_image_id: u32,
    },
    /// `first_track == second_track`: one track lists the segment twice.
    SegmentInTwoTracks {
        limap_image_id: u32,
        line_id: u32,
        first_track: usize,
        second_track: usize,
    },
    UnknownLimapImage {
        track: usize,
        support: usize,
        limap_image_id: u32,
    },
    MissingSegmentsFile {
        track: usize,
        support: usize,
        limap_image_id: u32,
    },
    UnknownLineId {
        track: usize,
        support: usize,
        limap_image_id: u32,
        line_id: u32,
        n_segments: usize,
    },
    TrackSegmentMismatch {
        track: usize,
        support: usize,
        limap_image_id: u32,
        line_id: u32,
        max_difference_px: f64,
    },
    Alltracks {
        message: String,
    },
    SegmentsOutsideImage {
        frame_id: u32,
        name: String,
        count: usize,
        first_index: usize,
        first: [f64; 4],
        size: (u64, u64),
        /// How far (pixels) the farthest endpoint of the frame lies past the border.
        max_overshoot_px: f64,
    },
}

/// How far past the image border LSD puts segment endpoints: pytlsd (LIMAP's `lsd`)
/// detects on the image scaled by 0.8 and extends a segment to its support rectangle, so
/// an endpoint of a segment along the border lands up to about this far outside (1.0 px
/// on LIMAP 2.0's output of the tiny synthetic scene, 2.7 px on the 200-image room;
/// docs/formats.md section 2). Segments farther out than this point at a wrong scale.
pub const LSD_OVERSHOOT_PX: f64 = 3.0;

impl ImportProblem {
    /// A stable name of the kind of problem (the serde tag), for grouping.
    pub fn kind(&self) -> &'static str {
        use ImportProblem::*;
        match self {
            NoTrainingFrames => "no_training_frames",
            ModelNameUnmappable { .. } => "model_name_unmappable",
            ModelImageNotInDataset { .. } => "model_image_not_in_dataset",
            ModelImageIsTestFrame { .. } => "model_image_is_test_frame",
            DuplicateModelName { .. } => "duplicate_model_name",
            TrainFrameNotInModel { .. } => "train_frame_not_in_model",
            UnknownCamera { .. } => "unknown_camera",
            InvalidModelPose { .. } => "invalid_model_pose",
            UnknownPoint3d { .. } => "unknown_point3d",
            CameraSizeMismatch { .. } => "camera_size_mismatch",
            KeypointsOutsideImage { .. } => "keypoints_outside_image",
            LimapNameUnmappable { .. } => "limap_name_unmappable",
            LimapImageNotInDataset { .. } => "limap_image_not_in_dataset",
            LimapImageIsTestFrame { .. } => "limap_image_is_test_frame",
            DuplicateLimapName { .. } => "duplicate_limap_name",
            TrainFrameNotInLimap { .. } => "train_frame_not_in_limap",
            TrainFrameWithoutSegments { .. } => "train_frame_without_segments",
            SegmentInTwoTracks { .. } => "segment_in_two_tracks",
            UnknownLimapImage { .. } => "unknown_limap_image",
            MissingSegmentsFile { .. } => "missing_segments_file",
            UnknownLineId { .. } => "unknown_line_id",
            TrackSegmentMismatch { .. } => "track_segment_mismatch",
            Alltracks { .. } => "alltracks",
            SegmentsOutsideImage { .. } => "segments_outside_image",
        }
    }

    /// The import's version of a LIMAP folder error; None for LIMAP's warnings, which
    /// the import checks itself where they matter (training images without segments).
    pub fn from_limap(p: &limap::Problem) -> Option<ImportProblem> {
        use limap::Problem as L;
        Some(match p {
            L::UnknownImage {
                track,
                support,
                image_id,
            } => ImportProblem::UnknownLimapImage {
                track: *track,
                support: *support,
                limap_image_id: *image_id,
            },
            L::NoSegmentsFile {
                track,
                support,
                image_id,
            } => ImportProblem::MissingSegmentsFile {
                track: *track,
                support: *support,
                limap_image_id: *image_id,
            },
            L::LineIdOutOfRange {
                track,
                support,
                image_id,
                line_id,
                n_segments,
            } => ImportProblem::UnknownLineId {
                track: *track,
                support: *support,
                limap_image_id: *image_id,
                line_id: *line_id,
                n_segments: *n_segments,
            },
            L::DuplicateSupport {
                image_id,
                line_id,
                first,
                second,
            } => ImportProblem::SegmentInTwoTracks {
                limap_image_id: *image_id,
                line_id: *line_id,
                first_track: *first,
                second_track: *second,
            },
            L::Line2dMismatch {
                track,
                support,
                image_id,
                line_id,
                max_difference,
            } => ImportProblem::TrackSegmentMismatch {
                track: *track,
                support: *support,
                limap_image_id: *image_id,
                line_id: *line_id,
                max_difference_px: *max_difference,
            },
            L::AlltracksCount { .. } | L::AlltracksMismatch { .. } => ImportProblem::Alltracks {
                message: p.to_string(),
            },
            L::ImageWithoutSegments { .. } | L::SegmentsOfUnlistedImage { .. } => return None,
        })
    }
}
