//! Perspective models with polynomial (or rational) radial and Brown-Conrady
//! tangential distortion of the normalised image plane: SIMPLE_RADIAL, RADIAL, OPENCV,
//! FULL_OPENCV. Projection divides by depth (None for points with w < eps, as in
//! COLMAP), distorts, applies the focal lengths; lifting inverts the distortion
//! iteratively (there is no closed form). Past the fold of a barrel distortion no ray
//! projects, and lifting returns None (COLMAP's iteration fails there too).

use super::intrinsics::{Intrinsics, MIN_DEPTH};
use super::jet::Scalar;
use super::undistort::undistort;
use crate::camera::CameraModel;
use nalgebra::{Vector2, Vector3};

/// Distorts the normalised point (u, v) with the model's extra parameters `k`
/// (the parameters after the focal lengths and principal point, in COLMAP order).
fn distort<S: Scalar>(m: CameraModel, k: &[f64], u: S, v: S) -> (S, S) {
    let c = S::cst;
    let (u2, v2, uv) = (u * u, v * v, u * v);
    let r2 = u2 + v2;
    match m {
        CameraModel::SimpleRadial => {
            let s = c(1.0) + c(k[0]) * r2;
            (u * s, v * s)
        }
        CameraModel::Radial => {
            let s = c(1.0) + r2 * (c(k[0]) + c(k[1]) * r2);
            (u * s, v * s)
        }
        CameraModel::OpenCv => {
            let (k1, k2, p1, p2) = (k[0], k[1], k[2], k[3]);
            let s = c(1.0) + r2 * (c(k1) + c(k2) * r2);
            tangential(u * s, v * s, u2, v2, uv, r2, p1, p2)
        }
        CameraModel::FullOpenCv => {
            let (k1, k2, p1, p2) = (k[0], k[1], k[2], k[3]);
            let (k3, k4, k5, k6) = (k[4], k[5], k[6], k[7]);
            let num = c(1.0) + r2 * (c(k1) + r2 * (c(k2) + c(k3) * r2));
            let den = c(1.0) + r2 * (c(k4) + r2 * (c(k5) + c(k6) * r2));
            let s = num / den;
            tangential(u * s, v * s, u2, v2, uv, r2, p1, p2)
        }
        _ => (u, v),
    }
}

/// Adds the decentering (Brown-Conrady) terms of OpenCV's convention to the radially
/// scaled point (xu, xv).
#[allow(clippy::too_many_arguments)]
fn tangential<S: Scalar>(xu: S, xv: S, u2: S, v2: S, uv: S, r2: S, p1: f64, p2: f64) -> (S, S) {
    let c = S::cst;
    (
        xu + c(2.0 * p1) * uv + c(p2) * (r2 + c(2.0) * u2),
        xv + c(2.0 * p2) * uv + c(p1) * (r2 + c(2.0) * v2),
    )
}

pub(super) fn project(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    if x.z < MIN_DEPTH {
        return None;
    }
    let k = Intrinsics::extra(m, p);
    let (ud, vd) = distort(m, k, x.x / x.z, x.y / x.z);
    Some(Intrinsics::of(m, p).pixel(ud, vd))
}

pub(super) fn lift(m: CameraModel, p: &[f64], px: &Vector2<f64>) -> Option<Vector3<f64>> {
    let target = Intrinsics::of(m, p).normalised(px);
    let k = Intrinsics::extra(m, p);
    let (u, v) = undistort(target, |u, v| distort(m, k, u, v))?;
    Some(Vector3::new(u, v, 1.0))
}
