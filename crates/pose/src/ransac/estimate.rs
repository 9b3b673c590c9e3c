//! What [`crate::estimate_pose`] returns, and its last step (step 6 of the module docs):
//! every input correspondence's error and inlier flag in pixels, with the real camera
//! model.

use crate::matches::{LineMatch, PointMatch};
use crate::normalized::{Normalized, line_error_px, point_error_px};
use geometry::{Camera, Pose};

/// The estimated pose and what supports it.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseEstimate {
    /// World-to-camera.
    pub pose: Pose,
    /// Per input point: reprojection error in pixels under `pose` (infinite when
    /// behind the camera, not projectable or not usable).
    pub point_errors_px: Vec<f64>,
    /// Per input line: sum of endpoint distances in pixels (infinite as above).
    pub line_errors_px: Vec<f64>,
    /// `error < threshold`, per input correspondence.
    pub point_inliers: Vec<bool>,
    pub line_inliers: Vec<bool>,
    pub num_point_inliers: usize,
    pub num_line_inliers: usize,
    /// RANSAC iterations (minimal samples drawn).
    pub iterations: usize,
    /// Local optimisations run.
    pub refinements: usize,
    /// Samples drawn per solver: P3P, P2P1LL, P1P2LL, P3LL.
    pub samples_per_solver: [usize; 4],
    /// Correspondences left out because they could not be lifted to the normalised
    /// image plane or are degenerate (zero-length segments, non-finite values).
    pub num_unusable: usize,
}

/// The pixel errors of every input point and line under `pose`, in input order.
/// Correspondences RANSAC could not use (not in `data`) keep an infinite error, so
/// they are never inliers.
pub(super) fn pixel_errors(
    camera: &Camera,
    pose: &Pose,
    points: &[PointMatch],
    lines: &[LineMatch],
    data: &Normalized,
) -> (Vec<f64>, Vec<f64>) {
    let mut point_errors_px = vec![f64::INFINITY; points.len()];
    for &i in &data.point_index {
        point_errors_px[i] = point_error_px(camera, pose, &points[i]);
    }
    let mut line_errors_px = vec![f64::INFINITY; lines.len()];
    for &i in &data.line_index {
        line_errors_px[i] = line_error_px(camera, pose, &lines[i]);
    }
    (point_errors_px, line_errors_px)
}

/// `error < threshold` per error.
pub(super) fn below(errors: &[f64], threshold: f64) -> Vec<bool> {
    errors.iter().map(|&e| e < threshold).collect()
}
