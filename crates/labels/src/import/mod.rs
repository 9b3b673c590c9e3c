//! The import stage: COLMAP model + LIMAP folder + frames table -> label tables.
//!
//! Per training frame (docs/method.md section 3):
//! - points: every keypoint of the image in the model (COLMAP points2D, COLMAP pixels),
//!   its point3D id and xyz, or no label;
//! - lines: every segment of LIMAP's `segments_<LIMAP image id>.txt` (times
//!   [`ImportConfig::segment_scale`]), the track that lists it among its supports and the
//!   track's 3D endpoints ordered to follow the segment ([`crate::align`]), or no label;
//! - the camera and pose the labels go with: the model's (default, as the reference
//!   implementation) or the frames table's ([`PoseSource`]).
//!
//! Images are joined by name through explicit [`NameMapping`]s (one for the model, one
//! for LIMAP's image_list.txt). Inconsistent input is refused with every problem listed
//! ([`ImportProblem`]); the disagreement between SfM and dataset poses is reported.
//!
//! Stage folder: `points.parquet`, `lines.parquet`, `poses.parquet` (`tables::labels`),
//! `import_report.json`, `stage.json`. A rerun with the same configuration and inputs
//! (content hashes of the frames table, of the model's files and of the LIMAP files
//! read) is skipped.

mod build;
mod detected;
mod detectors;
mod problems;
mod report;

pub use build::build;
pub use detected::{DETECTED_RADIUS_PX, DetectedLabelsReport, PointLabels, detected_rows};
pub use detectors::{
    DetectorCheck, DetectorCheckReport, MATCH_RADIUS_PX, MIN_KEYPOINT_RATE, MIN_SEGMENT_RATE,
    MakeFrontEnd, SAMPLE_IMAGES, keypoints_near, matched_keypoints, matched_segments, sift_only,
};
pub use problems::{EXAMPLES_PER_KIND, ImportProblem, summarize};
pub use report::{
    ImportReport, LimapCounts, LineCounts, ModelCounts, PointCounts, PoseDisagreement,
};

use crate::names::NameMapping;
use limap::{LimapDir, LimapDirOptions};
use serde::{Deserialize, Serialize};
use stage::{Done, Stage};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tables::frames::FramesTable;
use tables::labels::{LINES_FILE, POINTS_FILE, POSES_FILE, PoseSource};
use tables::parquet::TableError;
use thiserror::Error;

pub const STAGE: &str = "import";
pub const REPORT_FILE: &str = "import_report.json";

