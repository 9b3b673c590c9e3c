//! The ingest stage: reads a dataset in its published layout and writes the frames table
//! (DESIGN.md "Data flow"). One adapter per dataset converts its conventions once, here:
//! poses become world-to-camera, cameras COLMAP models, names dataset-relative paths.
//!
//! Stage folder layout: `frames.parquet` (see [`crate::frames`]), `depth/<stem>.depth.png`
//! (registered depth, `--depth raw` only) and `stage.json`. A rerun whose configuration
//! and input files (content hashes of every file read) match the record is skipped.
//!
//! Frame ids: frames sorted by split (train, then test), then by name in byte order,
//! numbered from 0.

mod build;
pub mod cambridge;
pub mod camera_spec;
mod config;
pub mod depth;
mod error;
pub mod nvm;
mod plan;
pub mod sevenscenes;
mod text;

pub use config::{DatasetKind, DepthOption, IngestConfig, PoseOption};
pub use error::{FrameCountError, IngestError, Result};

use crate::frames::FramesTable;
use stage::{RecordCheck, StageRecord};
use std::path::{Path, PathBuf};

pub const STAGE: &str = "ingest";
pub const FRAMES_FILE: &str = "frames.parquet";
pub const DEPTH_DIR: &str = "depth";
/// The stage record file (stage crate convention).
const RECORD_FILE: &str = "stage.json";

/// Result of [`run`].
#[derive(Debug)]
pub struct IngestOutput {
    pub table: FramesTable,
    /// True when the stage record matched and nothing was recomputed.
    pub skipped: bool,
    pub frames_path: PathBuf,
}

/// Runs the ingest stage into `out_dir`: skipped when `out_dir/stage.json` matches the
/// configuration and the content of every input file; otherwise writes `depth/` (raw
/// depth), `frames.parquet` and, last, `stage.json`.
pub fn run(config: &IngestConfig, out_dir: &Path) -> Result<IngestOutput> {
    std::fs::create_dir_all(out_dir).map_err(error::io_err(out_dir))?;
    let out_dir = std::fs::canonicalize(out_dir).map_err(error::io_err(out_dir))?;
    let frames_path = out_dir.join(FRAMES_FILE);
    let plan = plan::plan(config)?;
    let hashes = build::hash_inputs(&plan)?;
    let config_hash = stage::hash_config(&plan.normalised_config)?;
    // An unreadable record (a crash of another tool, a hand edit) only means "rerun".
    let previous = StageRecord::load(&out_dir).ok().flatten();
    let check = match StageRecord::check(&out_dir, STAGE, &config_hash, &hashes.inputs) {
        Err(stage::StageError::Record { path, source }) => {
            RecordCheck::Changed(format!("unreadable record {}: {source}", path.display()))
        }
        other => other?,
    };
    match check {
        RecordCheck::UpToDate => {
            tracing::info!("ingest: {} is up to date, skipped", out_dir.display());
            let table = FramesTable::read_parquet(&frames_path)?;
            return Ok(IngestOutput {
                table,
                skipped: true,
                frames_path,
            });
        }
        RecordCheck::Missing => {}
        RecordCheck::Changed(why) => tracing::info!("ingest: rerunning ({why})"),
    }
    // From here on the folder holds no valid record until the new one is saved.
    remove_if_exists(&out_dir.join(RECORD_FILE))?;
    let depth_dir = out_dir.join(DEPTH_DIR);
    // Registered depth of an earlier ingest run would linger; only a folder this stage
    // wrote (its record says so) is removed.
    if previous.is_some_and(|r| r.stage == STAGE) && depth_dir.is_dir() {
        std::fs::remove_dir_all(&depth_dir).map_err(error::io_err(&depth_dir))?;
    }
    let table = build::build(&plan, &hashes, Some(&depth_dir))?;
    table.write_parquet(&frames_path)?;
    let mut record = StageRecord::new(STAGE, config_hash, hashes.inputs);
    record.add_output(&out_dir, FRAMES_FILE)?;
    for f in &table.frames {
        if let Some(rel) = f
            .depth_path
            .as_deref()
            .and_then(|p| p.strip_prefix(&out_dir).ok())
            .and_then(Path::to_str)
        {
            record.add_output(&out_dir, rel)?;
        }
    }
    record.save(&out_dir)?;
    Ok(IngestOutput {
        table,
        skipped: false,
        frames_path,
    })
}

/// Reads a dataset into a frames table without a stage folder. `depth_out` is where
/// registered depth goes (required with `depth = raw`).
pub fn read_dataset(config: &IngestConfig, depth_out: Option<&Path>) -> Result<FramesTable> {
    let plan = plan::plan(config)?;
    let hashes = build::hash_inputs(&plan)?;
    build::build(&plan, &hashes, depth_out)
}

fn remove_if_exists(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(error::io_err(path)(e)),
        _ => Ok(()),
    }
}
