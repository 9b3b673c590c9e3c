//! The import stage: COLMAP model + LIMAP folder + frames table -> label tables.
//!
//! Per training frame (specs/pl2map.md section 3):
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
//! Stage folder: `points.parquet`, `lines.parquet`, `poses.parquet` ([`crate::tables`]),
//! `import_report.json`, `stage.json`. A rerun with the same configuration and inputs
//! (content hashes of the frames table, of the model's files and of the LIMAP files
//! read) is skipped.

mod build;
mod problems;
mod report;

pub use build::build;
pub use problems::{EXAMPLES_PER_KIND, ImportProblem, summarize};
pub use report::{
    ImportReport, LimapCounts, LineCounts, ModelCounts, PointCounts, PoseDisagreement,
};

use crate::names::NameMapping;
use crate::parquet::TableError;
use crate::tables::{LINES_FILE, POINTS_FILE, POSES_FILE, PoseSource};
use datasets::frames::{FramesError, FramesTable};
use limap::{LimapDir, LimapDirOptions};
use serde::{Deserialize, Serialize};
use stage::{RecordCheck, StageRecord};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

pub const STAGE: &str = "import";
pub const REPORT_FILE: &str = "import_report.json";

/// What the import does; hashed into the stage record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImportConfig {
    /// COLMAP image name -> frames table name.
    pub model_names: NameMapping,
    /// LIMAP image_list.txt name -> frames table name.
    pub limap_names: NameMapping,
    pub pose_source: PoseSource,
    /// Test frames found in the model or in LIMAP are skipped (true) or refused (false,
    /// the default: labels made with test images leak them into training).
    pub allow_test_images: bool,
    /// LIMAP segment coordinates times this are pixels of the image (LIMAP detects on
    /// images resized to `max_image_dim`, 1600 by default: for a 1920-wide image the
    /// scale is 1920 / 1600 = 1.2).
    pub segment_scale: f64,
    /// How far outside the image (pixels) a keypoint or segment endpoint may lie before
    /// the input is refused (it would mean another resolution or camera).
    pub bounds_tolerance_px: f64,
    /// The LIMAP segments folder, relative to the LIMAP folder; None: the only one of
    /// `line_detections/*/segments` and `segments`.
    pub limap_segments: Option<PathBuf>,
    /// The LIMAP track folder, relative to the LIMAP folder; None: `finaltracks`.
    pub limap_tracks: Option<PathBuf>,
}

impl Default for ImportConfig {
    fn default() -> Self {
        ImportConfig {
            model_names: NameMapping::identity(),
            limap_names: NameMapping::identity(),
            pose_source: PoseSource::Sfm,
            allow_test_images: false,
            segment_scale: 1.0,
            bounds_tolerance_px: 1.0,
            limap_segments: None,
            limap_tracks: None,
        }
    }
}

impl ImportConfig {
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
        Ok(())
    }
}

#[derive(Debug, Error)]
pub enum ImportError {
    #[error("frames table: {0}")]
    Frames(#[from] FramesError),
    #[error("COLMAP model {}: {source}", dir.display())]
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
    /// The record matched: nothing was recomputed.
    pub skipped: bool,
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

fn sorted_files(dir: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<String>, ImportError> {
    let io = |source| ImportError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if keep(&name) && entry.path().is_file() {
            out.push(name);
        }
    }
    out.sort();
    Ok(out)
}

/// Content hashes of every LIMAP file the import reads.
fn limap_hashes(dir: &LimapDir) -> Result<BTreeMap<String, String>, ImportError> {
    let mut top = vec![limap::dir::IMAGE_LIST_FILE.to_string()];
    if dir.root.join(limap::dir::ALLTRACKS_FILE).is_file() {
        top.push(limap::dir::ALLTRACKS_FILE.to_string());
    }
    let segs = sorted_files(&dir.segments_dir, |n| {
        n.starts_with("segments_") && n.ends_with(".txt")
    })?;
    let tracks = sorted_files(&dir.tracks_dir, |n| {
        n.starts_with("track") && n.ends_with(".txt")
    })?;
    Ok(BTreeMap::from([
        (
            "limap".to_string(),
            stage::sha256_files(&dir.root, top.iter().map(String::as_str))?,
        ),
        (
            "limap_segments".to_string(),
            stage::sha256_files(&dir.segments_dir, segs.iter().map(String::as_str))?,
        ),
        (
            "limap_tracks".to_string(),
            stage::sha256_files(&dir.tracks_dir, tracks.iter().map(String::as_str))?,
        ),
    ]))
}

fn limap_options(config: &ImportConfig, limap_dir: &Path) -> LimapDirOptions {
    LimapDirOptions {
        segments: config.limap_segments.as_ref().map(|p| limap_dir.join(p)),
        tracks_folder: config.limap_tracks.clone(),
        allow_legacy_tracks: false,
    }
}

/// Runs the import stage into `out` (see the module docs); skipped when its record
/// matches.
pub fn run(
    config: &ImportConfig,
    frames_path: &Path,
    model_dir: &Path,
    limap_dir: &Path,
    out: &Path,
) -> Result<ImportOutput, ImportError> {
    config.validate()?;
    let frames_sha256 = stage::sha256_file(frames_path)?;
    let model_files = model_files(model_dir)?;
    // Reading LIMAP's folder fixes which segments and tracks folders are used (and
    // refuses an ambiguous one) before anything is hashed.
    let limap = LimapDir::open_unchecked(limap_dir, &limap_options(config, limap_dir))?;
    let mut inputs = limap_hashes(&limap)?;
    inputs.insert("frames".into(), frames_sha256.clone());
    inputs.insert(
        "model".into(),
        stage::sha256_files(model_dir, model_files.iter().map(String::as_str))?,
    );
    let config_hash = stage::hash_config(config)?;
    if StageRecord::check(out, STAGE, &config_hash, &inputs)? == RecordCheck::UpToDate {
        let path = out.join(REPORT_FILE);
        let bytes = std::fs::read(&path).map_err(|source| ImportError::Io {
            path: path.clone(),
            source,
        })?;
        let report = serde_json::from_slice(&bytes).map_err(|e| ImportError::Io {
            path,
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        })?;
        return Ok(ImportOutput {
            report,
            skipped: true,
        });
    }

    let frames = FramesTable::read_parquet(frames_path)?;
    let model = colmap::read(model_dir).map_err(|source| ImportError::Colmap {
        dir: model_dir.to_path_buf(),
        source,
    })?;
    let (tables, report) = build(config, &frames, &frames_sha256, &model, &limap)?;

    std::fs::create_dir_all(out).map_err(|source| ImportError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    // The old record goes first: from here until the new one is written, the folder
    // does not claim to be complete.
    remove_record(out)?;
    tables.write(out)?;
    let mut json = serde_json::to_vec_pretty(&report)
        .map_err(|e| ImportError::Config(format!("cannot encode the import report: {e}")))?;
    json.push(b'\n');
    stage::write_atomic(out.join(REPORT_FILE), &json)?;
    let mut record = StageRecord::new(STAGE, config_hash, inputs);
    for f in [POINTS_FILE, LINES_FILE, POSES_FILE, REPORT_FILE] {
        record.add_output(out, f)?;
    }
    record.save(out)?;
    Ok(ImportOutput {
        report,
        skipped: false,
    })
}

pub(crate) fn remove_record(dir: &Path) -> Result<(), stage::StageError> {
    let path = dir.join("stage.json");
    match std::fs::remove_file(&path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(stage::StageError::Io { path, source }),
    }
}
