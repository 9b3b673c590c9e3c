//! `[import] point_labels = "detected"`: only the model keypoints that the front-end
//! detects itself enter the labels (docs/method.md section 3, "Labels at the query's
//! detections").
//!
//! Why: the query describes the front-end's own detections, training describes the SfM
//! model's keypoints. When another implementation of the detector made the model
//! (COLMAP's SIFT under OpenCV's, with its lower contrast threshold), the model holds
//! about twice as many keypoints as the front-end detects, and half of them are weak
//! ones the query never describes (measured on the synthetic room: 90 % of OpenCV's
//! detections lie within 0.5 px of a COLMAP keypoint, only 41 % of COLMAP's keypoints
//! within 2 px of an OpenCV detection). A map trained on all of them spends its steps
//! on positions it never sees at query time. The other keypoints are left out entirely:
//! kept as unlabelled keypoints, they took over half of every step's samples and the map
//! localised worse still (docs/training-notes.md, "Real-tool labels").

use super::detectors::{MakeFrontEnd, keypoints_near};
use super::error::ImportError;
use features::FrontEndConfig;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use tables::frames::FramesTable;
use tables::labels::{LabelTables, PointRow};

/// Distance (pixels) within which a front-end detection confirms a model keypoint. The
/// same detector's positions agree to a median 0.06 px across implementations (COLMAP
/// against OpenCV SIFT on the synthetic room, COLMAP pixel convention on both sides);
/// 1 px keeps those and drops neighbours of other keypoints.
pub const DETECTED_RADIUS_PX: f64 = 1.0;

/// `[import] point_labels`: which model keypoints enter the labels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PointLabels {
    /// Every keypoint with a 3D point.
    #[default]
    All,
    /// Only the keypoints the front-end detects within [`DETECTED_RADIUS_PX`], labelled
    /// or not; the others are left out.
    Detected,
}

impl PointLabels {
    /// Serialised only when not the default, so that configurations (and the records and
    /// reports that hash them) written before the option existed keep their bytes.
    pub(super) fn is_default(&self) -> bool {
        *self == PointLabels::default()
    }
}

/// What `point_labels = "detected"` kept: in `import_report.json` when it ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectedLabelsReport {
    /// The front-end whose detections confirm the keypoints (`sift`, `superpoint`).
    pub front_end: String,
    pub radius_px: f64,
    /// Training frames detected in.
    pub frames: usize,
    /// Model keypoints (rows of the points table) before and after.
    pub keypoints: usize,
    pub keypoints_kept: usize,
    /// Of those, with a 3D label.
    pub labels: usize,
    pub labels_kept: usize,
}

impl DetectedLabelsReport {
    /// One line for the import's table.
    pub fn line(&self) -> String {
        let pct = |n: usize, of: usize| {
            if of == 0 {
                0.0
            } else {
                100.0 * n as f64 / of as f64
            }
        };
        format!(
            "model keypoints at {} detections (within {} px): {} of {} kept ({:.1} %), {} of \
             {} labels ({:.1} %), on {} training frame(s)",
            self.front_end,
            self.radius_px,
            self.keypoints_kept,
            self.keypoints,
            pct(self.keypoints_kept, self.keypoints),
            self.labels_kept,
            self.labels,
            pct(self.labels_kept, self.labels),
            self.frames
        )
    }
}

