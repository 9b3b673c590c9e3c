//! 2D and 3D line segments: projection, distances, clipping.

use crate::camera::Camera;
use crate::pose::Pose;
use nalgebra::{Vector2, Vector3};

/// A 2D segment in pixels (COLMAP convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment2 {
    pub start: Vector2<f64>,
    pub end: Vector2<f64>,
}

impl Segment2 {
    pub fn new(start: Vector2<f64>, end: Vector2<f64>) -> Self {
        Segment2 { start, end }
    }

    pub fn from_array(s: [f64; 4]) -> Self {
        Segment2::new(Vector2::new(s[0], s[1]), Vector2::new(s[2], s[3]))
    }

    pub fn to_array(&self) -> [f64; 4] {
        [self.start.x, self.start.y, self.end.x, self.end.y]
    }

    pub fn length(&self) -> f64 {
        (self.end - self.start).norm()
    }

    pub fn direction(&self) -> Vector2<f64> {
        self.end - self.start
    }

    /// The point at parameter `s` in [0, 1] from start to end.
    pub fn at(&self, s: f64) -> Vector2<f64> {
        self.start + (self.end - self.start) * s
    }

    pub fn reversed(&self) -> Self {
        Segment2::new(self.end, self.start)
    }
}

/// A 3D segment in world coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment3 {
    pub start: Vector3<f64>,
    pub end: Vector3<f64>,
}

impl Segment3 {
    pub fn new(start: Vector3<f64>, end: Vector3<f64>) -> Self {
        Segment3 { start, end }
    }

    pub fn length(&self) -> f64 {
        (self.end - self.start).norm()
    }

    pub fn reversed(&self) -> Self {
        Segment3::new(self.end, self.start)
    }
}

/// Homogeneous line `a x + b y + c = 0` through two points, scaled so that
/// `(a, b)` has unit norm (then `a x + b y + c` is a signed distance). None when the
/// points coincide.
pub fn line_through(p: &Vector2<f64>, q: &Vector2<f64>) -> Option<Vector3<f64>> {
    let l = Vector3::new(p.x, p.y, 1.0).cross(&Vector3::new(q.x, q.y, 1.0));
    let n = (l.x * l.x + l.y * l.y).sqrt();
    (n > 0.0 && n.is_finite()).then(|| l / n)
}

/// Distance from `p` to the infinite line through `a` and `b`; the distance to `a`
/// when `a == b`.
pub fn point_line_distance(p: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    let d = b - a;
    let len = d.norm();
    if len == 0.0 {
        return (p - a).norm();
    }
    (d.x * (p.y - a.y) - d.y * (p.x - a.x)).abs() / len
}

/// Distance from `p` to the closest point of the segment `[a, b]`.
pub fn point_segment_distance(p: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    let d = b - a;
    let l2 = d.norm_squared();
    if l2 == 0.0 {
        return (p - a).norm();
    }
    let s = ((p - a).dot(&d) / l2).clamp(0.0, 1.0);
    (p - (a + d * s)).norm()
}

/// Distance from the 3D point `p` to the infinite 3D line through `a` and `b`.
pub fn point_line_distance_3d(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let len = d.norm();
    if len == 0.0 {
        return (p - a).norm();
    }
    d.cross(&(p - a)).norm() / len
}

/// Clips a 3D segment given in the camera frame to the half-space `z >= near`.
/// None when the whole segment lies behind.
pub fn clip_to_near_plane(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    near: f64,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    match (a.z >= near, b.z >= near) {
        (true, true) => Some((*a, *b)),
        (false, false) => None,
        (a_in, _) => {
            let s = (near - a.z) / (b.z - a.z);
            let cut = a + (b - a) * s;
            Some(if a_in { (*a, cut) } else { (cut, *b) })
        }
    }
}

