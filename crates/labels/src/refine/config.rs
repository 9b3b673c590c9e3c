//! The refine stage's configuration (`[refine]`, `pl2map refine`).

use super::error::RefineError;
use serde::{Deserialize, Serialize};

/// Where a point observation reads its depth.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    strum::Display,
    strum::EnumString,
    strum::VariantNames,
)]
#[serde(rename_all = "lowercase")]
#[strum(
    serialize_all = "lowercase",
    parse_err_ty = String,
    parse_err_fn = unknown_point_sampling
)]
pub enum PointSampling {
    /// At the keypoint (the 2D measurement).
    #[default]
    Keypoint,
    /// At the projection of the current 3D label (the upstream tool).
    Projection,
}

/// The parse error, naming the accepted values.
fn unknown_point_sampling(s: &str) -> String {
    use strum::VariantNames;
    format!(
        "expected {}, got {s:?}",
        PointSampling::VARIANTS.join(" or ")
    )
}

/// The refine stage's configuration: `[refine]` of a pipeline file and the flags of
/// `pl2map refine`, the only place its settings and defaults live (metres, pixels).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
// Missing keys take the defaults; unknown keys are refused (pipeline files are typed).
#[serde(default, deny_unknown_fields)]
pub struct RefineConfig {
    /// Where point depth is read: keypoint (the 2D measurement) or projection (of the
    /// current 3D label, the upstream tool).
    #[arg(long, default_value_t = RefineConfig::default().point_sampling)]
    pub point_sampling: PointSampling,
    /// Observations of a point farther than this (metres) from the median are rejected.
    #[arg(long, default_value_t = RefineConfig::default().point_inlier_threshold_m)]
    pub point_inlier_threshold_m: f64,
    /// Depth beyond this (metres) is invalid (upstream: 1000).
    #[arg(long, default_value_t = RefineConfig::default().max_depth_m)]
    pub max_depth_m: f64,
    /// RANSAC inlier distance of line samples to a 3D line (metres).
    #[arg(long, default_value_t = RefineConfig::default().line_inlier_threshold_m)]
    pub line_inlier_threshold_m: f64,
    /// Fraction of a support's valid samples that must be inliers (upstream: 0.9).
    #[arg(long, default_value_t = RefineConfig::default().line_min_inlier_ratio)]
    pub line_min_inlier_ratio: f64,
    /// Distance between depth samples along a segment (pixels).
    #[arg(long, default_value_t = RefineConfig::default().line_sample_spacing_px)]
    pub line_sample_spacing_px: f64,
    /// Samples per segment: at least this many (short segments)...
    #[arg(long, default_value_t = RefineConfig::default().line_min_samples)]
    pub line_min_samples: usize,
    /// ... and at most this many (long ones).
    #[arg(long, default_value_t = RefineConfig::default().line_max_samples)]
    pub line_max_samples: usize,
    /// A support needs this many samples with valid depth (upstream: 7).
    #[arg(long, default_value_t = RefineConfig::default().line_min_valid_samples)]
    pub line_min_valid_samples: usize,
    /// RANSAC iterations at most (fewer when the inlier ratio allows).
    #[arg(long, default_value_t = RefineConfig::default().ransac_iterations)]
    pub ransac_iterations: usize,
    /// Seed of the RANSAC draws (each track draws from its own seeded stream).
    #[arg(long, default_value_t = RefineConfig::default().seed)]
    pub seed: u64,
}

impl Default for RefineConfig {
    fn default() -> Self {
        RefineConfig {
            point_sampling: PointSampling::Keypoint,
            point_inlier_threshold_m: 0.05,
            max_depth_m: 1000.0,
            line_inlier_threshold_m: 0.02,
            line_min_inlier_ratio: 0.9,
            line_sample_spacing_px: 2.0,
            line_min_samples: 8,
            line_max_samples: 256,
            line_min_valid_samples: 7,
            ransac_iterations: 200,
            seed: 0,
        }
    }
}

impl RefineConfig {
    pub fn validate(&self) -> Result<(), RefineError> {
        let positive = [
            ("point_inlier_threshold_m", self.point_inlier_threshold_m),
            ("max_depth_m", self.max_depth_m),
            ("line_inlier_threshold_m", self.line_inlier_threshold_m),
            ("line_sample_spacing_px", self.line_sample_spacing_px),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(RefineError::Config(format!(
                    "{name} must be positive and finite, got {v}"
                )));
            }
        }
        if !(0.0..=1.0).contains(&self.line_min_inlier_ratio) {
            return Err(RefineError::Config(format!(
                "line_min_inlier_ratio must be in [0, 1], got {}",
                self.line_min_inlier_ratio
            )));
        }
        if self.line_min_samples < 2 || self.line_max_samples < self.line_min_samples {
            return Err(RefineError::Config(format!(
                "need 2 <= line_min_samples <= line_max_samples, got {} and {}",
                self.line_min_samples, self.line_max_samples
            )));
        }
        if self.line_min_valid_samples < 2 || self.ransac_iterations == 0 {
            return Err(RefineError::Config(
                "line_min_valid_samples must be >= 2 and ransac_iterations >= 1".into(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_sampling_serde_and_strum_names_agree() {
        for p in [PointSampling::Keypoint, PointSampling::Projection] {
            assert_eq!(serde_json::to_string(&p).unwrap(), format!("\"{p}\""));
            assert_eq!(p.to_string().parse::<PointSampling>(), Ok(p));
        }
        assert_eq!(
            "Keypoint".parse::<PointSampling>(),
            Err("expected keypoint or projection, got \"Keypoint\"".to_string())
        );
    }
}
