//! One split of a shard folder, opened the way the Rust trainer opens it: the manifest,
//! checked, then the split's shards through `shards::ShardReader`. No Python here, so
//! the crate's tests exercise it without an interpreter.

use shards::{FrameRecord, Manifest, ReaderOptions, ShardReader, Split};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// An error of opening or reading, with the shard file and frame it concerns where
/// there is one (the Python exception carries both as attributes).
#[derive(Debug)]
pub struct ReadError {
    pub message: String,
    pub shard: Option<PathBuf>,
    pub frame_id: Option<u64>,
}

impl ReadError {
    fn plain(message: impl Into<String>) -> Self {
        ReadError {
            message: message.into(),
            shard: None,
            frame_id: None,
        }
    }
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// How a split is opened.
#[derive(Clone, Debug)]
pub struct OpenOptions {
    /// Hash every shard of the split against the manifest before reading (and, where
    /// the shard stage's `stage.json` is there, the manifest against it).
    pub verify: bool,
    /// Decompressed chunks kept for out-of-order reads (`shards::ReaderOptions`).
    pub cache_bytes: u64,
}

/// The frames of one split of a shard folder.
pub struct SplitSet {
    pub dir: PathBuf,
    pub split: Split,
    pub manifest: Manifest,
    reader: ShardReader,
    /// Frame ids in reading order: shards in manifest order, frames by id.
    frame_ids: Vec<u64>,
    /// Frame id -> its shard file (for errors).
    shard_of: HashMap<u64, PathBuf>,
}

pub fn parse_split(name: &str) -> Result<Split, ReadError> {
    match name {
        "train" => Ok(Split::Train),
        "test" => Ok(Split::Test),
        other => Err(ReadError::plain(format!(
            "unknown split {other:?} (train or test)"
        ))),
    }
}

/// The manifest of `dir`: as the trainer checks it (`shards::checked_manifest`) where
/// the shard stage's record is there; else `manifest.json` alone, complete, and with
/// `verify` every listed shard of `split` hashed against it.
fn manifest_of(dir: &Path, split: Split, verify: bool) -> Result<Manifest, ReadError> {
    let from_shards = |e: shards::ShardError| ReadError::plain(e.to_string());
    if verify && dir.join(stage::RECORD_FILE).is_file() {
        return shards::checked_manifest(dir).map_err(from_shards);
    }
    let path = dir.join(shards::MANIFEST_FILE);
    let manifest = Manifest::load(&path).map_err(from_shards)?;
    if !manifest.is_complete() {
        return Err(ReadError::plain(format!(
            "{}: the manifest is incomplete (missing shard(s) {:?})",
            path.display(),
            manifest.missing_shards()
        )));
    }
    if verify {
        verify_hashes(dir, &manifest, split)?;
    }
    Ok(manifest)
}

/// Every shard of `split` has the sha256 the manifest lists (in parallel; the first
/// mismatch in manifest order is reported).
fn verify_hashes(dir: &Path, manifest: &Manifest, split: Split) -> Result<(), ReadError> {
    use rayon::prelude::*;
    let listed = shards::shards_of_split(manifest, split);
    let problems: Vec<Option<ReadError>> = listed
        .par_iter()
        .map(|s| {
            let file = dir.join(&s.file);
            match stage::sha256_file(&file) {
                Err(e) => Some(ReadError {
                    message: e.to_string(),
                    shard: Some(file),
                    frame_id: None,
                }),
                Ok(now) if now != s.sha256 => Some(ReadError {
                    message: format!(
                        "{}: sha256 {now}, but {} lists {} (the shard is damaged or not the \
                         one the manifest describes)",
                        file.display(),
                        shards::MANIFEST_FILE,
                        s.sha256
                    ),
                    shard: Some(file),
                    frame_id: None,
                }),
                Ok(_) => None,
            }
        })
        .collect();
    match problems.into_iter().flatten().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl SplitSet {
    pub fn open(dir: &Path, split: Split, options: &OpenOptions) -> Result<Self, ReadError> {
        let manifest = manifest_of(dir, split, options.verify)?;
        let paths: Vec<PathBuf> = shards::shards_of_split(&manifest, split)
            .iter()
            .map(|s| dir.join(&s.file))
            .collect();
        if paths.is_empty() {
            return Err(ReadError::plain(format!(
                "{}: no {split} shards in {}",
                dir.display(),
                shards::MANIFEST_FILE
            )));
        }
        let reader_options = ReaderOptions {
            cache_bytes: options.cache_bytes,
            ..ReaderOptions::default()
        };
        let reader = ShardReader::open_with(&paths, reader_options).map_err(|e| ReadError {
            message: e.to_string(),
            shard: None,
            frame_id: None,
        })?;
        let mut frame_ids = Vec::with_capacity(reader.frame_count());
        let mut shard_of = HashMap::with_capacity(reader.frame_count());
        for s in reader.shards() {
            for id in s.frame_ids() {
                frame_ids.push(id);
                shard_of.insert(id, s.path().to_path_buf());
            }
        }
        Ok(SplitSet {
            dir: dir.to_path_buf(),
            split,
            manifest,
            reader,
            frame_ids,
            shard_of,
        })
    }

    pub fn len(&self) -> usize {
        self.frame_ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frame_ids.is_empty()
    }

    pub fn frame_ids(&self) -> &[u64] {
        &self.frame_ids
    }

    /// The shard file holding `frame_id`.
    pub fn shard_of(&self, frame_id: u64) -> Option<&Path> {
        self.shard_of.get(&frame_id).map(PathBuf::as_path)
    }

    /// The frame at `index` of the reading order.
    pub fn read_index(&mut self, index: usize) -> Result<FrameRecord, ReadError> {
        let id = *self.frame_ids.get(index).ok_or_else(|| {
            ReadError::plain(format!(
                "index {index} is outside the {} frames of the {} split",
                self.frame_ids.len(),
                self.split
            ))
        })?;
        self.read_id(id)
    }

    /// The frame with id `frame_id`; an error names its shard and the frame.
    pub fn read_id(&mut self, frame_id: u64) -> Result<FrameRecord, ReadError> {
        let Some(shard) = self.shard_of.get(&frame_id).cloned() else {
            return Err(ReadError::plain(format!(
                "frame {frame_id} is not in the {} split of {}",
                self.split,
                self.dir.display()
            )));
        };
        self.reader.read_frame(frame_id).map_err(|e| ReadError {
            message: format!("{}: frame {frame_id}: {e}", shard.display()),
            shard: Some(shard),
            frame_id: Some(frame_id),
        })
    }
}
