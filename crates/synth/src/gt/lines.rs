//! Line tracks: each LSD segment is associated to the analytic 3D edge it lies on; an
//! edge seen in enough images becomes a track spanning its supports.

use super::config::GtConfig;
use super::observations::{FrameObservations, SegmentObs, pixel_ray};
use crate::dataset::SynthDataset;
use crate::scene::Scene;
use geometry::{Camera, Pose, Vector2, Vector3};
use std::collections::BTreeMap;

/// Points closer to the camera plane than this (metres) are clipped off an edge.
const NEAR_M: f64 = 0.01;
/// Visibility tolerance (metres) of the edge points a segment covers.
const VISIBILITY_TOL_M: f64 = 0.01;

/// A labelled 3D line.
#[derive(Clone, Debug, PartialEq)]
pub struct LineTrackGt {
    /// Index into `Scene::edges()`.
    pub edge: u32,
    /// Exact endpoints on the edge, in the edge's direction.
    pub line: [[f64; 3]; 2],
    /// (image position, row in that image's segments), in image then row order.
    pub supports: Vec<(usize, u32)>,
}

/// An edge projected into one view (the part in front of the camera).
struct ProjectedEdge {
    index: u32,
    a: Vector3<f64>,
    b: Vector3<f64>,
    /// Edge parameters of the clipped part.
    range: [f64; 2],
    p0: Vector2<f64>,
    dir: Vector2<f64>,
    len: f64,
}

fn project_edge(
    camera: &Camera,
    pose: &Pose,
    index: u32,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
) -> Option<ProjectedEdge> {
    let (ac, bc) = (pose.transform_point(a), pose.transform_point(b));
    if ac.z < NEAR_M && bc.z < NEAR_M {
        return None;
    }
    let mut range = [0.0, 1.0];
    if ac.z < NEAR_M {
        range[0] = (NEAR_M - ac.z) / (bc.z - ac.z);
    } else if bc.z < NEAR_M {
        range[1] = (NEAR_M - ac.z) / (bc.z - ac.z);
    }
    let p0 = camera.project(&(ac + (bc - ac) * range[0]))?;
    let p1 = camera.project(&(ac + (bc - ac) * range[1]))?;
    let d = p1 - p0;
    let len = d.norm();
    if len.is_nan() || len < 1.0 {
        return None;
    }
    let (w, h) = (camera.width as f64, camera.height as f64);
    let m = 2.0;
    if p0.x.max(p1.x) < -m
        || p0.x.min(p1.x) > w + m
        || p0.y.max(p1.y) < -m
        || p0.y.min(p1.y) > h + m
    {
        return None;
    }
    Some(ProjectedEdge {
        index,
        a: *a,
        b: *b,
        range,
        p0,
        dir: d / len,
        len,
    })
}

/// Edge parameter of the point of line `a + l (b - a)` closest to the ray `o + s d`.
fn edge_parameter(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    o: &Vector3<f64>,
    d: &Vector3<f64>,
) -> Option<f64> {
    let u = b - a;
    let w = a - o;
    let (uu, ud, dd) = (u.dot(&u), u.dot(d), d.dot(d));
    let (uw, dw) = (u.dot(&w), d.dot(&w));
    let den = uu * dd - ud * ud;
    if den.abs() <= 1e-15 * uu * dd {
        return None;
    }
    Some((ud * dw - dd * uw) / den)
}