/// The import stage's configuration: `[import]` of a pipeline file and the flags of
/// `pl2map import`, the only place its settings and defaults live. The two input
/// folders are part of it; the record hashes their content, not their paths.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default, deny_unknown_fields)]
pub struct ImportConfig {
    /// COLMAP model folder (cameras/images/points3D, .bin or .txt), e.g. hloc's
    /// `sfm_superpoint+superglue/` (a pipeline with [synth] takes its scene's).
    #[arg(long, required = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<PathBuf>,
    /// LIMAP output folder (image_list.txt, finaltracks/, line_detections/*/segments/).
    #[arg(long, required = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limap: Option<PathBuf>,
    /// COLMAP image name -> frames table name: `identity` or rules
    /// `strip_prefix=P,add_prefix=P,replace_extension=.jpg:.png`.
    #[arg(long, default_value = "identity", value_parser = NameMapping::parse_rules)]
    pub model_names: NameMapping,
    /// LIMAP image_list.txt name -> frames table name (same rules).
    #[arg(long, default_value = "identity", value_parser = NameMapping::parse_rules)]
    pub limap_names: NameMapping,
    /// Camera and pose of the labels: sfm (the model's, as the reference implementation)
    /// or dataset (the frames table's).
    #[arg(long, default_value_t = ImportConfig::default().pose_source)]
    pub pose_source: PoseSource,
    /// Test frames found in the model or in LIMAP are skipped (true) or refused (false,
    /// the default: labels made with test images leak them into training).
    #[arg(long, default_value_t = ImportConfig::default().allow_test_images, action = clap::ArgAction::Set)]
    pub allow_test_images: bool,
    /// LIMAP segment coordinates times this are pixels of the image (LIMAP detects on
    /// images resized to `max_image_dim`, 1600 by default: for a 1920-wide image the
    /// scale is 1920 / 1600 = 1.2).
    #[arg(long, default_value_t = ImportConfig::default().segment_scale)]
    pub segment_scale: f64,
    /// How far outside the image (pixels) a keypoint or segment endpoint may lie before
    /// the input is refused (it would mean another resolution or camera). 3 px by
    /// default: LSD extrapolates segments past the border (LIMAP's pytlsd output of the
    /// synthetic room reaches 2.7 px, docs/formats.md section 2).
    #[arg(long, default_value_t = ImportConfig::default().bounds_tolerance_px)]
    pub bounds_tolerance_px: f64,
    /// The LIMAP segments folder, relative to the LIMAP folder; default: the only one of
    /// `line_detections/*/segments` and `segments`.
    #[arg(long)]
    pub limap_segments: Option<PathBuf>,
    /// The LIMAP track folder, relative to the LIMAP folder; default: `finaltracks`.
    #[arg(long)]
    pub limap_tracks: Option<PathBuf>,
    /// Which line tracks label the lines: `finaltracks` (every track of the track folder)
    /// or `alltracks` (LIMAP's alltracks.txt: the tracks seen in at least 4 images, what
    /// the reference implementation trains on).
    #[serde(skip_serializing_if = "LineTrackSet::is_default")]
    #[arg(long, value_enum, default_value_t = LineTrackSet::default())]
    pub line_tracks: LineTrackSet,
    /// The detector check (docs/method.md section 3): on a sample of training images,
    /// compare the model's keypoints and LIMAP's segments with the front-end's
    /// detections; `refuse` (default) when they say another detector made them, `accept`
    /// (import anyway, the report keeps the rates) or `off`.
    #[serde(skip_serializing_if = "DetectorCheck::is_default")]
    #[arg(long, value_enum, default_value_t = DetectorCheck::default())]
    pub detector_check: DetectorCheck,
    /// Which model keypoints enter the labels: `all` (default) or `detected`, only those
    /// the front-end detects itself within 1 px (docs/method.md section 3). For a model whose detector is another
    /// implementation of the front-end's (COLMAP's or hloc's SIFT under OpenCV's SIFT),
    /// so that training describes the positions the query detects.
    #[serde(skip_serializing_if = "PointLabels::is_default")]
    #[arg(long, value_enum, default_value_t = PointLabels::default())]
    pub point_labels: PointLabels,
    /// The front-end the check compares with (`pl2map import --front-end`; a pipeline's
    /// `[features]` sets its kind and SuperPoint weights). Left out of the serialised
    /// form when the default (SIFT), and its weights file is hashed by content.
    #[serde(skip_serializing_if = "is_default_front_end")]
    #[arg(skip)]
    pub front_end: features::FrontEndConfig,
}

fn is_default_front_end(c: &features::FrontEndConfig) -> bool {
    *c == features::FrontEndConfig::default()
}

/// The LIMAP tracks the line labels come from (`[import] line_tracks`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum LineTrackSet {
    /// Every track of the track folder (`finaltracks/`).
    #[default]
    Finaltracks,
    /// `alltracks.txt`: the tracks seen in at least 4 images.
    Alltracks,
}

impl LineTrackSet {
    /// Serialised only when not the default, so that configurations (and the records
    /// and reports that hash them) written before the option existed keep their bytes.
    fn is_default(&self) -> bool {
        *self == LineTrackSet::default()
    }

    pub fn as_str(self) -> &'static str {
        match self {
            LineTrackSet::Finaltracks => "finaltracks",
            LineTrackSet::Alltracks => "alltracks",
        }
    }
}

impl std::fmt::Display for LineTrackSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Default for ImportConfig {
    fn default() -> Self {
        ImportConfig {
            model: None,
            limap: None,
            model_names: NameMapping::identity(),
            limap_names: NameMapping::identity(),
            pose_source: PoseSource::Sfm,
            allow_test_images: false,
            segment_scale: 1.0,
            bounds_tolerance_px: problems::LSD_OVERSHOOT_PX,
            limap_segments: None,
            limap_tracks: None,
            line_tracks: LineTrackSet::Finaltracks,
            detector_check: DetectorCheck::Refuse,
            point_labels: PointLabels::All,
            front_end: features::FrontEndConfig::default(),
        }
    }
}

