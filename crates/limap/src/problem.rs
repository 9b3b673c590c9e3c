//! What a consistency check finds: a [`Problem`] between files and its [`Severity`].
//! Their own file because both the checks (`check.rs`) and the error of a folder that
//! fails them (`error.rs`, [`crate::LimapError::Inconsistent`]) hold problems.

use std::fmt;

use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    Error,
    Warning,
}

/// One disagreement between files. Tracks are finaltracks indices (`track_<i>.txt`).
#[derive(Debug, Clone, PartialEq)]
pub enum Problem {
    UnknownImage {
        track: usize,
        support: usize,
        image_id: u32,
    },
    NoSegmentsFile {
        track: usize,
        support: usize,
        image_id: u32,
    },
    LineIdOutOfRange {
        track: usize,
        support: usize,
        image_id: u32,
        line_id: u32,
        n_segments: usize,
    },
    /// `first == second` when one track lists the same support twice.
    DuplicateSupport {
        image_id: u32,
        line_id: u32,
        first: usize,
        second: usize,
    },
    Line2dMismatch {
        track: usize,
        support: usize,
        image_id: u32,
        line_id: u32,
        max_difference: f64,
    },
    AlltracksCount {
        alltracks: usize,
        expected: usize,
    },
    AlltracksMismatch {
        alltracks_id: usize,
        track: usize,
        what: String,
    },
    ImageWithoutSegments {
        image_id: u32,
    },
    SegmentsOfUnlistedImage {
        image_id: u32,
    },
}

impl Problem {
    pub fn severity(&self) -> Severity {
        match self {
            Problem::ImageWithoutSegments { .. } | Problem::SegmentsOfUnlistedImage { .. } => {
                Severity::Warning
            }
            _ => Severity::Error,
        }
    }
}

fn track_file(i: usize) -> String {
    format!("track_{i}.txt")
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::UnknownImage {
                track,
                support,
                image_id,
            } => write!(
                f,
                "{}: support {support} is in image {image_id}, which image_list.txt does not list",
                track_file(*track)
            ),
            Problem::NoSegmentsFile {
                track,
                support,
                image_id,
            } => write!(
                f,
                "{}: support {support} is in image {image_id}, which has no segments_{image_id}.txt",
                track_file(*track)
            ),
            Problem::LineIdOutOfRange {
                track,
                support,
                image_id,
                line_id,
                n_segments,
            } => write!(
                f,
                "{}: support {support} has line id {line_id}, but segments_{image_id}.txt has \
                 {n_segments} segments (ids 0..{n_segments})",
                track_file(*track)
            ),
            Problem::DuplicateSupport {
                image_id,
                line_id,
                first,
                second,
            } => {
                if first == second {
                    write!(
                        f,
                        "{} lists the support (image {image_id}, line {line_id}) twice",
                        track_file(*first)
                    )
                } else {
                    write!(
                        f,
                        "the support (image {image_id}, line {line_id}) is claimed by both {} and {}",
                        track_file(*first),
                        track_file(*second)
                    )
                }
            }
            Problem::Line2dMismatch {
                track,
                support,
                image_id,
                line_id,
                max_difference,
            } => write!(
                f,
                "{}: support {support} (image {image_id}, line {line_id}) differs from row \
                 {line_id} of segments_{image_id}.txt by up to {max_difference:.3e} px",
                track_file(*track)
            ),
            Problem::AlltracksCount {
                alltracks,
                expected,
            } => write!(
                f,
                "alltracks.txt has {alltracks} tracks, but {expected} finaltracks are seen in >= 4 images"
            ),
            Problem::AlltracksMismatch {
                alltracks_id,
                track,
                what,
            } => write!(
                f,
                "alltracks.txt track {alltracks_id} differs from {} (the finaltrack it should \
                 copy): {what}",
                track_file(*track)
            ),
            Problem::ImageWithoutSegments { image_id } => write!(
                f,
                "image {image_id} is listed in image_list.txt but has no segments_{image_id}.txt"
            ),
            Problem::SegmentsOfUnlistedImage { image_id } => write!(
                f,
                "segments_{image_id}.txt belongs to no image of image_list.txt"
            ),
        }
    }
}
