use std::path::PathBuf;
use thiserror::Error;

/// Errors of the shards crate. Errors about a shard file name the file and the place
/// in it (a byte offset in the file, a chunk's offset and an offset inside the
/// decompressed chunk, or a frame id); errors about a frame name its frame id.
#[derive(Debug, Error)]
pub enum ShardError {
    #[error(transparent)]
    Io(#[from] fileio::IoError),
    #[error(transparent)]
    Stage(#[from] stage::StageError),

    // ---- frames handed to the writer ----
    #[error("frame {frame_id}: {reason}")]
    InvalidFrame { frame_id: u64, reason: String },
    #[error("frames must have strictly increasing ids: frame {next} follows frame {previous}")]
    FramesNotSorted { previous: u64, next: u64 },
    #[error("a shard needs at least one frame ({what})")]
    EmptyShard { what: String },
    #[error("frames_per_shard must be at least 1")]
    ZeroFramesPerShard,
    #[error("shard range {start}..{end} is outside the plan's {count} shards")]
    ShardRange {
        start: usize,
        end: usize,
        count: usize,
    },
    #[error("loading frame {frame_id}: {source}")]
    Source {
        frame_id: u64,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("frame source returned frame {got} when frame {expected} was asked for")]
    SourceMismatch { expected: u64, got: u64 },
    #[error("{path}: MCAP writer failed {context}: {source}")]
    Write {
        path: PathBuf,
        context: String,
        #[source]
        source: mcap::McapError,
    },
    #[error("cannot encode frame {frame_id} for {topic}: {reason}")]
    Encode {
        frame_id: u64,
        topic: &'static str,
        reason: String,
    },

    // ---- shard files given to the reader ----
    #[error("{path}: not a complete MCAP file ({len} bytes): {reason}")]
    NotMcap {
        path: PathBuf,
        len: u64,
        reason: String,
    },
    #[error(
        "{path}: cannot read the summary section (footer says it starts at byte {summary_start}): {source}"
    )]
    Summary {
        path: PathBuf,
        summary_start: u64,
        #[source]
        source: mcap::McapError,
    },
    #[error("{path}: {what}")]
    MissingIndex { path: PathBuf, what: String },
    #[error("{path}: channel {topic}: {reason}")]
    Channel {
        path: PathBuf,
        topic: String,
        reason: String,
    },
    #[error("{path}: bad index at byte {offset}: {reason}")]
    BadIndex {
        path: PathBuf,
        offset: u64,
        reason: String,
    },
    #[error("{path}: chunk at byte {chunk_offset}: {reason}")]
    Chunk {
        path: PathBuf,
        chunk_offset: u64,
        reason: String,
    },
    #[error(
        "{path}: chunk at byte {chunk_offset}: CRC of the decompressed data is {computed:#010x}, the chunk says {expected:#010x}"
    )]
    ChunkCrc {
        path: PathBuf,
        chunk_offset: u64,
        expected: u32,
        computed: u32,
    },
    #[error(
        "{path}: chunk at byte {chunk_offset}, record at offset {record_offset} of the decompressed chunk: {reason}"
    )]
    Record {
        path: PathBuf,
        chunk_offset: u64,
        record_offset: u64,
        reason: String,
    },
    #[error("{path}: frame {frame_id} ({topic}, chunk at byte {chunk_offset}): {reason}")]
    Decode {
        path: PathBuf,
        frame_id: u64,
        topic: String,
        chunk_offset: u64,
        reason: String,
    },
    #[error("frame {frame_id} is in none of the open shards")]
    FrameNotFound { frame_id: u64 },
    #[error("frame {frame_id} is in both {first} and {second}")]
    DuplicateFrame {
        frame_id: u64,
        first: PathBuf,
        second: PathBuf,
    },

    // ---- manifests ----
    #[error("{path}: invalid manifest: {source}")]
    ManifestParse {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{digests} source digest(s) for a plan of {shards} shard(s)")]
    DigestCount { digests: usize, shards: usize },
    #[error("cannot merge manifests: {0}")]
    ManifestMerge(String),
    #[error(
        "{}: the manifest is incomplete ({reason}): run the shard stage to the end",
        path.display()
    )]
    IncompleteManifest { path: PathBuf, reason: String },
}