/// Labels each segment of one view with the edge it lies on (angle, perpendicular
/// distance of both endpoints, overlap, visibility); the closest edge wins.
pub(crate) fn associate_segments(
    scene: &Scene,
    camera: &Camera,
    pose: &Pose,
    segs: &[[f64; 4]],
    cfg: &GtConfig,
) -> Vec<SegmentObs> {
    let edges: Vec<ProjectedEdge> = scene
        .edges()
        .iter()
        .enumerate()
        .filter_map(|(j, e)| project_edge(camera, pose, j as u32, &e.a, &e.b))
        .collect();
    let sin_max = cfg.max_line_angle_deg.to_radians().sin();
    let centre = pose.centre();
    segs.iter()
        .map(|s| {
            let p = Vector2::new(s[0], s[1]);
            let q = Vector2::new(s[2], s[3]);
            let sl = (q - p).norm();
            let mut best: Option<(f64, &ProjectedEdge, [f64; 2])> = None;
            if sl > 0.0 {
                let sd = (q - p) / sl;
                for e in &edges {
                    if (sd.x * e.dir.y - sd.y * e.dir.x).abs() > sin_max {
                        continue;
                    }
                    let n = Vector2::new(-e.dir.y, e.dir.x);
                    let (dp, dq) = (n.dot(&(p - e.p0)).abs(), n.dot(&(q - e.p0)).abs());
                    if dp.max(dq) >= cfg.max_line_distance_px {
                        continue;
                    }
                    let tp = e.dir.dot(&(p - e.p0));
                    let tq = e.dir.dot(&(q - e.p0));
                    if tp.max(tq).min(e.len) - tp.min(tq).max(0.0) <= 0.0 {
                        continue;
                    }
                    let score = dp.max(dq);
                    if best.as_ref().is_none_or(|b| score < b.0) {
                        best = Some((score, e, [tp, tq]));
                    }
                }
            }
            let edge = best.and_then(|(_, e, t)| {
                let mut lam = [0.0; 2];
                for (l, tt) in lam.iter_mut().zip(t) {
                    let foot = e.p0 + e.dir * tt;
                    let (o, d) = pixel_ray(camera, pose, &foot)?;
                    *l = edge_parameter(&e.a, &e.b, &o, &d)?.clamp(e.range[0], e.range[1]);
                }
                let at = |l: f64| e.a + (e.b - e.a) * l;
                let visible = [lam[0], 0.5 * (lam[0] + lam[1]), lam[1]]
                    .iter()
                    .all(|&l| scene.is_visible(&centre, &at(l), VISIBILITY_TOL_M));
                (visible && (lam[1] - lam[0]).abs() > 1e-9).then_some((e.index, lam))
            });
            SegmentObs { xy: *s, edge }
        })
        .collect()
}

/// One track per edge supported in at least `min_line_images` images; its endpoints
/// are the extreme edge parameters of its supports.
pub(crate) fn build_tracks(
    dataset: &SynthDataset,
    _poses: &[Pose],
    obs: &[FrameObservations],
    cfg: &GtConfig,
) -> Vec<LineTrackGt> {
    let mut by_edge: BTreeMap<u32, Vec<(usize, u32, [f64; 2])>> = BTreeMap::new();
    for (k, o) in obs.iter().enumerate() {
        for (r, s) in o.segments.iter().enumerate() {
            if let Some((e, lam)) = s.edge {
                by_edge.entry(e).or_default().push((k, r as u32, lam));
            }
        }
    }
    let edges = dataset.scene.edges();
    by_edge
        .into_iter()
        .filter_map(|(e, sup)| {
            let mut images: Vec<usize> = sup.iter().map(|s| s.0).collect();
            images.dedup();
            if images.len() < cfg.min_line_images {
                return None;
            }
            let edge = edges.get(e as usize)?;
            let lo = sup.iter().flat_map(|s| s.2).fold(f64::INFINITY, f64::min);
            let hi = sup
                .iter()
                .flat_map(|s| s.2)
                .fold(f64::NEG_INFINITY, f64::max);
            let at = |l: f64| {
                let p = edge.a + (edge.b - edge.a) * l;
                [p.x, p.y, p.z]
            };
            Some(LineTrackGt {
                edge: e,
                line: [at(lo), at(hi)],
                supports: sup.iter().map(|s| (s.0, s.1)).collect(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edge_parameter_of_a_crossing_ray() {
        // Edge along x at y = 1, z = 2; ray from the origin towards (0.5, 1, 2).
        let a = Vector3::new(0.0, 1.0, 2.0);
        let b = Vector3::new(2.0, 1.0, 2.0);
        let l = edge_parameter(&a, &b, &Vector3::zeros(), &Vector3::new(0.25, 0.5, 1.0)).unwrap();
        assert!((l - 0.25).abs() < 1e-12, "{l}");
    }

    #[test]
    fn edges_behind_the_camera_are_clipped() {
        let cam = crate::default_camera();
        let pose = Pose::identity();
        let a = Vector3::new(0.0, 0.0, -1.0);
        let b = Vector3::new(0.0, 0.5, 3.0);
        let e = project_edge(&cam, &pose, 0, &a, &b).unwrap();
        assert!((e.range[0] - 1.01 / 4.0).abs() < 1e-12);
        assert_eq!(e.range[1], 1.0);
        assert!(project_edge(&cam, &pose, 0, &a, &Vector3::new(1.0, 0.0, -2.0)).is_none());
    }
}
