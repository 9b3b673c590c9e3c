//! The detector check of the import (docs/method.md section 3, "Inputs checked against
//! their detectors"): are the SfM model's keypoints and LIMAP's segments what the
//! configured front-end detects?
//!
//! Training describes the model's keypoint positions with the front-end's descriptor, and
//! the query describes the front-end's own detections (docs/method.md section 1). When
//! another detector made the model's keypoints (hloc's SuperPoint model under the SIFT
//! front-end, say), the two sides describe different kinds of image positions and the
//! network learns from inputs it never sees at query time. The same holds for LIMAP's
//! segments and the query's line detector.
//!
//! On a fixed sample of training images (up to [`SAMPLE_IMAGES`], evenly spaced over the
//! training frames in frame-id order) the front-end detects keypoints and segments in the
//! image the frames table points to. A model keypoint matches when a detection lies
//! within [`MATCH_RADIUS_PX`]; a LIMAP segment (times `segment_scale`) matches when a
//! detected segment has both endpoints within [`MATCH_RADIUS_PX`] of its endpoints, in
//! either order. Both sides are in COLMAP pixels (centre of the top-left pixel at
//! (0.5, 0.5)): the model's by COLMAP's definition, the segments as the import reads them,
//! the front-end's by `features::FrontEnd`'s contract. The detector keeps at least as many
//! keypoints as the model has in the image, so that a different top-K is not taken for a
//! different detector.

use super::detector_report::DetectorCheckReport;
use super::error::ImportError;
use features::{FrontEnd, FrontEndConfig};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::sync::Arc;
use tables::frames::FramesTable;
use tables::labels::LabelTables;

/// Training images the check detects in.
pub const SAMPLE_IMAGES: usize = 8;
/// Distance (pixels) within which a detection matches a model keypoint or endpoint.
pub const MATCH_RADIUS_PX: f64 = 2.0;
/// Keypoint match rate below which another detector made the model's keypoints. Measured
/// (docs/method.md section 3, crates/labels/tests/detector_check.rs): the synthetic
/// scene's SIFT model under the SIFT front-end 1.00; COLMAP's own SIFT (another
/// implementation of the same detector) on 10 real photos 0.57, and pycolmap's SIFT
/// model of the tiny synthetic scene 0.41 (crates/labels/tests/limap_real.rs); the
/// synthetic SIFT model under SuperPoint (random weights) 0.10. The threshold sits
/// between the genuine detector's lowest rate and the other detector's, with a margin
/// to both (pycolmap's rate varies by about a point between runs of the real tools).
pub const MIN_KEYPOINT_RATE: f64 = 0.3;
/// Segment match rate (of the LIMAP segments long enough for the front-end to report)
/// below which another line detector made LIMAP's segments. Measured: the synthetic
/// scene's LSD segments 1.00; LIMAP 2.0's own LSD (pytlsd) on the tiny synthetic scene
/// 0.55 (pytlsd is another implementation of LSD, as COLMAP's SIFT is of SIFT); jittered
/// by up to 3 px 0.12; LSD at half resolution (another detector's endpoints) 0.12. The
/// threshold sits between the two groups with a margin to both.
pub const MIN_SEGMENT_RATE: f64 = 0.35;

/// `[import] detector_check`: what the import does with the check's result.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    clap::ValueEnum,
    strum::Display,
    strum::IntoStaticStr,
)]
#[serde(rename_all = "lowercase")]
#[strum(serialize_all = "lowercase")]
pub enum DetectorCheck {
    /// Check; refuse the import when a rate says another detector made the inputs.
    #[default]
    Refuse,
    /// Check and report the rates, and import whatever they say.
    Accept,
    /// No check.
    Off,
}

impl DetectorCheck {
    /// Serialised only when not the default, so that configurations written before the
    /// option existed keep their bytes.
    pub(super) fn is_default(&self) -> bool {
        *self == DetectorCheck::default()
    }

    pub fn as_str(self) -> &'static str {
        self.into()
    }
}

/// Builds the front-end of a configuration: the import stage's caller passes it, since
/// this crate does not link SuperPoint (burn); [`sift_only`] builds SIFT, and a caller
/// that links the `superpoint` crate passes `superpoint::front_end`.
pub type MakeFrontEnd<'a> =
    &'a (dyn Fn(&FrontEndConfig) -> Result<Arc<dyn FrontEnd>, String> + Sync);

/// The builder for a caller without SuperPoint: SIFT; SuperPoint is refused with the
/// builder to pass instead.
pub fn sift_only(config: &FrontEndConfig) -> Result<Arc<dyn FrontEnd>, String> {
    if config.kind.is_sift() {
        Ok(Arc::new(
            features::SiftFrontEnd::new(config.clone()).map_err(|e| e.to_string())?,
        ))
    } else {
        Err(format!(
            "the {} front-end is built by the caller (labels::import_stage::run with \
             superpoint::front_end)",
            config.kind
        ))
    }
}

