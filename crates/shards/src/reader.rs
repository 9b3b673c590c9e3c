//! Streaming, seekable reader of shards for the trainer.
//!
//! A shard is memory-mapped; opening it reads only the footer, the summary (schemas,
//! channels, chunk indexes, statistics) and the per-chunk message index records of
//! `/labels` and `/camera/image`, which give every frame's chunk and offset inside
//! the decompressed chunk. Reading a frame decompresses its chunk once (checking the
//! chunk's CRC) and slices the two messages out; the Foxglove visualisation channels
//! are never decoded. Seeking is a table look-up: no chunk before the frame's is read.
//!
//! Every offset and length read from a file is checked against the bytes there
//! before use; a bad shard gives a [`ShardError`] naming the file and the place.

use crate::error::{ShardError, io_err};
use crate::record::{FrameRecord, ImageFormat};
use crate::schema::{FRAME_LABELS_SCHEMA_NAME, from_proto, proto};
use crate::writer::{TOPIC_IMAGE, TOPIC_LABELS, frame_id_of_log_time};
use mcap::records::{ChunkIndex, Record, op};
use memmap2::Mmap;
use prost::Message as _;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const MAGIC_LEN: u64 = 8;
/// Footer record: opcode, length, summary_start, summary_offset_start, summary_crc.
const FOOTER_RECORD_LEN: u64 = 1 + 8 + 8 + 8 + 4;
/// opcode + record length.
const RECORD_PREFIX: u64 = 9;
/// Record opcodes that may appear in a summary section.
const SUMMARY_OPCODES: [u8; 7] = [
    op::SCHEMA,
    op::CHANNEL,
    op::CHUNK_INDEX,
    op::ATTACHMENT_INDEX,
    op::STATISTICS,
    op::METADATA_INDEX,
    op::SUMMARY_OFFSET,
];

/// Limits and checks of the reader.
#[derive(Clone, Debug)]
pub struct ReaderOptions {
    /// Largest decompressed chunk accepted (the size comes from the file, so it is
    /// bounded before allocating).
    pub max_chunk_bytes: u64,
    /// Check each chunk's CRC32 after decompressing it.
    pub verify_chunk_crc: bool,
    /// Decompressed chunks a [`ShardReader`] keeps, least recently used out first, up
    /// to this many bytes (the two most recent are always kept: a frame's image and
    /// labels may straddle a chunk boundary). A sequential read needs no more; random
    /// access in a window (a training stream's shuffle buffer) decompresses each chunk
    /// of the window once instead of once per frame.
    pub cache_bytes: u64,
}

impl Default for ReaderOptions {
    fn default() -> Self {
        ReaderOptions {
            max_chunk_bytes: 1 << 30,
            verify_chunk_crc: true,
            cache_bytes: 0,
        }
    }
}

/// Where a message is: which chunk, and the offset of its record in the
/// decompressed chunk.
#[derive(Clone, Copy, Debug)]
struct MsgLoc {
    chunk: usize,
    offset: u64,
}

#[derive(Clone, Copy, Debug)]
struct FrameLoc {
    frame_id: u64,
    log_time: u64,
    labels: MsgLoc,
    image: MsgLoc,
}

/// One open shard: its map, chunk indexes and frame table.
pub struct ShardFile {
    path: PathBuf,
    mmap: Mmap,
    chunks: Vec<ChunkIndex>,
    frames: Vec<FrameLoc>,
    labels_channel: u16,
    image_channel: u16,
    topics: BTreeMap<u16, String>,
    channel_message_counts: BTreeMap<u16, u64>,
}

impl std::fmt::Debug for ShardFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShardFile")
            .field("path", &self.path)
            .field("chunks", &self.chunks.len())
            .field("frames", &self.frames.len())
            .finish()
    }
}

impl ShardFile {
    pub fn open(path: impl AsRef<Path>) -> Result<Self, ShardError> {
        Self::open_with(path, &ReaderOptions::default())
    }

