//! One shard opened for reading: the channels it must have, its chunk indexes and the
//! frame table built from the per-chunk message indexes; decompressing a chunk and
//! slicing a message out of it, each checked against the index.

use super::framing::{RECORD_PREFIX, check_chunk_indexes, read_summary, record_at};
use super::options::ReaderOptions;
use crate::error::ShardError;
use crate::schema::FRAME_LABELS_SCHEMA_NAME;
use crate::writer::{TOPIC_IMAGE, TOPIC_LABELS, frame_id_of_log_time};
use fileio::io_err;
use mcap::records::{ChunkIndex, Record, op};
use memmap2::Mmap;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where a message is: which chunk, and the offset of its record in the
/// decompressed chunk.
#[derive(Clone, Copy, Debug)]
pub(super) struct MsgLoc {
    pub(super) chunk: usize,
    offset: u64,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct FrameLoc {
    pub(super) frame_id: u64,
    pub(super) log_time: u64,
    pub(super) labels: MsgLoc,
    pub(super) image: MsgLoc,
}

/// One open shard: its map, chunk indexes and frame table.
pub struct ShardFile {
    pub(super) path: PathBuf,
    mmap: Mmap,
    pub(super) chunks: Vec<ChunkIndex>,
    pub(super) frames: Vec<FrameLoc>,
    pub(super) labels_channel: u16,
    pub(super) image_channel: u16,
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
    pub(super) fn decompress_chunk(
        &self,
        ci: usize,
        options: &ReaderOptions,
    ) -> Result<Vec<u8>, ShardError> {
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
        self.release(at, idx.chunk_length);
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

    /// Drops this process's pages of a byte range of the file it has read. The mapped
    /// pages of every chunk read would otherwise stay in the process: a pass over a shard
    /// set (the trainer describes every frame once) left the whole set resident, and the
    /// process's RSS grew by its size (3 GB at 7,000 training frames; docs/performance.md,
    /// "A real scene's size"). The kernel's page cache keeps the data, so reading the
    /// chunk again costs page faults, not disk reads. Advice only: a failure changes
    /// nothing.
    fn release(&self, offset: u64, len: u64) {
        use memmap2::UncheckedAdvice;
        let (Ok(offset), Ok(len)) = (usize::try_from(offset), usize::try_from(len)) else {
            return;
        };
        if offset.saturating_add(len) > self.mmap.len() {
            return;
        }
        // SAFETY: the map is a read-only MAP_SHARED map of a file that is never modified
        // (see `open_with`). MADV_DONTNEED on such a map only unmaps the pages: any later
        // read of the range (by this thread, or another thread decompressing the same
        // chunk at this moment) faults the same bytes back in from the file. Nothing can
        // observe a change.
        let _ = unsafe {
            self.mmap
                .unchecked_advise_range(UncheckedAdvice::DontNeed, offset, len)
        };
    }

    /// The payload of the message at `loc` in the decompressed chunk `data`, checked
    /// to be on `channel` at `log_time`.
    pub(super) fn message<'d>(
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
