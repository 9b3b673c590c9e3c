//! One frame: filter the correspondences by reliability, estimate the pose from points
//! only and from points + lines, and measure both against the ground truth.

use crate::error::ScoreError;
use crate::localiser::{Correspondences, TestFrame, Timing};
use geometry::metrics::{PoseError, pose_error};
use geometry::{Camera, Pose};
use pose::{LineMatch, PointMatch, RansacOptions, estimate_pose};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The two poses estimated per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    Points,
    PointsLines,
}

impl Variant {
    pub const ALL: [Variant; 2] = [Variant::Points, Variant::PointsLines];

    /// File and column name part: `points`, `points_lines`.
    pub fn key(self) -> &'static str {
        match self {
            Variant::Points => "points",
            Variant::PointsLines => "points_lines",
        }
    }

    /// Human name: `points`, `points + lines`.
    pub fn label(self) -> &'static str {
        match self {
            Variant::Points => "points",
            Variant::PointsLines => "points + lines",
        }
    }
}

/// Reliability filters and RANSAC settings. Defaults: the reference evaluation's
/// (docs/method.md section 6): r >= 0.5 for points, r >= 0.02 for lines, 12 px / 10 px.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoreConfig {
    pub min_point_reliability: f64,
    pub min_line_reliability: f64,
    /// `ransac.seed` is the run's seed; each frame uses [`frame_seed`] of it, so a
    /// frame's pose does not depend on which other frames are scored.
    pub ransac: RansacOptions,
}

impl Default for ScoreConfig {
    fn default() -> Self {
        ScoreConfig {
            min_point_reliability: 0.5,
            min_line_reliability: 0.02,
            ransac: RansacOptions::default(),
        }
    }
}

impl ScoreConfig {
    /// The configuration `pl2map score` and the pipeline's `[score]` build: RANSAC with
    /// these thresholds (`pose::RansacOptions::with_thresholds`, as `pl2map pose`) and
    /// seed, and the iteration cap (None: the default) bounding the minimum too.
    pub fn with_ransac(
        min_point_reliability: f64,
        min_line_reliability: f64,
        point_threshold_px: f64,
        line_threshold_px: f64,
        seed: u64,
        max_iterations: Option<usize>,
    ) -> Self {
        let base = RansacOptions::with_thresholds(point_threshold_px, line_threshold_px);
        let max_iterations = max_iterations.unwrap_or(base.max_iterations);
        ScoreConfig {
            min_point_reliability,
            min_line_reliability,
            ransac: RansacOptions {
                seed,
                max_iterations,
                min_iterations: base.min_iterations.min(max_iterations),
                ..base
            },
        }
    }

    pub fn validate(&self) -> Result<(), ScoreError> {
        for (name, v) in [
            ("min_point_reliability", self.min_point_reliability),
            ("min_line_reliability", self.min_line_reliability),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(ScoreError::Config(format!(
                    "{name} must be in [0, 1], got {v}"
                )));
            }
        }
        for (name, v) in [
            ("point_threshold_px", self.ransac.point_threshold_px),
            ("line_threshold_px", self.ransac.line_threshold_px),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ScoreError::Config(format!(
                    "{name} must be a finite number of pixels > 0, got {v}"
                )));
            }
        }
        // The rest of the RANSAC options (iterations, probability...): refused here,
        // before any frame, rather than as a failure of every frame.
        self.ransac
            .validate()
            .map_err(|e| ScoreError::Config(format!("RANSAC options: {e}")))?;
        Ok(())
    }
}

/// The RANSAC seed of one image: the run's seed mixed with a hash of the image's name
/// (FNV-1a, then SplitMix64's finaliser), so that neighbouring images get unrelated
/// random streams and an image's pose depends neither on its position in a query list
/// nor on which command localised it (`pl2map score` keys frames by id, `pl2map
/// localize` by list position; both by name here).
pub fn frame_seed(seed: u64, name: &str) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for b in name.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    let mut z = seed ^ h.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// What one variant gave on one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct VariantResult {
    /// World-to-camera; None when the pose could not be estimated.
    pub pose: Option<Pose>,
    pub error: Option<PoseError>,
    /// Why there is no pose.
    pub failure: Option<String>,
    pub point_inliers: usize,
    pub line_inliers: usize,
    pub iterations: usize,
    pub ms: f64,
    /// Per kept correspondence (points, then lines, in the order of [`filter`]'s
    /// output): an inlier of the pose. Empty without a pose.
    pub point_inlier_mask: Vec<bool>,
    pub line_inlier_mask: Vec<bool>,
}