/// Projects a world segment into an image: transformed into the camera frame, clipped
/// to `z >= near` (a segment crossing the camera plane keeps its visible part) and its
/// endpoints projected with the camera model. Only the endpoints are projected: under
/// distortion the image of a 3D line is a curve, and callers compare endpoints or the
/// line through them, as LIMAP and PoseLib do.
pub fn project_segment(
    camera: &Camera,
    cam_from_world: &Pose,
    seg: &Segment3,
    near: f64,
) -> Option<Segment2> {
    let a = cam_from_world.transform_point(&seg.start);
    let b = cam_from_world.transform_point(&seg.end);
    let (a, b) = clip_to_near_plane(&a, &b, near)?;
    Some(Segment2::new(camera.project(&a)?, camera.project(&b)?))
}

/// Clips a segment to the rectangle `[xmin, xmax] x [ymin, ymax]` (Liang-Barsky),
/// keeping its direction. Vertical and horizontal segments are handled (a zero
/// direction component is tested against its slab directly). None when nothing of the
/// segment is inside.
pub fn clip_segment_to_rect(
    seg: &Segment2,
    xmin: f64,
    ymin: f64,
    xmax: f64,
    ymax: f64,
) -> Option<Segment2> {
    let d = seg.end - seg.start;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let checks = [
        (-d.x, seg.start.x - xmin),
        (d.x, xmax - seg.start.x),
        (-d.y, seg.start.y - ymin),
        (d.y, ymax - seg.start.y),
    ];
    for (p, q) in checks {
        if p == 0.0 {
            // Parallel to this boundary: inside its slab or entirely out.
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    Some(Segment2::new(seg.start + d * t0, seg.start + d * t1))
}

/// Clips a segment to an image `[0, width] x [0, height]` (COLMAP corner convention).
pub fn clip_segment_to_image(seg: &Segment2, width: f64, height: f64) -> Option<Segment2> {
    clip_segment_to_rect(seg, 0.0, 0.0, width, height)
}

/// Sum of the distances of both endpoints of a detected 2D segment to the infinite
/// line through a projected segment: the line reprojection error of docs/method.md sections 4 and 6
/// (and of PoseLib's line RANSAC). None when the projected segment is degenerate.
pub fn line_reprojection_error(detected: &Segment2, projected: &Segment2) -> Option<f64> {
    let l = line_through(&projected.start, &projected.end)?;
    let dist = |p: &Vector2<f64>| (l.x * p.x + l.y * p.y + l.z).abs();
    Some(dist(&detected.start) + dist(&detected.end))
}

/// `n` points evenly spaced along a segment, both endpoints included
/// (step = (end - start) / (n - 1)); a single point for `n == 1` (the start).
pub fn sample_segment(seg: &Segment2, n: usize) -> Vec<Vector2<f64>> {
    match n {
        0 => Vec::new(),
        1 => vec![seg.start],
        _ => (0..n).map(|i| seg.at(i as f64 / (n - 1) as f64)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraModel;

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    #[test]
    fn distances() {
        assert!(
            (point_line_distance(&v(0.0, 3.0), &v(-1.0, 0.0), &v(5.0, 0.0)) - 3.0).abs() < 1e-12
        );
        // Beyond the segment end: the infinite line distance stays, the segment one grows.
        assert!(
            (point_line_distance(&v(10.0, 3.0), &v(0.0, 0.0), &v(1.0, 0.0)) - 3.0).abs() < 1e-12
        );
        assert!(
            (point_segment_distance(&v(4.0, 4.0), &v(0.0, 0.0), &v(1.0, 0.0)) - 5.0).abs() < 1e-12
        );
        assert!(
            (point_line_distance(&v(3.0, 4.0), &v(0.0, 0.0), &v(0.0, 0.0)) - 5.0).abs() < 1e-12
        );
        let p = Vector3::new(0.0, 2.0, 0.0);
        let d = point_line_distance_3d(
            &p,
            &Vector3::new(0.0, 0.0, 1.0),
            &Vector3::new(0.0, 0.0, 5.0),
        );
        assert!((d - 2.0).abs() < 1e-12);
    }

    #[test]
    fn clip_diagonal_vertical_horizontal() {
        let s = Segment2::new(v(-10.0, -10.0), v(110.0, 110.0));
        let c = clip_segment_to_rect(&s, 0.0, 0.0, 100.0, 50.0).unwrap();
        assert!((c.start - v(0.0, 0.0)).norm() < 1e-12);
        assert!((c.end - v(50.0, 50.0)).norm() < 1e-12);
        // Vertical, crossing both horizontal borders.
        let s = Segment2::new(v(20.0, -5.0), v(20.0, 80.0));
        let c = clip_segment_to_rect(&s, 0.0, 0.0, 100.0, 50.0).unwrap();
        assert_eq!(c, Segment2::new(v(20.0, 0.0), v(20.0, 50.0)));
        // Vertical, outside the slab.
        assert!(
            clip_segment_to_rect(
                &Segment2::new(v(120.0, 1.0), v(120.0, 9.0)),
                0.0,
                0.0,
                100.0,
                50.0
            )
            .is_none()
        );
        // Horizontal, reversed direction kept.
        let s = Segment2::new(v(130.0, 10.0), v(-30.0, 10.0));
        let c = clip_segment_to_rect(&s, 0.0, 0.0, 100.0, 50.0).unwrap();
        assert_eq!(c, Segment2::new(v(100.0, 10.0), v(0.0, 10.0)));
        // Entirely inside: unchanged.
        let s = Segment2::new(v(1.0, 2.0), v(3.0, 4.0));
        assert_eq!(clip_segment_to_rect(&s, 0.0, 0.0, 100.0, 50.0).unwrap(), s);
        // Misses the corner.
        assert!(
            clip_segment_to_rect(
                &Segment2::new(v(90.0, -20.0), v(120.0, 10.0)),
                0.0,
                0.0,
                100.0,
                50.0
            )
            .is_none()
        );
    }

    #[test]
    fn projection_and_reprojection_error() {
        let cam = Camera::new(
            CameraModel::Pinhole,
            640,
            480,
            vec![500.0, 500.0, 320.0, 240.0],
        )
        .unwrap();
        let pose = Pose::identity();
        let seg = Segment3::new(Vector3::new(-1.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 2.0));
        let p = project_segment(&cam, &pose, &seg, 0.01).unwrap();
        assert!((p.start - v(70.0, 240.0)).norm() < 1e-9);
        assert!((p.end - v(570.0, 240.0)).norm() < 1e-9);
        let det = Segment2::new(v(100.0, 243.0), v(400.0, 238.0));
        assert!((line_reprojection_error(&det, &p).unwrap() - 5.0).abs() < 1e-9);
        // A segment crossing the camera plane keeps only its visible part.
        let seg = Segment3::new(Vector3::new(0.0, 0.0, -1.0), Vector3::new(0.0, 1.0, 1.0));
        let p = project_segment(&cam, &pose, &seg, 0.5).unwrap();
        assert!((p.start - v(320.0, 240.0 + 500.0 * 0.75 / 0.5)).norm() < 1e-9);
        // Entirely behind.
        let seg = Segment3::new(Vector3::new(0.0, 0.0, -1.0), Vector3::new(0.0, 1.0, -2.0));
        assert!(project_segment(&cam, &pose, &seg, 0.01).is_none());
    }

    #[test]
    fn sampling_includes_endpoints() {
        let s = Segment2::new(v(0.0, 0.0), v(11.0, 22.0));
        let pts = sample_segment(&s, 12);
        assert_eq!(pts.len(), 12);
        assert_eq!(pts[0], s.start);
        assert!((pts[11] - s.end).norm() < 1e-12);
        assert!((pts[1] - v(1.0, 2.0)).norm() < 1e-12);
    }
}
