//! The per-iteration metrics table, as CSV (`metrics.csv` in the output folder).
//!
//! One row per iteration; a resumed run first drops the rows past its checkpoint (they
//! belong to the iterations it replays) and appends from there, so the file of a resumed
//! run lists every iteration once.

use crate::error::{TrainError, io_err};
use model::LossValues;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

pub const METRICS_FILE: &str = "metrics.csv";

pub const COLUMNS: &[&str] = &[
    "iteration",
    "frame_id",
    "total",
    "map_points",
    "map_lines",
    "reliability_points",
    "reliability_lines",
    "reprojection_points",
    "reprojection_lines",
    "reprojection_active",
    "tau",
    "lr",
    "valid_fraction_points",
    "valid_fraction_lines",
    "keypoints",
    "labelled_points",
    "lines",
    "labelled_lines",
    "seconds",
    "data_seconds",
];

/// One row of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct MetricsRow {
    /// 1-based: the row of iteration i is written after i steps.
    pub iteration: u64,
    /// The first image of the step.
    pub frame_id: u64,
    pub losses: LossValues,
    pub lr: f64,
    pub keypoints: usize,
    pub labelled_points: usize,
    pub lines: usize,
    pub labelled_lines: usize,
    /// Wall time of the iteration, and the part spent waiting for the frame stream
    /// (non-zero when data preparation, not the step, is the bottleneck).
    pub seconds: f64,
    pub data_seconds: f64,
}

fn opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

impl MetricsRow {
    pub fn to_csv(&self) -> String {
        let l = &self.losses;
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4}",
            self.iteration,
            self.frame_id,
            l.total,
            l.map_points,
            l.map_lines,
            l.reliability_points,
            l.reliability_lines,
            l.reprojection_points,
            l.reprojection_lines,
            l.reprojection_active as u8,
            l.tau,
            self.lr,
            opt(l.valid_fraction_points()),
            opt(l.valid_fraction_lines()),
            self.keypoints,
            self.labelled_points,
            self.lines,
            self.labelled_lines,
            self.seconds,
            self.data_seconds
        )
    }
}

/// Appends rows, flushing each so a killed run leaves a readable file.
pub struct MetricsWriter {
    path: PathBuf,
    file: std::fs::File,
}

impl MetricsWriter {
    /// Opens `dir/metrics.csv`, keeping only the rows of iterations `<= keep_through`
    /// (0: a fresh table).
    pub fn open(dir: &Path, keep_through: u64) -> Result<Self, TrainError> {
        let path = dir.join(METRICS_FILE);
        let mut kept = String::new();
        kept.push_str(&COLUMNS.join(","));
        kept.push('\n');
        if keep_through > 0 && path.is_file() {
            let f = std::fs::File::open(&path).map_err(io_err(&path))?;
            for line in BufReader::new(f).lines().skip(1) {
                let line = line.map_err(io_err(&path))?;
                let it = line.split(',').next().and_then(|v| v.parse::<u64>().ok());
                if matches!(it, Some(i) if i <= keep_through) {
                    kept.push_str(&line);
                    kept.push('\n');
                }
            }
        }
        crate::checkpoint::write_atomic(&path, kept.as_bytes())?;
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .map_err(io_err(&path))?;
        Ok(MetricsWriter { path, file })
    }

    pub fn append(&mut self, row: &MetricsRow) -> Result<(), TrainError> {
        writeln!(self.file, "{}", row.to_csv()).map_err(io_err(&self.path))?;
        Ok(self.file.flush().map_err(io_err(&self.path))?)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Reads the named columns of a metrics file (for the plot), rows in file order;
/// empty cells are NaN.
pub fn read_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, TrainError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let idx: Vec<usize> = names
        .iter()
        .map(|n| {
            header.iter().position(|h| h == n).ok_or_else(|| {
                TrainError::Io(fileio::IoError::new(
                    path,
                    std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!("no column {n:?}"),
                    ),
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    let mut out = vec![Vec::new(); names.len()];
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        for (k, &i) in idx.iter().enumerate() {
            out[k].push(
                cells
                    .get(i)
                    .and_then(|c| c.parse().ok())
                    .unwrap_or(f64::NAN),
            );
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(i: u64) -> MetricsRow {
        MetricsRow {
            iteration: i,
            frame_id: 7,
            losses: LossValues {
                total: i as f64,
                map_points: 1.0,
                map_lines: 2.0,
                reliability_points: 0.5,
                reliability_lines: 0.25,
                reprojection_points: 0.0,
                reprojection_lines: 0.0,
                reprojection_valid_points: 0,
                reprojection_valid_lines: 0,
                reprojection_candidates_points: 0,
                reprojection_candidates_lines: 0,
                reprojection_active: false,
                tau: 51.0,
            },
            lr: 1e-3,
            keypoints: 10,
            labelled_points: 5,
            lines: 2,
            labelled_lines: 1,
            seconds: 0.1,
            data_seconds: 0.01,
        }
    }

    #[test]
    fn resume_keeps_rows_up_to_the_checkpoint() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = MetricsWriter::open(dir.path(), 0).unwrap();
        for i in 1..=5 {
            w.append(&row(i)).unwrap();
        }
        drop(w);
        let mut w = MetricsWriter::open(dir.path(), 3).unwrap();
        w.append(&row(4)).unwrap();
        let cols =
            read_columns(w.path(), &["iteration", "total", "valid_fraction_points"]).unwrap();
        assert_eq!(cols[0], vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(cols[1], vec![1.0, 2.0, 3.0, 4.0]);
        assert!(cols[2][0].is_nan());
        let header = std::fs::read_to_string(w.path()).unwrap();
        assert_eq!(
            header.lines().next().unwrap().split(',').count(),
            COLUMNS.len()
        );
        assert_eq!(row(1).to_csv().split(',').count(), COLUMNS.len());
    }
}
