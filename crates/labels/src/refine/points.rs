//! Depth refinement of point labels (see the module docs of [`super`]).

use super::config::{PointSampling, RefineConfig};
use super::report::{KindReport, Outcome, Tally};
use crate::depth::{DepthMap, back_project};
use crate::stats::{dist3, median3};
use geometry::{Vector2, Vector3};
use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use tables::labels::{PointRow, PoseRow};

/// Back-projected observations of one frame: (row, world point, or None when the
/// frame's depth map has no valid depth there). Empty for frames without depth.
pub(crate) struct FrameSamples {
    obs: Vec<(usize, Option<[f64; 3]>)>,
}

pub(crate) fn sample_frame(
    config: &RefineConfig,
    view: &PoseRow,
    depth: Option<&DepthMap>,
    rows: &[PointRow],
    range: Range<usize>,
) -> FrameSamples {
    let Some(depth) = depth else {
        return FrameSamples { obs: Vec::new() };
    };
    let mut obs = Vec::new();
    for i in range {
        let row = &rows[i];
        let Some(xyz) = row.xyz else {
            continue;
        };
        let px = match config.point_sampling {
            PointSampling::Keypoint => Some(Vector2::new(row.xy[0], row.xy[1])),
            PointSampling::Projection => {
                let pc = view.pose.transform_point(&Vector3::from(xyz));
                if pc.z > 0.0 {
                    view.camera.project(&pc)
                } else {
                    None
                }
            }
        };
        let world = px.and_then(|px| {
            let d = depth.sample(&px)?;
            back_project(&view.camera, &view.pose, &px, d)
        });
        obs.push((i, world.map(|w| [w.x, w.y, w.z])));
    }
    FrameSamples { obs }
}

/// Groups the labels of each 3D point (a valid label without a point id is its own
/// group), combines the observations and rewrites `rows`.
pub(crate) fn combine(
    config: &RefineConfig,
    rows: &mut [PointRow],
    samples: Vec<FrameSamples>,
) -> KindReport {
    let mut groups: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        if r.xyz.is_some() {
            let key = if r.point3d_id >= 0 {
                r.point3d_id
            } else {
                -2 - i as i64
            };
            groups.entry(key).or_default().push(i);
        }
    }
    let observed: HashMap<usize, Option<[f64; 3]>> =
        samples.into_iter().flat_map(|s| s.obs).collect();
    let mut tally = Tally::default();
    for members in groups.values() {
        let valid: Vec<(usize, [f64; 3])> = members
            .iter()
            .filter_map(|i| observed.get(i).copied().flatten().map(|w| (*i, w)))
            .collect();
        let combined = median3(&valid.iter().map(|(_, w)| *w).collect::<Vec<_>>()).and_then(|m| {
            let inliers: Vec<[f64; 3]> = valid
                .iter()
                .map(|(_, w)| *w)
                .filter(|w| dist3(w, &m) <= config.point_inlier_threshold_m)
                .collect();
            median3(&inliers)
        });
        let Some(point) = combined else {
            let outcome = if valid.is_empty() {
                Outcome::NoDepth
            } else {
                Outcome::Disagree
            };
            for &i in members {
                rows[i].xyz = None;
                tally.add(outcome, None);
            }
            tally.object(false);
            continue;
        };
        tally.object(true);
        for &i in members {
            let outcome = match observed.get(&i) {
                // Frame without a depth map: the combined point.
                None => Outcome::Kept,
                Some(None) => Outcome::NoDepth,
                Some(Some(w)) if dist3(w, &point) <= config.point_inlier_threshold_m => {
                    Outcome::Kept
                }
                Some(Some(_)) => Outcome::Disagree,
            };
            let old = rows[i].xyz;
            if outcome == Outcome::Kept {
                rows[i].xyz = Some(point);
                tally.add(outcome, old.map(|o| dist3(&o, &point)));
            } else {
                rows[i].xyz = None;
                tally.add(outcome, None);
            }
        }
    }
    tally.report()
}