/// Detects keypoints on every training frame of `tables` with the front-end `make` builds
/// from `front_end`, and keeps the rows of the points table (model keypoints, labelled or
/// not) that it confirms within [`DETECTED_RADIUS_PX`]; their order is kept. Frames are
/// detected in parallel; the result depends only on the inputs (each frame's detection
/// is a pure function of its image).
pub fn keep_detected(
    front_end: &FrontEndConfig,
    make: MakeFrontEnd<'_>,
    frames: &FramesTable,
    tables: &mut LabelTables,
) -> Result<DetectedLabelsReport, ImportError> {
    let fe = make(front_end).map_err(|e| {
        ImportError::Config(format!(
            "point_labels = \"detected\": cannot build the {} front-end: {e}",
            front_end.kind
        ))
    })?;
    let by_id: HashMap<u32, &tables::frames::Frame> =
        frames.frames.iter().map(|f| (f.id, f)).collect();
    let ids: Vec<u32> = tables.poses.iter().map(|p| p.frame_id).collect();
    let bar = stage::progress_bar(ids.len() as u64, "keypoints for point_labels = detected");
    let detections: HashMap<u32, Vec<[f64; 2]>> = ids
        .par_iter()
        .map(|&id| {
            let frame = by_id.get(&id).ok_or_else(|| {
                ImportError::Config(format!(
                    "frame {id} of the labels is not in the frames table"
                ))
            })?;
            let fail = |e: features::FeatureError| {
                ImportError::Config(format!(
                    "point_labels = \"detected\", frame {id} ({}): {e}",
                    frame.path.display()
                ))
            };
            let img = features::load_gray(&frame.path).map_err(fail)?;
            let kps = fe.detect(&img).map_err(fail)?.keypoints;
            bar.inc(1);
            Ok((id, kps))
        })
        .collect::<Result<_, ImportError>>()?;
    bar.finish_and_clear();
    let labels = tables.points.iter().filter(|p| p.xyz.is_some()).count();
    let keypoints = tables.points.len();
    let mut keep = detected_rows(&tables.points, &detections, DETECTED_RADIUS_PX).into_iter();
    tables.points.retain(|_| keep.next().unwrap_or(false));
    Ok(DetectedLabelsReport {
        front_end: front_end.kind.name().to_string(),
        radius_px: DETECTED_RADIUS_PX,
        frames: detections.len(),
        keypoints,
        keypoints_kept: tables.points.len(),
        labels,
        labels_kept: tables.points.iter().filter(|p| p.xyz.is_some()).count(),
    })
}

/// For each row of `points`, whether its frame's `detections` have one within `r` (rows of
/// frames without detections: false).
pub fn detected_rows(
    points: &[PointRow],
    detections: &HashMap<u32, Vec<[f64; 2]>>,
    r: f64,
) -> Vec<bool> {
    let mut keep = Vec::with_capacity(points.len());
    // The table is sorted by frame; a frame split into several runs would only cost
    // one more grid.
    for rows in points.chunk_by(|a, b| a.frame_id == b.frame_id) {
        match detections.get(&rows[0].frame_id) {
            Some(det) => {
                let xy: Vec<[f64; 2]> = rows.iter().map(|p| p.xy).collect();
                keep.extend(keypoints_near(&xy, det, r));
            }
            None => keep.extend(std::iter::repeat_n(false, rows.len())),
        }
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(frame_id: u32, xy: [f64; 2], labelled: bool) -> PointRow {
        PointRow {
            frame_id,
            kp_index: 0,
            xy,
            point3d_id: if labelled { 7 } else { -1 },
            xyz: labelled.then_some([1.0, 2.0, 3.0]),
        }
    }

    #[test]
    fn rows_without_a_detection_of_their_frame_within_the_radius_are_dropped() {
        let points = vec![
            row(0, [10.0, 10.0], true),  // detected exactly
            row(0, [20.9, 5.0], true),   // 0.9 px off
            row(0, [40.0, 40.0], true),  // 1.5 px off
            row(0, [60.0, 60.0], false), // unlabelled, detected: kept as unlabelled
            row(1, [10.0, 10.0], true),  // frame 1's detections are elsewhere
            row(2, [10.0, 10.0], true),  // frame 2 has none
        ];
        let det = HashMap::from([
            (
                0,
                vec![[10.0, 10.0], [20.0, 5.0], [41.5, 40.0], [60.0, 60.0]],
            ),
            (1, vec![[30.0, 30.0]]),
        ]);
        assert_eq!(
            detected_rows(&points, &det, 1.0),
            [true, true, false, true, false, false]
        );
    }
}
