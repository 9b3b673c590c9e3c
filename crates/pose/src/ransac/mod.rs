//! Hybrid LO-RANSAC for the absolute pose from point and line correspondences.
//!
//! 1. Every observation is lifted to the normalised, undistorted image plane with the
//!    camera model (crates/pose/src/normalized.rs); pixel thresholds become
//!    `px / mean focal length`.
//! 2. Each iteration draws a minimal solver (P3P, P2P1LL, P1P2LL, P3LL) by the available
//!    counts and current inlier ratios (`sampler.rs`), solves a random sample and scores
//!    every solution with MSAC (squared errors capped at the squared threshold). A point's
//!    error is its reprojection error; a line's is the sum of the distances of the two
//!    detected endpoints to the projected world line.
//! 3. Local optimisation: whenever a minimal model has more inliers than any before,
//!    Levenberg-Marquardt with the truncated (MSAC) loss refines it on all
//!    correspondences (as PoseLib does).
//! 4. Adaptive stopping between `min_iterations` and `max_iterations` for the requested
//!    success probability. Steps 2 to 4 are `search.rs`.
//! 5. The best model is refined once more with the truncated loss, then on its inliers,
//!    points and lines jointly, with a Cauchy loss (`finish.rs`).
//! 6. Inlier masks and errors are reported in pixels with the real camera model
//!    (`estimate.rs`).
//!
//! Deterministic: the same inputs, options and seed give the same result.

mod estimate;
mod finish;
mod options;
mod sampler;
mod score;
mod search;

pub use estimate::PoseEstimate;
pub use options::RansacOptions;

use crate::error::PoseError;
use crate::matches::{LineMatch, PointMatch};
use crate::normalized::normalize;
use crate::refine::{Loss, Refinement};
use geometry::Camera;
use sampler::Sampler;
use score::Thresholds;

/// Estimates the world-to-camera pose of `camera` from point and line matches (either
/// may be empty). Errors when the camera has no image plane, the options are invalid,
/// fewer than 3 correspondences are usable, or no minimal sample gave a model.
pub fn estimate_pose(
    camera: &Camera,
    points: &[PointMatch],
    lines: &[LineMatch],
    opt: &RansacOptions,
) -> Result<PoseEstimate, PoseError> {
    opt.validate()?;
    if !camera.model.is_perspective() {
        return Err(PoseError::UnsupportedCamera(camera.model.name()));
    }
    // Step 1.
    let data = normalize(camera, points, lines);
    let (pts, lns) = (&data.points, &data.lines);
    let num_unusable = points.len() + lines.len() - pts.len() - lns.len();
    let sampler = Sampler::new(pts.len(), lns.len());
    if !sampler.feasible() {
        return Err(PoseError::NotEnoughCorrespondences {
            points: pts.len(),
            lines: lns.len(),
            invalid: num_unusable,
        });
    }
    let th = thresholds(camera, opt);
    let lo = local_optimisation(&th, opt);

    // Steps 2 to 4.
    let found = search::search(&sampler, pts, lns, &th, &lo, opt);
    let Some((model, best_score)) = found.best else {
        return Err(PoseError::NoModel {
            iterations: found.iterations,
        });
    };

    // Step 5.
    let model = finish::optimise_last(model, &best_score, pts, lns, &th, &lo);
    let model = finish::refine_on_inliers(model, pts, lns, &th, &final_refinement(camera, opt));

    // Step 6.
    let pose = model.to_pose();
    let (point_errors_px, line_errors_px) =
        estimate::pixel_errors(camera, &pose, points, lines, &data);
    let point_inliers = estimate::below(&point_errors_px, opt.point_threshold_px);
    let line_inliers = estimate::below(&line_errors_px, opt.line_threshold_px);
    Ok(PoseEstimate {
        pose,
        num_point_inliers: point_inliers.iter().filter(|&&b| b).count(),
        num_line_inliers: line_inliers.iter().filter(|&&b| b).count(),
        point_errors_px,
        line_errors_px,
        point_inliers,
        line_inliers,
        iterations: found.iterations,
        // The last local optimisation of step 5 counts too.
        refinements: found.refinements + 1,
        samples_per_solver: found.samples_per_solver,
        num_unusable,
    })
}

/// The inlier thresholds on the normalised plane, squared.
fn thresholds(camera: &Camera, opt: &RansacOptions) -> Thresholds {
    let tp = camera.cam_from_img_threshold(opt.point_threshold_px);
    let tl = camera.cam_from_img_threshold(opt.line_threshold_px);
    Thresholds {
        point_sq: tp * tp,
        line_sq: tl * tl,
    }
}

/// The local optimisation: the MSAC cost (the truncated loss) on all correspondences.
fn local_optimisation(th: &Thresholds, opt: &RansacOptions) -> Refinement {
    Refinement {
        point_loss: Loss::Truncated { cap: th.point_sq },
        line_loss: Loss::Truncated { cap: th.line_sq },
        max_iterations: opt.lo_iterations,
    }
}

/// The final refinement on the inliers: Cauchy losses of the options' scales.
fn final_refinement(camera: &Camera, opt: &RansacOptions) -> Refinement {
    let cp = camera.cam_from_img_threshold(opt.point_loss_scale_px);
    let cl = camera.cam_from_img_threshold(opt.line_loss_scale_px);
    Refinement {
        point_loss: Loss::Cauchy { scale_sq: cp * cp },
        line_loss: Loss::Cauchy { scale_sq: cl * cl },
        max_iterations: opt.refine_iterations,
    }
}
