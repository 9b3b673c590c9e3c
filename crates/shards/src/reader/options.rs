//! The reader's limits and checks ([`ReaderOptions`]), which the reader (`mod.rs`), one
//! shard's index (`shard_file.rs`) and the framing checks (`framing.rs`) all apply.

/// Limits and checks of the reader.
#[derive(Clone, Debug)]
pub struct ReaderOptions {
    /// Largest decompressed chunk accepted (the size comes from the file, so it is
    /// bounded before allocating).
    pub max_chunk_bytes: u64,
    /// Check each chunk's CRC32 after decompressing it.
    pub verify_chunk_crc: bool,
    /// Decompressed chunks a [`crate::ShardReader`] keeps, least recently used out first, up
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
