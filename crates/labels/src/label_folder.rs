//! The folder a label stage writes (import and refine, ARCHITECTURE.md "Data flow"): the
//! three label tables and the stage's JSON report, written through the stage runner;
//! and the report read back when the stage is up to date. One writer for both stages, so
//! their folders have one layout.

use fileio::{IoError, IoResultExt};
use serde::Serialize;
use serde::de::DeserializeOwned;
use stage::{Outputs, StageError};
use std::path::Path;
use tables::labels::{LINES_FILE, LabelTables, POINTS_FILE, POSES_FILE};
use tables::parquet::TableError;

/// Writes `tables` and `report` (pretty JSON and a newline, as `report_file`) into the
/// stage's folder and records them. `encode_err` words the (unexpected) failure to
/// encode the report as the stage's own error.
pub(crate) fn write<R: Serialize, E>(
    outputs: &mut Outputs,
    tables: &LabelTables,
    report_file: &str,
    report: &R,
    encode_err: impl FnOnce(serde_json::Error) -> E,
) -> Result<(), E>
where
    E: From<TableError> + From<StageError>,
{
    tables.write(outputs.dir())?;
    for f in [POINTS_FILE, LINES_FILE, POSES_FILE] {
        outputs.path(f);
    }
    let mut json = serde_json::to_vec_pretty(report).map_err(encode_err)?;
    json.push(b'\n');
    outputs.write(report_file, &json)?;
    Ok(())
}

/// The report of an up-to-date folder. Invalid JSON reads as an IO error of kind
/// `InvalidData` naming the file.
pub(crate) fn read_report<R: DeserializeOwned>(path: &Path) -> Result<R, IoError> {
    let bytes = std::fs::read(path).at(path)?;
    serde_json::from_slice(&bytes).map_err(|e| {
        IoError::new(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        )
    })
}
