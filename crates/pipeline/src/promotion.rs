//! The promotion gate of nightly retraining (`pl2map run --warm-start`): the new model
//! and the one it started from are scored on the same test frames, and the better one
//! is `<work>/train/model.ckpt`; a worse model never replaces a better one silently.
//!
//! The new model's score goes to `<work>/score` (the score stage then finds it up to
//! date when the new model is kept), the previous one's to `<work>/score-previous`. The
//! model not kept stays beside the kept one under a stable name: `warm-start.ckpt` (the
//! previous model, when the new one is kept) or `model.rejected.ckpt` (the new one, when
//! the previous one is kept). docs/operations.md, "Nightly retraining", has the rule.

use score::{Summary, Variant};
use std::cmp::Ordering;

/// The folder of the previous model's score.
pub const PREVIOUS_SCORE_DIR: &str = "score-previous";

/// Which model the gate kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kept {
    New,
    Previous,
}

/// The gate's decision and the two scores it was made on.
#[derive(Clone, Debug)]
pub struct Promotion {
    pub new: Summary,
    pub previous: Summary,
    pub kept: Kept,
    /// The comparison that decided, in words.
    pub reason: String,
}

impl Promotion {
    /// Both scores (both variants each) as a markdown table, then the decision.
    pub fn table(&self) -> String {
        let mut s = format!(
            "| model |{} inliers (pts / lines) |\n|---|{}---:|\n",
            score::summary::header_cells(),
            score::summary::align_cells()
        );
        for (name, summary) in [("new", &self.new), ("previous", &self.previous)] {
            for v in &summary.variants {
                s.push_str(&format!(
                    "| {name} |{} {:.0} / {:.0} |\n",
                    v.row_cells(),
                    v.median_point_inliers,
                    v.median_line_inliers
                ));
            }
        }
        s
    }

    /// The run's last line.
    pub fn verdict(&self) -> String {
        match self.kept {
            Kept::New => format!("kept the new model as train/model.ckpt: {}", self.reason),
            Kept::Previous => format!(
                "kept the previous model as train/model.ckpt (the new one is train/model.rejected.ckpt): {}",
                self.reason
            ),
        }
    }
}

/// The figures compared, in order: points + lines first (the map's own variant), then
/// points alone; for each the fraction under 5 cm / 5 deg, under 10 cm / 10 deg, the
/// median position error (lower is better), the frames localised; last the median
/// point inliers of points + lines (more consistent 2D-3D matches). The first figure
/// that differs decides; the new model is kept when nothing differs (it has seen more
/// frames).
pub fn decide(new: &Summary, previous: &Summary) -> (Kept, String) {
    for (variant, label) in [
        (Variant::PointsLines, "points + lines"),
        (Variant::Points, "points"),
    ] {
        let (Some(a), Some(b)) = (variant_of(new, variant), variant_of(previous, variant)) else {
            continue;
        };
        let figures: [(&str, f64, f64, bool); 4] = [
            (
                "under 5 cm / 5 deg",
                fraction(a, 5.0),
                fraction(b, 5.0),
                true,
            ),
            (
                "under 10 cm / 10 deg",
                fraction(a, 10.0),
                fraction(b, 10.0),
                true,
            ),
            ("median cm", a.median_cm, b.median_cm, false),
            ("localised", a.localised as f64, b.localised as f64, true),
        ];
        for (what, x, y, higher_better) in figures {
            let order = compare(x, y, higher_better);
            if order != Ordering::Equal {
                let kept = if order == Ordering::Greater {
                    Kept::New
                } else {
                    Kept::Previous
                };
                return (
                    kept,
                    format!(
                        "{label} {what}: new {} against previous {}",
                        show(what, x),
                        show(what, y)
                    ),
                );
            }
        }
    }
    let inliers = |s: &Summary| {
        variant_of(s, Variant::PointsLines).map_or(f64::NAN, |v| v.median_point_inliers)
    };
    let (x, y) = (inliers(new), inliers(previous));
    match compare(x, y, true) {
        Ordering::Less => (
            Kept::Previous,
            format!("equal poses; median point inliers: new {x:.0} against previous {y:.0}"),
        ),
        _ => (
            Kept::New,
            "scores equal: the new model has seen more frames".into(),
        ),
    }
}

