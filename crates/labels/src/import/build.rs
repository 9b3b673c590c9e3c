//! The join and the labels, in memory: frames table + COLMAP model + LIMAP folder ->
//! label tables and report, or every problem found.

use super::config::ImportConfig;
use super::error::ImportError;
use super::join::{join_names, limap_problem, limap_root_prefix, model_problem};
use super::labelling::Labelling;
use super::problems::ImportProblem;
use super::report::ImportReport;
use crate::names::NameMapping;
use colmap::Reconstruction;
use limap::LimapDir;
use std::collections::HashMap;
use tables::frames::{Frame, FramesTable, Split};
use tables::labels::LabelTables;

/// The label tables and report of an import, or every problem of its inputs.
pub fn build(
    config: &ImportConfig,
    frames: &FramesTable,
    frames_sha256: &str,
    model: &Reconstruction,
    limap: &LimapDir,
) -> Result<(LabelTables, ImportReport), ImportError> {
    config.validate()?;
    let train: Vec<&Frame> = frames
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .collect();
    let mut problems = Vec::new();
    if train.is_empty() {
        problems.push(ImportProblem::NoTrainingFrames);
    }
    let mut report = new_report(config, frames, frames_sha256, model, limap, train.len());
    let joined = Joined::new(config, frames, model, limap, &mut problems, &mut report);
    joined.check_training_frames(&train, limap, &mut problems);
    check_limap(limap, &mut problems, &mut report);

    let mut labelling = Labelling::new(config, model, limap, frames_sha256, problems, report);
    let bar = stage::progress_bar(train.len() as u64, "import");
    for f in &train {
        bar.inc(1);
        if let (Some(&image_id), Some(&lid)) = (joined.model.get(&f.id), joined.limap.get(&f.id)) {
            labelling.frame(f, image_id, lid);
        }
    }
    bar.finish_and_clear();
    labelling
        .finish()
        .map_err(|problems| ImportError::Inconsistent {
            hints: hints(&problems, config, &train),
            problems,
        })
}

/// The report's header: the configuration, the frames table and the input counts.
fn new_report(
    config: &ImportConfig,
    frames: &FramesTable,
    frames_sha256: &str,
    model: &Reconstruction,
    limap: &LimapDir,
    train_frames: usize,
) -> ImportReport {
    let mut report = ImportReport {
        config: config.clone(),
        frames_sha256: frames_sha256.to_string(),
        train_frames,
        test_frames: frames.count(Split::Test),
        ..Default::default()
    };
    report.model.cameras = model.cameras.len();
    report.model.images = model.images.len();
    report.model.points3d = model.points3d.len();
    report.limap.images = limap.image_list.len();
    report.limap.tracks = limap.tracks.len();
    report
}

/// Frame id -> model image id and frame id -> LIMAP image id.
struct Joined {
    model: HashMap<u32, u32>,
    limap: HashMap<u32, u32>,
}

impl Joined {
    /// Joins the model's images, then LIMAP's, to the frames by name.
    fn new(
        config: &ImportConfig,
        frames: &FramesTable,
        model: &Reconstruction,
        limap: &LimapDir,
        problems: &mut Vec<ImportProblem>,
        report: &mut ImportReport,
    ) -> Joined {
        let by_name: HashMap<&str, &Frame> =
            frames.frames.iter().map(|f| (f.name.as_str(), f)).collect();
        let model_of = join_names(
            model.images.iter().map(|im| (im.image_id, im.name.clone())),
            &config.model_names,
            &by_name,
            config.allow_test_images,
            problems,
            &mut report.model.test_images_skipped,
            model_problem,
        );
        // Without a mapping, LIMAP 1.x's absolute paths lose their common dataset root
        // (`join::limap_root_prefix`); the report says which.
        let names: Vec<&str> = limap
            .image_list
            .images
            .iter()
            .map(|(_, n)| n.as_str())
            .collect();
        let root = config
            .limap_names
            .is_identity()
            .then(|| limap_root_prefix(&names, &by_name))
            .flatten();
        let limap_names = match &root {
            Some(prefix) => NameMapping {
                strip_prefix: Some(prefix.clone()),
                ..NameMapping::identity()
            },
            None => config.limap_names.clone(),
        };
        report.limap.root_prefix_stripped = root;
        let limap_of = join_names(
            limap.image_list.images.iter().cloned(),
            &limap_names,
            &by_name,
            config.allow_test_images,
            problems,
            &mut report.limap.test_images_skipped,
            limap_problem,
        );
        Joined {
            model: model_of,
            limap: limap_of,
        }
    }

    /// Every training frame is in the model and in LIMAP, with a segments file.
    fn check_training_frames(
        &self,
        train: &[&Frame],
        limap: &LimapDir,
        problems: &mut Vec<ImportProblem>,
    ) {
        for f in train {
            if !self.model.contains_key(&f.id) {
                problems.push(ImportProblem::TrainFrameNotInModel {
                    frame_id: f.id,
                    name: f.name.clone(),
                });
            }
            match self.limap.get(&f.id) {
                None => problems.push(ImportProblem::TrainFrameNotInLimap {
                    frame_id: f.id,
                    name: f.name.clone(),
                }),
                Some(lid) if !limap.segments.contains_key(lid) => {
                    problems.push(ImportProblem::TrainFrameWithoutSegments {
                        frame_id: f.id,
                        name: f.name.clone(),
                        limap_image_id: *lid,
                    })
                }
                Some(_) => {}
            }
        }
    }
}

/// LIMAP's own check of its folder: its errors are problems of the import; segments
/// files of no listed image are a warning.
fn check_limap(limap: &LimapDir, problems: &mut Vec<ImportProblem>, report: &mut ImportReport) {
    let check = limap.check();
    let mut unlisted_segments = 0;
    for p in check.results.iter().flat_map(|r| &r.problems) {
        match ImportProblem::from_limap(p) {
            Some(ip) if p.severity() == limap::Severity::Error => problems.push(ip),
            _ => {
                if matches!(p, limap::Problem::SegmentsOfUnlistedImage { .. }) {
                    unlisted_segments += 1;
                }
            }
        }
    }
    if unlisted_segments > 0 {
        report.warnings.push(format!(
            "{unlisted_segments} segments file(s) belong to no image of LIMAP's image_list.txt (ignored)"
        ));
    }
}

/// What the frames table's names look like, when a model or LIMAP image did not join.
fn hints(problems: &[ImportProblem], config: &ImportConfig, train: &[&Frame]) -> Vec<String> {
    let mut hints = Vec::new();
    let unmatched = problems.iter().any(|p| {
        matches!(
            p,
            ImportProblem::ModelImageNotInDataset { .. }
                | ImportProblem::LimapImageNotInDataset { .. }
        )
    });
    if unmatched {
        let examples: Vec<String> = train
            .iter()
            .take(3)
            .map(|f| format!("{:?}", f.name))
            .collect();
        hints.push(format!(
            "frames table names look like {}; model names mapping: {}; LIMAP names mapping: {}",
            examples.join(", "),
            config.model_names,
            config.limap_names
        ));
    }
    hints
}
