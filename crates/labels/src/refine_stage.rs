//! The refine stage (optional): frames table + the import's label folder -> label tables
//! moved onto the depth maps (the steps are in [`crate::refine`]).
//!
//! Stage folder: the three label tables (label source `depth-refined`),
//! `refine_report.json`, `stage.json` (crates/labels/src/label_folder.rs).

use crate::label_folder;
use crate::refine::inputs::Inputs;
use crate::refine::{RefineConfig, RefineError, RefineReport, refine};
use stage::{Done, Stage};
use std::path::Path;

pub const STAGE: &str = "refine";
pub const REPORT_FILE: &str = "refine_report.json";

/// What a run did.
#[derive(Clone, Debug)]
pub struct RefineOutput {
    pub report: RefineReport,
}

impl stage::Note for RefineOutput {
    fn note(&self) -> String {
        let (p, l) = (&self.report.points, &self.report.lines);
        format!(
            "{} of {} point labels and {} of {} line labels kept",
            p.kept, p.labels, l.kept, l.labels
        )
    }
}

/// Runs the refine stage: frames table + label folder -> refined label folder `out`.
pub fn run(
    config: &RefineConfig,
    frames_path: &Path,
    labels_dir: &Path,
    out: &Path,
) -> Result<Done<RefineOutput>, RefineError> {
    config.validate()?;
    let inputs = Inputs::open(frames_path, labels_dir)?;
    let depth_paths = inputs.depth_paths();
    let Inputs {
        labels,
        units_per_metre,
        hashes,
        ..
    } = inputs;
    Stage::new(STAGE, out, config, hashes)?.run(
        |dir| {
            let report = label_folder::read_report(&dir.join(REPORT_FILE))?;
            Ok(RefineOutput { report })
        },
        |outputs| {
            let (refined, report) = refine(config, labels, &depth_paths, units_per_metre)?;
            label_folder::write(outputs, &refined, REPORT_FILE, &report, |e| {
                RefineError::Config(format!("cannot encode the refine report: {e}"))
            })?;
            Ok(RefineOutput { report })
        },
    )
}
