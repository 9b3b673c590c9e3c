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
mod intrinsics;
mod jet;
mod radial;
mod spherical;
mod undistort;

use super::camera_model::CameraModel;
use intrinsics::{Intrinsics, MIN_DEPTH};
use nalgebra::{Vector2, Vector3};

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
