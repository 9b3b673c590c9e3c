//! Everything that makes import input inconsistent. The import collects all of them
//! before refusing, so one run shows every problem of its inputs.

use serde::Serialize;
use std::fmt;

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

fn track_file(i: usize) -> String {
    format!("track_{i}.txt")
}

impl fmt::Display for ImportProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        match self {
            NoTrainingFrames => write!(f, "the frames table has no training frames"),
            ModelNameUnmappable {
                image_id,
                name,
                reason,
            } => write!(
                f,
                "model image {image_id} {name:?}: the model name mapping does not apply: it {reason}"
            ),
            ModelImageNotInDataset {
                image_id,
                name,
                mapped,
            } => write!(
                f,
                "model image {image_id} {name:?} (as dataset name {mapped:?}) is not in the frames table"
            ),
            ModelImageIsTestFrame {
                image_id,
                name,
                frame_id,
            } => write!(
                f,
                "model image {image_id} {name:?} is test frame {frame_id}: a model built with test \
                 images leaks them into the training labels"
            ),
            DuplicateModelName {
                mapped,
                first_image_id,
                second_image_id,
            } => write!(
                f,
                "model images {first_image_id} and {second_image_id} both map to the dataset name {mapped:?}"
            ),
            TrainFrameNotInModel { frame_id, name } => write!(
                f,
                "training frame {frame_id} {name:?} is not registered in the model"
            ),
            UnknownCamera {
                image_id,
                camera_id,
            } => write!(
                f,
                "model image {image_id} uses camera {camera_id}, which the model does not have"
            ),
            InvalidModelPose { image_id, reason } => {
                write!(f, "model image {image_id}: invalid pose: {reason}")
            }
            UnknownPoint3d {
                image_id,
                kp_index,
                point3d_id,
            } => write!(
                f,
                "model image {image_id}, keypoint {kp_index}: point3D id {point3d_id} is not in points3D"
            ),
            CameraSizeMismatch {
                frame_id,
                name,
                model,
                frame,
            } => write!(
                f,
                "training frame {frame_id} {name:?}: the model's camera is {}x{} but the image is {}x{} \
                 (the keypoints would be in another resolution)",
                model.0, model.1, frame.0, frame.1
            ),
            KeypointsOutsideImage {
                frame_id,
                name,
                count,
                first_index,
                first,
                size,
            } => write!(
                f,
                "training frame {frame_id} {name:?}: {count} keypoint(s) outside the {}x{} image, \
                 first #{first_index} at ({}, {})",
                size.0, size.1, first[0], first[1]
            ),
            LimapNameUnmappable {
                limap_image_id,
                name,
                reason,
            } => write!(
                f,
                "LIMAP image {limap_image_id} {name:?}: the LIMAP name mapping does not apply: it {reason}"
            ),
            LimapImageNotInDataset {
                limap_image_id,
                name,
                mapped,
            } => write!(
                f,
                "LIMAP image {limap_image_id} {name:?} (as dataset name {mapped:?}) is not in the frames table"
            ),
            LimapImageIsTestFrame {
                limap_image_id,
                name,
                frame_id,
            } => write!(
                f,
                "LIMAP image {limap_image_id} {name:?} is test frame {frame_id}: line tracks built with \
                 test images leak them into the training labels"
            ),
            DuplicateLimapName {
                mapped,
                first_limap_image_id,
                second_limap_image_id,
            } => write!(
                f,
                "LIMAP images {first_limap_image_id} and {second_limap_image_id} both map to the dataset \
                 name {mapped:?}"
            ),
            TrainFrameNotInLimap { frame_id, name } => write!(
                f,
                "training frame {frame_id} {name:?} is not in LIMAP's image_list.txt"
            ),
            TrainFrameWithoutSegments {
                frame_id,
                name,
                limap_image_id,
            } => write!(
                f,
                "training frame {frame_id} {name:?} (LIMAP image {limap_image_id}) has no \
                 segments_{limap_image_id}.txt"
            ),
            SegmentInTwoTracks {
                limap_image_id,
                line_id,
                first_track,
                second_track,
            } => {
                if first_track == second_track {
                    write!(
                        f,
                        "segment {line_id} of LIMAP image {limap_image_id} is listed twice by {}",
                        track_file(*first_track)
                    )
                } else {
                    write!(
                        f,
                        "segment {line_id} of LIMAP image {limap_image_id} is in two tracks: {} and {}",
                        track_file(*first_track),
                        track_file(*second_track)
                    )
                }
            }
            UnknownLimapImage {
                track,
                support,
                limap_image_id,
            } => write!(
                f,
                "{} support {support}: LIMAP image id {limap_image_id} is not in image_list.txt",
                track_file(*track)
            ),
            MissingSegmentsFile {
                track,
                support,
                limap_image_id,
            } => write!(
                f,
                "{} support {support}: LIMAP image {limap_image_id} has no segments_{limap_image_id}.txt",
                track_file(*track)
            ),
            UnknownLineId {
                track,
                support,
                limap_image_id,
                line_id,
                n_segments,
            } => write!(
                f,
                "{} support {support}: line id {line_id} is not a row of segments_{limap_image_id}.txt \
                 ({n_segments} segments)",
                track_file(*track)
            ),
            TrackSegmentMismatch {
                track,
                support,
                limap_image_id,
                line_id,
                max_difference_px,
            } => write!(
                f,
                "{} support {support}: its 2D segment differs from row {line_id} of \
                 segments_{limap_image_id}.txt by {max_difference_px:.3e} px (segments from another run?)",
                track_file(*track)
            ),
            Alltracks { message } => f.write_str(message),
            SegmentsOutsideImage {
                frame_id,
                name,
                count,
                first_index,
                first,
                size,
                max_overshoot_px,
            } => {
                write!(
                    f,
                    "training frame {frame_id} {name:?}: {count} segment(s) outside the {}x{} image, \
                     first #{first_index} ({}, {}, {}, {}), the farthest endpoint {max_overshoot_px:.2} px \
                     past the border ",
                    size.0, size.1, first[0], first[1], first[2], first[3]
                )?;
                if *max_overshoot_px <= LSD_OVERSHOOT_PX {
                    write!(
                        f,
                        "(LSD puts endpoints up to about {LSD_OVERSHOOT_PX} px past the border: \
                         import with bounds_tolerance_px = {LSD_OVERSHOOT_PX} \
                         (--bounds-tolerance-px {LSD_OVERSHOOT_PX}))"
                    )
                } else {
                    f.write_str("(LIMAP rescales images to max_image_dim: set the segment scale)")
                }
            }
        }
    }
}

