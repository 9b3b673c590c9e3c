//! Fisheye models: the ray at angle `theta` from the optical axis first goes to the
//! equidistant plane, at distance `theta` from the centre in the ray's azimuth, then an
//! optional distortion of that plane, then the focal lengths. Models: OPENCV_FISHEYE,
//! SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE, THIN_PRISM_FISHEYE, RAD_TAN_THIN_PRISM_FISHEYE
//! (distorted, lifted iteratively) and SIMPLE_FISHEYE, FISHEYE (pure equidistant).
//!
//! As in COLMAP, `theta = atan(|(u/w, v/w)|)`: only points in front of the camera
//! (w > 0) project, so these models see at most 90 degrees off axis even where the
//! lens polynomial would allow more. Lifting returns None for an equidistant radius of
//! pi/2 or more (COLMAP returns an unscaled, meaningless point there).

use super::intrinsics::{Intrinsics, MIN_DEPTH};
use super::jet::Scalar;
use super::undistort::undistort;
use crate::camera::CameraModel;
use nalgebra::{Vector2, Vector3};
use std::f64::consts::FRAC_PI_2;

/// Below this radius `atan(r)/r` and `tan(t)/t` equal 1 to double precision.
const TINY_RADIUS: f64 = 1e-8;

fn has_distortion(m: CameraModel) -> bool {
    !matches!(m, CameraModel::SimpleFisheye | CameraModel::Fisheye)
}

/// Distortion of the equidistant plane, point (a, b) with `theta^2 = a^2 + b^2`.
fn distort<S: Scalar>(m: CameraModel, k: &[f64], a: S, b: S) -> (S, S) {
    let c = S::cst;
    let t2 = a * a + b * b;
    // 1 + sum_i coeffs[i] * theta^(2 i + 2), by Horner.
    let series = |coeffs: &[f64]| {
        let mut acc = c(0.0);
        for &k in coeffs.iter().rev() {
            acc = (acc + c(k)) * t2;
        }
        c(1.0) + acc
    };
    match m {
        CameraModel::SimpleRadialFisheye => {
            let s = series(&k[..1]);
            (a * s, b * s)
        }
        CameraModel::RadialFisheye => {
            let s = series(&k[..2]);
            (a * s, b * s)
        }
        CameraModel::OpenCvFisheye => {
            let s = series(&k[..4]);
            (a * s, b * s)
        }
        CameraModel::ThinPrismFisheye => {
            // k1, k2, p1, p2, k3, k4, sx1, sy1
            let (p1, p2, sx1, sy1) = (k[2], k[3], k[6], k[7]);
            let s = series(&[k[0], k[1], k[4], k[5]]);
            let ab = a * b;
            (
                a * s + c(2.0 * p1) * ab + c(p2) * (t2 + c(2.0) * a * a) + c(sx1) * t2,
                b * s + c(2.0 * p2) * ab + c(p1) * (t2 + c(2.0) * b * b) + c(sy1) * t2,
            )
        }
        CameraModel::RadTanThinPrismFisheye => {
            // k0..k5 radial in theta; then, on the radially mapped point, tangential
            // p0, p1 and thin prism s0..s3 (Meta's "Fisheye624").
            let (p0, p1) = (k[6], k[7]);
            let (s0, s1, s2, s3) = (k[8], k[9], k[10], k[11]);
            let s = series(&k[..6]);
            let (x, y) = (a * s, b * s);
            let (x2, y2, xy) = (x * x, y * y, x * y);
            let r2 = x2 + y2;
            let r4 = r2 * r2;
            (
                x + c(2.0 * p1) * xy + c(p0) * (r2 + c(2.0) * x2) + c(s0) * r2 + c(s1) * r4,
                y + c(2.0 * p0) * xy + c(p1) * (r2 + c(2.0) * y2) + c(s2) * r2 + c(s3) * r4,
            )
        }
        _ => (a, b),
    }
}

pub(super) fn project(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    if x.z < MIN_DEPTH {
        return None;
    }
    let (u, v) = (x.x / x.z, x.y / x.z);
    let r = u.hypot(v);
    let scale = if r > TINY_RADIUS { r.atan() / r } else { 1.0 };
    let (a, b) = (u * scale, v * scale);
    let (ad, bd) = distort(m, Intrinsics::extra(m, p), a, b);
    Some(Intrinsics::of(m, p).pixel(ad, bd))
}

pub(super) fn lift(m: CameraModel, p: &[f64], px: &Vector2<f64>) -> Option<Vector3<f64>> {
    let target = Intrinsics::of(m, p).normalised(px);
    let (a, b) = if has_distortion(m) {
        let k = Intrinsics::extra(m, p);
        undistort(target, |a, b| distort(m, k, a, b))?
    } else {
        target
    };
    let theta = a.hypot(b);
    if theta >= FRAC_PI_2 {
        return None;
    }
    let scale = if theta > TINY_RADIUS {
        theta.tan() / theta
    } else {
        1.0
    };
    Some(Vector3::new(a * scale, b * scale, 1.0))
}
