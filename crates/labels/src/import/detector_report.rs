//! What the detector check of the import measured and decided (the check runs in
//! crates/labels/src/import/detectors.rs): in `import_report.json` when it ran, and the
//! refusal's text.

use serde::{Deserialize, Serialize};

/// What the check measured and decided: in `import_report.json` when it ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectorCheckReport {
    /// The front-end whose keypoints were compared (`sift`, `superpoint`).
    pub front_end: String,
    /// Its line detector (`lsd`).
    pub line_detector: String,
    /// The sampled training images (frames table names).
    pub images: Vec<String>,
    pub radius_px: f64,
    pub keypoints: usize,
    pub keypoints_matched: usize,
    pub keypoint_rate: f64,
    pub min_keypoint_rate: f64,
    /// LIMAP segments compared: those at least `min_segment_length_px` long.
    pub segments: usize,
    /// The front-end's own minimum segment length plus twice the match radius: a
    /// segment this long is one the front-end reports even with both endpoints moved by
    /// the radius. Shorter LIMAP segments (LIMAP's LSD keeps every length) are left out
    /// of the rate, since the front-end drops them by design.
    #[serde(default)]
    pub min_segment_length_px: f64,
    /// LIMAP segments shorter than that, not compared.
    #[serde(default)]
    pub segments_short: usize,
    pub segments_matched: usize,
    pub segment_rate: f64,
    pub min_segment_rate: f64,
    /// `passed`, `refused`, or `accepted` (the rates failed and `detector_check =
    /// "accept"` imported anyway).
    pub decision: String,
}

impl DetectorCheckReport {
    pub fn keypoints_pass(&self) -> bool {
        self.keypoints == 0 || self.keypoint_rate >= self.min_keypoint_rate
    }

    pub fn segments_pass(&self) -> bool {
        self.segments == 0 || self.segment_rate >= self.min_segment_rate
    }

    pub fn passed(&self) -> bool {
        self.keypoints_pass() && self.segments_pass()
    }

    /// The rates, one line.
    pub fn rates(&self) -> String {
        format!(
            "{:.1} % of {} model keypoints within {} px of a {} detection (needs {:.0} %), \
             {:.1} % of {} LIMAP segments of at least {} px with both endpoints within {} px \
             of a {} segment (needs {:.0} %; {} shorter ones not compared), on {} training \
             image(s)",
            100.0 * self.keypoint_rate,
            self.keypoints,
            self.radius_px,
            self.front_end,
            100.0 * self.min_keypoint_rate,
            100.0 * self.segment_rate,
            self.segments,
            self.min_segment_length_px,
            self.radius_px,
            self.line_detector,
            100.0 * self.min_segment_rate,
            self.segments_short,
            self.images.len()
        )
    }

    /// The refusal: rates, likely cause and fix.
    pub fn refusal(&self) -> String {
        let mut s = format!(
            "the inputs were not made by the configured detectors: {}.",
            self.rates()
        );
        if !self.keypoints_pass() {
            s.push_str(&format!(
                " Likely cause: the model's keypoints were made by another detector than \
                 {fe} (e.g. SuperPoint for hloc's sfm_superpoint+superglue, SIFT for a \
                 COLMAP or hloc SIFT model), so training would describe positions the {fe} \
                 front-end never detects at query time.",
                fe = self.front_end
            ));
        }
        if !self.segments_pass() {
            s.push_str(&format!(
                " Likely cause: LIMAP's segments were made by another line detector than \
                 {} (e.g. DeepLSD), or segment_scale is wrong (LIMAP detects on images \
                 resized to max_image_dim), or the segments were moved.",
                self.line_detector
            ));
        }
        s.push_str(
            " Fix: set [features] kind (pl2map import --front-end) to the detector that made \
             the keypoints, or import these inputs anyway with [import] detector_check = \
             \"accept\" (--detector-check accept; the report keeps the rates).",
        );
        s
    }
}
