//! LSD line segments: the `lsd` crate as LIMAP's pytlsd runs it (the default), or
//! OpenCV's `createLineSegmentDetector`.

use crate::config::{LsdConfig, LsdImplementation};
use crate::convert::{from_cv, mat_view};
use crate::error::{CvContext, FeatureError};
use crate::sift::single_threaded_opencv;
use geometry::Vector2;
use geometry::lines::{Segment2, clip_segment_to_image};
use image::GrayImage;
use opencv::core::{Vec4f, Vector, no_array};
use opencv::imgproc::{self, LineSegmentDetectorTrait};

/// Detects line segments `[x1, y1, x2, y2]` (COLMAP convention) with the configured
/// LSD, clipped to the image `[0, W] x [0, H]`, drops those shorter than `min_length`,
/// keeps the `max_lines` longest. Order: length descending, then coordinates (a total
/// order). The direction is the detector's (dark side on one hand).
pub fn detect_segments(img: &GrayImage, cfg: &LsdConfig) -> Result<Vec<[f64; 4]>, FeatureError> {
    let raw = match cfg.implementation {
        LsdImplementation::Pytlsd => detect_pytlsd(img)?,
        LsdImplementation::Opencv => detect_opencv(img)?,
    };
    Ok(keep_segments(raw, img, cfg))
}

/// The `lsd` crate as pytlsd runs it, on the grey image as LIMAP gives it to pytlsd.
/// Its coordinates are used as they come, as LIMAP uses them with its COLMAP cameras
/// (the crate's documentation, "Coordinates": a step edge comes out 0.125 px from its
/// COLMAP position, and adding half a pixel would move the query's segments half a
/// pixel away from those its map was trained on).
fn detect_pytlsd(img: &GrayImage) -> Result<Vec<[f64; 4]>, FeatureError> {
    let segs = lsd::detect(
        img.as_raw(),
        img.width() as usize,
        img.height() as usize,
        &lsd::Params::pytlsd(),
    )
    .map_err(|e| FeatureError::Lsd(e.to_string()))?;
    Ok(segs.iter().map(|s| [s.x1, s.y1, s.x2, s.y2]).collect())
}

/// OpenCV's LSD (with its refinement), shifted to COLMAP pixels.
fn detect_opencv(img: &GrayImage) -> Result<Vec<[f64; 4]>, FeatureError> {
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
    Ok(lines
        .iter()
        .map(|l| [from_cv(l[0]), from_cv(l[1]), from_cv(l[2]), from_cv(l[3])])
        .collect())
}

/// Clip to the image, drop the short ones, keep the longest `max_lines` in a total order.
fn keep_segments(raw: Vec<[f64; 4]>, img: &GrayImage, cfg: &LsdConfig) -> Vec<[f64; 4]> {
    let (w, h) = (img.width() as f64, img.height() as f64);
    let mut segs: Vec<([f64; 4], f64)> = raw
        .into_iter()
        .filter_map(|s| {
            if !s.iter().all(|v| v.is_finite()) {
                return None;
            }
            // LSD puts endpoints up to a few pixels past the border (pytlsd's rectangles,
            // OpenCV's refinement); every consumer (LIMAP files, labels, sampling)
            // expects segments inside.
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
    segs.into_iter().map(|(s, _)| s).collect()
}