    pub fn open_with(path: impl AsRef<Path>, options: &ReaderOptions) -> Result<Self, ShardError> {
        let path = path.as_ref().to_path_buf();
        let file = std::fs::File::open(&path).map_err(io_err(&path))?;
        // SAFETY: shards are written to a temp file and renamed into place, never
        // modified afterwards; a file changed under the map by another process is
        // outside what this reader supports (as for any mmap reader).
        let mmap = unsafe { Mmap::map(&file) }.map_err(io_err(&path))?;
        let summary = read_summary(&path, &mmap)?;
        let chunks = check_chunk_indexes(&path, &summary, options)?;

        let channel_for = |topic: &str, schema: &str| -> Result<u16, ShardError> {
            let bad = |reason: String| ShardError::Channel {
                path: path.clone(),
                topic: topic.into(),
                reason,
            };
            let mut found = summary.channels.values().filter(|c| c.topic == topic);
            let ch = found
                .next()
                .ok_or_else(|| bad("not in the summary".into()))?;
            if found.next().is_some() {
                return Err(bad("appears on two channels".into()));
            }
            let s = ch
                .schema
                .as_ref()
                .ok_or_else(|| bad("has no schema".into()))?;
            if s.name != schema || s.encoding != "protobuf" || ch.message_encoding != "protobuf" {
                return Err(bad(format!(
                    "expected schema {schema} (protobuf), found {} ({}), messages {}",
                    s.name, s.encoding, ch.message_encoding
                )));
            }
            Ok(ch.id)
        };
        let labels_channel = channel_for(TOPIC_LABELS, FRAME_LABELS_SCHEMA_NAME)?;
        let image_channel = channel_for(TOPIC_IMAGE, "foxglove.CompressedImage")?;
        let topics = summary
            .channels
            .iter()
            .map(|(id, c)| (*id, c.topic.clone()))
            .collect();
        let channel_message_counts = summary
            .stats
            .as_ref()
            .map(|s| s.channel_message_counts.clone())
            .unwrap_or_default();

        let mut shard = ShardFile {
            path,
            mmap,
            chunks,
            frames: Vec::new(),
            labels_channel,
            image_channel,
            topics,
            channel_message_counts,
        };
        shard.frames = shard.frame_table()?;
        Ok(shard)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Frame ids in the shard, increasing.
    pub fn frame_ids(&self) -> impl ExactSizeIterator<Item = u64> + '_ {
        self.frames.iter().map(|f| f.frame_id)
    }

    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    pub fn chunk_count(&self) -> usize {
        self.chunks.len()
    }

    /// Messages per topic, from the summary's statistics record.
    pub fn channel_message_counts(&self) -> BTreeMap<String, u64> {
        self.topics
            .iter()
            .map(|(id, topic)| {
                let n = self.channel_message_counts.get(id).copied().unwrap_or(0);
                (topic.clone(), n)
            })
            .collect()
    }

    fn bad_index(&self, offset: u64, reason: impl Into<String>) -> ShardError {
        ShardError::BadIndex {
            path: self.path.clone(),
            offset,
            reason: reason.into(),
        }
    }

