//! The text of every import problem (crates/labels/src/import/problems.rs) and the
//! error message that lists them.

use super::problems::{ImportProblem, LSD_OVERSHOOT_PX};
use std::fmt;

fn track_file(i: usize) -> String {
    format!("track_{i}.txt")
}

impl fmt::Display for ImportProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        // One group of problems per function; every variant is named here, so a new one
        // has to be given its group.
        match self {
            NoTrainingFrames => write!(f, "the frames table has no training frames"),
            ModelNameUnmappable { .. }
            | ModelImageNotInDataset { .. }
            | ModelImageIsTestFrame { .. }
            | DuplicateModelName { .. }
            | TrainFrameNotInModel { .. }
            | UnknownCamera { .. }
            | InvalidModelPose { .. }
            | UnknownPoint3d { .. } => self.fmt_model_image(f),
            LimapNameUnmappable { .. }
            | LimapImageNotInDataset { .. }
            | LimapImageIsTestFrame { .. }
            | DuplicateLimapName { .. }
            | TrainFrameNotInLimap { .. }
            | TrainFrameWithoutSegments { .. } => self.fmt_limap_image(f),
            SegmentInTwoTracks { .. } | Alltracks { .. } => self.fmt_track_set(f),
            UnknownLimapImage { .. }
            | MissingSegmentsFile { .. }
            | UnknownLineId { .. }
            | TrackSegmentMismatch { .. } => self.fmt_track_support(f),
            CameraSizeMismatch { .. }
            | KeypointsOutsideImage { .. }
            | SegmentsOutsideImage { .. } => self.fmt_bounds(f),
        }
    }
}

impl ImportProblem {
    /// A model image or a training frame against the model: names, cameras, poses, points.
    fn fmt_model_image(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        match self {
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
            _ => unreachable!("not a model image problem: {}", self.kind()),
        }
    }

    /// A LIMAP image or a training frame against LIMAP's image list.
    fn fmt_limap_image(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        match self {
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
            _ => unreachable!("not a limap image problem: {}", self.kind()),
        }
    }

    /// Two tracks claim one segment, or the track set disagrees with alltracks.txt.
    fn fmt_track_set(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        match self {
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
            Alltracks { message } => f.write_str(message),
            _ => unreachable!("not a track set problem: {}", self.kind()),
        }
    }

    /// A support of a LIMAP track against LIMAP's images and segments.
    fn fmt_track_support(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        match self {
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
            _ => unreachable!("not a track support problem: {}", self.kind()),
        }
    }

    /// A training frame's keypoints or segments against its image size.
    fn fmt_bounds(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ImportProblem::*;
        match self {
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
            _ => unreachable!("not a bounds problem: {}", self.kind()),
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
