//! What the import stage reads, opened and hashed before the stage runner decides
//! whether to run: the frames table, the COLMAP model's files, the LIMAP files of the
//! chosen segments and tracks, and the SuperPoint weights the detector check uses.

use super::config::{ImportConfig, LineTrackSet};
use super::detected::PointLabels;
use super::detectors::DetectorCheck;
use super::error::ImportError;
use limap::{LimapDir, LimapDirOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The inputs of one import.
pub(crate) struct Inputs<'a> {
    pub(crate) model_dir: &'a Path,
    /// Opened (its segments and tracks folders chosen, an ambiguous one refused) with the
    /// configured track set selected.
    pub(crate) limap: LimapDir,
    pub(crate) frames_sha256: String,
    /// Input name -> content hash: what the stage record compares.
    pub(crate) hashes: BTreeMap<String, String>,
}

impl<'a> Inputs<'a> {
    /// Opens and hashes the inputs of `config` (with its input folders).
    pub(crate) fn open(config: &'a ImportConfig, frames_path: &Path) -> Result<Self, ImportError> {
        let (model_dir, limap_dir) = config.inputs()?;
        let weights = superpoint_weights(config);
        // Only the ingest stage's recorded table (crates/stage/src/record.rs,
        // `recorded_file`): a refused or killed ingest leaves none to read.
        let frames_sha256 = stage::recorded_file(frames_path, &[tables::frames::FRAMES_STAGE])?;
        let model_files = model_files(model_dir)?;
        // Reading LIMAP's folder fixes which segments and tracks folders are used (and
        // refuses an ambiguous one) before anything is hashed.
        let mut limap = LimapDir::open_unchecked(limap_dir, &limap_options(config, limap_dir))?;
        select_tracks(&mut limap, config.line_tracks)?;
        let mut hashes = limap_hashes(&limap)?;
        hashes.insert("frames".into(), frames_sha256.clone());
        if let Some(w) = &weights {
            hashes.insert("superpoint_weights".into(), stage::sha256_file(w)?);
        }
        hashes.insert(
            "model".into(),
            stage::sha256_files(model_dir, model_files.iter().map(String::as_str))?,
        );
        Ok(Inputs {
            model_dir,
            limap,
            frames_sha256,
            hashes,
        })
    }
}

/// The SuperPoint weights file when the import detects with SuperPoint: the record
/// hashes its content instead of its path.
fn superpoint_weights(config: &ImportConfig) -> Option<PathBuf> {
    let detects =
        config.detector_check != DetectorCheck::Off || config.point_labels == PointLabels::Detected;
    match (detects, config.front_end.kind) {
        (false, _) | (_, features::FrontEndKind::Sift) => None,
        (true, features::FrontEndKind::Superpoint) => config.front_end.superpoint.weights_path(),
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
