//! Enhanced Unified Camera Model (Khomutenko et al. 2016), parameters alpha, beta:
//! `m = (u, v) / (alpha d + (1 - alpha) w)` with `d = sqrt(beta (u^2 + v^2) + w^2)`.
//!
//! As in COLMAP, only points with w >= eps project (the model itself could see beyond
//! 90 degrees for alpha > 0.5) and lifting, in closed form, fails where the lifted
//! ray would not be in front of the camera or the square root is undefined (pixels
//! outside the image circle `|m|^2 < 1/(beta alpha^2)`).

use super::intrinsics::{Intrinsics, MIN_DEPTH};
use crate::camera::CameraModel;
use nalgebra::{Vector2, Vector3};

fn alpha_beta(p: &[f64]) -> (f64, f64) {
    (p[4], p[5])
}

pub(super) fn project(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    if x.z < MIN_DEPTH {
        return None;
    }
    let (alpha, beta) = alpha_beta(p);
    let d2 = beta * (x.x * x.x + x.y * x.y) + x.z * x.z;
    if d2 < 0.0 {
        return None;
    }
    let den = alpha * d2.sqrt() + (1.0 - alpha) * x.z;
    if den < f64::EPSILON {
        return None;
    }
    Some(Intrinsics::of(m, p).pixel(x.x / den, x.y / den))
}

pub(super) fn lift(m: CameraModel, p: &[f64], px: &Vector2<f64>) -> Option<Vector3<f64>> {
    let (alpha, beta) = alpha_beta(p);
    let (mx, my) = Intrinsics::of(m, p).normalised(px);
    let r2 = mx * mx + my * my;
    // The lifted ray is (mx, my, mz) with
    // mz = (1 - beta alpha^2 r^2) / (alpha sqrt(1 - (2 alpha - 1) beta r^2) + 1 - alpha).
    let radicand = 1.0 - (2.0 * alpha - 1.0) * beta * r2;
    if radicand < 0.0 {
        return None;
    }
    let den = alpha * radicand.sqrt() + (1.0 - alpha);
    if den < f64::EPSILON {
        return None;
    }
    let mz = (1.0 - alpha * alpha * beta * r2) / den;
    if mz < f64::EPSILON {
        return None;
    }
    Some(Vector3::new(mx / mz, my / mz, 1.0))
}