impl ImportConfig {
    /// The settings without the input folders: what the record and the report hash
    /// (the inputs are hashed by content).
    pub fn settings(&self) -> ImportConfig {
        let mut front_end = self.front_end.clone();
        front_end.superpoint.weights = None;
        ImportConfig {
            model: None,
            limap: None,
            front_end,
            ..self.clone()
        }
    }

    /// The COLMAP model and LIMAP folders, or the error naming the missing one.
    pub fn inputs(&self) -> Result<(&Path, &Path), ImportError> {
        let model = self.model.as_deref().ok_or_else(|| {
            ImportError::Config("no COLMAP model: give --model DIR ([import] model)".into())
        })?;
        let limap = self.limap.as_deref().ok_or_else(|| {
            ImportError::Config("no LIMAP folder: give --limap DIR ([import] limap)".into())
        })?;
        Ok((model, limap))
    }

    pub fn validate(&self) -> Result<(), ImportError> {
        if !(self.segment_scale.is_finite() && self.segment_scale > 0.0) {
            return Err(ImportError::Config(format!(
                "segment_scale must be positive and finite, got {}",
                self.segment_scale
            )));
        }
        if !(self.bounds_tolerance_px.is_finite() && self.bounds_tolerance_px >= 0.0) {
            return Err(ImportError::Config(format!(
                "bounds_tolerance_px must be >= 0 and finite, got {}",
                self.bounds_tolerance_px
            )));
        }
        self.front_end
            .validate()
            .map_err(|e| ImportError::Config(format!("front_end: {e}")))?;
        Ok(())
    }
}

#[derive(Debug, Error)]
pub enum ImportError {
    /// The COLMAP crate's errors name the model's file (and line) already.
    #[error("COLMAP model: {source}")]
    Colmap {
        dir: PathBuf,
        #[source]
        source: colmap::ColmapError,
    },
    #[error("LIMAP folder: {0}")]
    Limap(#[from] limap::LimapError),
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("import configuration: {0}")]
    Config(String),
    /// The detector check says another detector made the model's keypoints or LIMAP's
    /// segments (`detector_check = "refuse"`).
    #[error("{}", report.refusal())]
    DetectorMismatch { report: Box<DetectorCheckReport> },
    #[error("{}", summarize(problems, hints))]
    Inconsistent {
        problems: Vec<ImportProblem>,
        hints: Vec<String>,
    },
}

impl ImportError {
    /// The problems of an inconsistent input (empty for other errors).
    pub fn problems(&self) -> &[ImportProblem] {
        match self {
            ImportError::Inconsistent { problems, .. } => problems,
            _ => &[],
        }
    }
}

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

/// Files of a COLMAP model directory in the format `colmap::read` uses, sorted.
fn model_files(dir: &Path) -> Result<Vec<String>, ImportError> {
    let format = colmap::detect_format(dir).map_err(|source| ImportError::Colmap {
        dir: dir.to_path_buf(),
        source,
    })?;
    let ext = match format {
        colmap::Format::Binary => "bin",
        colmap::Format::Text => "txt",
    };
    let mut out: Vec<String> = ["cameras", "frames", "images", "points3D", "rigs"]
        .iter()
        .map(|stem| format!("{stem}.{ext}"))
        .filter(|f| dir.join(f).is_file())
        .collect();
    out.sort();
    Ok(out)
}

/// Content hashes of every LIMAP file the import reads (either layout: the folder lists
/// them, `limap::LimapDir::input_files`).
fn limap_hashes(dir: &LimapDir) -> Result<BTreeMap<String, String>, ImportError> {
    let mut out = BTreeMap::new();
    for group in dir.input_files()? {
        out.insert(
            group.name.to_string(),
            stage::sha256_files(&group.dir, group.files.iter().map(String::as_str))?,
        );
    }
    Ok(out)
}