/// The training frames of the check: up to [`SAMPLE_IMAGES`] evenly spaced over the
/// imported frames in frame-id order (`poses` is sorted by frame id).
pub fn sample(tables: &LabelTables) -> Vec<u32> {
    let ids: Vec<u32> = tables.poses.iter().map(|p| p.frame_id).collect();
    let n = ids.len();
    let k = n.min(SAMPLE_IMAGES);
    (0..k).map(|i| ids[i * n / k]).collect()
}

/// Points bucketed in square cells of the match radius.
struct Grid {
    cells: HashMap<(i64, i64), Vec<usize>>,
    r: f64,
}

impl Grid {
    fn new(points: impl Iterator<Item = [f64; 2]>, r: f64) -> Grid {
        let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, p) in points.enumerate() {
            cells.entry(Self::cell(p, r)).or_default().push(i);
        }
        Grid { cells, r }
    }

    fn cell(p: [f64; 2], r: f64) -> (i64, i64) {
        ((p[0] / r).floor() as i64, (p[1] / r).floor() as i64)
    }

    /// Indices of the points in the 3 x 3 cells around `p` (a superset of those within r).
    fn near(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        let (cx, cy) = Self::cell(p, self.r);
        (-1..=1)
            .flat_map(move |dx| (-1..=1).map(move |dy| (cx + dx, cy + dy)))
            .filter_map(|c| self.cells.get(&c))
            .flatten()
            .copied()
    }
}

fn close(a: [f64; 2], b: [f64; 2], r: f64) -> bool {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) <= r * r
}

/// How many of `keypoints` lie within `r` of one of `detections`.
pub fn matched_keypoints(keypoints: &[[f64; 2]], detections: &[[f64; 2]], r: f64) -> usize {
    keypoints_near(keypoints, detections, r)
        .filter(|&m| m)
        .count()
}

/// For each of `keypoints`, whether one of `detections` lies within `r`.
pub fn keypoints_near<'a>(
    keypoints: &'a [[f64; 2]],
    detections: &'a [[f64; 2]],
    r: f64,
) -> impl Iterator<Item = bool> + 'a {
    let grid = Grid::new(detections.iter().copied(), r);
    keypoints
        .iter()
        .map(move |&p| grid.near(p).any(|i| close(p, detections[i], r)))
}

fn segment_length(s: &[f64; 4]) -> f64 {
    (s[2] - s[0]).hypot(s[3] - s[1])
}

/// How many of `segments` have both endpoints within `r` of the endpoints of one of
/// `detected`, in either order.
pub fn matched_segments(segments: &[[f64; 4]], detected: &[[f64; 4]], r: f64) -> usize {
    let ends = |s: &[f64; 4]| ([s[0], s[1]], [s[2], s[3]]);
    // Both endpoints of every detection, tagged by detection and end.
    let points: Vec<(usize, bool)> = (0..detected.len())
        .flat_map(|i| [(i, false), (i, true)])
        .collect();
    let at = |&(i, second): &(usize, bool)| {
        let (a, b) = ends(&detected[i]);
        if second { b } else { a }
    };
    let grid = Grid::new(points.iter().map(at), r);
    segments
        .iter()
        .filter(|s| {
            let (a, b) = ends(s);
            grid.near(a).any(|k| {
                let (i, second) = points[k];
                let (d0, d1) = ends(&detected[i]);
                let (near_a, other) = if second { (d1, d0) } else { (d0, d1) };
                close(a, near_a, r) && close(b, other, r)
            })
        })
        .count()
}

