//! The valid domain of a camera: the set of rays on which projection is defined and
//! one-to-one, and its image, the set of pixels on which lifting must succeed and
//! invert projection.
//!
//! How it is chosen (perspective models): along each azimuth `phi`, a ray at angle
//! `theta` off the optical axis is in the domain while
//! - `theta < 90 degrees`: COLMAP's perspective and fisheye models only project points
//!   in front of the camera, and lifting returns a point (u, v, 1) on the image plane;
//! - projection is defined up to `theta` (the division model with k > 0 stops at its
//!   fold, where its quadratic has no root);
//! - the Jacobian of the projection (pixels per unit of the equidistant plane
//!   `theta * (cos phi, sin phi)`) stays orientation-preserving up to `theta`. This
//!   stops the domain at the first fold of a distortion polynomial (the turning point
//!   of a barrel distortion), where the model stops being invertible.
//!
//! The region where lifting must succeed additionally keeps the Jacobian well
//! conditioned, `det J >= DET_FRACTION * det J(axis)`: right at a fold, lifting is
//! ill-posed (two rays a hair apart image to the same pixel). Because the distorted
//! radius is stationary at a fold, this removes only a sliver of pixels.
//!
//! The limits are found by marching and bisecting the projection along 180 azimuths,
//! independently of the lifting under test. The pixel side is bounded by two
//! normalised radii around the principal point, `|((x - cx)/fx, (y - cy)/fy)|`:
//! - `inner`: the nearest point of the image of the well-conditioned region's rim.
//!   That region maps one-to-one onto the area the rim's image encloses, so every
//!   pixel closer than this is the image of a valid ray: lifting must succeed and
//!   invert projection there.
//! - `outer`: the farthest point of the image of the orientation-preserving region's
//!   rim. No pixel beyond it is the image of a ray the camera sees: lifting must fail
//!   there.
//!
//! Between the two (the sliver at a fold, and the slight eccentricity tangential and
//! thin-prism terms give the rims) the only claim is that whatever lifting returns
//! projects back to the pixel.
//!
//! EQUIRECTANGULAR is one-to-one from the whole sphere (minus the poles' longitude and
//! the seam) onto the open image rectangle.

use crate::camera::{Camera, CameraModel};
use nalgebra::{Vector2, Vector3};
use std::f64::consts::{FRAC_PI_2, TAU};

/// How small the projection Jacobian may get, relative to the optical axis, where
/// lifting must succeed.
const DET_FRACTION: f64 = 1e-3;
/// Largest angle considered: 90 degrees minus a hair (the image plane ends at 90).
const ANGLE_LIMIT: f64 = FRAC_PI_2 - 1e-6;
const ANGLE_STEPS: usize = 300;
const BISECTIONS: usize = 40;
const AZIMUTHS: usize = 180;
/// Safety margin on the radii for the rim between sampled azimuths.
const RIM_MARGIN: f64 = 1e-3;

#[derive(Clone, Copy, Debug)]
pub struct Domain {
    /// Rays at most this far off axis (radians, any azimuth) are in the
    /// well-conditioned region.
    pub max_angle: f64,
    /// Pixels with a smaller normalised radius are images of valid rays.
    pub inner: f64,
    /// Pixels with a larger normalised radius are not.
    pub outer: f64,
}

/// The unit ray with equidistant-plane coordinates (a, b): angle `hypot(a, b)` off
/// axis, azimuth `atan2(b, a)`.
pub fn ray(a: f64, b: f64) -> Vector3<f64> {
    let theta = a.hypot(b);
    let sinc = if theta < 1e-12 {
        1.0
    } else {
        theta.sin() / theta
    };
    Vector3::new(a * sinc, b * sinc, theta.cos())
}

/// Determinant of d(pixel)/d(a, b) by central differences, or None where projection
/// fails on the stencil.
fn jacobian_det(cam: &Camera, a: f64, b: f64) -> Option<f64> {
    const H: f64 = 1e-7;
    let p = |a, b| cam.project(&ray(a, b));
    let dx = (p(a + H, b)? - p(a - H, b)?) / (2.0 * H);
    let dy = (p(a, b + H)? - p(a, b - H)?) / (2.0 * H);
    Some(dx.x * dy.y - dx.y * dy.x)
}

/// Normalised radius of a pixel around the principal point.
pub fn normalised_radius(cam: &Camera, px: &Vector2<f64>) -> f64 {
    let (fx, fy) = cam.focal_xy();
    let (cx, cy) = cam.principal_point();
    ((px.x - cx) / fx).hypot((px.y - cy) / fy)
}

/// The largest angle along azimuth `phi` up to which `det J > min_det` holds
/// everywhere on the way out from the axis (marched, then bisected).
fn limit_along(cam: &Camera, phi: f64, min_det: f64) -> f64 {
    let good = |theta: f64| {
        jacobian_det(cam, theta * phi.cos(), theta * phi.sin()).is_some_and(|d| d > min_det)
    };
    let step = ANGLE_LIMIT / ANGLE_STEPS as f64;
    let Some(first_bad) = (1..=ANGLE_STEPS).find(|&i| !good(step * i as f64)) else {
        return ANGLE_LIMIT;
    };
    let (mut lo, mut hi) = (step * (first_bad - 1) as f64, step * first_bad as f64);
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if good(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Limit angles along each sampled azimuth, and the normalised radii of their images.
fn rim(cam: &Camera, min_det: f64) -> Vec<(f64, f64)> {
    (0..AZIMUTHS)
        .map(|j| {
            let phi = TAU * j as f64 / AZIMUTHS as f64;
            let theta = limit_along(cam, phi, min_det);
            let px = cam
                .project(&ray(theta * phi.cos(), theta * phi.sin()))
                .expect("the rim of the domain projects");
            (theta, normalised_radius(cam, &px))
        })
        .collect()
}

pub fn domain(cam: &Camera) -> Domain {
    assert!(cam.model != CameraModel::Equirectangular);
    let det0 = jacobian_det(cam, 0.0, 0.0).expect("the optical axis projects");
    assert!(det0 > 0.0, "{cam:?}: orientation-reversing at the centre");
    let conditioned = rim(cam, DET_FRACTION * det0);
    let unfolded = rim(cam, 0.0);
    let min =
        |v: &[(f64, f64)], f: fn(&(f64, f64)) -> f64| v.iter().map(f).fold(f64::INFINITY, f64::min);
    let outer = unfolded.iter().map(|r| r.1).fold(0.0, f64::max);
    Domain {
        max_angle: min(&conditioned, |r| r.0),
        inner: min(&conditioned, |r| r.1) * (1.0 - RIM_MARGIN),
        outer: outer * (1.0 + RIM_MARGIN),
    }
}

/// Where a pixel lies relative to the valid domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    Inside,
    /// Between `inner` and `outer`: no claim either way.
    Edge,
    Outside,
}

pub fn region(cam: &Camera, dom: &Domain, px: &Vector2<f64>) -> Region {
    let r = normalised_radius(cam, px);
    if r < dom.inner {
        Region::Inside
    } else if r > dom.outer {
        Region::Outside
    } else {
        Region::Edge
    }
}
