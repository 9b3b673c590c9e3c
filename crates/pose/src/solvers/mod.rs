//! Minimal absolute-pose solvers. Each returns every real solution with the points in
//! front of the camera, as world-to-camera poses (`X_cam = R X + t`).
//!
//! Inputs live on the camera side as rays / plane normals (normalised image
//! coordinates lifted to `(u, v, 1)`, any scale), on the world side as points and lines.
//!
//! The plain functions polish every solution with Newton's method on the six minimal
//! equations (see `polish.rs`); the `_unpolished` ones skip that step and are what
//! RANSAC runs, where local optimisation follows anyway.

mod lines;
mod p3p;
mod polish;
mod rotation;

pub(crate) use lines::{p1p2ll_into, p2p1ll_into, p3ll_into};
pub(crate) use p3p::p3p_into;

use crate::rigid::{Rigid, Solutions};
use geometry::Pose;
use nalgebra::{Vector2, Vector3};
use polish::{Equation, line_equations, point_equations, polish};

/// An infinite 3D line: a point on it and a direction (any non-zero length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line3D {
    pub point: Vector3<f64>,
    pub direction: Vector3<f64>,
}

impl Line3D {
    /// The line through two distinct points.
    pub fn through(a: &Vector3<f64>, b: &Vector3<f64>) -> Self {
        Line3D {
            point: *a,
            direction: b - a,
        }
    }

    /// Same line with a unit direction; None when the direction is zero or not finite.
    pub fn normalized(&self) -> Option<Self> {
        let n = self.direction.norm();
        (n > 0.0 && n.is_finite() && self.point.iter().all(|v| v.is_finite())).then(|| Line3D {
            point: self.point,
            direction: self.direction / n,
        })
    }
}

/// Unit normal of the plane through the camera centre and the 2D line through two
/// points of the normalised image plane. None when the points coincide.
pub fn image_line_normal(a: &Vector2<f64>, b: &Vector2<f64>) -> Option<Vector3<f64>> {
    let n = Vector3::new(a.x, a.y, 1.0).cross(&Vector3::new(b.x, b.y, 1.0));
    let len = n.norm();
    (len > 0.0 && len.is_finite()).then(|| n / len)
}

fn finish(out: &Solutions, eqs: Option<[Equation; 6]>) -> Vec<Pose> {
    out.as_slice()
        .iter()
        .map(|s| {
            let mut s: Rigid = *s;
            if let Some(eqs) = &eqs {
                polish(&mut s, eqs);
            }
            s.to_pose()
        })
        .collect()
}

fn eqs6(a: [Equation; 2], b: [Equation; 2], c: [Equation; 2]) -> [Equation; 6] {
    [a[0], a[1], b[0], b[1], c[0], c[1]]
}

fn p3p_impl(rays: &[Vector3<f64>; 3], points: &[Vector3<f64>; 3], polished: bool) -> Vec<Pose> {
    let mut out = Solutions::new();
    p3p_into(rays, points, &mut out);
    let eqs = polished.then(|| {
        eqs6(
            point_equations(&rays[0], &points[0]),
            point_equations(&rays[1], &points[1]),
            point_equations(&rays[2], &points[2]),
        )
    });
    finish(&out, eqs)
}

fn p2p1ll_impl(
    rays: &[Vector3<f64>; 2],
    points: &[Vector3<f64>; 2],
    line_normal: &Vector3<f64>,
    line: &Line3D,
    polished: bool,
) -> Vec<Pose> {
    let mut out = Solutions::new();
    let Some(line) = line.normalized() else {
        return Vec::new();
    };
    p2p1ll_into(
        rays,
        points,
        line_normal,
        &line.point,
        &line.direction,
        &mut out,
    );
    let eqs = polished.then(|| {
        eqs6(
            point_equations(&rays[0], &points[0]),
            point_equations(&rays[1], &points[1]),
            line_equations(line_normal, &line.point, &line.direction),
        )
    });
    finish(&out, eqs)
}

