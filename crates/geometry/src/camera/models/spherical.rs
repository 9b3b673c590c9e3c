//! EQUIRECTANGULAR: longitude `theta = atan2(x, z)` in (-pi, pi] spans the width
//! (+x, right, at 3/4 of it; forward at the centre), latitude
//! `phi = atan2(-y, hypot(x, z))` spans the height with up (-y) at the top row.
//! Parameters are the panorama's width and height in pixels. Every direction projects;
//! every pixel lifts to a unit bearing (COLMAP `CamRayFromImg`), including pixels
//! outside [0, w) x [0, h), which wrap around the sphere.

use nalgebra::{Vector2, Vector3};
use std::f64::consts::{PI, TAU};

pub(super) fn project(p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    let (w, h) = (p[0], p[1]);
    let horizontal = x.x.hypot(x.z);
    if horizontal + x.y.abs() < f64::EPSILON {
        return None;
    }
    let theta = x.x.atan2(x.z);
    let phi = (-x.y).atan2(horizontal);
    Some(Vector2::new((theta / TAU + 0.5) * w, (0.5 - phi / PI) * h))
}

pub(super) fn lift(p: &[f64], px: &Vector2<f64>) -> Option<Vector3<f64>> {
    let (w, h) = (p[0], p[1]);
    let theta = TAU * (px.x / w - 0.5);
    let phi = PI * (0.5 - px.y / h);
    let (sin_phi, cos_phi) = phi.sin_cos();
    let (sin_theta, cos_theta) = theta.sin_cos();
    Some(Vector3::new(
        cos_phi * sin_theta,
        -sin_phi,
        cos_phi * cos_theta,
    ))
}
