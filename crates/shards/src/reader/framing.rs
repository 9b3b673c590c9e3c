//! The MCAP framing, read without trusting it: a record's opcode and length checked
//! against the bytes there, the file's magic and footer, the summary section (its CRC
//! and its record kinds) and the chunk indexes, before the mcap crate parses any of it.

use super::options::ReaderOptions;
use crate::error::ShardError;
use mcap::records::{ChunkIndex, op};
use std::path::Path;

const MAGIC_LEN: u64 = 8;
/// Footer record: opcode, length, summary_start, summary_offset_start, summary_crc.
const FOOTER_RECORD_LEN: u64 = 1 + 8 + 8 + 8 + 4;
/// opcode + record length.
pub(super) const RECORD_PREFIX: u64 = 9;
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

/// The record starting at `offset` of `buf`: its opcode and body, with the length
/// checked against the bytes there.
pub(super) fn record_at(buf: &[u8], offset: u64) -> Result<(u8, &[u8]), String> {
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
pub(super) fn read_summary(path: &Path, mmap: &[u8]) -> Result<mcap::Summary, ShardError> {
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
pub(super) fn check_chunk_indexes(
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