/// Makes the chosen track set the one the labels are built from.
fn select_tracks(limap: &mut LimapDir, set: LineTrackSet) -> Result<(), ImportError> {
    if set == LineTrackSet::Alltracks {
        let path = limap.root.join(limap::dir::ALLTRACKS_FILE);
        limap.tracks = limap.alltracks.clone().ok_or_else(|| {
            ImportError::Config(format!(
                "line_tracks = alltracks, but {} does not exist (LIMAP writes it next to \
                 finaltracks/); use line_tracks = finaltracks",
                path.display()
            ))
        })?;
    }
    Ok(())
}

fn limap_options(config: &ImportConfig, limap_dir: &Path) -> LimapDirOptions {
    LimapDirOptions {
        segments: config.limap_segments.as_ref().map(|p| limap_dir.join(p)),
        tracks_folder: config.limap_tracks.clone(),
        allow_legacy_tracks: false,
    }
}

/// Runs the import stage into `out` through the stage runner (see the module docs);
/// skipped when its record matches. The detector check builds SIFT itself; for a
/// SuperPoint front-end use [`run_with`].
pub fn run(
    config: &ImportConfig,
    frames_path: &Path,
    out: &Path,
) -> Result<Done<ImportOutput>, ImportError> {
    run_with(config, frames_path, out, &sift_only)
}

/// [`run`] with the builder of the detector check's front-end (`superpoint::front_end`
/// for either kind).
pub fn run_with(
    config: &ImportConfig,
    frames_path: &Path,
    out: &Path,
    make_front_end: MakeFrontEnd<'_>,
) -> Result<Done<ImportOutput>, ImportError> {
    config.validate()?;
    let (model_dir, limap_dir) = config.inputs()?;
    // The check's front-end is built from the configuration with its weights path; the
    // record hashes the weights' content instead of the path.
    let front_end = config.front_end.clone();
    let detects =
        config.detector_check != DetectorCheck::Off || config.point_labels == PointLabels::Detected;
    let weights = match (detects, front_end.kind) {
        (false, _) | (_, features::FrontEndKind::Sift) => None,
        (true, features::FrontEndKind::Superpoint) => front_end.superpoint.weights_path(),
    };
    let config = &config.settings();
    let frames_sha256 = stage::sha256_file(frames_path)?;
    let model_files = model_files(model_dir)?;
    // Reading LIMAP's folder fixes which segments and tracks folders are used (and
    // refuses an ambiguous one) before anything is hashed.
    let mut limap = LimapDir::open_unchecked(limap_dir, &limap_options(config, limap_dir))?;
    select_tracks(&mut limap, config.line_tracks)?;
    let mut inputs = limap_hashes(&limap)?;
    inputs.insert("frames".into(), frames_sha256.clone());
    if let Some(w) = &weights {
        inputs.insert("superpoint_weights".into(), stage::sha256_file(w)?);
    }
    inputs.insert(
        "model".into(),
        stage::sha256_files(model_dir, model_files.iter().map(String::as_str))?,
    );
    Stage::new(STAGE, out, config, inputs)?.run(
        |dir| {
            let path = dir.join(REPORT_FILE);
            let bytes = std::fs::read(&path).map_err(|source| ImportError::Io {
                path: path.clone(),
                source,
            })?;
            let report = serde_json::from_slice(&bytes).map_err(|e| ImportError::Io {
                path,
                source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
            })?;
            Ok(ImportOutput { report })
        },
        |outputs| {
            let frames = FramesTable::read_parquet(frames_path)?;
            let model = colmap::read(model_dir).map_err(|source| ImportError::Colmap {
                dir: model_dir.to_path_buf(),
                source,
            })?;
            let (mut tables, mut report) = build(config, &frames, &frames_sha256, &model, &limap)?;
            if config.detector_check != DetectorCheck::Off {
                let mut check = detectors::check(&front_end, make_front_end, &frames, &tables)?;
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
                    &front_end,
                    make_front_end,
                    &frames,
                    &mut tables,
                )?);
            }
            tables.write(outputs.dir())?;
            for f in [POINTS_FILE, LINES_FILE, POSES_FILE] {
                outputs.path(f);
            }
            let mut json = serde_json::to_vec_pretty(&report).map_err(|e| {
                ImportError::Config(format!("cannot encode the import report: {e}"))
            })?;
            json.push(b'\n');
            outputs.write(REPORT_FILE, &json)?;
            Ok(ImportOutput { report })
        },
    )
}
