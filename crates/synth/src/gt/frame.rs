//! The per-frame half of the labelling: features of one rendered training frame, the
//! exact surface point under each keypoint and the edge under each segment.

use super::GtConfig;
use super::error::GtError;
use super::lines::associate_segments;
use crate::generate::SynthDataset;
use crate::scene::Scene;
use geometry::{Camera, Pose, Vector2, Vector3};
use image::RgbImage;

/// Descriptors are stored quantised like COLMAP's (`round(512 v)`, clamped to 255): a
/// quarter of the memory of f32 for a few hundred training frames.
pub const DESCRIPTOR_SCALE: f32 = 512.0;

/// One SIFT keypoint (COLMAP pixels) and, when it lies inside a plane, its exact surface
/// point in world coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeypointObs {
    pub xy: [f64; 2],
    pub point: Option<[f64; 3]>,
    /// Colour of the pixel containing the keypoint.
    pub rgb: [u8; 3],
}

/// One LSD segment and, when it lies on one, the scene edge it belongs to with the edge
/// parameters (0 at `Edge3::a`, 1 at `Edge3::b`) of its two endpoints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentObs {
    pub xy: [f64; 4],
    pub edge: Option<(u32, [f64; 2])>,
}

/// Everything the merge needs from one training frame.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct FrameObservations {
    pub keypoints: Vec<KeypointObs>,
    /// N x 128, quantised (see [`DESCRIPTOR_SCALE`]).
    pub descriptors: Vec<u8>,
    pub segments: Vec<SegmentObs>,
}

impl FrameObservations {
    pub fn descriptor(&self, i: usize) -> &[u8] {
        &self.descriptors[i * features::SIFT_DIM..(i + 1) * features::SIFT_DIM]
    }
}

/// The ray of pixel `px` in world coordinates: (origin, direction with camera z = 1, so
/// that the hit parameter is the depth).
pub(crate) fn pixel_ray(
    camera: &Camera,
    pose: &Pose,
    px: &Vector2<f64>,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let d = camera.unproject(px)?;
    Some((pose.centre(), pose.rotation.inverse() * d))
}

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