/// Everything measured on one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameResult {
    pub frame_id: u64,
    pub name: String,
    /// Correspondences proposed, and kept by the reliability filters.
    pub points_total: usize,
    pub lines_total: usize,
    pub points_kept: usize,
    pub lines_kept: usize,
    /// Indexed like [`Variant::ALL`].
    pub variants: [VariantResult; 2],
    /// `read` (shard decoding), the localiser's steps, `filter`, `pose_points`,
    /// `pose_points_lines`, in that order.
    pub timings: Vec<Timing>,
}

impl FrameResult {
    pub fn variant(&self, v: Variant) -> &VariantResult {
        &self.variants[v as usize]
    }
}

/// One frame localised: the result and the correspondences it was computed from
/// ([`crate::localize::localize_batch`]'s output, what [`crate::visual`] draws).
#[derive(Clone, Debug)]
pub struct Localised {
    pub result: FrameResult,
    pub correspondences: Correspondences,
}

/// The correspondences that pass the reliability filters, as the pose crate takes
/// them. A NaN reliability never passes.
pub fn filter(c: &Correspondences, config: &ScoreConfig) -> (Vec<PointMatch>, Vec<LineMatch>) {
    let points = c
        .points
        .iter()
        .filter(|p| p.reliability >= config.min_point_reliability)
        .map(|p| p.point)
        .collect();
    let lines = c
        .lines
        .iter()
        .filter(|l| l.reliability >= config.min_line_reliability)
        .map(|l| l.line)
        .collect();
    (points, lines)
}

fn run_variant(
    camera: &Camera,
    points: &[PointMatch],
    lines: &[LineMatch],
    options: &RansacOptions,
) -> VariantResult {
    let t = Instant::now();
    let result = estimate_pose(camera, points, lines, options);
    let ms = t.elapsed().as_secs_f64() * 1e3;
    match result {
        // RANSAC's final count in pixels can reach 0 (a camera or correspondences that
        // no pose explains): no inlier supports such a pose, so it is no pose.
        Ok(est) if est.num_point_inliers + est.num_line_inliers == 0 => VariantResult {
            pose: None,
            error: None,
            failure: Some("no inliers support the pose RANSAC returned".into()),
            point_inliers: 0,
            line_inliers: 0,
            iterations: est.iterations,
            ms,
            point_inlier_mask: Vec::new(),
            line_inlier_mask: Vec::new(),
        },
        Ok(est) => VariantResult {
            error: None,
            pose: Some(est.pose),
            failure: None,
            point_inliers: est.num_point_inliers,
            line_inliers: est.num_line_inliers,
            iterations: est.iterations,
            ms,
            point_inlier_mask: est.point_inliers,
            line_inlier_mask: est.line_inliers,
        },
        Err(e) => VariantResult {
            pose: None,
            error: None,
            failure: Some(e.to_string()),
            point_inliers: 0,
            line_inliers: 0,
            iterations: 0,
            ms,
            point_inlier_mask: Vec::new(),
            line_inlier_mask: Vec::new(),
        },
    }
}

/// Localises one image from its correspondences: the reliability filters, then RANSAC
/// with points only and with points + lines (side by side), seeded with [`frame_seed`] of the run's
/// seed and the image's `name`. The one localisation step of both the score stage
/// ([`score_frame`]) and `pl2map localize` ([`crate::localize`]); the variants carry
/// no errors (no ground truth here). `timings` holds what came before; the filter and
/// both pose estimations are added.
pub fn localize_frame(
    frame_id: u64,
    name: &str,
    camera: &Camera,
    corr: &Correspondences,
    config: &ScoreConfig,
    mut timings: Vec<Timing>,
) -> FrameResult {
    let t = Instant::now();
    let (points, lines) = filter(corr, config);
    timings.push(Timing {
        step: "filter".into(),
        ms: t.elapsed().as_secs_f64() * 1e3,
    });
    let options = RansacOptions {
        seed: frame_seed(config.ransac.seed, name),
        ..config.ransac.clone()
    };
    // Both variants side by side on the rayon pool: each is seeded alike and reads
    // only its inputs, so the poses are those of one after the other.
    let (p, pl) = rayon::join(
        || run_variant(camera, &points, &[], &options),
        || run_variant(camera, &points, &lines, &options),
    );
    timings.push(Timing {
        step: "pose_points".into(),
        ms: p.ms,
    });
    timings.push(Timing {
        step: "pose_points_lines".into(),
        ms: pl.ms,
    });
    FrameResult {
        frame_id,
        name: name.to_string(),
        points_total: corr.points.len(),
        lines_total: corr.lines.len(),
        points_kept: points.len(),
        lines_kept: lines.len(),
        variants: [p, pl],
        timings,
    }
}

