//! LSD line segments through OpenCV's `createLineSegmentDetector`.

use crate::config::LsdConfig;
use crate::convert::{from_cv, mat_view};
use crate::error::{CvContext, FeatureError};
use crate::sift::single_threaded_opencv;
use geometry::Vector2;
use geometry::lines::{Segment2, clip_segment_to_image};
use image::GrayImage;
use opencv::core::{Vec4f, Vector, no_array};
use opencv::imgproc::{self, LineSegmentDetectorTrait};

/// Detects line segments `[x1, y1, x2, y2]` (COLMAP convention), clipped to the image
/// `[0, W] x [0, H]`, drops those shorter
/// than `min_length`, keeps the `max_lines` longest. Order: length descending, then
/// coordinates (a total order). The direction is LSD's (dark side on one hand).
pub fn detect_segments(img: &GrayImage, cfg: &LsdConfig) -> Result<Vec<[f64; 4]>, FeatureError> {
    single_threaded_opencv();
    let mat = mat_view(img)?;
    // OpenCV's defaults (those of the LSD paper): refinement on, scale 0.8, sigma
    // scale 0.6, quantisation 2, angle tolerance 22.5 deg, density 0.7, 1024 bins.
    let mut lsd = imgproc::create_line_segment_detector(
        imgproc::LSD_REFINE_STD,
        0.8,
        0.6,
        2.0,
        22.5,
        0.0,
        0.7,
        1024,
    )
    .cv("createLineSegmentDetector")?;
    let mut lines = Vector::<Vec4f>::new();
    lsd.detect(
        &mat,
        &mut lines,
        &mut no_array(),
        &mut no_array(),
        &mut no_array(),
    )
    .cv("LSD detect")?;
    let (w, h) = (img.width() as f64, img.height() as f64);
    let mut segs: Vec<([f64; 4], f64)> = lines
        .iter()
        .filter_map(|l| {
            let s = [from_cv(l[0]), from_cv(l[1]), from_cv(l[2]), from_cv(l[3])];
            if !s.iter().all(|v| v.is_finite()) {
                return None;
            }
            // LSD's refinement can move an endpoint up to a few pixels past the border;
            // every consumer (LIMAP files, labels, sampling) expects segments inside.
            let c = clip_segment_to_image(
                &Segment2::new(Vector2::new(s[0], s[1]), Vector2::new(s[2], s[3])),
                w,
                h,
            )?;
            let s = [c.start.x, c.start.y, c.end.x, c.end.y];
            let len = ((s[2] - s[0]).powi(2) + (s[3] - s[1]).powi(2)).sqrt();
            (len >= cfg.min_length).then_some((s, len))
        })
        .collect();
    segs.sort_by(|(a, la), (b, lb)| {
        lb.total_cmp(la).then_with(|| {
            a.iter()
                .zip(b)
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
    segs.truncate(cfg.max_lines);
    Ok(segs.into_iter().map(|(s, _)| s).collect())
}
