//! The refine stage (optional): moves SfM labels onto the depth maps of the training
//! frames (docs/method.md section 8).
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
//! Stage folder: the three label tables (label source `depth-refined`),
//! `refine_report.json`, `stage.json`.

mod fit;
mod lines;
mod points;
mod report;

pub use fit::{Fit, Line3, principal_line, ransac_line};
pub use report::{KindReport, RefineReport};

use crate::depth::{DepthError, DepthMap};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use stage::{Done, Stage};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use tables::frames::{FramesTable, Split};
use tables::labels::{LINES_FILE, LabelSource, LabelTables, POINTS_FILE, POSES_FILE, PoseRow};
use tables::parquet::TableError;
use thiserror::Error;

pub const STAGE: &str = "refine";
pub const REPORT_FILE: &str = "refine_report.json";

/// Where a point observation reads its depth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PointSampling {
    /// At the keypoint (the 2D measurement).
    #[default]
    Keypoint,
    /// At the projection of the current 3D label (the upstream tool).
    Projection,
}

impl std::fmt::Display for PointSampling {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PointSampling::Keypoint => "keypoint",
            PointSampling::Projection => "projection",
        })
    }
}

impl std::str::FromStr for PointSampling {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "keypoint" => Ok(PointSampling::Keypoint),
            "projection" => Ok(PointSampling::Projection),
            _ => Err(format!("expected keypoint or projection, got {s:?}")),
        }
    }
}

/// The refine stage's configuration: `[refine]` of a pipeline file and the flags of
/// `pl2map refine`, the only place its settings and defaults live (metres, pixels).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
// Missing keys take the defaults; unknown keys are refused (pipeline files are typed).
#[serde(default, deny_unknown_fields)]
pub struct RefineConfig {
    /// Where point depth is read: keypoint (the 2D measurement) or projection (of the
    /// current 3D label, the upstream tool).
    #[arg(long, default_value_t = RefineConfig::default().point_sampling)]
    pub point_sampling: PointSampling,
    /// Observations of a point farther than this (metres) from the median are rejected.
    #[arg(long, default_value_t = RefineConfig::default().point_inlier_threshold_m)]
    pub point_inlier_threshold_m: f64,
    /// Depth beyond this (metres) is invalid (upstream: 1000).
    #[arg(long, default_value_t = RefineConfig::default().max_depth_m)]
    pub max_depth_m: f64,
    /// RANSAC inlier distance of line samples to a 3D line (metres).
    #[arg(long, default_value_t = RefineConfig::default().line_inlier_threshold_m)]
    pub line_inlier_threshold_m: f64,
    /// Fraction of a support's valid samples that must be inliers (upstream: 0.9).
    #[arg(long, default_value_t = RefineConfig::default().line_min_inlier_ratio)]
    pub line_min_inlier_ratio: f64,
    /// Distance between depth samples along a segment (pixels).
    #[arg(long, default_value_t = RefineConfig::default().line_sample_spacing_px)]
    pub line_sample_spacing_px: f64,
    /// Samples per segment: at least this many (short segments)...
    #[arg(long, default_value_t = RefineConfig::default().line_min_samples)]
    pub line_min_samples: usize,
    /// ... and at most this many (long ones).
    #[arg(long, default_value_t = RefineConfig::default().line_max_samples)]
    pub line_max_samples: usize,
    /// A support needs this many samples with valid depth (upstream: 7).
    #[arg(long, default_value_t = RefineConfig::default().line_min_valid_samples)]
    pub line_min_valid_samples: usize,
    /// RANSAC iterations at most (fewer when the inlier ratio allows).
    #[arg(long, default_value_t = RefineConfig::default().ransac_iterations)]
    pub ransac_iterations: usize,
    /// Seed of the RANSAC draws (each track draws from its own seeded stream).
    #[arg(long, default_value_t = RefineConfig::default().seed)]
    pub seed: u64,
}

impl Default for RefineConfig {
    fn default() -> Self {
        RefineConfig {
            point_sampling: PointSampling::Keypoint,
            point_inlier_threshold_m: 0.05,
            max_depth_m: 1000.0,
            line_inlier_threshold_m: 0.02,
            line_min_inlier_ratio: 0.9,
            line_sample_spacing_px: 2.0,
            line_min_samples: 8,
            line_max_samples: 256,
            line_min_valid_samples: 7,
            ransac_iterations: 200,
            seed: 0,
        }
    }
}

impl RefineConfig {
    pub fn validate(&self) -> Result<(), RefineError> {
        let positive = [
            ("point_inlier_threshold_m", self.point_inlier_threshold_m),
            ("max_depth_m", self.max_depth_m),
            ("line_inlier_threshold_m", self.line_inlier_threshold_m),
            ("line_sample_spacing_px", self.line_sample_spacing_px),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(RefineError::Config(format!(
                    "{name} must be positive and finite, got {v}"
                )));
            }
        }
        if !(0.0..=1.0).contains(&self.line_min_inlier_ratio) {
            return Err(RefineError::Config(format!(
                "line_min_inlier_ratio must be in [0, 1], got {}",
                self.line_min_inlier_ratio
            )));
        }
        if self.line_min_samples < 2 || self.line_max_samples < self.line_min_samples {
            return Err(RefineError::Config(format!(
                "need 2 <= line_min_samples <= line_max_samples, got {} and {}",
                self.line_min_samples, self.line_max_samples
            )));
        }
        if self.line_min_valid_samples < 2 || self.ransac_iterations == 0 {
            return Err(RefineError::Config(
                "line_min_valid_samples must be >= 2 and ransac_iterations >= 1".into(),
            ));
        }
        Ok(())
    }
}

