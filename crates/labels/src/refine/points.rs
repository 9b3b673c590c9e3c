//! Depth refinement of point labels (see the module docs of [`super`]).

use super::config::{PointSampling, RefineConfig};
use super::report::{KindReport, Outcome, Tally};
use crate::depth::{DepthMap, back_project};
use crate::stats::{dist3, median3};
use geometry::{Vector2, Vector3};
use std::collections::BTreeMap;
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

/// Every frame's observations, looked up by row with two binary searches. A map from
/// row to observation would hold every observation again: at a 7,000-frame scene's size
/// (6.9 M observations) about 0.7 GB (docs/performance.md, "A real scene's size").
struct Observed {
    /// Frames with observations, ordered by their rows (each frame's rows are one
    /// ascending run, and runs of different frames do not overlap).
    frames: Vec<FrameSamples>,
}

impl Observed {
    fn new(samples: Vec<FrameSamples>) -> Self {
        let mut frames: Vec<FrameSamples> =
            samples.into_iter().filter(|f| !f.obs.is_empty()).collect();
        frames.sort_by_key(|f| f.obs[0].0);
        Observed { frames }
    }

    /// None: the row was not observed (its frame has no depth map); Some(None): observed
    /// without a valid depth; Some(Some(w)): the back-projected point.
    fn get(&self, row: usize) -> Option<Option<[f64; 3]>> {
        let k = self
            .frames
            .partition_point(|f| f.obs.last().is_some_and(|(i, _)| *i < row));
        let obs = &self.frames.get(k)?.obs;
        let j = obs.binary_search_by_key(&row, |(i, _)| *i).ok()?;
        Some(obs[j].1)
    }
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
    let observed = Observed::new(samples);
    let mut tally = Tally::default();
    for members in groups.values() {
        let valid: Vec<(usize, [f64; 3])> = members
            .iter()
            .filter_map(|&i| observed.get(i).flatten().map(|w| (i, w)))
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
            let outcome = match observed.get(i) {
                // Frame without a depth map: the combined point.
                None => Outcome::Kept,
                Some(None) => Outcome::NoDepth,
                Some(Some(w)) if dist3(&w, &point) <= config.point_inlier_threshold_m => {
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
