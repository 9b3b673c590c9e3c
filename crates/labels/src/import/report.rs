//! What the import found and wrote: counts, pose disagreement between the SfM model and
//! the dataset, and warnings. Saved as JSON and printed as a short table.

use super::config::ImportConfig;
use super::detected::DetectedLabelsReport;
use super::detector_report::DetectorCheckReport;
use crate::stats::Spread;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelCounts {
    pub cameras: usize,
    pub images: usize,
    pub points3d: usize,
    /// Model images that are training frames.
    pub images_used: usize,
    /// Model images that are test frames, skipped (only with `allow_test_images`).
    pub test_images_skipped: usize,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LimapCounts {
    pub images: usize,
    pub tracks: usize,
    /// Tracks with at least one support in a training frame.
    pub tracks_used: usize,
    pub test_images_skipped: usize,
    /// Training frames whose LIMAP image id differs from their COLMAP image id (the join
    /// is by name; LIMAP keeps COLMAP's ids when built from a COLMAP model, so a
    /// difference hints at a model from another run).
    pub ids_differ_from_model: usize,
    /// The prefix stripped from every LIMAP image name without a `limap_names` mapping:
    /// LIMAP 1.x writes absolute paths, and every name was this dataset root followed by
    /// a frames table name. Absent when the names joined as they are (or were mapped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub root_prefix_stripped: Option<String>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCounts {
    pub keypoints: usize,
    pub valid: usize,
    pub without_point3d: usize,
    /// Distinct 3D points observed by training frames.
    pub points3d_observed: usize,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LineCounts {
    pub segments: usize,
    pub valid: usize,
    pub in_no_track: usize,
    /// Segments of a track whose 3D endpoints coincide or are not finite (LIMAP writes
    /// NaN as 0): no label.
    pub degenerate_track: usize,
    /// Valid labels whose endpoints were swapped to follow the 2D segment.
    pub swapped: usize,
    pub aligned_by_projection: usize,
    pub aligned_by_rays: usize,
    pub order_undecided: usize,
}

/// SfM pose against the frames table's pose, over training frames: camera-centre
/// distance (metres) and rotation angle (degrees), as `geometry::metrics::pose_error`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseDisagreement {
    pub translation_m: Spread,
    pub rotation_deg: Spread,
    /// Frame with the largest centre distance.
    pub worst_frame: Option<String>,
}

impl Default for PoseDisagreement {
    fn default() -> Self {
        PoseDisagreement {
            translation_m: Spread::of(&[]),
            rotation_deg: Spread::of(&[]),
            worst_frame: None,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ImportReport {
    pub config: ImportConfig,
    /// sha256 of the frames table.
    pub frames_sha256: String,
    pub train_frames: usize,
    pub test_frames: usize,
    pub model: ModelCounts,
    pub limap: LimapCounts,
    pub points: PointCounts,
    pub lines: LineCounts,
    pub pose_disagreement: PoseDisagreement,
    /// Training frames whose SfM camera differs from the frames table's camera
    /// (model or any parameter by more than 1e-6 relative).
    pub intrinsics_differ: usize,
    pub intrinsics_example: Option<String>,
    pub warnings: Vec<String>,
    /// The detector check's rates and decision; absent when it did not run
    /// (`detector_check = "off"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detector_check: Option<DetectorCheckReport>,
    /// What `point_labels = "detected"` kept; absent with `all`. `points` counts the
    /// labels before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detected_labels: Option<DetectedLabelsReport>,
}

fn pct(n: usize, of: usize) -> String {
    if of == 0 {
        "-".into()
    } else {
        format!("{:.1} %", 100.0 * n as f64 / of as f64)
    }
}

fn num(v: f64, scale: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{:.*}", decimals, v * scale)
    } else {
        "-".into()
    }
}

impl ImportReport {
    /// The short table printed after an import.
    /// One line: the labelled points and lines of the training frames.
    pub fn note(&self) -> String {
        // With point_labels = "detected", the keypoints that remain.
        let (valid, keypoints) = match &self.detected_labels {
            Some(d) => (d.labels_kept, d.keypoints_kept),
            None => (self.points.valid, self.points.keypoints),
        };
        format!(
            "{} training frames: {} of {} keypoints{} and {} of {} segments labelled",
            self.train_frames,
            valid,
            keypoints,
            if self.detected_labels.is_some() {
                " at the front-end's detections"
            } else {
                ""
            },
            self.lines.valid,
            self.lines.segments
        )
    }

    pub fn table(&self) -> String {
        let p = &self.points;
        let l = &self.lines;
        let d = &self.pose_disagreement;
        let mut s = String::new();
        s.push_str(&format!(
            "frames: {} train, {} test; pose source {}; model names {}; LIMAP names {}\n",
            self.train_frames,
            self.test_frames,
            self.config.pose_source.as_str(),
            self.config.model_names,
            self.config.limap_names
        ));
        if let Some(prefix) = &self.limap.root_prefix_stripped {
            s.push_str(&format!(
                "LIMAP names: the dataset root {prefix:?} stripped from every name (each rest \
                 is a frames table name)\n"
            ));
        }
        s.push_str(&format!(
            "model: {} images ({} used), {} points3D; LIMAP: {} images, {} tracks of {} ({} \
             used)\n",
            self.model.images,
            self.model.images_used,
            self.model.points3d,
            self.limap.images,
            self.limap.tracks,
            self.config.line_tracks,
            self.limap.tracks_used
        ));
        s.push_str("labels       total     valid   valid %   no 3D\n");
        s.push_str(&format!(
            "points  {:>10} {:>9} {:>9} {:>7}\n",
            p.keypoints,
            p.valid,
            pct(p.valid, p.keypoints),
            p.without_point3d
        ));
        s.push_str(&format!(
            "lines   {:>10} {:>9} {:>9} {:>7}\n",
            l.segments,
            l.valid,
            pct(l.valid, l.segments),
            l.in_no_track + l.degenerate_track
        ));
        s.push_str(&format!(
            "line endpoints swapped to follow the 2D segment: {} of {} ({} by projection, {} by rays, {} undecided)\n",
            l.swapped, l.valid, l.aligned_by_projection, l.aligned_by_rays, l.order_undecided
        ));
        s.push_str("SfM vs dataset pose   median      p90      max\n");
        s.push_str(&format!(
            "translation (cm) {:>10} {:>8} {:>8}\n",
            num(d.translation_m.median, 100.0, 2),
            num(d.translation_m.p90, 100.0, 2),
            num(d.translation_m.max, 100.0, 2)
        ));
        s.push_str(&format!(
            "rotation (deg)   {:>10} {:>8} {:>8}\n",
            num(d.rotation_deg.median, 1.0, 3),
            num(d.rotation_deg.p90, 1.0, 3),
            num(d.rotation_deg.max, 1.0, 3)
        ));
        if let Some(w) = &d.worst_frame {
            s.push_str(&format!("largest pose difference: {w}\n"));
        }
        if self.intrinsics_differ > 0 {
            s.push_str(&format!(
                "cameras differing from the frames table: {} frame(s), e.g. {}\n",
                self.intrinsics_differ,
                self.intrinsics_example.as_deref().unwrap_or("-")
            ));
        }
        if let Some(c) = &self.detector_check {
            s.push_str(&format!("detector check ({}): {}\n", c.decision, c.rates()));
        }
        if let Some(d) = &self.detected_labels {
            s.push_str(&format!("{}\n", d.line()));
        }
        for w in &self.warnings {
            s.push_str(&format!("warning: {w}\n"));
        }
        s
    }
}