#[derive(Debug, Error)]
pub enum RefineError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Depth(#[from] DepthError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("refine configuration: {0}")]
    Config(String),
    #[error("label tables: frame {frame_id} is not a training frame of the frames table")]
    UnknownFrame { frame_id: u32 },
    #[error("no training frame has a depth map (frames table depth source: {depth_source})")]
    NoDepth { depth_source: String },
    #[error("the frames table has depth maps but no depth_units_per_metre")]
    NoDepthUnits,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct RefineOutput {
    pub report: RefineReport,
}

impl stage::Note for RefineOutput {
    fn note(&self) -> String {
        let (p, l) = (&self.report.points, &self.report.lines);
        format!(
            "{} of {} point labels and {} of {} line labels kept",
            p.kept, p.labels, l.kept, l.labels
        )
    }
}

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
/// depth map; `units_per_metre` of every depth map.
pub fn refine(
    config: &RefineConfig,
    labels: &LabelTables,
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

    let mut out = LabelTables {
        source: LabelSource::DepthRefined,
        pose_source: labels.pose_source,
        frames_sha256: labels.frames_sha256.clone(),
        line_tracks: labels.line_tracks.clone(),
        points: labels.points.clone(),
        lines: labels.lines.clone(),
        poses: labels.poses.clone(),
    };
    let points_report = points::combine(config, &mut out.points, point_samples);
    let poses_by_frame: HashMap<u32, &PoseRow> =
        labels.poses.iter().map(|p| (p.frame_id, p)).collect();
    let lines_report = lines::combine(config, &mut out.lines, line_samples, &poses_by_frame);
    let report = RefineReport {
        config: config.clone(),
        frames: views.len(),
        frames_with_depth: with_depth,
        points: points_report,
        lines: lines_report,
    };
    Ok((out, report))
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

/// Content hash of the depth maps of the given frames (name and file hash per frame,
/// in frame order), hashed in parallel.
fn depth_hash(paths: &BTreeMap<u32, (String, PathBuf)>) -> Result<String, RefineError> {
    let hashes: Vec<String> = paths
        .par_iter()
        .map(|(_, (_, p))| stage::sha256_file(p))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    let mut all = String::new();
    for ((_, (name, _)), h) in paths.iter().zip(hashes) {
        all.push_str(name);
        all.push('\0');
        all.push_str(&h);
        all.push('\n');
    }
    Ok(stage::sha256_bytes(all.as_bytes()))
}

/// Runs the refine stage: frames table + label folder -> refined label folder `out`.
pub fn run(
    config: &RefineConfig,
    frames_path: &Path,
    labels_dir: &Path,
    out: &Path,
) -> Result<Done<RefineOutput>, RefineError> {
    config.validate()?;
    let frames_sha256 = stage::sha256_file(frames_path)?;
    let frames = FramesTable::read_parquet(frames_path)?;
    let labels = LabelTables::read(labels_dir)?;
    labels.require_frames(frames_path, &frames_sha256)?;
    let train: HashMap<u32, &tables::frames::Frame> = frames
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .map(|f| (f.id, f))
        .collect();
    let mut depth: BTreeMap<u32, (String, PathBuf)> = BTreeMap::new();
    for p in &labels.poses {
        let f = train.get(&p.frame_id).ok_or(RefineError::UnknownFrame {
            frame_id: p.frame_id,
        })?;
        if let Some(d) = &f.depth_path {
            depth.insert(p.frame_id, (f.name.clone(), d.clone()));
        }
    }
    if depth.is_empty() {
        return Err(RefineError::NoDepth {
            depth_source: frames.meta.depth_source.clone(),
        });
    }
    let units = frames
        .meta
        .depth_units_per_metre
        .ok_or(RefineError::NoDepthUnits)?;

    let mut inputs = BTreeMap::from([
        ("frames".to_string(), frames_sha256),
        ("depth".to_string(), depth_hash(&depth)?),
    ]);
    for f in [POINTS_FILE, LINES_FILE, POSES_FILE] {
        inputs.insert(
            format!("labels/{f}"),
            stage::sha256_file(&labels_dir.join(f))?,
        );
    }
    Stage::new(STAGE, out, config, inputs)?.run(
        |dir| {
            let path = dir.join(REPORT_FILE);
            let io = |source| RefineError::Io {
                path: path.clone(),
                source,
            };
            let bytes = std::fs::read(&path).map_err(io)?;
            let report = serde_json::from_slice(&bytes)
                .map_err(|e| io(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))?;
            Ok(RefineOutput { report })
        },
        |outputs| {
            let depth_paths: HashMap<u32, PathBuf> =
                depth.into_iter().map(|(id, (_, p))| (id, p)).collect();
            let (refined, report) = refine(config, &labels, &depth_paths, units)?;
            refined.write(outputs.dir())?;
            for f in [POINTS_FILE, LINES_FILE, POSES_FILE] {
                outputs.path(f);
            }
            let mut json = serde_json::to_vec_pretty(&report).map_err(|e| {
                RefineError::Config(format!("cannot encode the refine report: {e}"))
            })?;
            json.push(b'\n');
            outputs.write(REPORT_FILE, &json)?;
            Ok(RefineOutput { report })
        },
    )
}
