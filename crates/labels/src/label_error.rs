//! Label error: the 3D error of point and line labels against exact ones (the synthetic
//! scene's `sfm_gt/exact.json`), before and after depth refinement (the label ablation
//! of docs/training-notes.md, `pl2map refine --exact`).
//!
//! Point error: distance of a keypoint's label to the exact position of its 3D point.
//! Line error: mean distance of the two label endpoints to the exact endpoints of the
//! track (the better of both orders: a label's endpoint order follows its 2D segment).

use crate::stats::Spread;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tables::labels::LabelTables;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum ExactLabelsError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error("{}: not an exact-labels file: {source}", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{}: {what} {id} has a label but no exact value", path.display())]
    Unknown {
        path: PathBuf,
        what: &'static str,
        id: i64,
    },
}

#[derive(Deserialize)]
struct ExactLine {
    endpoints: [[f64; 3]; 2],
}

#[derive(Deserialize)]
struct ExactFile {
    points3d: BTreeMap<u64, [f64; 3]>,
    line_tracks: BTreeMap<u64, ExactLine>,
}

/// Exact 3D points (by point3D id) and line tracks (by track id).
pub struct ExactLabels {
    path: PathBuf,
    points: BTreeMap<u64, [f64; 3]>,
    tracks: BTreeMap<u64, [[f64; 3]; 2]>,
}

fn d3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

impl ExactLabels {
    pub fn read(path: &Path) -> Result<Self, ExactLabelsError> {
        let bytes = std::fs::read(path).map_err(fileio::io_err(path))?;
        let f: ExactFile =
            serde_json::from_slice(&bytes).map_err(|source| ExactLabelsError::Json {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(ExactLabels {
            path: path.to_path_buf(),
            points: f.points3d,
            tracks: f
                .line_tracks
                .into_iter()
                .map(|(k, v)| (k, v.endpoints))
                .collect(),
        })
    }

    /// Errors (metres) of every valid point label and every valid line label.
    pub fn errors(&self, t: &LabelTables) -> Result<(Vec<f64>, Vec<f64>), ExactLabelsError> {
        let unknown = |what, id| ExactLabelsError::Unknown {
            path: self.path.clone(),
            what,
            id,
        };
        let mut points = Vec::new();
        for r in &t.points {
            if let Some(xyz) = r.xyz {
                let g = u64::try_from(r.point3d_id)
                    .ok()
                    .and_then(|id| self.points.get(&id))
                    .ok_or_else(|| unknown("point3D", r.point3d_id))?;
                points.push(d3(&xyz, g));
            }
        }
        let mut lines = Vec::new();
        for r in &t.lines {
            if let Some(e) = r.endpoints {
                let g = u64::try_from(r.track_id)
                    .ok()
                    .and_then(|id| self.tracks.get(&id))
                    .ok_or_else(|| unknown("line track", r.track_id))?;
                let keep = 0.5 * (d3(&e[0], &g[0]) + d3(&e[1], &g[1]));
                let swap = 0.5 * (d3(&e[0], &g[1]) + d3(&e[1], &g[0]));
                lines.push(keep.min(swap));
            }
        }
        Ok((points, lines))
    }
}

/// One label kind of the label error table.
#[derive(Clone, Debug)]
pub struct LabelErrorRow {
    pub kind: &'static str,
    pub before: Spread,
    pub after: Spread,
    /// Valid labels before and after.
    pub labels_before: usize,
    pub labels_after: usize,
}

impl LabelErrorRow {
    /// Relative reduction of the median error (0.8 = 80 % smaller).
    pub fn reduction(&self) -> f64 {
        1.0 - self.after.median / self.before.median
    }

    pub fn dropped_fraction(&self) -> f64 {
        if self.labels_before == 0 {
            return 0.0;
        }
        1.0 - self.labels_after as f64 / self.labels_before as f64
    }
}

/// Compares the label tables before and after refinement against the exact labels.
pub fn compare(
    exact: &ExactLabels,
    before: &LabelTables,
    after: &LabelTables,
) -> Result<[LabelErrorRow; 2], ExactLabelsError> {
    let (pb, lb) = exact.errors(before)?;
    let (pa, la) = exact.errors(after)?;
    let row = |kind, b: &[f64], a: &[f64]| LabelErrorRow {
        kind,
        before: Spread::of(b),
        after: Spread::of(a),
        labels_before: b.len(),
        labels_after: a.len(),
    };
    Ok([row("points", &pb, &pa), row("lines", &lb, &la)])
}

/// The table a person reads.
pub fn table(rows: &[LabelErrorRow]) -> String {
    let mut s = String::from(
        "3D label error against the exact labels\n\
         labels   median before (cm)  median after (cm)  p90 after (cm)  reduction  dropped\n",
    );
    for r in rows {
        s.push_str(&format!(
            "{:<7} {:>19.3} {:>18.3} {:>15.3} {:>8.1} % {:>6.2} % ({} of {})\n",
            r.kind,
            r.before.median * 100.0,
            r.after.median * 100.0,
            r.after.p90 * 100.0,
            100.0 * r.reduction(),
            100.0 * r.dropped_fraction(),
            r.labels_before - r.labels_after.min(r.labels_before),
            r.labels_before
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduction_and_dropped_fraction() {
        let r = LabelErrorRow {
            kind: "points",
            before: Spread::of(&[0.05, 0.05, 0.05]),
            after: Spread::of(&[0.005, 0.005]),
            labels_before: 3,
            labels_after: 2,
        };
        assert!((r.reduction() - 0.9).abs() < 1e-12);
        assert!((r.dropped_fraction() - 1.0 / 3.0).abs() < 1e-12);
        assert!(table(&[r]).contains("90.0 %"));
    }

    #[test]
    fn reads_exact_files_and_refuses_others() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("exact.json");
        std::fs::write(
            &p,
            r#"{"label_noise_cm":5,"points3d":{"1":[0,0,1]},"line_tracks":{"0":{"edge":3,"endpoints":[[0,0,0],[1,0,0]]}}}"#,
        )
        .unwrap();
        let e = ExactLabels::read(&p).unwrap();
        assert_eq!(e.points[&1], [0.0, 0.0, 1.0]);
        assert_eq!(e.tracks[&0][1], [1.0, 0.0, 0.0]);
        std::fs::write(&p, "{}").unwrap();
        let err = ExactLabels::read(&p).err().unwrap().to_string();
        assert!(err.contains("exact.json"), "{err}");
    }
}