/// How many examples of each kind the error message shows (the error holds all).
pub const EXAMPLES_PER_KIND: usize = 5;

/// The problems grouped by kind, in order of first appearance, each with its count and
/// first examples; `hints` (e.g. what dataset names look like) are printed last.
pub fn summarize(problems: &[ImportProblem], hints: &[String]) -> String {
    let mut kinds: Vec<&'static str> = Vec::new();
    for p in problems {
        if !kinds.contains(&p.kind()) {
            kinds.push(p.kind());
        }
    }
    let mut s = format!(
        "{} problem(s) in the import inputs, of {} kind(s):",
        problems.len(),
        kinds.len()
    );
    for k in kinds {
        let of_kind: Vec<&ImportProblem> = problems.iter().filter(|p| p.kind() == k).collect();
        s.push_str(&format!("\n  {k}: {}", of_kind.len()));
        for p in of_kind.iter().take(EXAMPLES_PER_KIND) {
            s.push_str(&format!("\n    - {p}"));
        }
        if of_kind.len() > EXAMPLES_PER_KIND {
            s.push_str(&format!(
                "\n    - ... and {} more",
                of_kind.len() - EXAMPLES_PER_KIND
            ));
        }
    }
    for h in hints {
        s.push_str(&format!("\n  hint: {h}"));
    }
    s
}