    /// Reads the message index records of the labels and image channels (they sit
    /// in the data section after each chunk; the chunk index gives their offsets) and
    /// pairs them by log time into the frame table.
    fn frame_table(&self) -> Result<Vec<FrameLoc>, ShardError> {
        let mut labels: BTreeMap<u64, MsgLoc> = BTreeMap::new();
        let mut images: BTreeMap<u64, MsgLoc> = BTreeMap::new();
        for (ci, chunk) in self.chunks.iter().enumerate() {
            for (channel, table) in [
                (self.labels_channel, &mut labels),
                (self.image_channel, &mut images),
            ] {
                let Some(&offset) = chunk.message_index_offsets.get(&channel) else {
                    continue;
                };
                let (opcode, body) = record_at(&self.mmap, offset)
                    .map_err(|reason| self.bad_index(offset, format!("message index: {reason}")))?;
                if opcode != op::MESSAGE_INDEX {
                    return Err(self.bad_index(
                        offset,
                        format!("expected a message index record (opcode 0x07), found opcode {opcode:#04x}"),
                    ));
                }
                let index = match mcap::parse_record(opcode, body) {
                    Ok(Record::MessageIndex(i)) => i,
                    Ok(_) => return Err(self.bad_index(offset, "not a message index")),
                    Err(e) => return Err(self.bad_index(offset, format!("message index: {e}"))),
                };
                if index.channel_id != channel {
                    return Err(self.bad_index(
                        offset,
                        format!(
                            "message index is for channel {}, the chunk index says {channel}",
                            index.channel_id
                        ),
                    ));
                }
                for e in index.records {
                    if e.offset >= chunk.uncompressed_size {
                        return Err(self.bad_index(
                            offset,
                            format!(
                                "message offset {} is past the chunk's {} bytes",
                                e.offset, chunk.uncompressed_size
                            ),
                        ));
                    }
                    let loc = MsgLoc {
                        chunk: ci,
                        offset: e.offset,
                    };
                    if table.insert(e.log_time, loc).is_some() {
                        let topic = self.topics.get(&channel).map_or("?", |t| t.as_str());
                        return Err(self.bad_index(
                            offset,
                            format!("two {topic} messages at log time {}", e.log_time),
                        ));
                    }
                }
            }
        }
        if labels.is_empty() {
            return Err(ShardError::MissingIndex {
                path: self.path.clone(),
                what: "no /labels messages in the message indexes".into(),
            });
        }
        let mut frames = Vec::with_capacity(labels.len());
        for (log_time, l) in &labels {
            let missing = |what: String| ShardError::MissingIndex {
                path: self.path.clone(),
                what,
            };
            let frame_id = frame_id_of_log_time(*log_time).ok_or_else(|| {
                missing(format!(
                    "log time {log_time} is not a multiple of the frame period"
                ))
            })?;
            let image = images
                .remove(log_time)
                .ok_or_else(|| missing(format!("frame {frame_id} has labels but no image")))?;
            frames.push(FrameLoc {
                frame_id,
                log_time: *log_time,
                labels: *l,
                image,
            });
        }
        if let Some((t, _)) = images.first_key_value() {
            return Err(ShardError::MissingIndex {
                path: self.path.clone(),
                what: format!("an image at log time {t} has no labels"),
            });
        }
        Ok(frames)
    }

    /// The decompressed contents of chunk `ci`, checked against its CRC.
    fn decompress_chunk(&self, ci: usize, options: &ReaderOptions) -> Result<Vec<u8>, ShardError> {
        let idx = &self.chunks[ci];
        let at = idx.chunk_start_offset;
        let bad = |reason: String| ShardError::Chunk {
            path: self.path.clone(),
            chunk_offset: at,
            reason,
        };
        let (opcode, body) = record_at(&self.mmap, at).map_err(bad)?;
        if opcode != op::CHUNK {
            return Err(bad(format!(
                "expected a chunk record (opcode 0x06), found opcode {opcode:#04x}"
            )));
        }
        if body.len() as u64 + RECORD_PREFIX != idx.chunk_length {
            return Err(bad(format!(
                "chunk record is {} bytes, the chunk index says {}",
                body.len() as u64 + RECORD_PREFIX,
                idx.chunk_length
            )));
        }
        let (header, data) = match mcap::parse_record(op::CHUNK, body) {
            Ok(Record::Chunk { header, data }) => (header, data),
            Ok(_) => return Err(bad("not a chunk".into())),
            Err(e) => return Err(bad(e.to_string())),
        };
        if header.uncompressed_size != idx.uncompressed_size
            || header.compression != idx.compression
        {
            return Err(bad(format!(
                "chunk header ({} bytes, {:?}) disagrees with the chunk index ({} bytes, {:?})",
                header.uncompressed_size,
                header.compression,
                idx.uncompressed_size,
                idx.compression
            )));
        }
        // Bounded in check_chunk_indexes.
        let size = header.uncompressed_size as usize;
        let out = match header.compression.as_str() {
            "zstd" => {
                let mut out = Vec::with_capacity(size);
                let mut z = zstd::bulk::Decompressor::new().map_err(|e| bad(e.to_string()))?;
                z.decompress_to_buffer(&data, &mut out)
                    .map_err(|e| bad(format!("zstd: {e}")))?;
                out
            }
            "" => data.to_vec(),
            other => return Err(bad(format!("unsupported compression {other:?}"))),
        };
        if out.len() != size {
            return Err(bad(format!(
                "decompressed to {} bytes, the chunk says {size}",
                out.len()
            )));
        }
        if options.verify_chunk_crc && header.uncompressed_crc != 0 {
            let computed = crc32fast::hash(&out);
            if computed != header.uncompressed_crc {
                return Err(ShardError::ChunkCrc {
                    path: self.path.clone(),
                    chunk_offset: at,
                    expected: header.uncompressed_crc,
                    computed,
                });
            }
        }
        Ok(out)
    }

