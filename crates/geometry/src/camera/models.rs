//! Per-model projection math. Written from the model equations (COLMAP
//! sensor/models.h documents them); the distortion is `(u, v) -> (u + du, v + dv)` on
//! the normalised image plane, then `x = fx * u_d + cx`.

use super::CameraModel;
use nalgebra::{Vector2, Vector3};

/// Points closer to the camera plane than this cannot be projected.
const MIN_DEPTH: f64 = f64::EPSILON;

pub(super) fn img_from_cam(m: CameraModel, p: &[f64], x: &Vector3<f64>) -> Option<Vector2<f64>> {
    use CameraModel::*;
    if !(x.x.is_finite() && x.y.is_finite() && x.z.is_finite()) {
        return None;
    }
    match m {
        SimplePinhole | Pinhole | SimpleRadial | Radial | OpenCv => {
            if x.z < MIN_DEPTH {
                return None;
            }
            let (u, v) = (x.x / x.z, x.y / x.z);
            let (du, dv) = distortion(m, p, u, v);
            Some(to_pixel(m, p, u + du, v + dv))
        }
        _ => None,
    }
}

pub(super) fn cam_ray_from_img(
    m: CameraModel,
    p: &[f64],
    px: &Vector2<f64>,
) -> Option<Vector3<f64>> {
    use CameraModel::*;
    if !(px.x.is_finite() && px.y.is_finite()) {
        return None;
    }
    match m {
        SimplePinhole | Pinhole => {
            let (u, v) = from_pixel(m, p, px);
            Some(Vector3::new(u, v, 1.0))
        }
        SimpleRadial | Radial | OpenCv => {
            let (ud, vd) = from_pixel(m, p, px);
            let (u, v) = iterative_undistortion(m, p, ud, vd)?;
            Some(Vector3::new(u, v, 1.0))
        }
        _ => None,
    }
}

/// (fx, fy, cx, cy) of a perspective model.
fn intrinsics(m: CameraModel, p: &[f64]) -> (f64, f64, f64, f64) {
    if m.focal_length_idxs().len() == 1 {
        (p[0], p[0], p[1], p[2])
    } else {
        (p[0], p[1], p[2], p[3])
    }
}

fn to_pixel(m: CameraModel, p: &[f64], u: f64, v: f64) -> Vector2<f64> {
    let (fx, fy, cx, cy) = intrinsics(m, p);
    Vector2::new(fx * u + cx, fy * v + cy)
}

fn from_pixel(m: CameraModel, p: &[f64], px: &Vector2<f64>) -> (f64, f64) {
    let (fx, fy, cx, cy) = intrinsics(m, p);
    ((px.x - cx) / fx, (px.y - cy) / fy)
}

/// Distortion offsets (du, dv) of the radial / tangential perspective models.
fn distortion(m: CameraModel, p: &[f64], u: f64, v: f64) -> (f64, f64) {
    use CameraModel::*;
    let (u2, v2, uv) = (u * u, v * v, u * v);
    let r2 = u2 + v2;
    match m {
        SimplePinhole | Pinhole => (0.0, 0.0),
        SimpleRadial => {
            let radial = p[3] * r2;
            (u * radial, v * radial)
        }
        Radial => {
            let radial = p[3] * r2 + p[4] * r2 * r2;
            (u * radial, v * radial)
        }
        OpenCv => {
            let (k1, k2, p1, p2) = (p[4], p[5], p[6], p[7]);
            let radial = k1 * r2 + k2 * r2 * r2;
            (
                u * radial + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u2),
                v * radial + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v2),
            )
        }
        _ => (0.0, 0.0),
    }
}

/// Inverts `(u, v) -> (u, v) + distortion(u, v)` by Newton's method with a
/// central-difference Jacobian. None when it does not converge (the distortion is not
/// invertible there, e.g. beyond the turning point of a strong barrel distortion).
fn iterative_undistortion(m: CameraModel, p: &[f64], ud: f64, vd: f64) -> Option<(f64, f64)> {
    const MAX_ITERATIONS: usize = 100;
    const STEP_TOLERANCE: f64 = 1e-14;
    const REL_DIFF_STEP: f64 = 1e-6;
    let (mut u, mut v) = (ud, vd);
    for _ in 0..MAX_ITERATIONS {
        let (du, dv) = distortion(m, p, u, v);
        let (ru, rv) = (u + du - ud, v + dv - vd);
        let hu = (u.abs() * REL_DIFF_STEP).max(1e-10);
        let hv = (v.abs() * REL_DIFF_STEP).max(1e-10);
        let f = |a: f64, b: f64| {
            let (da, db) = distortion(m, p, a, b);
            (a + da, b + db)
        };
        let (a1, b1) = f(u + hu, v);
        let (a0, b0) = f(u - hu, v);
        let (c1, d1) = f(u, v + hv);
        let (c0, d0) = f(u, v - hv);
        let j00 = (a1 - a0) / (2.0 * hu);
        let j10 = (b1 - b0) / (2.0 * hu);
        let j01 = (c1 - c0) / (2.0 * hv);
        let j11 = (d1 - d0) / (2.0 * hv);
        let det = j00 * j11 - j01 * j10;
        if !det.is_finite() || det.abs() < 1e-300 {
            return None;
        }
        let su = (j11 * ru - j01 * rv) / det;
        let sv = (-j10 * ru + j00 * rv) / det;
        u -= su;
        v -= sv;
        if !(u.is_finite() && v.is_finite()) {
            return None;
        }
        if su * su + sv * sv <= STEP_TOLERANCE * STEP_TOLERANCE * (1.0 + u * u + v * v) {
            let (du, dv) = distortion(m, p, u, v);
            let residual = ((u + du - ud).powi(2) + (v + dv - vd).powi(2)).sqrt();
            return (residual < 1e-9).then_some((u, v));
        }
    }
    None
}
