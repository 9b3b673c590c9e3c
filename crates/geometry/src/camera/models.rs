//! Per-model projection math, written from the model equations (COLMAP's
//! sensor/models.h documents them), one file per family:
//!
//! - `radial`: perspective with radial/tangential distortion, lifted by Newton;
//! - `fisheye`: equidistant fisheye, with or without a lens polynomial;
//! - `fov`, `division`, `eucm`: closed-form perspective models;
//! - `spherical`: EQUIRECTANGULAR.
//!
//! Pixels follow COLMAP: `x = fx * u_d + cx` with the image corner at (0, 0).
//! Where COLMAP returns a meaningless value instead of failing (e.g. lifting a fisheye
//! pixel beyond 90 degrees), we return None; each family's docs list those cases.

mod division;
mod eucm;
mod fisheye;
mod fov;
mod jet;
mod radial;
mod spherical;
mod undistort;

use super::CameraModel;
use nalgebra::{Vector2, Vector3};

/// Points closer to the camera plane than this cannot be projected (COLMAP's
/// cheirality threshold for every model that has one).
const MIN_DEPTH: f64 = f64::EPSILON;

pub(super) fn img_from_cam(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    use CameraModel::*;
    // A Camera built field by field may carry the wrong number of parameters.
    if p.len() != m.num_params() || !x.iter().all(|c| c.is_finite()) {
        return None;
    }
    let px = match m {
        SimplePinhole | Pinhole => {
            if x.z < MIN_DEPTH {
                return None;
            }
            Some(Intrinsics::of(m, p).pixel(x.x / x.z, x.y / x.z))
        }
        SimpleRadial | Radial | OpenCv | FullOpenCv => radial::project(m, p, x),
        OpenCvFisheye
        | SimpleRadialFisheye
        | RadialFisheye
        | ThinPrismFisheye
        | RadTanThinPrismFisheye
        | SimpleFisheye
        | Fisheye => fisheye::project(m, p, x),
        Fov => fov::project(m, p, x),
        SimpleDivision | Division => division::project(m, p, x),
        Eucm => eucm::project(m, p, x),
        Equirectangular => spherical::project(p, x),
    }?;
    (px.x.is_finite() && px.y.is_finite()).then_some(px)
}

pub(super) fn cam_ray_from_img(
    m: CameraModel,
    p: &[f64],
    px: &Vector2<f64>,
) -> Option<Vector3<f64>> {
    use CameraModel::*;
    if p.len() != m.num_params() || !(px.x.is_finite() && px.y.is_finite()) {
        return None;
    }
    let ray = match m {
        SimplePinhole | Pinhole => {
            let (u, v) = Intrinsics::of(m, p).normalised(px);
            Some(Vector3::new(u, v, 1.0))
        }
        SimpleRadial | Radial | OpenCv | FullOpenCv => radial::lift(m, p, px),
        OpenCvFisheye
        | SimpleRadialFisheye
        | RadialFisheye
        | ThinPrismFisheye
        | RadTanThinPrismFisheye
        | SimpleFisheye
        | Fisheye => fisheye::lift(m, p, px),
        Fov => fov::lift(m, p, px),
        SimpleDivision | Division => division::lift(m, p, px),
        Eucm => eucm::lift(m, p, px),
        Equirectangular => spherical::lift(p, px),
    }?;
    ray.iter().all(|c| c.is_finite()).then_some(ray)
}

/// Focal lengths and principal point of a perspective model.
struct Intrinsics {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
}

impl Intrinsics {
    fn of(m: CameraModel, p: &[f64]) -> Self {
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
    fn extra(m: CameraModel, p: &[f64]) -> &[f64] {
        &p[m.focal_length_idxs().len() + 2..]
    }

    fn pixel(&self, u: f64, v: f64) -> Vector2<f64> {
        Vector2::new(self.fx * u + self.cx, self.fy * v + self.cy)
    }

    fn normalised(&self, px: &Vector2<f64>) -> (f64, f64) {
        ((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy)
    }
}
