//! Hybrid LO-RANSAC for the absolute pose from point and line correspondences.
//!
//! 1. Every observation is lifted to the normalised, undistorted image plane with the
//!    camera model; pixel thresholds become `px / mean focal length`.
//! 2. Each iteration draws a minimal solver (P3P, P2P1LL, P1P2LL, P3LL) by the available
//!    counts and current inlier ratios (`sampler.rs`), solves a random sample and scores
//!    every solution with MSAC (squared errors capped at the squared threshold). A point's
//!    error is its reprojection error; a line's is the sum of the distances of the two
//!    detected endpoints to the projected world line.
//! 3. Local optimisation: whenever a minimal model has more inliers than any before,
//!    Levenberg-Marquardt with the truncated (MSAC) loss refines it on all
//!    correspondences (as PoseLib does).
//! 4. Adaptive stopping between `min_iterations` and `max_iterations` for the requested
//!    success probability.
//! 5. The best model is refined once more with the truncated loss, then on its inliers,
//!    points and lines jointly, with a Cauchy loss.
//! 6. Inlier masks and errors are reported in pixels with the real camera model.
//!
//! Deterministic: the same inputs, options and seed give the same result.

pub(crate) mod data;
mod sampler;
mod score;

use crate::error::PoseError;
use crate::refine::{Loss, Refinement, refine};
use crate::rigid::{Rigid, Solutions};
use crate::solvers::{p1p2ll_into, p2p1ll_into, p3ll_into, p3p_into};
use data::{NLine, NPoint, line_error_px, normalize, point_error_px};
use geometry::lines::{Segment2, Segment3};
use geometry::{Camera, Pose};
use nalgebra::{Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sampler::{SOLVERS, Sampler};
use score::{Score, Thresholds, line_sq_error, point_sq_error, score};
use serde::{Deserialize, Serialize};

/// A 2D keypoint (pixels, COLMAP convention) and its 3D world point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointMatch {
    pub pixel: Vector2<f64>,
    pub world: Vector3<f64>,
}

/// A detected 2D segment (pixels) and a 3D world segment on the same line. The
/// endpoints need not correspond: only the lines they span matter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineMatch {
    pub segment: Segment2,
    pub world: Segment3,
}

/// RANSAC and refinement settings. The defaults are the reference evaluation's
/// (docs/method.md section 6) and PoseLib 2.0.5's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RansacOptions {
    /// Inlier threshold on a point's reprojection error, pixels.
    pub point_threshold_px: f64,
    /// Inlier threshold on a line's error (sum of both endpoint distances), pixels.
    pub line_threshold_px: f64,
    pub min_iterations: usize,
    pub max_iterations: usize,
    /// Probability of drawing at least one all-inlier sample before stopping.
    pub success_probability: f64,
    /// Multiplies the number of iterations the success probability asks for (PoseLib's
    /// `dyn_num_trials_mult`, 3 by default).
    pub dynamic_trials_factor: f64,
    pub seed: u64,
    /// LM iterations of each local optimisation inside RANSAC.
    pub lo_iterations: usize,
    /// LM iterations of the final refinement on the inliers.
    pub refine_iterations: usize,
    /// Cauchy loss scale of the final refinement for points, pixels (the reference: 6).
    pub point_loss_scale_px: f64,
    /// Cauchy loss scale for lines, pixels, on the norm of the pair of endpoint
    /// distances. 6 px, the point scale, as PoseLib applies one loss scale to both;
    /// half the line threshold (5 px) measured 1 % worse median translation on the
    /// points + lines benchmark (`pl2map bench pose`).
    pub line_loss_scale_px: f64,
}

impl Default for RansacOptions {
    fn default() -> Self {
        RansacOptions {
            point_threshold_px: 12.0,
            line_threshold_px: 10.0,
            min_iterations: 1000,
            max_iterations: 100_000,
            success_probability: 0.9999,
            dynamic_trials_factor: 3.0,
            seed: 0,
            lo_iterations: 25,
            refine_iterations: 100,
            point_loss_scale_px: 6.0,
            line_loss_scale_px: 6.0,
        }
    }
}

