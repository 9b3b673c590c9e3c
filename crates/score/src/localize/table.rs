//! `per_image.csv` of `pl2map localize`: one row per query, in query order
//! (docs/formats.md, "Localisation outputs"), and the summary printed at the end
//! ([`LocalizeOutput::summary`]).

use super::output::{LocalizeOutput, QueryResult};
use crate::evaluate::{FrameResult, Variant};

/// Time columns, in this order: `time_<step>_ms`.
pub const STEPS: [&str; 7] = [
    "read",
    "decode",
    "front_end",
    "network",
    "filter",
    "pose_points",
    "pose_points_lines",
];

/// A CSV field: quoted (with doubled quotes) when it holds a comma, a quote or a line
/// break (RFC 4180).
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn step_ms(r: &FrameResult, step: &str) -> Option<f64> {
    r.timings.iter().find(|t| t.step == step).map(|t| t.ms)
}

/// The table's text. `status` is `localised` (the chosen variant has a pose; the
/// caller's variant is not known here, so both variants' columns are given),
/// `no_pose` (read and corresponded, RANSAC found no pose for either variant) or
/// `bad_input`; `failure` is the bad input's reason, else the first RANSAC failure.
pub fn csv(results: &[QueryResult]) -> String {
    let mut s =
        String::from("id,name,origin,status,points_total,lines_total,points_kept,lines_kept");
    for v in Variant::ALL {
        let k = v.key();
        s.push_str(&format!(
            ",{k}_ok,{k}_point_inliers,{k}_line_inliers,{k}_iterations"
        ));
    }
    for step in STEPS {
        s.push_str(&format!(",time_{step}_ms"));
    }
    s.push_str(",failure\n");
    for r in results {
        let q = &r.query;
        s.push_str(&format!("{},{},{}", q.id, field(&q.name), field(&q.origin)));
        match &r.outcome {
            Err(reason) => {
                s.push_str(",bad_input,,,,");
                s.push_str(&",,,,".repeat(Variant::ALL.len()));
                s.push_str(&",".repeat(STEPS.len()));
                s.push_str(&format!(",{}\n", field(reason)));
            }
            Ok(f) => {
                let any = Variant::ALL.iter().any(|&v| f.variant(v).pose.is_some());
                s.push_str(&format!(
                    ",{},{},{},{},{}",
                    if any { "localised" } else { "no_pose" },
                    f.points_total,
                    f.lines_total,
                    f.points_kept,
                    f.lines_kept
                ));
                for v in Variant::ALL {
                    let vr = f.variant(v);
                    s.push_str(&format!(
                        ",{},{},{},{}",
                        vr.pose.is_some(),
                        vr.point_inliers,
                        vr.line_inliers,
                        vr.iterations
                    ));
                }
                for step in STEPS {
                    match step_ms(f, step) {
                        Some(ms) => s.push_str(&format!(",{ms:.3}")),
                        None => s.push(','),
                    }
                }
                let failure = Variant::ALL.iter().find_map(|&v| {
                    f.variant(v)
                        .failure
                        .as_deref()
                        .map(|m| format!("{}: {m}", v.label()))
                });
                s.push_str(&format!(",{}\n", field(failure.as_deref().unwrap_or(""))));
            }
        }
    }
    s
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

impl LocalizeOutput {
    /// A few lines for the terminal: counts, inliers and time per phase.
    pub fn summary(&self) -> String {
        summary(self)
    }
}

fn summary(o: &LocalizeOutput) -> String {
    let v = o.variant;
    let n = o.results.len();
    let bad = o.failed_inputs().count();
    let read: Vec<&FrameResult> = o
        .results
        .iter()
        .filter_map(|r| r.outcome.as_ref().ok())
        .collect();
    let mut s = format!(
        "{n} queries: {} localised ({}), {} without a pose, {bad} bad input(s)\n",
        o.localised(),
        v.label(),
        read.len() - o.localised(),
    );
    let with_pose: Vec<&&FrameResult> = read
        .iter()
        .filter(|f| f.variant(v).pose.is_some())
        .collect();
    if let (Some(p), Some(l)) = (
        median(
            with_pose
                .iter()
                .map(|f| f.variant(v).point_inliers as f64)
                .collect(),
        ),
        median(
            with_pose
                .iter()
                .map(|f| f.variant(v).line_inliers as f64)
                .collect(),
        ),
    ) {
        s.push_str(&format!("median inliers: {p:.0} points, {l:.0} lines\n"));
    }
    let mut steps = Vec::new();
    for step in STEPS {
        if let Some(ms) = median(read.iter().filter_map(|f| step_ms(f, step)).collect()) {
            steps.push(format!("{step} {ms:.1}"));
        }
    }
    if !steps.is_empty() {
        s.push_str(&format!("median ms per image: {}\n", steps.join(", ")));
    }
    for r in o.failed_inputs().take(10) {
        if let Err(e) = &r.outcome {
            s.push_str(&format!("failed: {e}\n"));
        }
    }
    if bad > 10 {
        s.push_str(&format!("... and {} more (see the table)\n", bad - 10));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_with_commas_and_quotes_are_quoted() {
        assert_eq!(field("a.png"), "a.png");
        assert_eq!(field("x, y"), "\"x, y\"");
        assert_eq!(field("say \"no\""), "\"say \"\"no\"\"\"");
    }
}