fn variant_of(s: &Summary, v: Variant) -> Option<&score::summary::VariantSummary> {
    s.variants.iter().find(|x| x.variant == v)
}

/// The fraction under `t` cm / `t` deg (NaN when the summary does not have it).
fn fraction(v: &score::summary::VariantSummary, t: f64) -> f64 {
    v.accuracy
        .iter()
        .find(|a| a.cm == t && a.deg == t)
        .map_or(f64::NAN, |a| a.fraction)
}

/// Greater: `x` is better. NaN (no figure) compares equal to anything, and two
/// infinite medians (more than half the frames failed) are equal.
fn compare(x: f64, y: f64, higher_better: bool) -> Ordering {
    if x.is_nan() || y.is_nan() || x == y {
        return Ordering::Equal;
    }
    let o = x.partial_cmp(&y).unwrap_or(Ordering::Equal);
    if higher_better { o } else { o.reverse() }
}

fn show(what: &str, v: f64) -> String {
    if what.starts_with("under") {
        format!("{:.1} %", 100.0 * v)
    } else if what == "median cm" {
        format!("{v:.2}")
    } else {
        format!("{v:.0}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use score::summary::{Accuracy, VariantSummary};

    fn summary(pl: [f64; 2], median_cm: f64, localised: usize, inliers: f64) -> Summary {
        let variant = |v| VariantSummary {
            variant: v,
            frames: 10,
            localised,
            median_cm,
            median_deg: 1.0,
            accuracy: geometry::metrics::ACCURACY_THRESHOLDS
                .iter()
                .map(|&(cm, deg)| Accuracy {
                    cm,
                    deg,
                    fraction: if cm < 10.0 { pl[0] } else { pl[1] },
                })
                .collect(),
            median_point_inliers: inliers,
            median_line_inliers: 0.0,
        };
        Summary {
            source: "test".into(),
            split: "test".into(),
            min_point_reliability: 0.5,
            min_line_reliability: 0.0,
            point_threshold_px: 12.0,
            line_threshold_px: 10.0,
            seed: 0,
            variants: vec![variant(Variant::Points), variant(Variant::PointsLines)],
        }
    }

    #[test]
    fn the_first_figure_that_differs_decides() {
        let good = summary([0.9, 0.95], 2.0, 10, 50.0);
        let worse = summary([0.8, 0.99], 1.0, 10, 80.0);
        let (k, why) = decide(&worse, &good);
        assert_eq!(k, Kept::Previous);
        assert!(
            why.contains("points + lines under 5 cm / 5 deg: new 80.0 % against previous 90.0 %"),
            "{why}"
        );
        assert_eq!(decide(&good, &worse).0, Kept::New);
        // Equal fractions: the median decides (lower is better).
        let closer = summary([0.9, 0.95], 1.5, 10, 10.0);
        assert_eq!(decide(&closer, &good).0, Kept::New);
        assert_eq!(decide(&good, &closer).0, Kept::Previous);
        // Nothing localised by either (infinite medians): frames localised, then inliers.
        let a = summary([0.0, 0.0], f64::INFINITY, 3, 5.0);
        let b = summary([0.0, 0.0], f64::INFINITY, 2, 9.0);
        assert_eq!(decide(&b, &a).0, Kept::Previous);
        let c = summary([0.0, 0.0], f64::INFINITY, 3, 4.0);
        let (k, why) = decide(&c, &a);
        assert_eq!(k, Kept::Previous, "{why}");
        assert_eq!(decide(&a, &a.clone()).0, Kept::New);
    }
}
