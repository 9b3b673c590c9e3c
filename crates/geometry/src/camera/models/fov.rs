//! FOV model (Devernay & Faugeras): the distorted radius is
//! `r_d = atan(2 r tan(omega/2)) / omega` for undistorted radius `r`, inverted in
//! closed form by `r = tan(r_d omega) / (2 tan(omega/2))`.
//!
//! Both factors are written with `atanc(z) = atan(z)/z` and `tanc(z) = tan(z)/z`,
//! which have removable singularities at 0 and are evaluated by series there, so the
//! model is smooth in `omega` through 0 (the pinhole). COLMAP switches to a series
//! for `omega^2 < 1e-4` whose projection branch has the signs of the lifting series
//! (`1 + r^2 omega^2/3 - omega^2/12` instead of `1 - r^2 omega^2/3 + omega^2/12`), so
//! for |omega| < 0.01 its projection deviates from the formula (and from its own
//! lifting) by `(2 r^2/3 - 1/6) omega^2` relative (5e-3 px at f = 300 px, r = 1.1,
//! omega = 0.005, checked with pycolmap 4.2.1). We follow the formula.

use super::intrinsics::{Intrinsics, MIN_DEPTH};
use crate::camera::CameraModel;
use nalgebra::{Vector2, Vector3};
use std::f64::consts::{FRAC_PI_2, PI};

/// Below this |z| the series below are exact to double precision (next term < 1e-20).
const SERIES_BELOW: f64 = 1e-4;

/// atan(z) / z.
fn atanc(z: f64) -> f64 {
    if z.abs() < SERIES_BELOW {
        let z2 = z * z;
        1.0 - z2 / 3.0 + z2 * z2 / 5.0
    } else {
        z.atan() / z
    }
}

/// tan(z) / z, for |z| < pi/2.
fn tanc(z: f64) -> f64 {
    if z.abs() < SERIES_BELOW {
        let z2 = z * z;
        1.0 + z2 / 3.0 + 2.0 * z2 * z2 / 15.0
    } else {
        z.tan() / z
    }
}

/// omega is a field of view: beyond pi, tan(omega/2) changes sign and the model has no
/// meaning.
fn omega(p: &[f64]) -> Option<f64> {
    let omega = p[4];
    (omega.abs() < PI).then_some(omega)
}

pub(super) fn project(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    if x.z < MIN_DEPTH {
        return None;
    }
    let omega = omega(p)?;
    let (u, v) = (x.x / x.z, x.y / x.z);
    let half = 0.5 * omega;
    // atan(2 r t)/(r omega) = atanc(2 r t) * (2 t / omega), t = tan(omega/2).
    let factor = atanc(2.0 * u.hypot(v) * half.tan()) * tanc(half);
    Some(Intrinsics::of(m, p).pixel(u * factor, v * factor))
}

pub(super) fn lift(m: CameraModel, p: &[f64], px: &Vector2<f64>) -> Option<Vector3<f64>> {
    let omega = omega(p)?;
    let (ud, vd) = Intrinsics::of(m, p).normalised(px);
    let angle = ud.hypot(vd) * omega;
    // The undistorted radius tan(r_d omega)/(2 tan(omega/2)) goes to infinity at
    // r_d omega = pi/2 (a ray at 90 degrees); beyond, the formula wraps around.
    if angle.abs() >= FRAC_PI_2 {
        return None;
    }
    // tan(r_d omega)/(2 r_d tan(omega/2)) = tanc(r_d omega) / tanc(omega/2).
    let factor = tanc(angle) / tanc(0.5 * omega);
    Some(Vector3::new(ud * factor, vd * factor, 1.0))
}
