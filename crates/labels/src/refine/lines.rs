//! Depth refinement of line labels (see the module docs of [`super`]).

use super::config::RefineConfig;
use super::fit::{principal_line, ransac_line};
use super::report::{KindReport, Outcome, Tally};
use crate::align::align_endpoints;
use crate::depth::{DepthMap, back_project};
use geometry::{Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use tables::labels::{LineRow, PoseRow};

/// The samples of one support: candidate sets, the depth read on the segment first, then
/// (for segments on an occluding edge) the depth of each side extrapolated to the
/// segment. None when no set had `line_min_valid_samples` valid.
type SupportSamples = Option<Vec<DepthSet>>;

/// One candidate set: the depth at each of the support's samples, NaN where it has no
/// valid one. The world points are back-projected again where the support's track is
/// refined ([`set_points`]: the same pixel and depth, so the same bits). Keeping the
/// points instead cost three times the memory: at a 7,000-frame scene's size (0.6 M
/// supports) well over a gigabyte (docs/performance.md, "A real scene's size").
type DepthSet = Vec<f64>;

pub(crate) struct FrameSamples {
    supports: Vec<(usize, SupportSamples)>,
}

/// Offset (pixels) of the side samples from the segment, and twice that for the
/// extrapolation. Rendered or sensor depth on an occluding edge mixes both surfaces within
/// about a pixel; 1.5 px is clear of that.
const SIDE_OFFSET_PX: f64 = 1.5;

fn sample_count(config: &RefineConfig, seg: &[f64; 4]) -> usize {
    let len = ((seg[2] - seg[0]).powi(2) + (seg[3] - seg[1]).powi(2)).sqrt();
    let n = (len / config.line_sample_spacing_px).ceil() + 1.0;
    // `as` saturates; the clamp bounds it by the configured maximum.
    (n as usize).clamp(config.line_min_samples, config.line_max_samples)
}

/// Depth at `px` as seen from one side of an edge: read at 1 and 2 offsets along `normal`
/// and extrapolated back to `px` linearly in inverse depth (exact for a planar surface,
/// whose inverse depth is affine in the pixel coordinates).
fn side_depth(depth: &DepthMap, px: &Vector2<f64>, normal: &Vector2<f64>) -> Option<f64> {
    let d1 = depth.sample(&(px + normal * SIDE_OFFSET_PX))?;
    let d2 = depth.sample(&(px + normal * (2.0 * SIDE_OFFSET_PX)))?;
    let inv = 2.0 / d1 - 1.0 / d2;
    (inv > 0.0).then(|| 1.0 / inv)
}

/// The pixel of sample `k` of `n` along a segment, both endpoints included.
fn sample_pixel(s: &[f64; 4], k: usize, n: usize) -> Vector2<f64> {
    let t = k as f64 / (n - 1) as f64;
    Vector2::new(s[0] + t * (s[2] - s[0]), s[1] + t * (s[3] - s[1]))
}

/// The world points of one candidate set of a support (segment `s`, seen from `view`).
fn set_points(view: &PoseRow, s: &[f64; 4], depths: &[f64]) -> Vec<Vector3<f64>> {
    let n = depths.len();
    depths
        .iter()
        .enumerate()
        .filter(|(_, d)| !d.is_nan())
        .filter_map(|(k, &d)| back_project(&view.camera, &view.pose, &sample_pixel(s, k, n), d))
        .collect()
}

pub(crate) fn sample_frame(
    config: &RefineConfig,
    view: &PoseRow,
    depth: Option<&DepthMap>,
    rows: &[LineRow],
    range: Range<usize>,
) -> FrameSamples {
    let Some(depth) = depth else {
        return FrameSamples {
            supports: Vec::new(),
        };
    };
    let mut supports = Vec::new();
    for i in range {
        let row = &rows[i];
        if row.endpoints.is_none() {
            continue;
        }
        let s = &row.segment;
        let n = sample_count(config, s);
        let dir = Vector2::new(s[2] - s[0], s[3] - s[1]);
        let normal = Vector2::new(-dir.y, dir.x) / dir.norm().max(f64::MIN_POSITIVE);
        // On the segment, then each side of it.
        let mut sets: [DepthSet; 3] = std::array::from_fn(|_| vec![f64::NAN; n]);
        let mut valid = [0usize; 3];
        let mut depth_sum = [0.0f64; 3];
        // k is the sample's index in all three sets and the pixel's along the segment.
        #[allow(clippy::needless_range_loop)]
        for k in 0..n {
            let px = sample_pixel(s, k, n);
            let depths = [
                depth.sample(&px),
                side_depth(depth, &px, &normal),
                side_depth(depth, &px, &-normal),
            ];
            for (j, d) in depths.into_iter().enumerate() {
                // Kept only where it back-projects (as `set_points` will again).
                if let Some(d) =
                    d.filter(|&d| back_project(&view.camera, &view.pose, &px, d).is_some())
                {
                    sets[j][k] = d;
                    valid[j] += 1;
                    depth_sum[j] += d;
                }
            }
        }
        // An occluding edge belongs to the nearer surface: try that side first.
        let mean = |j: usize| depth_sum[j] / valid[j].max(1) as f64;
        if valid[2] >= config.line_min_valid_samples
            && (valid[1] < config.line_min_valid_samples || mean(2) < mean(1))
        {
            sets.swap(1, 2);
            valid.swap(1, 2);
        }
        let sets: Vec<DepthSet> = sets
            .into_iter()
            .zip(valid)
            .filter(|(_, v)| *v >= config.line_min_valid_samples)
            .map(|(set, _)| set)
            .collect();
        supports.push((i, (!sets.is_empty()).then_some(sets)));
    }
    FrameSamples { supports }
}

/// The decision for every row of one track.
struct TrackResult {
    /// Track-order endpoints, when refined.
    line: Option<[[f64; 3]; 2]>,
    outcomes: Vec<(usize, Outcome)>,
}

fn seed_of(seed: u64, key: i64) -> u64 {
    // splitmix64 of the pair: independent streams per track, any thread count.
    let mut z = seed ^ (key as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn ratio_ok(config: &RefineConfig, inliers: usize, total: usize) -> bool {
    total > 0 && inliers as f64 >= config.line_min_inlier_ratio * total as f64
}

/// An accepted support of a track: its row, the inlier samples of its first fitting
/// set, and all its sets' points.
type Accepted = (usize, Vec<Vector3<f64>>, Vec<Vec<Vector3<f64>>>);

/// `points(row, sets)`: the world points of a support's candidate sets.
fn refine_track(
    config: &RefineConfig,
    key: i64,
    members: &[usize],
    observed: &HashMap<usize, &SupportSamples>,
    points: impl Fn(usize, &[DepthSet]) -> Vec<Vec<Vector3<f64>>>,
    old_direction: Vector3<f64>,
) -> TrackResult {
    let thr = config.line_inlier_threshold_m;
    let mut rng = ChaCha8Rng::seed_from_u64(seed_of(config.seed, key));
    let mut outcomes: Vec<(usize, Outcome)> = Vec::with_capacity(members.len());
    // Accepted supports: (row, inlier samples of its first fitting set, all its sets).
    let mut accepted: Vec<Accepted> = Vec::new();
    for &i in members {
        match observed.get(&i) {
            None => {}
            Some(None) => outcomes.push((i, Outcome::NoDepth)),
            Some(Some(depths)) => {
                let sets = points(i, depths);
                // The first candidate set whose samples lie on one line: the depth on the
                // segment, else one side of an occluding edge.
                let fitted = sets.iter().find_map(|pts| {
                    let fit = ransac_line(pts, thr, config.ransac_iterations, &mut rng)?;
                    ratio_ok(config, fit.inlier_count(), pts.len()).then(|| {
                        pts.iter()
                            .zip(&fit.inliers)
                            .filter(|(_, b)| **b)
                            .map(|(p, _)| *p)
                            .collect::<Vec<_>>()
                    })
                });
                match fitted {
                    Some(inl) => accepted.push((i, inl, sets)),
                    None => outcomes.push((i, Outcome::Fit)),
                }
            }
        }
    }
    let drop_rest = |mut outcomes: Vec<(usize, Outcome)>, why: Outcome| {
        for &i in members {
            if !outcomes.iter().any(|(r, _)| *r == i) {
                outcomes.push((i, why));
            }
        }
        TrackResult {
            line: None,
            outcomes,
        }
    };
    if accepted.is_empty() {
        let why = if outcomes.iter().any(|(_, o)| *o == Outcome::Fit) {
            Outcome::Fit
        } else {
            Outcome::NoDepth
        };
        return drop_rest(outcomes, why);
    }
    // Merge: one line through the supports' samples; a support stays when most of its
    // samples are on it.
    let union: Vec<Vector3<f64>> = accepted
        .iter()
        .flat_map(|(_, p, _)| p.iter().copied())
        .collect();
    let Some(merged) = ransac_line(&union, thr, config.ransac_iterations, &mut rng) else {
        return drop_rest(outcomes, Outcome::Disagree);
    };
    let mut kept_points = Vec::new();
    let mut kept_rows = Vec::new();
    for (i, _, sets) in &accepted {
        // Judged on the merged line, a support's best set may be another side than the
        // one it fitted alone (a segment just off an occluding edge reads the background).
        let best = sets
            .iter()
            .map(|pts| {
                let on: Vec<Vector3<f64>> = pts
                    .iter()
                    .filter(|p| merged.line.distance(p) <= thr)
                    .copied()
                    .collect();
                (on, pts.len())
            })
            .filter(|(on, n)| ratio_ok(config, on.len(), *n))
            .max_by_key(|(on, _)| on.len());
        match best {
            Some((on, _)) => {
                kept_points.extend(on);
                kept_rows.push(*i);
            }
            None => outcomes.push((*i, Outcome::Disagree)),
        }
    }
    if kept_rows.is_empty() {
        return drop_rest(outcomes, Outcome::Disagree);
    }
    let line = principal_line(&kept_points).unwrap_or(merged.line);
    let (lo, hi) = kept_points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let t = line.param(p);
            (lo.min(t), hi.max(t))
        });
    let (mut a, mut b) = (line.at(lo), line.at(hi));
    if (b - a).dot(&old_direction) < 0.0 {
        std::mem::swap(&mut a, &mut b);
    }
    for &i in &kept_rows {
        outcomes.push((i, Outcome::Kept));
    }
    // Rows in frames without a depth map take the refined track.
    for &i in members {
        if !observed.contains_key(&i) {
            outcomes.push((i, Outcome::Kept));
        }
    }
    TrackResult {
        line: Some([[a.x, a.y, a.z], [b.x, b.y, b.z]]),
        outcomes,
    }
}

/// Groups the labels of each track, fits and merges, rewrites `rows`.
pub(crate) fn combine(
    config: &RefineConfig,
    rows: &mut [LineRow],
    samples: Vec<FrameSamples>,
    poses: &HashMap<u32, &PoseRow>,
) -> KindReport {
    let mut groups: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        if r.endpoints.is_some() {
            let key = if r.track_id >= 0 {
                r.track_id
            } else {
                -2 - i as i64
            };
            groups.entry(key).or_default().push(i);
        }
    }
    let observed_owned: Vec<(usize, SupportSamples)> =
        samples.into_iter().flat_map(|s| s.supports).collect();
    let observed: HashMap<usize, &SupportSamples> =
        observed_owned.iter().map(|(i, s)| (*i, s)).collect();
    let groups: Vec<(i64, Vec<usize>)> = groups.into_iter().collect();
    let rows_ref: &[LineRow] = rows;
    let results: Vec<TrackResult> = groups
        .par_iter()
        .map(|(key, members)| {
            // The track's own order, recovered from its first label.
            let r = &rows_ref[members[0]];
            let ends = r.endpoints.unwrap_or_default();
            let (s, e) = if r.swapped {
                (ends[1], ends[0])
            } else {
                (ends[0], ends[1])
            };
            let dir = Vector3::from(e) - Vector3::from(s);
            let points = |i: usize, depths: &[DepthSet]| {
                let row = &rows_ref[i];
                match poses.get(&row.frame_id) {
                    Some(view) => depths
                        .iter()
                        .map(|d| set_points(view, &row.segment, d))
                        .collect(),
                    // Sampled rows have a view (`sample_frame` ran on it).
                    None => Vec::new(),
                }
            };
            refine_track(config, *key, members, &observed, points, dir)
        })
        .collect();

    let mut tally = Tally::default();
    for result in results {
        tally.object(result.line.is_some());
        let mut outcomes = result.outcomes;
        outcomes.sort_by_key(|(i, _)| *i);
        for (i, outcome) in outcomes {
            let row = &mut rows[i];
            let old = row.endpoints;
            match (outcome, result.line, poses.get(&row.frame_id)) {
                (Outcome::Kept, Some(line), Some(view)) => {
                    let (ends, swapped, _) =
                        align_endpoints(&view.camera, &view.pose, &row.segment, &line);
                    let moved = old.map(|o| {
                        0.5 * (crate::stats::dist3(&o[0], &ends[0])
                            + crate::stats::dist3(&o[1], &ends[1]))
                    });
                    row.endpoints = Some(ends);
                    row.swapped = swapped;
                    tally.add(Outcome::Kept, moved);
                }
                (Outcome::Kept, _, _) => {
                    row.endpoints = None;
                    row.swapped = false;
                    tally.add(Outcome::NoDepth, None);
                }
                (o, _, _) => {
                    row.endpoints = None;
                    row.swapped = false;
                    tally.add(o, None);
                }
            }
        }
    }
    tally.report()
}
