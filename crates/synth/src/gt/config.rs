//! The labelling's tolerances ([`GtConfig`]), which every step of it reads.

use super::error::GtError;

/// Tolerances of the labelling. The defaults are those the tests and the CLI use.
#[derive(Clone, Debug, PartialEq)]
pub struct GtConfig {
    /// Front-end settings: SIFT top-K (4096, the training configuration), the fixed
    /// descriptor scale and LSD.
    pub features: features::FrontEndConfig,
    /// Offset (pixels) of the four extra rays cast around a keypoint to detect depth
    /// discontinuities.
    pub discontinuity_offset_px: f64,
    /// A keypoint is kept when the four offset hits lie on its hit's plane (same normal,
    /// distance within this fraction of its depth: 1 mm at 2 m). A plane test rather than
    /// a depth comparison: slanted floors pass, creases, silhouettes and the 3 mm step of a
    /// poster's border fail.
    pub discontinuity_rel: f64,
    /// Surface points of two keypoints closer than this (metres) may form a track.
    pub point_tolerance_m: f64,
    /// L2 distance of unit-norm SIFT descriptors below which two keypoints may match.
    pub max_descriptor_distance: f32,
    /// Observations reprojecting farther than this (pixels) leave their track.
    pub max_reprojection_px: f64,
    /// Segment-edge association: maximum angle (degrees) ...
    pub max_line_angle_deg: f64,
    /// ... and perpendicular distance (pixels) of both segment endpoints to the
    /// projected edge.
    pub max_line_distance_px: f64,
    /// Line tracks need at least this many distinct images.
    pub min_line_images: usize,
    /// Standard deviation of the label noise, as RMS 3D error in centimetres (0 = exact).
    pub label_noise_cm: f64,
}

impl Default for GtConfig {
    fn default() -> Self {
        GtConfig {
            features: features::FrontEndConfig::default(),
            discontinuity_offset_px: 1.5,
            discontinuity_rel: 5e-4,
            point_tolerance_m: 0.01,
            max_descriptor_distance: 0.7,
            max_reprojection_px: 0.5,
            max_line_angle_deg: 2.0,
            max_line_distance_px: 1.5,
            min_line_images: 4,
            label_noise_cm: 0.0,
        }
    }
}

impl GtConfig {
    pub fn validate(&self) -> Result<(), GtError> {
        let bad = |m: &str| Err(GtError::Config(m.to_string()));
        self.features
            .validate()
            .map_err(|e| GtError::Config(e.to_string()))?;
        if !(self.label_noise_cm >= 0.0 && self.label_noise_cm.is_finite()) {
            return bad("label_noise_cm must be finite and >= 0");
        }
        if !(self.point_tolerance_m > 0.0 && self.point_tolerance_m.is_finite()) {
            return bad("point_tolerance_m must be finite and > 0");
        }
        if !(self.max_reprojection_px > 0.0
            && self.max_line_distance_px > 0.0
            && self.max_line_angle_deg > 0.0
            && self.discontinuity_offset_px > 0.0
            && self.discontinuity_rel > 0.0)
        {
            return bad("tolerances must be > 0");
        }
        if self.max_descriptor_distance.is_nan() || self.max_descriptor_distance <= 0.0 {
            return bad("max_descriptor_distance must be > 0");
        }
        if self.min_line_images < 2 {
            return bad("min_line_images must be >= 2");
        }
        Ok(())
    }
}