impl RansacOptions {
    /// Refuses options RANSAC cannot run with (thresholds, probability, iterations).
    pub fn validate(&self) -> Result<(), PoseError> {
        let positive = [
            ("point_threshold_px", self.point_threshold_px),
            ("line_threshold_px", self.line_threshold_px),
            ("dynamic_trials_factor", self.dynamic_trials_factor),
            ("point_loss_scale_px", self.point_loss_scale_px),
            ("line_loss_scale_px", self.line_loss_scale_px),
        ];
        for (name, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(PoseError::InvalidOptions(format!(
                    "{name} must be finite and > 0, got {v}"
                )));
            }
        }
        if !(self.success_probability > 0.0 && self.success_probability < 1.0) {
            return Err(PoseError::InvalidOptions(format!(
                "success_probability must be in (0, 1), got {}",
                self.success_probability
            )));
        }
        if self.max_iterations == 0 || self.min_iterations > self.max_iterations {
            return Err(PoseError::InvalidOptions(format!(
                "need 1 <= max_iterations and min_iterations <= max_iterations, got {} and {}",
                self.min_iterations, self.max_iterations
            )));
        }
        Ok(())
    }
}

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

/// Rounds of inlier selection + refinement at the end.
const FINAL_ROUNDS: usize = 3;

