//! 3D point tracks: keypoints of different training images whose exact surface points
//! agree (voxel hash) and whose SIFT descriptors agree, then pruned by reprojection.

use super::config::GtConfig;
use super::observations::{DESCRIPTOR_SCALE, FrameObservations};
use crate::dataset::SynthDataset;
use geometry::{Camera, Pose, Vector2, Vector3};
use std::collections::HashMap;

/// A labelled 3D point.
#[derive(Clone, Debug, PartialEq)]
pub struct PointTrack {
    /// Exact surface point (world, metres).
    pub xyz: [f64; 3],
    pub rgb: [u8; 3],
    /// Mean reprojection error (pixels) of `xyz` over the track.
    pub error: f64,
    /// (image position, keypoint index), one per image, in image order.
    pub track: Vec<(usize, u32)>,
}

/// Squared L2 distance of two quantised descriptors, in unit-norm units.
fn descriptor_distance(a: &[u8], b: &[u8]) -> f32 {
    let s: u32 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = x.abs_diff(y) as u32;
            d * d
        })
        .sum();
    (s as f32).sqrt() / DESCRIPTOR_SCALE
}

/// Reprojection error (pixels) of `x` in a view, None when it is behind the camera.
pub(crate) fn reprojection_error(
    camera: &Camera,
    pose: &Pose,
    x: &Vector3<f64>,
    xy: [f64; 2],
) -> Option<f64> {
    let pc = pose.transform_point(x);
    if pc.z <= 0.0 {
        return None;
    }
    let p = camera.project(&pc)?;
    Some((p - Vector2::new(xy[0], xy[1])).norm())
}

type Cell = [i64; 3];

fn cell_of(p: &Vector3<f64>, size: f64) -> Cell {
    [
        (p.x / size).floor() as i64,
        (p.y / size).floor() as i64,
        (p.z / size).floor() as i64,
    ]
}

struct Candidate {
    reference: Vector3<f64>,
    members: Vec<(usize, u32)>,
}

fn point_of(obs: &[FrameObservations], m: (usize, u32)) -> Option<Vector3<f64>> {
    obs[m.0].keypoints[m.1 as usize].point.map(Vector3::from)
}

/// Associates keypoints image after image (sequential, ordered), then refines and prunes
/// each track. Track order = order of creation.
pub(crate) fn build_tracks(
    dataset: &SynthDataset,
    poses: &[Pose],
    obs: &[FrameObservations],
    cfg: &GtConfig,
) -> Vec<PointTrack> {
    let tol = cfg.point_tolerance_m;
    let mut cands: Vec<Candidate> = Vec::new();
    let mut grid: HashMap<Cell, Vec<usize>> = HashMap::new();
    for (k, o) in obs.iter().enumerate() {
        // (descriptor distance, 3D distance, keypoint, candidate)
        let mut pairs: Vec<(f32, f64, u32, usize)> = Vec::new();
        for (i, kp) in o.keypoints.iter().enumerate() {
            let Some(p) = kp.point.map(Vector3::from) else {
                continue;
            };
            let c = cell_of(&p, tol);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                            continue;
                        };
                        for &t in list {
                            let cand = &cands[t];
                            let d3 = (cand.reference - p).norm();
                            if d3 >= tol || cand.members.last().is_some_and(|m| m.0 == k) {
                                continue;
                            }
                            let dd = cand
                                .members
                                .iter()
                                .map(|&(mk, mi)| {
                                    descriptor_distance(
                                        o.descriptor(i),
                                        obs[mk].descriptor(mi as usize),
                                    )
                                })
                                .fold(f32::INFINITY, f32::min);
                            if dd < cfg.max_descriptor_distance {
                                pairs.push((dd, d3, i as u32, t));
                            }
                        }
                    }
                }
            }
        }
        // Best pairs first, one keypoint per track and one track per keypoint.
        pairs.sort_by(|a, b| {
            a.0.total_cmp(&b.0)
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
                .then(a.3.cmp(&b.3))
        });
        let mut kp_used = vec![false; o.keypoints.len()];
        let mut track_used: HashMap<usize, ()> = HashMap::new();
        for (_, _, i, t) in pairs {
            if kp_used[i as usize] || track_used.contains_key(&t) {
                continue;
            }
            kp_used[i as usize] = true;
            track_used.insert(t, ());
            cands[t].members.push((k, i));
        }
        for (i, kp) in o.keypoints.iter().enumerate() {
            let Some(p) = kp.point.map(Vector3::from) else {
                continue;
            };
            if kp_used[i] {
                continue;
            }
            let t = cands.len();
            grid.entry(cell_of(&p, tol)).or_default().push(t);
            cands.push(Candidate {
                reference: p,
                members: vec![(k, i as u32)],
            });
        }
    }
    cands
        .into_iter()
        .filter(|c| c.members.len() >= 2)
        .filter_map(|c| refine(dataset, poses, obs, c.members, cfg))
        .collect()
}

/// The track's point: the mean of its members' surface points, moved back onto the
/// surface along the first member's ray; members reprojecting too far are dropped and the
/// point recomputed until none is. None when fewer than 2 images remain.
fn refine(
    dataset: &SynthDataset,
    poses: &[Pose],
    obs: &[FrameObservations],
    mut members: Vec<(usize, u32)>,
    cfg: &GtConfig,
) -> Option<PointTrack> {
    for _ in 0..8 {
        if members.len() < 2 {
            return None;
        }
        let pts: Vec<Vector3<f64>> = members.iter().filter_map(|&m| point_of(obs, m)).collect();
        let mean = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
        let centre = poses[members[0].0].centre();
        let x = dataset
            .scene
            .raycast(&centre, &(mean - centre))
            .map(|h| h.point)
            .filter(|p| (p - mean).norm() < cfg.point_tolerance_m)
            .unwrap_or(mean);
        let errs: Vec<Option<f64>> = members
            .iter()
            .map(|&(k, i)| {
                let xy = obs[k].keypoints[i as usize].xy;
                reprojection_error(&dataset.camera, &poses[k], &x, xy)
                    .filter(|e| *e <= cfg.max_reprojection_px)
            })
            .collect();
        if errs.iter().all(Option::is_some) {
            let error = errs.iter().flatten().sum::<f64>() / errs.len() as f64;
            let (k0, i0) = members[0];
            return Some(PointTrack {
                xyz: [x.x, x.y, x.z],
                rgb: obs[k0].keypoints[i0 as usize].rgb,
                error,
                track: members,
            });
        }
        members = members
            .into_iter()
            .zip(errs)
            .filter_map(|(m, e)| e.map(|_| m))
            .collect();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptor_distance_is_unit_norm_l2() {
        // Two orthogonal unit vectors quantised at 512 (clamped to 255 ~ 0.498).
        let mut a = vec![0u8; 128];
        let mut b = vec![0u8; 128];
        a[0] = 255;
        b[1] = 255;
        let d = descriptor_distance(&a, &b);
        let expect = (2.0f32).sqrt() * 255.0 / 512.0;
        assert!((d - expect).abs() < 1e-6, "{d} vs {expect}");
        assert_eq!(descriptor_distance(&a, &a), 0.0);
    }

    #[test]
    fn cells_floor_negative_coordinates() {
        assert_eq!(
            cell_of(&Vector3::new(-0.001, 0.0, 0.0199), 0.01),
            [-1, 0, 1]
        );
    }
}
