//! What the refine stage reads, opened and hashed before the stage runner decides
//! whether to run: the frames table, the import's label tables and the depth maps of
//! the labelled training frames. The tables are taken only as their stages recorded
//! them (`stage::recorded_outputs`), and each depth map only while it is the file the
//! frames table hashed at ingest.

use super::error::RefineError;
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use tables::frames::{FRAMES_STAGE, FramesTable, Split};
use tables::labels::{LABEL_FILES, LABEL_STAGES, LabelTables};

/// The inputs of one refinement.
pub(crate) struct Inputs {
    /// The import's tables.
    pub(crate) labels: LabelTables,
    /// Frame id -> the depth map of each labelled training frame with depth.
    depth: BTreeMap<u32, Depth>,
    /// Of every depth map.
    pub(crate) units_per_metre: f64,
    /// Input name -> content hash: what the stage record compares.
    pub(crate) hashes: BTreeMap<String, String>,
}

impl Inputs {
    /// Reads the frames table and the label tables of `labels_dir` (made from that
    /// frames table), finds the depth maps and hashes everything.
    pub(crate) fn open(frames_path: &Path, labels_dir: &Path) -> Result<Inputs, RefineError> {
        let frames_sha256 = stage::recorded_file(frames_path, &[FRAMES_STAGE])?;
        let label_record = stage::recorded_outputs(labels_dir, &LABEL_STAGES, &LABEL_FILES)?;
        let frames = FramesTable::read_parquet(frames_path)?;
        let labels = LabelTables::read(labels_dir)?;
        labels.require_frames(frames_path, &frames_sha256)?;
        let depth = depth_maps(&frames, &labels, frames_path)?;
        let units_per_metre = frames
            .meta
            .depth_units_per_metre
            .ok_or(RefineError::NoDepthUnits)?;
        let mut hashes = BTreeMap::from([
            ("frames".to_string(), frames_sha256),
            ("depth".to_string(), depth_hash(&depth)?),
        ]);
        // Checked by `recorded_outputs`: the record lists each table with its hash now.
        for f in LABEL_FILES {
            hashes.insert(format!("labels/{f}"), label_record.outputs[f].clone());
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
            .map(|(id, d)| (*id, d.path.clone()))
            .collect()
    }
}

/// A labelled training frame's depth map and the hash the frames table has for it.
struct Depth {
    name: String,
    path: PathBuf,
    sha256: String,
}

/// The depth maps of the labelled frames, which must be training frames; refused when
/// none has one.
fn depth_maps(
    frames: &FramesTable,
    labels: &LabelTables,
    frames_path: &Path,
) -> Result<BTreeMap<u32, Depth>, RefineError> {
    let train: HashMap<u32, &tables::frames::Frame> = frames
        .frames
        .iter()
        .filter(|f| f.split == Split::Train)
        .map(|f| (f.id, f))
        .collect();
    let mut depth: BTreeMap<u32, Depth> = BTreeMap::new();
    for p in &labels.poses {
        let f = train.get(&p.frame_id).ok_or(RefineError::UnknownFrame {
            frame_id: p.frame_id,
        })?;
        if let Some(d) = &f.depth_path {
            let sha256 = f
                .depth_hash
                .clone()
                .ok_or_else(|| RefineError::DepthUnhashed {
                    frames: frames_path.to_path_buf(),
                    frame_id: f.id,
                    name: f.name.clone(),
                })?;
            depth.insert(
                p.frame_id,
                Depth {
                    name: f.name.clone(),
                    path: d.clone(),
                    sha256,
                },
            );
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
/// in frame order), hashed in parallel. Each file must still be the one ingested (its
/// hash in the frames table): the first that is not, in frame order, is refused.
fn depth_hash(maps: &BTreeMap<u32, Depth>) -> Result<String, RefineError> {
    let hashes: Vec<String> = maps
        .par_iter()
        .map(|(_, d)| stage::sha256_file(&d.path))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    for ((id, d), h) in maps.iter().zip(&hashes) {
        if *h != d.sha256 {
            return Err(RefineError::DepthChanged {
                path: d.path.clone(),
                frame_id: *id,
                name: d.name.clone(),
                expected: d.sha256.clone(),
                actual: h.clone(),
            });
        }
    }
    let mut all = String::new();
    for ((_, Depth { name, .. }), h) in maps.iter().zip(hashes) {
        all.push_str(name);
        all.push('\0');
        all.push_str(&h);
        all.push('\n');
    }
    Ok(stage::sha256_bytes(all.as_bytes()))
}
