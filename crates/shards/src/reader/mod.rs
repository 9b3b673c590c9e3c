//! Streaming, seekable reader of shards for the trainer.
//!
//! A shard is memory-mapped; opening it reads only the footer, the summary (schemas,
//! channels, chunk indexes, statistics) and the per-chunk message index records of
//! `/labels` and `/camera/image`, which give every frame's chunk and offset inside
//! the decompressed chunk. Reading a frame decompresses its chunk once (checking the
//! chunk's CRC) and slices the two messages out; the Foxglove visualisation channels
//! are never decoded. A record's image is a view of the decompressed chunk (no copy),
//! so a record kept alive keeps its chunk (4 MiB by default) in memory. Seeking is a
//! table look-up: no chunk before the frame's is read.
//!
//! Every offset and length read from a file is checked against the bytes there
//! before use; a bad shard gives a [`ShardError`] naming the file and the place.
//!
//! This file holds the reader of several shards ([`ShardReader`]: frame order, seeking,
//! the chunk cache, decoding a frame); one shard's index and chunks are
//! `shard_file.rs` ([`ShardFile`]), the checked reading of the MCAP framing it
//! rests on (records, footer, summary, chunk indexes) is `framing.rs`, and the limits
//! all three apply ([`ReaderOptions`]) are `options.rs`.

mod framing;
mod options;
mod shard_file;

pub use options::ReaderOptions;
pub use shard_file::ShardFile;

use crate::error::ShardError;
use crate::record::{FrameRecord, ImageFormat};
use crate::schema::{from_proto, proto};
use crate::writer::{TOPIC_IMAGE, TOPIC_LABELS};
use bytes::Bytes;
use prost::Message as _;
use std::collections::HashMap;
use std::path::Path;

/// A decompressed chunk kept for the next frames.
struct CachedChunk {
    shard: usize,
    chunk: usize,
    /// Shared with the records whose images are slices of it.
    data: Bytes,
}

/// Frames of several shards, in order: the shards in the order given, the frames of
/// a shard by increasing frame id (= log time). An iterator of
/// `Result<FrameRecord, ShardError>`; [`ShardReader::seek`] moves it to a frame.
pub struct ShardReader {
    shards: Vec<ShardFile>,
    /// frame id -> (shard, position in its frame table).
    by_id: HashMap<u64, (usize, usize)>,
    cursor: (usize, usize),
    /// Recently used chunks, most recent last (see [`ReaderOptions::cache_bytes`]).
    cache: Vec<CachedChunk>,
    decompressed: u64,
    options: ReaderOptions,
}

impl std::fmt::Debug for ShardReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShardReader")
            .field("shards", &self.shards)
            .field("cursor", &self.cursor)
            .finish()
    }
}

impl ShardReader {
    /// Opens `paths` (any subset of a run's shards, in the order to read them).
    pub fn open<P: AsRef<Path>>(paths: impl IntoIterator<Item = P>) -> Result<Self, ShardError> {
        Self::open_with(paths, ReaderOptions::default())
    }

    pub fn open_with<P: AsRef<Path>>(
        paths: impl IntoIterator<Item = P>,
        options: ReaderOptions,
    ) -> Result<Self, ShardError> {
        let shards = paths
            .into_iter()
            .map(|p| ShardFile::open_with(p, &options))
            .collect::<Result<Vec<_>, _>>()?;
        let mut by_id = HashMap::new();
        for (si, s) in shards.iter().enumerate() {
            for (fi, id) in s.frame_ids().enumerate() {
                if let Some((other, _)) = by_id.insert(id, (si, fi)) {
                    return Err(ShardError::DuplicateFrame {
                        frame_id: id,
                        first: shards[other].path.clone(),
                        second: s.path.clone(),
                    });
                }
            }
        }
        Ok(ShardReader {
            shards,
            by_id,
            cursor: (0, 0),
            cache: Vec::with_capacity(2),
            decompressed: 0,
            options,
        })
    }

    pub fn shards(&self) -> &[ShardFile] {
        &self.shards
    }

    /// Number of frames in all open shards.
    pub fn frame_count(&self) -> usize {
        self.by_id.len()
    }

