//! Aggregates over the scored frames: medians and accuracies per variant (the metrics
//! of `geometry::metrics`, docs/method.md section 6), as a markdown table and JSON.
//! Both leave timings out so that a rerun writes the same bytes; the per-frame table and
//! [`timing_table`] carry them.

use crate::evaluate::{FrameResult, Variant};
use geometry::metrics::{ACCURACY_THRESHOLDS, ErrorSummary, median, summarize};
use serde::{Deserialize, Deserializer, Serialize};

/// The fraction of frames strictly under both thresholds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Accuracy {
    pub cm: f64,
    pub deg: f64,
    #[serde(deserialize_with = "null_as_nan")]
    pub fraction: f64,
}

/// The summary of one variant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VariantSummary {
    pub variant: Variant,
    pub frames: usize,
    /// Frames with a pose (the others count as infinitely wrong).
    pub localised: usize,
    /// Median over all frames; infinite when more than half failed, NaN for no frames
    /// (JSON: null).
    #[serde(deserialize_with = "null_as_nan")]
    pub median_cm: f64,
    #[serde(deserialize_with = "null_as_nan")]
    pub median_deg: f64,
    /// One per `ACCURACY_THRESHOLDS` entry.
    pub accuracy: Vec<Accuracy>,
    #[serde(deserialize_with = "null_as_nan")]
    pub median_point_inliers: f64,
    #[serde(deserialize_with = "null_as_nan")]
    pub median_line_inliers: f64,
}

/// JSON has no NaN or infinity: `to_json` writes them as null, read back as NaN
/// ([`Summary::read_json`] restores the infinite medians).
fn null_as_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// What the run scored and how.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The localiser's own description.
    pub source: String,
    /// `train` or `test`.
    pub split: String,
    pub min_point_reliability: f64,
    pub min_line_reliability: f64,
    pub point_threshold_px: f64,
    pub line_threshold_px: f64,
    pub seed: u64,
    pub variants: Vec<VariantSummary>,
}

pub(crate) fn summarize_variant(results: &[FrameResult], v: Variant) -> VariantSummary {
    let errors: Vec<_> = results.iter().map(|r| r.variant(v).error).collect();
    let ErrorSummary {
        count,
        median_cm,
        median_deg,
        accuracy,
    } = summarize(&errors);
    let inl = |f: fn(&crate::evaluate::VariantResult) -> usize| {
        median(
            &results
                .iter()
                .map(|r| f(r.variant(v)) as f64)
                .collect::<Vec<_>>(),
        )
    };
    VariantSummary {
        variant: v,
        frames: count,
        localised: errors.iter().filter(|e| e.is_some()).count(),
        median_cm,
        median_deg,
        accuracy: ACCURACY_THRESHOLDS
            .iter()
            .zip(accuracy)
            .map(|(&(cm, deg), fraction)| Accuracy { cm, deg, fraction })
            .collect(),
        median_point_inliers: inl(|r| r.point_inliers),
        median_line_inliers: inl(|r| r.line_inliers),
    }
}

/// The header cells of a variant row (see [`VariantSummary::row_cells`]), each closed
/// by `|`: variant, frames, localised, medians, one per accuracy threshold.
pub fn header_cells() -> String {
    let mut s = String::from(" variant | frames | localised | median cm | median deg |");
    for &(c, d) in &ACCURACY_THRESHOLDS {
        s.push_str(&format!(" {} cm {} deg |", fmt_thr(c), fmt_thr(d)));
    }
    s
}

/// The markdown alignment cells matching [`header_cells`].
pub fn align_cells() -> String {
    format!(
        "---|---:|---:|---:|---:|{}",
        "---:|".repeat(ACCURACY_THRESHOLDS.len())
    )
}

impl VariantSummary {
    /// The cells of this variant's table row, matching [`header_cells`].
    pub fn row_cells(&self) -> String {
        let mut s = format!(
            " {} | {} | {} | {} | {} |",
            self.variant.label(),
            self.frames,
            self.localised,
            fmt_value(self.median_cm),
            fmt_value(self.median_deg)
        );
        for a in &self.accuracy {
            s.push_str(&format!(" {:.1} % |", 100.0 * a.fraction));
        }
        s
    }
}

/// A number for the tables: 2 decimals, or 2 significant digits when tiny (the oracle's
/// errors are far below 0.01), `inf` / `-` for failures and empty sets.
pub fn fmt_value(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else if v.is_infinite() {
        "inf".into()
    } else if v == 0.0 || v.abs() >= 0.01 {
        format!("{v:.2}")
    } else {
        format!("{v:.1e}")
    }
}