    /// The payload of the message at `loc` in the decompressed chunk `data`, checked
    /// to be on `channel` at `log_time`.
    fn message<'d>(
        &self,
        data: &'d [u8],
        loc: MsgLoc,
        channel: u16,
        log_time: u64,
    ) -> Result<&'d [u8], ShardError> {
        let bad = |reason: String| ShardError::Record {
            path: self.path.clone(),
            chunk_offset: self.chunks[loc.chunk].chunk_start_offset,
            record_offset: loc.offset,
            reason,
        };
        let (opcode, body) = record_at(data, loc.offset).map_err(bad)?;
        if opcode != op::MESSAGE {
            return Err(bad(format!(
                "expected a message record (opcode 0x05), found opcode {opcode:#04x}"
            )));
        }
        let (header, payload) = match mcap::parse_record(op::MESSAGE, body) {
            Ok(Record::Message { header, data }) => (header, data),
            Ok(_) => return Err(bad("not a message".into())),
            Err(e) => return Err(bad(e.to_string())),
        };
        if header.channel_id != channel || header.log_time != log_time {
            return Err(bad(format!(
                "message is on channel {} at log time {}, the index says channel {channel} at {log_time}",
                header.channel_id, header.log_time
            )));
        }
        match payload {
            std::borrow::Cow::Borrowed(p) => Ok(p),
            // parse_record borrows from its input; an owned payload would be a change
            // of the mcap crate, reported rather than copied out of a temporary.
            std::borrow::Cow::Owned(_) => Err(bad("message payload was not borrowed".into())),
        }
    }
}

/// The record starting at `offset` of `buf`: its opcode and body, with the length
/// checked against the bytes there.
fn record_at(buf: &[u8], offset: u64) -> Result<(u8, &[u8]), String> {
    let len = buf.len() as u64;
    let body_start = offset
        .checked_add(RECORD_PREFIX)
        .filter(|&e| e <= len)
        .ok_or_else(|| format!("record at {offset} runs past the end ({len} bytes)"))?;
    let o = offset as usize;
    let opcode = buf[o];
    let mut le = [0u8; 8];
    le.copy_from_slice(&buf[o + 1..o + 9]);
    let body_len = u64::from_le_bytes(le);
    let end = body_start
        .checked_add(body_len)
        .filter(|&e| e <= len)
        .ok_or_else(|| {
            format!(
                "record (opcode {opcode:#04x}) claims {body_len} bytes, only {} remain",
                len - body_start
            )
        })?;
    Ok((opcode, &buf[body_start as usize..end as usize]))
}