/// Runs the check on the imported tables: detects on the sampled training images with
/// the front-end `make` builds from `front_end` (its top-K raised to the largest keypoint
/// count of a sampled image) and compares. The decision is `passed` or `refused`; the
/// caller turns `refused` into `accepted` when so configured.
pub fn check(
    front_end: &FrontEndConfig,
    make: MakeFrontEnd<'_>,
    frames: &FramesTable,
    tables: &LabelTables,
) -> Result<DetectorCheckReport, ImportError> {
    let ids = sample(tables);
    let mut keypoints: HashMap<u32, Vec<[f64; 2]>> = HashMap::new();
    for p in &tables.points {
        keypoints.entry(p.frame_id).or_default().push(p.xy);
    }
    let mut segments: HashMap<u32, Vec<[f64; 4]>> = HashMap::new();
    for l in &tables.lines {
        segments.entry(l.frame_id).or_default().push(l.segment);
    }
    let most = ids
        .iter()
        .map(|id| keypoints.get(id).map_or(0, Vec::len))
        .max()
        .unwrap_or(0);
    let mut config = front_end.clone();
    match config.kind {
        features::FrontEndKind::Sift => {
            config.sift.max_keypoints = config.sift.max_keypoints.max(most)
        }
        features::FrontEndKind::Superpoint => {
            config.superpoint.max_keypoints = config.superpoint.max_keypoints.max(most)
        }
    }
    let fe = make(&config).map_err(|e| {
        ImportError::Config(format!(
            "detector check: cannot build the {} front-end: {e} (detector_check = \"off\" \
             skips the check)",
            config.kind
        ))
    })?;
    let by_id: HashMap<u32, &tables::frames::Frame> =
        frames.frames.iter().map(|f| (f.id, f)).collect();
    let r = MATCH_RADIUS_PX;
    let mut report = DetectorCheckReport {
        front_end: config.kind.name().to_string(),
        line_detector: "lsd".to_string(),
        images: Vec::new(),
        radius_px: r,
        keypoints: 0,
        keypoints_matched: 0,
        keypoint_rate: 0.0,
        min_keypoint_rate: MIN_KEYPOINT_RATE,
        segments: 0,
        min_segment_length_px: config.lsd.min_length + 2.0 * r,
        segments_short: 0,
        segments_matched: 0,
        segment_rate: 0.0,
        min_segment_rate: MIN_SEGMENT_RATE,
        decision: String::new(),
    };
    let bar = stage::progress_bar(ids.len() as u64, "detector check");
    for id in &ids {
        bar.inc(1);
        let Some(frame) = by_id.get(id) else { continue };
        let img = features::load_gray(&frame.path).map_err(|e| {
            ImportError::Config(format!(
                "detector check, frame {} ({}): {e}",
                id, frame.name
            ))
        })?;
        let fail = |e: features::FeatureError| {
            ImportError::Config(format!(
                "detector check, frame {} ({}): {e}",
                id,
                frame.path.display()
            ))
        };
        let kps = keypoints.get(id).map_or(&[][..], Vec::as_slice);
        let segs = segments.get(id).map_or(&[][..], Vec::as_slice);
        let detections = fe.detect(&img).map_err(fail)?.keypoints;
        let detected_segments = fe.segments(&img).map_err(fail)?;
        report.images.push(frame.name.clone());
        report.keypoints += kps.len();
        report.keypoints_matched += matched_keypoints(kps, &detections, r);
        let (long, short): (Vec<[f64; 4]>, Vec<[f64; 4]>) = segs
            .iter()
            .partition(|s| segment_length(s) >= report.min_segment_length_px);
        report.segments += long.len();
        report.segments_short += short.len();
        report.segments_matched += matched_segments(&long, &detected_segments, r);
    }
    bar.finish_and_clear();
    let rate = |m: usize, n: usize| if n == 0 { 1.0 } else { m as f64 / n as f64 };
    report.keypoint_rate = rate(report.keypoints_matched, report.keypoints);
    report.segment_rate = rate(report.segments_matched, report.segments);
    report.decision = if report.passed() { "passed" } else { "refused" }.to_string();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keypoints_match_within_the_radius_only() {
        let det = [[10.0, 10.0], [100.0, 50.5]];
        let kps = [[11.9, 10.0], [10.0, 12.1], [101.0, 51.0], [300.0, 300.0]];
        assert_eq!(matched_keypoints(&kps, &det, 2.0), 2);
        assert_eq!(matched_keypoints(&kps, &[], 2.0), 0);
    }

    #[test]
    fn segments_match_in_either_order_with_both_endpoints() {
        let det = [[0.0, 0.0, 50.0, 0.0], [10.0, 10.0, 10.0, 80.0]];
        let segs = [
            [0.5, 0.5, 50.5, -0.5],   // same
            [10.0, 81.0, 11.0, 10.0], // reversed
            [0.0, 0.0, 45.0, 0.0],    // one endpoint off by 5 px
            [50.0, 0.0, 10.0, 80.0],  // endpoints of two different detections
        ];
        assert_eq!(matched_segments(&segs, &det, 2.0), 2);
    }

    #[test]
    fn detector_check_serde_and_strum_names_agree() {
        for c in [
            DetectorCheck::Refuse,
            DetectorCheck::Accept,
            DetectorCheck::Off,
        ] {
            assert_eq!(
                serde_json::to_string(&c).unwrap(),
                format!("\"{}\"", c.as_str())
            );
            assert_eq!(c.to_string(), c.as_str());
            let clap_name = clap::ValueEnum::to_possible_value(&c).unwrap();
            assert_eq!(clap_name.get_name(), c.as_str());
        }
    }
}