/// Solves the minimal sample of solver `s` into `out`.
fn solve_sample(
    s: usize,
    pidx: &[usize; 3],
    lidx: &[usize; 3],
    points: &[NPoint],
    lines: &[NLine],
    out: &mut Solutions,
) {
    let ray = |i: usize| {
        let p = &points[pidx[i]];
        Vector3::new(p.x.x, p.x.y, 1.0)
    };
    let wp = |i: usize| points[pidx[i]].world;
    let ln = |i: usize| &lines[lidx[i]];
    match s {
        0 => p3p_into(&[ray(0), ray(1), ray(2)], &[wp(0), wp(1), wp(2)], out),
        1 => p2p1ll_into(
            &[ray(0), ray(1)],
            &[wp(0), wp(1)],
            &ln(0).normal,
            &ln(0).a,
            &ln(0).dir,
            out,
        ),
        2 => p1p2ll_into(
            &ray(0),
            &wp(0),
            &[ln(0).normal, ln(1).normal],
            &[ln(0).a, ln(1).a],
            &[ln(0).dir, ln(1).dir],
            out,
        ),
        _ => p3ll_into(
            &[ln(0).normal, ln(1).normal, ln(2).normal],
            &[ln(0).a, ln(1).a, ln(2).a],
            &[ln(0).dir, ln(1).dir, ln(2).dir],
            out,
        ),
    }
}

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
    let tp = camera.cam_from_img_threshold(opt.point_threshold_px);
    let tl = camera.cam_from_img_threshold(opt.line_threshold_px);
    let th = Thresholds {
        point_sq: tp * tp,
        line_sq: tl * tl,
    };
    let lo = Refinement {
        point_loss: Loss::Truncated { cap: th.point_sq },
        line_loss: Loss::Truncated { cap: th.line_sq },
        max_iterations: opt.lo_iterations,
    };
    let stop_log = opt.dynamic_trials_factor * (1.0 - opt.success_probability).ln();

    let mut rng = ChaCha8Rng::seed_from_u64(opt.seed);
    let mut best: Option<(Rigid, Score)> = None;
    let mut best_minimal_cost = f64::INFINITY;
    let mut best_minimal_inliers = 0;
    let mut counts = [0usize; 4];
    let mut iterations = 0;
    let mut refinements = 0;
    let mut sols = Solutions::new();
    let (mut pidx, mut lidx) = ([0usize; 3], [0usize; 3]);
    while iterations < opt.max_iterations {
        let inliers = best.map(|(_, s)| (s.point_inliers, s.line_inliers));
        if let Some(inl) = inliers
            && iterations >= opt.min_iterations
            && sampler.log_miss(&counts, inl) <= stop_log
        {
            break;
        }
        let s = sampler.select(&mut rng, inliers);
        iterations += 1;
        counts[s] += 1;
        let (k, m) = SOLVERS[s];
        Sampler::draw(&mut rng, pts.len(), k, &mut pidx);
        Sampler::draw(&mut rng, lns.len(), m, &mut lidx);
        solve_sample(s, &pidx, &lidx, pts, lns, &mut sols);

        let mut lo_start = None;
        for model in sols.as_slice() {
            let Some(sc) = score(model, pts, lns, &th, best_minimal_cost) else {
                continue;
            };
            best_minimal_cost = sc.cost;
            if best.is_none_or(|(_, b)| sc.cost < b.cost) {
                best = Some((*model, sc));
            }
            if sc.inliers() > best_minimal_inliers {
                best_minimal_inliers = sc.inliers();
                lo_start = Some(*model);
            }
        }
        if let Some(start) = lo_start {
            let (refined, _) = refine(&start, pts, lns, &lo);
            refinements += 1;
            if let Some(sc) = score(&refined, pts, lns, &th, f64::INFINITY)
                && best.is_none_or(|(_, b)| sc.cost < b.cost)
            {
                best = Some((refined, sc));
            }
        }
    }
    let Some((mut model, best_score)) = best else {
        return Err(PoseError::NoModel { iterations });
    };

    // Last local optimisation, kept only if it improves the MSAC score.
    let (refined, _) = refine(&model, pts, lns, &lo);
    refinements += 1;
    if score(&refined, pts, lns, &th, best_score.cost).is_some() {
        model = refined;
    }

    // Final robust refinement on the inliers, points and lines jointly. The refined
    // pose can move a correspondence across the threshold: select again and refine
    // until the inlier set is stable (at most a few rounds).
    let cp = camera.cam_from_img_threshold(opt.point_loss_scale_px);
    let cl = camera.cam_from_img_threshold(opt.line_loss_scale_px);
    let fin = Refinement {
        point_loss: Loss::Cauchy { scale_sq: cp * cp },
        line_loss: Loss::Cauchy { scale_sq: cl * cl },
        max_iterations: opt.refine_iterations,
    };
    let select = |m: &Rigid| -> (Vec<bool>, Vec<bool>) {
        (
            pts.iter()
                .map(|p| point_sq_error(m, p) < th.point_sq)
                .collect(),
            lns.iter()
                .map(|l| line_sq_error(m, l) < th.line_sq)
                .collect(),
        )
    };
    let mut masks = select(&model);
    for _ in 0..FINAL_ROUNDS {
        let inl_pts: Vec<NPoint> = pts
            .iter()
            .zip(&masks.0)
            .filter(|(_, k)| **k)
            .map(|(p, _)| *p)
            .collect();
        let inl_lns: Vec<NLine> = lns
            .iter()
            .zip(&masks.1)
            .filter(|(_, k)| **k)
            .map(|(l, _)| *l)
            .collect();
        if inl_pts.len() + inl_lns.len() < 3 {
            break;
        }
        model = refine(&model, &inl_pts, &inl_lns, &fin).0;
        let next = select(&model);
        if next == masks {
            break;
        }
        masks = next;
    }

    let pose = model.to_pose();
    // Pixel errors with the real camera model; correspondences RANSAC could not use
    // keep an infinite error and are never inliers.
    let mut point_errors_px = vec![f64::INFINITY; points.len()];
    for &i in &data.point_index {
        point_errors_px[i] = point_error_px(camera, &pose, &points[i]);
    }
    let mut line_errors_px = vec![f64::INFINITY; lines.len()];
    for &i in &data.line_index {
        line_errors_px[i] = line_error_px(camera, &pose, &lines[i]);
    }
    let point_inliers: Vec<bool> = point_errors_px
        .iter()
        .map(|&e| e < opt.point_threshold_px)
        .collect();
    let line_inliers: Vec<bool> = line_errors_px
        .iter()
        .map(|&e| e < opt.line_threshold_px)
        .collect();
    Ok(PoseEstimate {
        pose,
        num_point_inliers: point_inliers.iter().filter(|&&b| b).count(),
        num_line_inliers: line_inliers.iter().filter(|&&b| b).count(),
        point_errors_px,
        line_errors_px,
        point_inliers,
        line_inliers,
        iterations,
        refinements,
        samples_per_solver: counts,
        num_unusable,
    })
}
