//! What refinement moved and dropped, per label kind; saved as JSON and printed.

use super::config::RefineConfig;
use crate::stats::Spread;
use serde::{Deserialize, Serialize};

/// Points or lines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KindReport {
    /// Valid labels before refinement.
    pub labels: usize,
    pub kept: usize,
    /// Dropped: no valid depth at the observation (or too few samples along a segment),
    /// or no valid depth in any view.
    pub dropped_no_depth: usize,
    /// Dropped: the observation disagreed with the others of its 3D point / track.
    pub dropped_disagree: usize,
    /// Dropped (lines): the support's samples were not on one 3D line (fewer than the
    /// minimum inlier ratio).
    pub dropped_fit: usize,
    /// How far kept labels moved (metres): the point, or the mean of the two endpoints.
    pub moved_m: Spread,
    /// 3D points / tracks with labels, refined ones, and ones that lost all labels.
    pub objects: usize,
    pub objects_refined: usize,
    pub objects_dropped: usize,
}

impl KindReport {
    pub fn dropped(&self) -> usize {
        self.dropped_no_depth + self.dropped_disagree + self.dropped_fit
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    Kept,
    NoDepth,
    Disagree,
    Fit,
}

#[derive(Default)]
pub(crate) struct Tally {
    kept: usize,
    no_depth: usize,
    disagree: usize,
    fit: usize,
    moved: Vec<f64>,
    objects: usize,
    refined: usize,
}

impl Tally {
    pub fn add(&mut self, outcome: Outcome, moved: Option<f64>) {
        match outcome {
            Outcome::Kept => self.kept += 1,
            Outcome::NoDepth => self.no_depth += 1,
            Outcome::Disagree => self.disagree += 1,
            Outcome::Fit => self.fit += 1,
        }
        if let Some(m) = moved {
            self.moved.push(m);
        }
    }

    pub fn object(&mut self, refined: bool) {
        self.objects += 1;
        self.refined += usize::from(refined);
    }

    pub fn report(self) -> KindReport {
        KindReport {
            labels: self.kept + self.no_depth + self.disagree + self.fit,
            kept: self.kept,
            dropped_no_depth: self.no_depth,
            dropped_disagree: self.disagree,
            dropped_fit: self.fit,
            moved_m: Spread::of(&self.moved),
            objects: self.objects,
            objects_refined: self.refined,
            objects_dropped: self.objects - self.refined,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RefineReport {
    pub config: RefineConfig,
    /// Training frames, and those with a depth map.
    pub frames: usize,
    pub frames_with_depth: usize,
    pub points: KindReport,
    pub lines: KindReport,
}

fn cm(v: f64) -> String {
    if v.is_finite() {
        format!("{:.2}", v * 100.0)
    } else {
        "-".into()
    }
}

impl RefineReport {
    /// The short table printed after a refinement.
    pub fn table(&self) -> String {
        let mut s = format!(
            "depth maps: {} of {} training frames; points sampled at the {:?}\n",
            self.frames_with_depth, self.frames, self.config.point_sampling
        );
        s.push_str(
            "labels    before     kept  dropped (no depth / disagree / fit)  moved cm: median    p90     max\n",
        );
        for (name, k) in [("points", &self.points), ("lines", &self.lines)] {
            s.push_str(&format!(
                "{name:<7} {:>8} {:>8} {:>8} ({} / {} / {}) {:>24} {:>6} {:>7}\n",
                k.labels,
                k.kept,
                k.dropped(),
                k.dropped_no_depth,
                k.dropped_disagree,
                k.dropped_fit,
                cm(k.moved_m.median),
                cm(k.moved_m.p90),
                cm(k.moved_m.max)
            ));
        }
        s.push_str(&format!(
            "3D points: {} refined, {} dropped; tracks: {} refined, {} dropped\n",
            self.points.objects_refined,
            self.points.objects_dropped,
            self.lines.objects_refined,
            self.lines.objects_dropped
        ));
        s
    }
}
