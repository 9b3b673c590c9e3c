//! Descriptors sampled along line segments.

use crate::config::{DescriptorConfig, SiftConfig};
use crate::error::FeatureError;
use crate::sift::KeySpec;
use image::GrayImage;

/// `t` points evenly spaced along a segment, endpoints included
/// (step = (end - start) / (t - 1)).
pub fn sample_points(seg: &[f64; 4], t: usize) -> Vec<[f64; 2]> {
    let s = geometry::lines::Segment2::from_array(*seg);
    geometry::lines::sample_segment(&s, t)
        .into_iter()
        .map(|p| [p.x, p.y])
        .collect()
}

/// OpenCV keypoint angle (degrees in [0, 360)) that aligns a SIFT patch's x axis with
/// the direction (dx, dy): the angle in image coordinates (y down), from +x towards +y.
/// The test `line_descriptors_follow_the_segment_orientation` pins this convention
/// (the opposite sign gives descriptors that do not follow a rotated image).
pub(crate) fn opencv_angle_along(dx: f64, dy: f64) -> f32 {
    dy.atan2(dx).to_degrees().rem_euclid(360.0) as f32
}

/// For each segment, `t` descriptors at the samples of `sample_points`, each oriented
/// along the segment at the fixed `DescriptorConfig::line_size`. Layout: M x T x 128,
/// row-major, rows L2-normalised.
pub fn describe_lines(
    img: &GrayImage,
    segments: &[[f64; 4]],
    t: usize,
    sift_cfg: &SiftConfig,
    desc_cfg: &DescriptorConfig,
) -> Result<Vec<f32>, FeatureError> {
    crate::sift::describe_specs(
        img,
        None,
        &line_keypoints(segments, t, desc_cfg),
        sift_cfg,
        desc_cfg,
    )
}

/// The OpenCV keypoints [`describe_lines`] describes: `t` per segment, in segment
/// order, each oriented along its segment at the fixed line size.
pub(crate) fn line_keypoints(
    segments: &[[f64; 4]],
    t: usize,
    desc_cfg: &DescriptorConfig,
) -> Vec<KeySpec> {
    let mut kps = Vec::with_capacity(segments.len() * t);
    for seg in segments {
        let angle = opencv_angle_along(seg[2] - seg[0], seg[3] - seg[1]);
        for xy in sample_points(seg, t) {
            kps.push(KeySpec {
                xy,
                size: desc_cfg.line_size,
                angle,
            });
        }
    }
    kps
}
