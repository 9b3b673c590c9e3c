//! The ingest stage: reads a dataset in its published layout and writes the frames table
//! (ARCHITECTURE.md, "Data flow"; the steps are in [`crate::ingest`]).
//!
//! Stage folder layout: `frames.parquet` (see [`tables::frames`]), `depth/<stem>.depth.png`
//! (registered depth, `--depth raw` only) and `stage.json`. A rerun whose configuration
//! and input files (content hashes of every file read) match the record is skipped.

use crate::ingest::{IngestConfig, Planned, Result};
use fileio::io_err;
use stage::{Done, Stage, StageRecord};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use tables::frames::FramesTable;

pub const STAGE: &str = "ingest";
pub const FRAMES_FILE: &str = "frames.parquet";
pub const DEPTH_DIR: &str = "depth";

/// Result of [`run`].
#[derive(Debug)]
pub struct IngestOutput {
    pub table: FramesTable,
    pub frames_path: PathBuf,
}

impl stage::Note for IngestOutput {
    fn note(&self) -> String {
        format!(
            "{} frames ({} train, {} test)",
            self.table.frames.len(),
            self.table.count(tables::Split::Train),
            self.table.count(tables::Split::Test)
        )
    }
}

/// Runs the ingest stage into `out_dir` through the stage runner: skipped when
/// `out_dir/stage.json` matches the configuration and the content of every input file;
/// otherwise writes `depth/` (raw depth), `frames.parquet` and, last, `stage.json`.
pub fn run(config: &IngestConfig, out_dir: &Path) -> Result<Done<IngestOutput>> {
    // A file in the way is named as such, not as "File exists".
    stage::require_folder(out_dir)?;
    std::fs::create_dir_all(out_dir).map_err(io_err(out_dir))?;
    let out_dir = std::fs::canonicalize(out_dir).map_err(io_err(out_dir))?;
    let frames_path = out_dir.join(FRAMES_FILE);
    let planned = Planned::new(config)?;
    let stage = Stage::new(STAGE, &out_dir, planned.config(), planned.inputs().clone())?;
    // Registered depth of an earlier ingest run would linger: the maps its record names
    // are removed (anything else in the folder is left alone).
    let previous = stage.previous();
    // A table written before depth maps were hashed (tables/src/frames.rs) is written
    // again, whatever its record says: the refine stage refuses depth maps without
    // their hash.
    if previous.as_ref().is_some_and(|r| r.stage == STAGE)
        && FramesTable::read_parquet(&frames_path).is_ok_and(|t| {
            t.frames
                .iter()
                .any(|f| f.depth_path.is_some() && f.depth_hash.is_none())
        })
    {
        tracing::info!("ingest: rerunning (the frames table has no depth hashes)");
        drop(stage.begin()?);
    }
    stage.run(
        |_| {
            let table = FramesTable::read_parquet(&frames_path)?;
            Ok(IngestOutput {
                table,
                frames_path: frames_path.clone(),
            })
        },
        |out| {
            let depth_dir = out_dir.join(DEPTH_DIR);
            if let Some(r) = previous.filter(|r| r.stage == STAGE) {
                remove_recorded_depth(&out_dir, &depth_dir, &r)?;
            }
            let table = planned.build(Some(&depth_dir))?;
            table.write_parquet(&out.path(FRAMES_FILE))?;
            for f in &table.frames {
                if let Some(p) = &f.depth_path {
                    out.add(p)?;
                }
            }
            Ok(IngestOutput {
                table,
                frames_path: frames_path.clone(),
            })
        },
    )
}

/// Removes the depth maps an earlier run recorded under `depth_dir`, and the folders
/// they leave empty.
fn remove_recorded_depth(out_dir: &Path, depth_dir: &Path, record: &StageRecord) -> Result<()> {
    let prefix = format!("{DEPTH_DIR}/");
    let mut folders = BTreeSet::new();
    for rel in record.outputs.keys().filter(|k| k.starts_with(&prefix)) {
        let p = out_dir.join(rel);
        match std::fs::remove_file(&p) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err(&p)(e).into()),
        }
        folders.extend(
            p.ancestors()
                .skip(1)
                .take_while(|a| a.starts_with(depth_dir))
                .map(Path::to_path_buf),
        );
    }
    // Folders left empty go too, deepest first; one holding a file the stage did not
    // write stays (remove_dir refuses it).
    for folder in folders.iter().rev() {
        let _ = std::fs::remove_dir(folder);
    }
    Ok(())
}