/// Checks the file's ends, the summary CRC and the summary's record opcodes, then
/// reads the summary with the mcap crate.
fn read_summary(path: &Path, mmap: &[u8]) -> Result<mcap::Summary, ShardError> {
    let len = mmap.len() as u64;
    let not_mcap = |reason: String| ShardError::NotMcap {
        path: path.to_path_buf(),
        len,
        reason,
    };
    if len < 2 * MAGIC_LEN + FOOTER_RECORD_LEN {
        return Err(not_mcap("shorter than the magic bytes and a footer".into()));
    }
    if !mmap.starts_with(mcap::MAGIC) {
        return Err(not_mcap("does not start with the MCAP magic".into()));
    }
    if !mmap.ends_with(mcap::MAGIC) {
        return Err(not_mcap(
            "does not end with the MCAP magic (truncated, or still being written)".into(),
        ));
    }
    let footer_at = len - MAGIC_LEN - FOOTER_RECORD_LEN;
    let (opcode, body) = record_at(mmap, footer_at).map_err(&not_mcap)?;
    if opcode != op::FOOTER || body.len() != 20 {
        return Err(not_mcap(format!("no footer record at byte {footer_at}")));
    }
    let footer = mcap::read::footer(mmap).map_err(|e| not_mcap(e.to_string()))?;
    let summary_start = footer.summary_start;
    if summary_start == 0 {
        return Err(ShardError::MissingIndex {
            path: path.to_path_buf(),
            what: "no summary section (written without an index?)".into(),
        });
    }
    let bad = |offset: u64, reason: String| ShardError::BadIndex {
        path: path.to_path_buf(),
        offset,
        reason,
    };
    if summary_start < MAGIC_LEN || summary_start > footer_at {
        return Err(bad(
            footer_at,
            format!("footer's summary start {summary_start} is outside the file"),
        ));
    }
    let summary_end = match footer.summary_offset_start {
        0 => footer_at,
        s if (summary_start..=footer_at).contains(&s) => s,
        s => {
            return Err(bad(
                footer_at,
                format!("footer's summary offset start {s} is outside the summary"),
            ));
        }
    };
    if footer.summary_crc != 0 {
        // The CRC covers the summary up to and including the footer's
        // summary_offset_start field.
        let computed =
            crc32fast::hash(&mmap[summary_start as usize..(len - MAGIC_LEN - 4) as usize]);
        if computed != footer.summary_crc {
            return Err(bad(
                summary_start,
                format!(
                    "summary CRC is {computed:#010x}, the footer says {:#010x}",
                    footer.summary_crc
                ),
            ));
        }
    }
    // Walk the summary's records once: lengths within the section, and only record
    // kinds a summary holds (the mcap crate's parser trusts attachment records).
    let mut at = summary_start;
    while at < summary_end {
        let (opcode, body) =
            record_at(&mmap[..summary_end as usize], at).map_err(|r| bad(at, r))?;
        if !SUMMARY_OPCODES.contains(&opcode) {
            return Err(bad(
                at,
                format!("record with opcode {opcode:#04x} in the summary section"),
            ));
        }
        at += RECORD_PREFIX + body.len() as u64;
    }
    let summary = mcap::Summary::read(mmap)
        .map_err(|source| ShardError::Summary {
            path: path.to_path_buf(),
            summary_start,
            source,
        })?
        .ok_or_else(|| ShardError::MissingIndex {
            path: path.to_path_buf(),
            what: "no summary section".into(),
        })?;
    Ok(summary)
}

/// The chunk indexes in file order, each checked to lie inside the data section,
/// with a supported compression and a bounded decompressed size.
fn check_chunk_indexes(
    path: &Path,
    summary: &mcap::Summary,
    options: &ReaderOptions,
) -> Result<Vec<ChunkIndex>, ShardError> {
    if summary.chunk_indexes.is_empty() {
        return Err(ShardError::MissingIndex {
            path: path.to_path_buf(),
            what: "the summary has no chunk indexes".into(),
        });
    }
    let mut chunks = summary.chunk_indexes.clone();
    chunks.sort_by_key(|c| c.chunk_start_offset);
    for c in &chunks {
        let bad = |reason: String| ShardError::BadIndex {
            path: path.to_path_buf(),
            offset: c.chunk_start_offset,
            reason: format!("chunk index: {reason}"),
        };
        if !matches!(c.compression.as_str(), "zstd" | "") {
            return Err(bad(format!("unsupported compression {:?}", c.compression)));
        }
        if c.uncompressed_size > options.max_chunk_bytes {
            return Err(bad(format!(
                "chunk decompresses to {} bytes, over the limit of {}",
                c.uncompressed_size, options.max_chunk_bytes
            )));
        }
        let data_start = c.compressed_data_offset().map_err(|e| bad(e.to_string()))?;
        let end = c.chunk_start_offset.checked_add(c.chunk_length);
        let data_end = data_start.checked_add(c.compressed_size);
        match (end, data_end) {
            (Some(end), Some(data_end)) if data_end <= end => {}
            _ => return Err(bad("chunk length or compressed size out of range".into())),
        }
    }
    Ok(chunks)
}

/// A decompressed chunk kept for the next frames.
struct CachedChunk {
    shard: usize,
    chunk: usize,
    data: Arc<Vec<u8>>,
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

    fn chunk(&mut self, shard: usize, chunk: usize) -> Result<Arc<Vec<u8>>, ShardError> {
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
        let data = Arc::new(self.shards[shard].decompress_chunk(chunk, &self.options)?);
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
        let image = foxglove::messages::CompressedImage::decode(raw)
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
        let frame = from_proto(labels, image.data.to_vec(), format)
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
