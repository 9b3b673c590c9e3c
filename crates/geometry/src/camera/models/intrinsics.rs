//! What the perspective models share: the focal lengths and principal point
//! ([`Intrinsics`]) and the cheirality threshold. Its own file because the dispatch
//! (`models.rs`) and every family file use them.

use crate::camera::CameraModel;
use nalgebra::Vector2;

/// Points closer to the camera plane than this cannot be projected (COLMAP's
/// cheirality threshold for every model that has one).
pub(super) const MIN_DEPTH: f64 = f64::EPSILON;

/// Focal lengths and principal point of a perspective model.
pub(super) struct Intrinsics {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
}

impl Intrinsics {
    pub(super) fn of(m: CameraModel, p: &[f64]) -> Self {
        if m.focal_length_idxs().len() == 1 {
            Intrinsics {
                fx: p[0],
                fy: p[0],
                cx: p[1],
                cy: p[2],
            }
        } else {
            Intrinsics {
                fx: p[0],
                fy: p[1],
                cx: p[2],
                cy: p[3],
            }
        }
    }

    /// The distortion parameters: everything after the focal length(s) and principal
    /// point, in COLMAP order.
    pub(super) fn extra(m: CameraModel, p: &[f64]) -> &[f64] {
        &p[m.focal_length_idxs().len() + 2..]
    }

    pub(super) fn pixel(&self, u: f64, v: f64) -> Vector2<f64> {
        Vector2::new(self.fx * u + self.cx, self.fy * v + self.cy)
    }

    pub(super) fn normalised(&self, px: &Vector2<f64>) -> (f64, f64) {
        ((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy)
    }
}
