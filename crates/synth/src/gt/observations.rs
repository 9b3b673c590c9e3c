//! What the labelling keeps of one training frame ([`FrameObservations`]: keypoints with
//! their surface points, quantised descriptors, segments with their edges), and the pixel
//! ray both halves cast. Its own file because the per-frame half (`frame.rs`, with the
//! segment-edge association of `lines.rs`) writes them and the merge (`points.rs`,
//! `lines.rs`) reads them.

use geometry::{Camera, Pose, Vector2, Vector3};

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
