use thiserror::Error;

/// Why a pose could not be estimated.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PoseError {
    #[error("camera model {0} has no image plane; pose estimation needs a perspective model")]
    UnsupportedCamera(&'static str),
    #[error("invalid RANSAC option: {0}")]
    InvalidOptions(String),
    #[error(
        "not enough usable correspondences for any minimal solver: {points} points and {lines} lines \
         (3 in total are needed; {invalid} could not be lifted to the normalised image plane or are degenerate)"
    )]
    NotEnoughCorrespondences {
        points: usize,
        lines: usize,
        invalid: usize,
    },
    #[error(
        "RANSAC found no pose after {iterations} iterations (every minimal sample was degenerate)"
    )]
    NoModel { iterations: usize },
}
