//! Fitzgibbon's one-parameter division model (SIMPLE_DIVISION, DIVISION): the pixel at
//! normalised distorted position `x_d` sees the ray `(x_d, 1 + k |x_d|^2)`. Both
//! directions have closed forms.
//!
//! Projection solves `k rho^2 s^2 - w s + 1 = 0` for the scale `s` with `x_d = s (u, v)`,
//! `rho = |(u, v)|`, taking the root `s = 2 / (w + sqrt(w^2 - 4 k rho^2))` that is
//! continuous with the pinhole at the centre. With barrel distortion (k < 0) this
//! images points up to and beyond 90 degrees off axis (w <= 0) and COLMAP projects
//! those too; so do we. Where `w + sqrt(..) <= 0` (k >= 0 and w <= 0) there is no
//! positive scale: COLMAP then returns the pixel of the opposite direction (or inf);
//! we return None.
//!
//! Lifting is `(u, v) = x_d / (1 + k |x_d|^2)`. It returns None where the ray
//! `(x_d, 1 + k |x_d|^2)` is not in front of the camera (k < 0, |x_d|^2 >= -1/k; COLMAP
//! returns the opposite direction or inf) and, for k > 0, beyond the fold at
//! `|x_d|^2 = 1/k`, where no point projects (projection always picks the smaller
//! distorted radius; COLMAP returns a ray that projects elsewhere).

use super::intrinsics::Intrinsics;
use crate::camera::CameraModel;
use nalgebra::{Vector2, Vector3};

/// Smallest `1 + k |x_d|^2` (the ray's z) that lifting accepts, as COLMAP's cheirality
/// threshold.
const MIN_RAY_Z: f64 = f64::EPSILON;

fn k(m: CameraModel, p: &[f64]) -> f64 {
    Intrinsics::extra(m, p)[0]
}

pub(super) fn project(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    let k = k(m, p);
    let rho2 = x.x * x.x + x.y * x.y;
    let disc2 = x.z * x.z - 4.0 * k * rho2;
    if disc2 < 0.0 {
        return None;
    }
    let den = x.z + disc2.sqrt();
    if den <= 0.0 {
        return None;
    }
    let s = 2.0 / den;
    Some(Intrinsics::of(m, p).pixel(s * x.x, s * x.y))
}

pub(super) fn lift(m: CameraModel, p: &[f64], px: &Vector2<f64>) -> Option<Vector3<f64>> {
    let k = k(m, p);
    let (xd, yd) = Intrinsics::of(m, p).normalised(px);
    let kr2 = k * (xd * xd + yd * yd);
    let z = 1.0 + kr2;
    if z < MIN_RAY_Z || kr2 > 1.0 {
        return None;
    }
    Some(Vector3::new(xd / z, yd / z, 1.0))
}
