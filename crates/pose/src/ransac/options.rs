//! The settings of RANSAC and of the refinements, with their defaults: the one place
//! the pose crate's callers (`pl2map pose`, the score stage) take them from.

use crate::error::PoseError;
use serde::{Deserialize, Serialize};

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
    /// 12 px for points, 10 px for lines: the reference evaluation's thresholds.
    fn default() -> Self {
        RansacOptions::with_thresholds(12.0, 10.0)
    }
}

impl RansacOptions {
    /// These inlier thresholds, with the final refinement's Cauchy scale half the point
    /// threshold for both kinds (6 px for the default 12 px, as PoseLib), and the
    /// default of every other setting. What `pl2map pose` and the score stage run.
    pub fn with_thresholds(point_threshold_px: f64, line_threshold_px: f64) -> Self {
        RansacOptions {
            point_threshold_px,
            line_threshold_px,
            min_iterations: 1000,
            max_iterations: 100_000,
            success_probability: 0.9999,
            dynamic_trials_factor: 3.0,
            seed: 0,
            lo_iterations: 25,
            refine_iterations: 100,
            point_loss_scale_px: 0.5 * point_threshold_px,
            line_loss_scale_px: 0.5 * point_threshold_px,
        }
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference's settings (docs/method.md section 6): 12 px / 10 px, and the
    /// Cauchy scale half the point threshold for both kinds.
    #[test]
    fn defaults_are_the_references() {
        let d = RansacOptions::default();
        assert_eq!((d.point_threshold_px, d.line_threshold_px), (12.0, 10.0));
        assert_eq!((d.point_loss_scale_px, d.line_loss_scale_px), (6.0, 6.0));
        assert!(d.validate().is_ok());
        let t = RansacOptions::with_thresholds(4.0, 3.0);
        assert_eq!((t.point_loss_scale_px, t.line_loss_scale_px), (2.0, 2.0));
        assert_eq!(t.max_iterations, d.max_iterations);
    }
}
