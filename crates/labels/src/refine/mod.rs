//! The refine stage's steps (optional stage): moves SfM labels onto the depth maps of the
//! training frames (docs/method.md section 8).
//!
//! Points: each observation of a 3D point in a training frame with a depth map reads
//! the depth at the observation (bilinear, nearest-neighbour fallback; see
//! [`crate::depth`]) and back-projects it. All valid observations of a point are
//! combined robustly: the coordinate-wise median, observations farther than
//! [`RefineConfig::point_inlier_threshold_m`] from it rejected, the median of the rest.
//! The upstream tool lets the last image win instead. An observation whose frame has
//! a depth map but no valid depth there, or that was rejected, loses its label;
//! observations in frames without a depth map get the combined point. A point with no
//! valid observation loses all its labels.
//!
//! Where the depth is read ([`PointSampling`]): at the keypoint (default), or at the
//! projection of the SfM point (the upstream tool). The keypoint is what the image
//! measured; the projection of a mislocated 3D point is off by the label's own error,
//! so reading depth there only corrects the error along the viewing ray.
//!
//! Lines: each support (a 2D segment of a track in a training frame with depth) is
//! sampled every [`RefineConfig::line_sample_spacing_px`] pixels, both endpoints
//! included, and back-projected. A 3D line is fitted to each support by RANSAC
//! (threshold [`RefineConfig::line_inlier_threshold_m`], in metres: upstream uses 0.75
//! times the size of 5 pixels at the median depth, about 1.4 cm at 2 m for 7-Scenes,
//! so the default is 2 cm) and accepted when at least
//! [`RefineConfig::line_min_inlier_ratio`] (90 %, as upstream) of its valid samples are
//! inliers. A segment on an occluding edge reads a mix of both surfaces, so each side's
//! depth (read 1.5 and 3 px off the segment, extrapolated to it in inverse depth, exact
//! for planes) is a second and third candidate, the nearer side first; without them
//! ~15 % of the synthetic scene's line labels were dropped, with them ~2 %.
//! The accepted supports of a track are merged: a RANSAC line over all their
//! inlier samples, supports none of whose candidate sets has 90 % of its samples on it
//! rejected, a
//! least-squares line over the rest; the new endpoints span the projections of those
//! samples on it. Every label of the track gets these endpoints, ordered to follow its
//! own 2D segment; labels of rejected supports are dropped.
//!
//! These are the stage's steps; the stage itself (its folder, record and skip) is
//! [`crate::refine_stage`].

mod config;
mod error;
mod fit;
pub(crate) mod inputs;
mod lines;
mod points;
mod report;

pub use config::{PointSampling, RefineConfig};
pub use error::RefineError;
pub use fit::{Fit, Line3, principal_line, ransac_line};
pub use report::{KindReport, RefineReport};

use crate::depth::{DepthError, DepthMap};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use tables::labels::{LabelSource, LabelTables, PoseRow};

/// A training frame's camera, pose and (loaded on demand) depth map.
pub(crate) struct View<'a> {
    pub pose: &'a PoseRow,
    pub depth_path: Option<&'a Path>,
}

impl View<'_> {
    pub fn load_depth(
        &self,
        units: f64,
        config: &RefineConfig,
    ) -> Result<Option<DepthMap>, RefineError> {
        let Some(path) = self.depth_path else {
            return Ok(None);
        };
        let d = DepthMap::read(path, units, config.max_depth_m)?;
        let cam = &self.pose.camera;
        if (u64::from(d.width()), u64::from(d.height())) != (cam.width, cam.height) {
            return Err(RefineError::Depth(DepthError::Size {
                path: path.to_path_buf(),
                frame_id: self.pose.frame_id,
                name: self.pose.name.clone(),
                width: d.width(),
                height: d.height(),
                expected_width: cam.width,
                expected_height: cam.height,
            }));
        }
        Ok(Some(d))
    }
}

/// Refines label tables in memory (see the module docs). `depth_paths`: frame id ->
/// depth map; `units_per_metre` of every depth map. Takes the tables and rewrites their
/// rows in place: at a 7,000-frame scene's size (8.7 M point rows) a copy alone costs
/// about 0.7 GB (docs/performance.md, "A real scene's size").
pub fn refine(
    config: &RefineConfig,
    mut labels: LabelTables,
    depth_paths: &HashMap<u32, PathBuf>,
    units_per_metre: f64,
) -> Result<(LabelTables, RefineReport), RefineError> {
    config.validate()?;
    let views: Vec<View> = labels
        .poses
        .iter()
        .map(|p| View {
            pose: p,
            depth_path: depth_paths.get(&p.frame_id).map(PathBuf::as_path),
        })
        .collect();
    let with_depth = views.iter().filter(|v| v.depth_path.is_some()).count();
    // Per frame: the row ranges of its points and lines (rows are sorted by frame).
    let point_ranges = ranges(labels.points.iter().map(|r| r.frame_id));
    let line_ranges = ranges(labels.lines.iter().map(|r| r.frame_id));

    let bar = stage::progress_bar(views.len() as u64, "refine");
    let samples: Vec<(points::FrameSamples, lines::FrameSamples)> = views
        .par_iter()
        .map(|v| {
            let depth = v.load_depth(units_per_metre, config)?;
            let prange = point_ranges.get(&v.pose.frame_id).cloned().unwrap_or(0..0);
            let lrange = line_ranges.get(&v.pose.frame_id).cloned().unwrap_or(0..0);
            let p = points::sample_frame(config, v.pose, depth.as_ref(), &labels.points, prange);
            let l = lines::sample_frame(config, v.pose, depth.as_ref(), &labels.lines, lrange);
            bar.inc(1);
            Ok((p, l))
        })
        // Every frame's result, in order: the error reported is the first frame's,
        // whatever the thread count.
        .collect::<Vec<Result<_, RefineError>>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    bar.finish_and_clear();
    let (point_samples, line_samples): (Vec<_>, Vec<_>) = samples.into_iter().unzip();

    let frames = views.len();
    drop(views);
    let points_report = points::combine(config, &mut labels.points, point_samples);
    let poses_by_frame: HashMap<u32, &PoseRow> =
        labels.poses.iter().map(|p| (p.frame_id, p)).collect();
    let lines_report = lines::combine(config, &mut labels.lines, line_samples, &poses_by_frame);
    drop(poses_by_frame);
    labels.source = LabelSource::DepthRefined;
    let report = RefineReport {
        config: config.clone(),
        frames,
        frames_with_depth: with_depth,
        points: points_report,
        lines: lines_report,
    };
    Ok((labels, report))
}

/// frame id -> row range, for rows sorted by frame id.
fn ranges(frames: impl Iterator<Item = u32>) -> HashMap<u32, std::ops::Range<usize>> {
    let mut out: HashMap<u32, std::ops::Range<usize>> = HashMap::new();
    for (i, f) in frames.enumerate() {
        out.entry(f)
            .and_modify(|r| r.end = i + 1)
            .or_insert(i..i + 1);
    }
    out
}