fn p1p2ll_impl(
    ray: &Vector3<f64>,
    point: &Vector3<f64>,
    line_normals: &[Vector3<f64>; 2],
    lines: &[Line3D; 2],
    polished: bool,
) -> Vec<Pose> {
    let mut out = Solutions::new();
    let (Some(a), Some(b)) = (lines[0].normalized(), lines[1].normalized()) else {
        return Vec::new();
    };
    p1p2ll_into(
        ray,
        point,
        line_normals,
        &[a.point, b.point],
        &[a.direction, b.direction],
        &mut out,
    );
    let eqs = polished.then(|| {
        eqs6(
            point_equations(ray, point),
            line_equations(&line_normals[0], &a.point, &a.direction),
            line_equations(&line_normals[1], &b.point, &b.direction),
        )
    });
    finish(&out, eqs)
}

fn p3ll_impl(line_normals: &[Vector3<f64>; 3], lines: &[Line3D; 3], polished: bool) -> Vec<Pose> {
    let mut out = Solutions::new();
    let (Some(a), Some(b), Some(c)) = (
        lines[0].normalized(),
        lines[1].normalized(),
        lines[2].normalized(),
    ) else {
        return Vec::new();
    };
    p3ll_into(
        line_normals,
        &[a.point, b.point, c.point],
        &[a.direction, b.direction, c.direction],
        &mut out,
    );
    let eqs = polished.then(|| {
        eqs6(
            line_equations(&line_normals[0], &a.point, &a.direction),
            line_equations(&line_normals[1], &b.point, &b.direction),
            line_equations(&line_normals[2], &c.point, &c.direction),
        )
    });
    finish(&out, eqs)
}

/// P3P: three rays and three world points; up to 4 solutions.
pub fn p3p(rays: &[Vector3<f64>; 3], points: &[Vector3<f64>; 3]) -> Vec<Pose> {
    p3p_impl(rays, points, true)
}

/// [`p3p`] without the final Newton polish.
pub fn p3p_unpolished(rays: &[Vector3<f64>; 3], points: &[Vector3<f64>; 3]) -> Vec<Pose> {
    p3p_impl(rays, points, false)
}

/// Two point correspondences and one line correspondence (`line_normal`: see
/// [`image_line_normal`]); up to 8 solutions.
pub fn p2p1ll(
    rays: &[Vector3<f64>; 2],
    points: &[Vector3<f64>; 2],
    line_normal: &Vector3<f64>,
    line: &Line3D,
) -> Vec<Pose> {
    p2p1ll_impl(rays, points, line_normal, line, true)
}

/// [`p2p1ll`] without the final Newton polish.
pub fn p2p1ll_unpolished(
    rays: &[Vector3<f64>; 2],
    points: &[Vector3<f64>; 2],
    line_normal: &Vector3<f64>,
    line: &Line3D,
) -> Vec<Pose> {
    p2p1ll_impl(rays, points, line_normal, line, false)
}

/// One point correspondence and two line correspondences; up to 8 solutions.
pub fn p1p2ll(
    ray: &Vector3<f64>,
    point: &Vector3<f64>,
    line_normals: &[Vector3<f64>; 2],
    lines: &[Line3D; 2],
) -> Vec<Pose> {
    p1p2ll_impl(ray, point, line_normals, lines, true)
}

/// [`p1p2ll`] without the final Newton polish.
pub fn p1p2ll_unpolished(
    ray: &Vector3<f64>,
    point: &Vector3<f64>,
    line_normals: &[Vector3<f64>; 2],
    lines: &[Line3D; 2],
) -> Vec<Pose> {
    p1p2ll_impl(ray, point, line_normals, lines, false)
}

/// Three line correspondences; up to 8 solutions.
pub fn p3ll(line_normals: &[Vector3<f64>; 3], lines: &[Line3D; 3]) -> Vec<Pose> {
    p3ll_impl(line_normals, lines, true)
}

/// [`p3ll`] without the final Newton polish.
pub fn p3ll_unpolished(line_normals: &[Vector3<f64>; 3], lines: &[Line3D; 3]) -> Vec<Pose> {
    p3ll_impl(line_normals, lines, false)
}