/// Scores one frame: [`localize_frame`], then each pose's error against the frame's
/// ground truth.
pub fn score_frame(
    frame: &TestFrame,
    corr: &Correspondences,
    config: &ScoreConfig,
    timings: Vec<Timing>,
) -> FrameResult {
    let mut r = localize_frame(
        frame.frame_id(),
        frame.name(),
        frame.camera(),
        corr,
        config,
        timings,
    );
    measure(&mut r, frame.gt_pose());
    r
}

/// Fills in each variant's error against the ground truth `gt`.
pub fn measure(r: &mut FrameResult, gt: &Pose) {
    for v in &mut r.variants {
        v.error = v.pose.as_ref().map(|p| pose_error(gt, p));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localiser::{LineCorrespondence, PointCorrespondence};

    /// A pose that no correspondence supports in the end (a camera whose principal point
    /// lies 1e12 px away, built past the readers' checks) is no pose, not "localised".
    #[test]
    fn a_pose_without_inliers_is_no_pose() {
        use geometry::{CameraModel, Vector2, Vector3};
        let good = Camera::new(
            CameraModel::SimplePinhole,
            640,
            480,
            vec![525.0, 320.0, 240.0],
        )
        .unwrap();
        let far = Camera {
            params: vec![525.0, 1e12, 240.0],
            ..good.clone()
        };
        let points: Vec<PointMatch> = (0..40)
            .map(|i| {
                let world = Vector3::new(
                    (i % 7) as f64 * 0.3 - 1.0,
                    (i % 5) as f64 * 0.2 - 0.5,
                    3.0 + (i % 3) as f64,
                );
                let (u, v) = (
                    525.0 * world.x / world.z + 320.0,
                    525.0 * world.y / world.z + 240.0,
                );
                PointMatch {
                    pixel: Vector2::new(u, v),
                    world,
                }
            })
            .collect();
        let options = RansacOptions::default();
        let sane = run_variant(&good, &points, &[], &options);
        assert!(sane.pose.is_some() && sane.point_inliers > 30, "{sane:?}");
        let r = run_variant(&far, &points, &[], &options);
        assert!(r.pose.is_none(), "{r:?}");
        assert_eq!(r.point_inliers + r.line_inliers, 0);
    }

    fn corr() -> Correspondences {
        let p = |r| PointCorrespondence::new([1.0, 2.0], [0.0, 0.0, 1.0], r);
        let l =
            |r| LineCorrespondence::new([0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0], r);
        Correspondences {
            points: vec![p(0.49), p(0.5), p(0.9), p(f64::NAN)],
            lines: vec![l(0.019), l(0.02), l(1.0), l(f64::NAN)],
            timings: vec![],
        }
    }

    #[test]
    fn reliability_thresholds_are_inclusive_and_reject_nan() {
        let (p, l) = filter(&corr(), &ScoreConfig::default());
        assert_eq!((p.len(), l.len()), (2, 2));
        let strict = ScoreConfig {
            min_point_reliability: 0.9,
            min_line_reliability: 1.0,
            ..ScoreConfig::default()
        };
        let (p, l) = filter(&corr(), &strict);
        assert_eq!((p.len(), l.len()), (1, 1));
        let all = ScoreConfig {
            min_point_reliability: 0.0,
            min_line_reliability: 0.0,
            ..ScoreConfig::default()
        };
        let (p, l) = filter(&corr(), &all);
        assert_eq!((p.len(), l.len()), (3, 3));
    }

    #[test]
    fn config_validation() {
        assert!(ScoreConfig::default().validate().is_ok());
        let c = ScoreConfig {
            min_point_reliability: 1.5,
            ..ScoreConfig::default()
        };
        assert!(c.validate().is_err());
        let c = ScoreConfig {
            min_line_reliability: f64::NAN,
            ..ScoreConfig::default()
        };
        assert!(c.validate().is_err());
        let mut c = ScoreConfig::default();
        c.ransac.line_threshold_px = 0.0;
        assert!(c.validate().is_err());
    }

    /// A frame from a synthetic problem: outliers carry low reliability, inliers high.
    fn synthetic_frame(seed: u64) -> (TestFrame, Correspondences) {
        use pose::synthetic::{SyntheticConfig, generate_seeded};
        let cfg = SyntheticConfig {
            num_points: 60,
            point_outlier_ratio: 0.3,
            num_lines: 30,
            line_outlier_ratio: 0.3,
            ..SyntheticConfig::indoor(SyntheticConfig::default_camera())
        };
        let pr = generate_seeded(&cfg, seed);
        let record = shards::FrameRecord {
            label_source: shards::LabelSource::SyntheticExact,
            ..shards::FrameRecord::unlabelled(
                seed,
                format!("f{seed}.png"),
                shards::Split::Test,
                pr.camera.clone(),
                pr.gt,
                vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A],
                shards::ImageFormat::Png,
            )
        };
        let points = pr
            .points
            .iter()
            .zip(&pr.point_is_inlier)
            .map(|(m, &inl)| PointCorrespondence {
                point: *m,
                reliability: if inl { 0.9 } else { 0.1 },
            })
            .collect();
        let lines = pr
            .lines
            .iter()
            .zip(&pr.line_is_inlier)
            .map(|(l, &inl)| LineCorrespondence {
                line: *l,
                reliability: if inl { 0.5 } else { 0.01 },
            })
            .collect();
        (
            TestFrame { record },
            Correspondences {
                points,
                lines,
                timings: vec![],
            },
        )
    }

    #[test]
    fn scores_a_synthetic_frame_and_repeats() {
        let (frame, corr) = synthetic_frame(3);
        let config = ScoreConfig::default();
        let r = score_frame(&frame, &corr, &config, vec![]);
        assert_eq!((r.points_total, r.lines_total), (60, 30));
        // The filters drop exactly the outliers.
        assert_eq!((r.points_kept, r.lines_kept), (42, 21));
        for v in Variant::ALL {
            let e = r.variant(v).error.expect("a pose");
            // 1 px noise at 1-8 m: centimetres at most.
            assert!(
                e.translation_cm() < 10.0 && e.rotation_deg < 1.0,
                "{v:?}: {e:?}"
            );
            // Only the kept (inlier) correspondences went in; 1 px noise, 12 px threshold.
            let n = r.variant(v).point_inliers;
            assert!((40..=42).contains(&n), "{v:?}: {n} point inliers");
        }
        assert_eq!(r.variant(Variant::Points).line_inliers, 0);
        assert!(r.variant(Variant::PointsLines).line_inliers >= 19);
        let steps: Vec<_> = r.timings.iter().map(|t| t.step.as_str()).collect();
        assert_eq!(steps, vec!["filter", "pose_points", "pose_points_lines"]);
        // Same frame, same seed: the same poses.
        let again = score_frame(&frame, &corr, &config, vec![]);
        for v in Variant::ALL {
            assert_eq!(r.variant(v).pose, again.variant(v).pose);
        }
    }

    #[test]
    fn too_few_correspondences_is_a_recorded_failure() {
        let (frame, mut corr) = synthetic_frame(4);
        corr.points.truncate(2);
        corr.lines.clear();
        let r = score_frame(&frame, &corr, &ScoreConfig::default(), vec![]);
        for v in Variant::ALL {
            let vr = r.variant(v);
            assert!(vr.pose.is_none() && vr.error.is_none());
            assert!(
                vr.failure.as_deref().unwrap().contains("not enough"),
                "{vr:?}"
            );
        }
    }

    #[test]
    fn frame_seeds_differ_and_repeat() {
        assert_eq!(frame_seed(0, "a/5.png"), frame_seed(0, "a/5.png"));
        assert_ne!(frame_seed(0, "a/5.png"), frame_seed(0, "a/6.png"));
        assert_ne!(frame_seed(0, "a/5.png"), frame_seed(1, "a/5.png"));
    }
}
