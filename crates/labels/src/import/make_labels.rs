//! The labels of an import's inputs: the join ([`super::build`]), then the detector
//! check (crates/labels/src/import/detectors.rs) and, with `point_labels = "detected"`,
//! the keypoints the front-end detects (crates/labels/src/import/detected.rs).

use super::build::build;
use super::config::ImportConfig;
use super::detected::{self, PointLabels};
use super::detectors::{self, DetectorCheck, MakeFrontEnd};
use super::error::ImportError;
use super::inputs::Inputs;
use super::report::ImportReport;
use features::FrontEndConfig;
use std::path::Path;
use tables::frames::FramesTable;
use tables::labels::LabelTables;

/// The label tables and report of `inputs` under `config` (the settings the record
/// hashes). `front_end` is the configured front-end with its weights path, which
/// `make_front_end` builds for the check.
pub(crate) fn make_labels(
    config: &ImportConfig,
    front_end: &FrontEndConfig,
    make_front_end: MakeFrontEnd<'_>,
    frames_path: &Path,
    inputs: &Inputs,
) -> Result<(LabelTables, ImportReport), ImportError> {
    let frames = FramesTable::read_parquet(frames_path)?;
    let model = colmap::read(inputs.model_dir).map_err(|source| ImportError::Colmap {
        dir: inputs.model_dir.to_path_buf(),
        source,
    })?;
    let (mut tables, mut report) = build(
        config,
        &frames,
        &inputs.frames_sha256,
        &model,
        &inputs.limap,
    )?;
    if config.detector_check != DetectorCheck::Off {
        let mut check = detectors::check(front_end, make_front_end, &frames, &tables)?;
        if !check.passed() {
            if config.detector_check == DetectorCheck::Refuse {
                return Err(ImportError::DetectorMismatch {
                    report: Box::new(check),
                });
            }
            check.decision = "accepted".into();
            report.warnings.push(format!(
                "detector check failed and was accepted (detector_check = \"accept\"): {}",
                check.rates()
            ));
        }
        report.detector_check = Some(check);
    }
    // After the check: it compares all of the model's keypoints.
    if config.point_labels == PointLabels::Detected {
        report.detected_labels = Some(detected::keep_detected(
            front_end,
            make_front_end,
            &frames,
            &mut tables,
        )?);
    }
    Ok((tables, report))
}
