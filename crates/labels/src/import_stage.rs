//! The import stage: COLMAP model + LIMAP folder + frames table -> label tables (the
//! steps are in [`crate::import`]).
//!
//! Stage folder: `points.parquet`, `lines.parquet`, `poses.parquet` (`tables::labels`),
//! `import_report.json`, `stage.json` (crates/labels/src/label_folder.rs). A rerun with
//! the same configuration and inputs (content hashes of the frames table, of the model's
//! files and of the LIMAP files read) is skipped.

use crate::import::inputs::Inputs;
use crate::import::make_labels::make_labels;
use crate::import::{ImportConfig, ImportError, ImportReport, MakeFrontEnd};
use crate::label_folder;
use stage::{Done, Stage};
use std::path::Path;

pub const STAGE: &str = "import";
pub const REPORT_FILE: &str = "import_report.json";

/// What a run did.
#[derive(Clone, Debug)]
pub struct ImportOutput {
    pub report: ImportReport,
}

impl stage::Note for ImportOutput {
    fn note(&self) -> String {
        self.report.note()
    }
}

/// Runs the import stage into `out` through the stage runner (see the module docs);
/// skipped when its record matches.
///
/// `make_front_end` builds the detector check's front-end: this crate does not link
/// SuperPoint (burn), so the caller passes `superpoint::front_end` for either kind, or
/// [`crate::import::sift_only`] where only SIFT is configured.
pub fn run(
    config: &ImportConfig,
    frames_path: &Path,
    out: &Path,
    make_front_end: MakeFrontEnd<'_>,
) -> Result<Done<ImportOutput>, ImportError> {
    config.validate()?;
    let inputs = Inputs::open(config, frames_path)?;
    // The check's front-end is built from the configuration with its weights path; the
    // record hashes the weights' content instead of the path.
    let front_end = &config.front_end;
    let config = &config.settings();
    Stage::new(STAGE, out, config, inputs.hashes.clone())?.run(
        |dir| {
            let report = label_folder::read_report(&dir.join(REPORT_FILE))?;
            Ok(ImportOutput { report })
        },
        |outputs| {
            let (tables, report) =
                make_labels(config, front_end, make_front_end, frames_path, &inputs)?;
            label_folder::write(outputs, &tables, REPORT_FILE, &report, |e| {
                ImportError::Config(format!("cannot encode the import report: {e}"))
            })?;
            Ok(ImportOutput { report })
        },
    )
}
