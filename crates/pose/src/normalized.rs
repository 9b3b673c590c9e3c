//! Correspondences lifted to the normalised image plane, where RANSAC and refinement
//! work, and the evaluation of a pose in pixels with the real camera model.

use crate::matches::{LineMatch, PointMatch};
use crate::solvers::image_line_normal;
use geometry::lines::{line_reprojection_error, project_segment};
use geometry::{Camera, CameraModel, Pose};
use nalgebra::{Vector2, Vector3};

/// A point correspondence on the normalised image plane (undistorted).
#[derive(Clone, Copy, Debug)]
pub(crate) struct NPoint {
    pub x: Vector2<f64>,
    pub world: Vector3<f64>,
}

/// A line correspondence: the detected endpoints on the normalised image plane, the
/// normal of the plane they span with the camera centre, and the world segment.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NLine {
    pub x1: Vector3<f64>,
    pub x2: Vector3<f64>,
    pub normal: Vector3<f64>,
    pub a: Vector3<f64>,
    pub b: Vector3<f64>,
    /// Unit direction of the world segment.
    pub dir: Vector3<f64>,
}

/// The usable correspondences and where each came from.
pub(crate) struct Normalized {
    pub points: Vec<NPoint>,
    pub point_index: Vec<usize>,
    pub lines: Vec<NLine>,
    pub line_index: Vec<usize>,
}

fn finite2(v: &Vector2<f64>) -> bool {
    v.x.is_finite() && v.y.is_finite()
}

fn finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// Lifts every observation with the camera model. Correspondences that cannot be used
/// (not finite, outside the model's domain, zero-length segments) are left out.
pub(crate) fn normalize(camera: &Camera, points: &[PointMatch], lines: &[LineMatch]) -> Normalized {
    let mut out = Normalized {
        points: Vec::with_capacity(points.len()),
        point_index: Vec::with_capacity(points.len()),
        lines: Vec::with_capacity(lines.len()),
        line_index: Vec::with_capacity(lines.len()),
    };
    for (i, p) in points.iter().enumerate() {
        if !(finite2(&p.pixel) && finite3(&p.world)) {
            continue;
        }
        if let Some(x) = camera.cam_from_img(&p.pixel) {
            out.points.push(NPoint { x, world: p.world });
            out.point_index.push(i);
        }
    }
    for (i, l) in lines.iter().enumerate() {
        let (s, w) = (&l.segment, &l.world);
        if !(finite2(&s.start) && finite2(&s.end) && finite3(&w.start) && finite3(&w.end)) {
            continue;
        }
        let len = (w.end - w.start).norm();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let (Some(x1), Some(x2)) = (camera.cam_from_img(&s.start), camera.cam_from_img(&s.end))
        else {
            continue;
        };
        let Some(normal) = image_line_normal(&x1, &x2) else {
            continue;
        };
        out.lines.push(NLine {
            x1: Vector3::new(x1.x, x1.y, 1.0),
            x2: Vector3::new(x2.x, x2.y, 1.0),
            normal,
            a: w.start,
            b: w.end,
            dir: (w.end - w.start) / len,
        });
        out.line_index.push(i);
    }
    out
}

/// Reprojection error in pixels of a point correspondence; infinite when the point is
/// behind the camera or cannot be projected.
pub(crate) fn point_error_px(camera: &Camera, pose: &Pose, p: &PointMatch) -> f64 {
    let pc = pose.transform_point(&p.world);
    if !(pc.z > 0.0) {
        return f64::INFINITY;
    }
    camera
        .project(&pc)
        .map_or(f64::INFINITY, |px| (px - p.pixel).norm())
}

/// Sum of the distances in pixels of the detected endpoints to the image of the world
/// line; infinite when the segment is behind the camera or degenerate.
///
/// Without distortion (SIMPLE_PINHOLE, PINHOLE) the image is the straight line through
/// the projected endpoints: geometry's `line_reprojection_error`. With distortion it is
/// a curve: each endpoint is measured to the distorted image of its closest point on
/// the line in the undistorted normalised plane (an upper bound of the distance to the
/// curve, equal to it without distortion).
pub(crate) fn line_error_px(camera: &Camera, pose: &Pose, l: &LineMatch) -> f64 {
    const NEAR: f64 = 1e-6;
    if matches!(
        camera.model,
        CameraModel::SimplePinhole | CameraModel::Pinhole
    ) {
        return project_segment(camera, pose, &l.world, NEAR)
            .and_then(|proj| line_reprojection_error(&l.segment, &proj))
            .filter(|e| e.is_finite())
            .unwrap_or(f64::INFINITY);
    }
    let p1 = pose.transform_point(&l.world.start);
    let p2 = pose.transform_point(&l.world.end);
    if p1.z < NEAR && p2.z < NEAR {
        return f64::INFINITY;
    }
    let n = p1.cross(&p2);
    let n2 = n.x * n.x + n.y * n.y;
    if !(n2 > 0.0 && n2.is_finite()) {
        return f64::INFINITY;
    }
    let mut total = 0.0;
    for e in [l.segment.start, l.segment.end] {
        let Some(x) = camera.cam_from_img(&e) else {
            return f64::INFINITY;
        };
        let s = (n.x * x.x + n.y * x.y + n.z) / n2;
        let foot = Vector3::new(x.x - n.x * s, x.y - n.y * s, 1.0);
        let Some(px) = camera.project(&foot) else {
            return f64::INFINITY;
        };
        total += (px - e).norm();
    }
    if total.is_finite() {
        total
    } else {
        f64::INFINITY
    }
}