/// A median of counts: an integer, or one decimal (the mean of two middle counts).
fn fmt_count(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

fn fmt_thr(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

impl Summary {
    /// The markdown report: settings, then one row per variant.
    /// One line for a run table: per variant, the median translation error and the
    /// fraction under 5 cm / 5 deg.
    pub fn line(&self) -> String {
        self.variants
            .iter()
            .map(|v| {
                let acc = v
                    .accuracy
                    .iter()
                    .find(|a| a.cm == 5.0 && a.deg == 5.0)
                    .or(v.accuracy.last())
                    .map(|a| {
                        format!(
                            "{:.1} % under {} cm / {} deg",
                            100.0 * a.fraction,
                            a.cm,
                            a.deg
                        )
                    })
                    .unwrap_or_default();
                format!("{}: median {:.1} cm, {acc}", v.variant.label(), v.median_cm)
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    pub fn markdown(&self) -> String {
        let mut s = String::from("# pl2map score\n\n");
        s.push_str(&format!("- source: {}\n", self.source));
        s.push_str(&format!("- frames: {} split\n", self.split));
        s.push_str(&format!(
            "- kept: point reliability >= {}, line reliability >= {}\n",
            self.min_point_reliability, self.min_line_reliability
        ));
        s.push_str(&format!(
            "- RANSAC: point threshold {} px, line threshold {} px, seed {}\n\n",
            self.point_threshold_px, self.line_threshold_px, self.seed
        ));
        s.push_str(&self.table());
        s.push_str(
            "\nAccuracy: fraction of frames strictly under both thresholds; frames without a \
             pose count as failures. Inliers: medians over frames.\n",
        );
        s
    }

    /// The markdown table alone: one row per variant, with the median inlier counts.
    pub fn table(&self) -> String {
        let mut s = format!(
            "|{} inliers (pts / lines) |\n|{}---:|\n",
            header_cells(),
            align_cells()
        );
        for v in &self.variants {
            s.push_str(&format!(
                "|{} {} / {} |\n",
                v.row_cells(),
                fmt_count(v.median_point_inliers),
                fmt_count(v.median_line_inliers)
            ));
        }
        s
    }

    /// Pretty JSON with a trailing newline; non-finite numbers become null.
    pub fn to_json(&self) -> Vec<u8> {
        let mut v = serde_json::to_vec_pretty(self).unwrap_or_default();
        v.push(b'\n');
        v
    }

    /// Reads what [`Summary::to_json`] wrote. A null median is infinite when the middle
    /// frame(s) failed (`localised <= frames / 2`: failures sort last), else NaN.
    pub fn read_json(path: &std::path::Path) -> Result<Summary, crate::ScoreError> {
        let bytes = std::fs::read(path).map_err(fileio::io_err(path))?;
        let mut s: Summary =
            serde_json::from_slice(&bytes).map_err(|e| crate::ScoreError::Summary {
                path: path.to_path_buf(),
                reason: e.to_string(),
            })?;
        for v in &mut s.variants {
            let failed_median = v.frames > 0 && v.localised <= v.frames / 2;
            for m in [&mut v.median_cm, &mut v.median_deg] {
                if m.is_nan() && failed_median {
                    *m = f64::INFINITY;
                }
            }
        }
        Ok(s)
    }
}

/// Median milliseconds of each step over the frames, in the order steps first appear.
pub fn step_medians(results: &[FrameResult]) -> Vec<(String, f64)> {
    let steps = crate::table::step_names(results);
    steps
        .into_iter()
        .map(|step| {
            let ms: Vec<f64> = results
                .iter()
                .filter_map(|r| r.timings.iter().find(|t| t.step == step).map(|t| t.ms))
                .collect();
            let m = median(&ms);
            (step, m)
        })
        .collect()
}

/// Markdown table of [`step_medians`] (printed, not written: timings differ per run).
pub fn timing_table(results: &[FrameResult]) -> String {
    let mut s = String::from("| step | median ms |\n|---|---:|\n");
    for (step, ms) in step_medians(results) {
        s.push_str(&format!("| {step} | {ms:.2} |\n"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate::VariantResult;
    use crate::localiser::Timing;
    use geometry::metrics::PoseError;

    fn vr(cm: Option<f64>, deg: f64) -> VariantResult {
        VariantResult {
            pose: None,
            error: cm.map(|c| PoseError {
                translation_m: c / 100.0,
                rotation_deg: deg,
            }),
            failure: cm.is_none().then(|| "no pose".to_string()),
            point_inliers: 10,
            line_inliers: 4,
            iterations: 1000,
            ms: 1.0,
            point_inlier_mask: vec![],
            line_inlier_mask: vec![],
        }
    }

    fn frame(id: u64, p: VariantResult, pl: VariantResult) -> FrameResult {
        FrameResult {
            frame_id: id,
            name: format!("f{id}.png"),
            points_total: 5,
            lines_total: 5,
            points_kept: 5,
            lines_kept: 5,
            variants: [p, pl],
            timings: vec![Timing {
                step: "read".into(),
                ms: id as f64,
            }],
        }
    }

    /// Hand cases on the threshold boundaries: 1 cm exactly is not under 1 cm, and a
    /// frame must be under both thresholds.
    #[test]
    fn strict_accuracy_on_hand_cases() {
        let results = vec![
            frame(0, vr(Some(0.999), 0.999), vr(Some(0.2), 0.2)),
            frame(1, vr(Some(1.0), 0.5), vr(Some(0.5), 1.0)),
            frame(2, vr(Some(0.5), 2.5), vr(Some(4.99), 4.99)),
            frame(3, vr(None, 0.0), vr(Some(10.0), 0.1)),
        ];
        let p = summarize_variant(&results, Variant::Points);
        let fr: Vec<f64> = p.accuracy.iter().map(|a| a.fraction).collect();
        // (1,1): frame 0 only; (2,2): 0, 1; (3,3): 0, 1, 2; failure never counts.
        assert_eq!(fr, vec![0.25, 0.5, 0.75, 0.75, 0.75]);
        assert_eq!((p.frames, p.localised), (4, 3));
        // cm sorted: 0.5, 0.999, 1.0, inf -> median (0.999 + 1.0) / 2.
        assert!((p.median_cm - 0.9995).abs() < 1e-12);
        let pl = summarize_variant(&results, Variant::PointsLines);
        let fr: Vec<f64> = pl.accuracy.iter().map(|a| a.fraction).collect();
        // frame 1 has 1.0 deg: not under (1, 1); frame 3 has 10 cm: not under (10, 10).
        assert_eq!(fr, vec![0.25, 0.5, 0.5, 0.75, 0.75]);
        assert_eq!(pl.localised, 4);
        assert_eq!(pl.median_point_inliers, 10.0);
    }

    #[test]
    fn markdown_lists_both_variants() {
        let results = vec![frame(0, vr(Some(0.5), 0.5), vr(None, 0.0))];
        let s = Summary {
            source: "oracle".into(),
            split: "train".into(),
            min_point_reliability: 0.5,
            min_line_reliability: 0.02,
            point_threshold_px: 12.0,
            line_threshold_px: 10.0,
            seed: 0,
            variants: Variant::ALL
                .iter()
                .map(|&v| summarize_variant(&results, v))
                .collect(),
        };
        let md = s.markdown();
        assert!(
            md.contains("| points | 1 | 1 | 0.50 | 0.50 | 100.0 % |"),
            "{md}"
        );
        assert!(
            md.contains("| points + lines | 1 | 0 | inf | inf | 0.0 % |"),
            "{md}"
        );
        assert!(md.contains("1 cm 1 deg"));
        let json: serde_json::Value = serde_json::from_slice(&s.to_json()).unwrap();
        assert_eq!(json["variants"][0]["localised"], 1);
        assert_eq!(json["variants"][1]["variant"], "points_lines");
        assert_eq!(json["variants"][0]["accuracy"][4]["cm"], 10.0);
        assert_eq!(json["variants"][0]["accuracy"][0]["fraction"], 1.0);
        // Infinite medians are written as null (JSON has no infinity).
        assert!(json["variants"][1]["median_cm"].is_null());
        assert!(timing_table(&results).contains("| read | 0.00 |"));
        // Read back: the null median of the failed variant is infinite again.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("summary.json");
        std::fs::write(&path, s.to_json()).unwrap();
        assert_eq!(Summary::read_json(&path).unwrap(), s);
        std::fs::write(&path, b"{\"source\": 3}").unwrap();
        let err = Summary::read_json(&path).unwrap_err().to_string();
        assert!(err.contains("summary.json: not a score summary"), "{err}");
    }

    #[test]
    fn number_format() {
        assert_eq!(fmt_value(1.234), "1.23");
        assert_eq!(fmt_value(0.0), "0.00");
        assert_eq!(fmt_value(3.2e-7), "3.2e-7");
        assert_eq!(fmt_value(f64::INFINITY), "inf");
        assert_eq!(fmt_value(f64::NAN), "-");
        assert_eq!(fmt_count(829.5), "829.5");
        assert_eq!(fmt_count(64.0), "64");
    }
}
