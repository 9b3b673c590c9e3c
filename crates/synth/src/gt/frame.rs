//! The per-frame half of the labelling: features of one rendered training frame, the
//! exact surface point under each keypoint and the edge under each segment.

use super::config::GtConfig;
use super::error::GtError;
use super::lines::associate_segments;
use super::observations::{DESCRIPTOR_SCALE, FrameObservations, KeypointObs, pixel_ray};
use crate::dataset::SynthDataset;
use crate::scene::Scene;
use geometry::{Camera, Pose, Vector2};
use image::RgbImage;

/// Exact surface point under keypoint `px`, or None near a depth or orientation
/// discontinuity (see [`GtConfig::discontinuity_rel`]).
fn surface_point(
    scene: &Scene,
    camera: &Camera,
    pose: &Pose,
    px: [f64; 2],
    cfg: &GtConfig,
) -> Option<[f64; 3]> {
    let (o, d) = pixel_ray(camera, pose, &Vector2::new(px[0], px[1]))?;
    let hit = scene.raycast(&o, &d)?;
    let tol = cfg.discontinuity_rel * hit.t;
    let r = cfg.discontinuity_offset_px;
    for (dx, dy) in [(r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r)] {
        let (o2, d2) = pixel_ray(camera, pose, &Vector2::new(px[0] + dx, px[1] + dy))?;
        let h2 = scene.raycast(&o2, &d2)?;
        if h2.normal.dot(&hit.normal) < 0.9998
            || hit.normal.dot(&(h2.point - hit.point)).abs() > tol
        {
            return None;
        }
    }
    Some([hit.point.x, hit.point.y, hit.point.z])
}

/// Detects, describes and labels the features of training frame `frame` rendered as
/// `rgb`. Pure: the same output on every call and thread.
pub fn observe_frame(
    dataset: &SynthDataset,
    frame: usize,
    rgb: &RgbImage,
    cfg: &GtConfig,
) -> Result<FrameObservations, GtError> {
    let spec = dataset.frames.get(frame).ok_or(GtError::FrameIndex {
        index: frame,
        count: dataset.frames.len(),
    })?;
    let fe = |source| GtError::Features { frame, source };
    let gray = features::gray_from_rgb(rgb);
    let positions: Vec<[f64; 2]> = features::detect_keypoints(&gray, &cfg.features.sift)
        .map_err(fe)?
        .into_iter()
        .map(|k| k.xy)
        .collect();
    let desc = features::describe_points(
        &gray,
        &positions,
        &cfg.features.sift,
        &cfg.features.descriptor,
    )
    .map_err(fe)?;
    let descriptors = desc
        .iter()
        .map(|v| (v * DESCRIPTOR_SCALE).round().clamp(0.0, 255.0) as u8)
        .collect();
    let (w, h) = (rgb.width(), rgb.height());
    let keypoints = positions
        .iter()
        .map(|&xy| {
            let px = (xy[0].floor().max(0.0) as u32).min(w.saturating_sub(1));
            let py = (xy[1].floor().max(0.0) as u32).min(h.saturating_sub(1));
            KeypointObs {
                xy,
                point: surface_point(&dataset.scene, &dataset.camera, &spec.pose, xy, cfg),
                rgb: rgb.get_pixel(px, py).0,
            }
        })
        .collect();
    let segs = features::detect_segments(&gray, &cfg.features.lsd).map_err(fe)?;
    let segments = associate_segments(&dataset.scene, &dataset.camera, &spec.pose, &segs, cfg);
    Ok(FrameObservations {
        keypoints,
        descriptors,
        segments,
    })
}