    /// Every frame id, in reading order.
    pub fn frame_ids(&self) -> impl Iterator<Item = u64> + '_ {
        self.shards.iter().flat_map(|s| s.frame_ids())
    }

    pub fn contains(&self, frame_id: u64) -> bool {
        self.by_id.contains_key(&frame_id)
    }

    /// Makes `frame_id` the next frame the iterator yields.
    pub fn seek(&mut self, frame_id: u64) -> Result<(), ShardError> {
        self.cursor = *self
            .by_id
            .get(&frame_id)
            .ok_or(ShardError::FrameNotFound { frame_id })?;
        Ok(())
    }

    /// Back to the first frame.
    pub fn rewind(&mut self) {
        self.cursor = (0, 0);
    }

    /// Reads one frame without moving the iterator.
    pub fn read_frame(&mut self, frame_id: u64) -> Result<FrameRecord, ShardError> {
        let (si, fi) = *self
            .by_id
            .get(&frame_id)
            .ok_or(ShardError::FrameNotFound { frame_id })?;
        self.decode(si, fi)
    }

    fn chunk(&mut self, shard: usize, chunk: usize) -> Result<Bytes, ShardError> {
        if let Some(i) = self
            .cache
            .iter()
            .position(|c| c.shard == shard && c.chunk == chunk)
        {
            let hit = self.cache.remove(i);
            let data = hit.data.clone();
            self.cache.push(hit);
            return Ok(data);
        }
        let data = Bytes::from(self.shards[shard].decompress_chunk(chunk, &self.options)?);
        self.decompressed += 1;
        self.cache.push(CachedChunk {
            shard,
            chunk,
            data: data.clone(),
        });
        let mut held: u64 = self.cache.iter().map(|c| c.data.len() as u64).sum();
        while self.cache.len() > 2 && held > self.options.cache_bytes {
            held -= self.cache.remove(0).data.len() as u64;
        }
        Ok(data)
    }

    /// Chunks decompressed so far (each counted once per decompression).
    pub fn chunks_decompressed(&self) -> u64 {
        self.decompressed
    }

    fn decode(&mut self, si: usize, fi: usize) -> Result<FrameRecord, ShardError> {
        let loc = self.shards[si].frames[fi];
        let image_chunk = self.chunk(si, loc.image.chunk)?;
        let labels_chunk = self.chunk(si, loc.labels.chunk)?;
        let shard = &self.shards[si];
        let decode_err = |topic: &str, chunk: usize, reason: String| ShardError::Decode {
            path: shard.path.clone(),
            frame_id: loc.frame_id,
            topic: topic.into(),
            chunk_offset: shard.chunks[chunk].chunk_start_offset,
            reason,
        };

        let raw = shard.message(&image_chunk, loc.image, shard.image_channel, loc.log_time)?;
        // Decoded from a `Bytes` view of the chunk, prost slices the image's bytes out of
        // it instead of copying them (half the trainer's reader thread's time was that
        // copy); the record then holds the chunk until it is dropped.
        let image = foxglove::messages::CompressedImage::decode(image_chunk.slice_ref(raw))
            .map_err(|e| decode_err(TOPIC_IMAGE, loc.image.chunk, e.to_string()))?;
        let format = ImageFormat::from_name(&image.format).ok_or_else(|| {
            decode_err(
                TOPIC_IMAGE,
                loc.image.chunk,
                format!("unsupported image format {:?}", image.format),
            )
        })?;

        let raw = shard.message(
            &labels_chunk,
            loc.labels,
            shard.labels_channel,
            loc.log_time,
        )?;
        let labels = proto::FrameLabels::decode(raw)
            .map_err(|e| decode_err(TOPIC_LABELS, loc.labels.chunk, e.to_string()))?;
        if labels.frame_id != loc.frame_id {
            return Err(decode_err(
                TOPIC_LABELS,
                loc.labels.chunk,
                format!(
                    "labels say frame {}, the log time says {}",
                    labels.frame_id, loc.frame_id
                ),
            ));
        }
        let frame = from_proto(labels, image.data, format)
            .map_err(|r| decode_err(TOPIC_LABELS, loc.labels.chunk, r))?;
        frame
            .validate()
            .map_err(|e| decode_err(TOPIC_LABELS, loc.labels.chunk, e.to_string()))?;
        Ok(frame)
    }
}

impl Iterator for ShardReader {
    type Item = Result<FrameRecord, ShardError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (mut si, mut fi) = self.cursor;
        while si < self.shards.len() && fi >= self.shards[si].frames.len() {
            si += 1;
            fi = 0;
        }
        if si >= self.shards.len() {
            self.cursor = (si, 0);
            return None;
        }
        // Move past the frame even when it fails to decode, so a caller may skip it.
        self.cursor = (si, fi + 1);
        Some(self.decode(si, fi))
    }
}
