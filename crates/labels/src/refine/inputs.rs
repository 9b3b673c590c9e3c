//! What the refine stage reads, opened and hashed before the stage runner decides
//! whether to run: the frames table, the import's label tables and the depth maps of
//! the labelled training frames.

use super::error::RefineError;
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use tables::frames::{FramesTable, Split};
use tables::labels::{LINES_FILE, LabelTables, POINTS_FILE, POSES_FILE};

/// The inputs of one refinement.
pub(crate) struct Inputs {
    /// The import's tables.
    pub(crate) labels: LabelTables,
    /// Frame id -> (name, depth map) of the labelled training frames with depth.
    depth: BTreeMap<u32, (String, PathBuf)>,
    /// Of every depth map.
    pub(crate) units_per_metre: f64,
    /// Input name -> content hash: what the stage record compares.
    pub(crate) hashes: BTreeMap<String, String>,
}

impl Inputs {
    /// Reads the frames table and the label tables of `labels_dir` (made from that
    /// frames table), finds the depth maps and hashes everything.
    pub(crate) fn open(frames_path: &Path, labels_dir: &Path) -> Result<Inputs, RefineError> {
        let frames_sha256 = stage::sha256_file(frames_path)?;
        let frames = FramesTable::read_parquet(frames_path)?;
        let labels = LabelTables::read(labels_dir)?;
        labels.require_frames(frames_path, &frames_sha256)?;
        let depth = depth_maps(&frames, &labels)?;
        let units_per_metre = frames
            .meta
            .depth_units_per_metre
            .ok_or(RefineError::NoDepthUnits)?;
        let mut hashes = BTreeMap::from([
            ("frames".to_string(), frames_sha256),
            ("depth".to_string(), depth_hash(&depth)?),
        ]);
        for f in [POINTS_FILE, LINES_FILE, POSES_FILE] {
            hashes.insert(
                format!("labels/{f}"),
                stage::sha256_file(&labels_dir.join(f))?,
            );
        }
        Ok(Inputs {
            labels,
            depth,
            units_per_metre,
            hashes,
        })
    }

    /// Frame id -> depth map.
    pub(crate) fn depth_paths(&self) -> HashMap<u32, PathBuf> {
        self.depth
            .iter()
            .map(|(id, (_, p))| (*id, p.clone()))
            .collect()
    }
}

/// The depth maps of the labelled frames, which must be training frames; refused when
/// none has one.
fn depth_maps(
    frames: &FramesTable,
    labels: &LabelTables,
) -> Result<BTreeMap<u32, (String, PathBuf)>, RefineError> {
    let train: HashMap<u32, &tables::frames::Frame> = frames
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .map(|f| (f.id, f))
        .collect();
    let mut depth: BTreeMap<u32, (String, PathBuf)> = BTreeMap::new();
    for p in &labels.poses {
        let f = train.get(&p.frame_id).ok_or(RefineError::UnknownFrame {
            frame_id: p.frame_id,
        })?;
        if let Some(d) = &f.depth_path {
            depth.insert(p.frame_id, (f.name.clone(), d.clone()));
        }
    }
    if depth.is_empty() {
        return Err(RefineError::NoDepth {
            depth_source: frames.meta.depth_source.clone(),
        });
    }
    Ok(depth)
}

/// Content hash of the depth maps of the given frames (name and file hash per frame,
/// in frame order), hashed in parallel.
fn depth_hash(paths: &BTreeMap<u32, (String, PathBuf)>) -> Result<String, RefineError> {
    let hashes: Vec<String> = paths
        .par_iter()
        .map(|(_, (_, p))| stage::sha256_file(p))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    let mut all = String::new();
    for ((_, (name, _)), h) in paths.iter().zip(hashes) {
        all.push_str(name);
        all.push('\0');
        all.push_str(&h);
        all.push('\n');
    }
    Ok(stage::sha256_bytes(all.as_bytes()))
}
