//! Bad shards give typed errors naming the file and the place; bad frames given to
//! the writer give typed errors naming the frame and leave no file behind.

use shards::{
    FrameRecord, ShardError, ShardJob, ShardReader, plan_shards, write_shard, write_shards,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use testkit::shard_frames::{assert_bitwise_eq, frame, small_chunks};

fn good_shard(dir: &Path) -> (PathBuf, Vec<FrameRecord>) {
    let frames: Vec<FrameRecord> = (0..12).map(|i| frame(i, 120, 20, 32, 24)).collect();
    let path = dir.join("good.mcap");
    write_shard(&path, &frames, &small_chunks()).unwrap();
    (path, frames)
}

/// Opens and reads every frame; the first error.
fn read_all(path: &Path) -> Result<Vec<FrameRecord>, ShardError> {
    ShardReader::open([path])?.collect()
}

/// The error of reading `path` (without printing a whole shard when there is none).
fn read_err(path: &Path) -> ShardError {
    match read_all(path) {
        Ok(frames) => panic!(
            "{} read without error ({} frames)",
            path.display(),
            frames.len()
        ),
        Err(e) => e,
    }
}

fn names_file(err: &ShardError, path: &Path) {
    let msg = err.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "no file name in {msg:?}"
    );
}

#[test]
fn truncated_shards() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = good_shard(dir.path());
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.mcap");
    for len in [
        0,
        5,
        8,
        40,
        bytes.len() / 2,
        bytes.len() - 9,
        bytes.len() - 1,
    ] {
        std::fs::write(&cut, &bytes[..len]).unwrap();
        let err = read_err(&cut);
        assert!(
            matches!(err, ShardError::NotMcap { .. }),
            "len {len}: {err}"
        );
        names_file(&err, &cut);
    }
    let err = read_err(&dir.path().join("missing.mcap"));
    assert!(matches!(err, ShardError::Io(_)), "{err}");
}

/// Offsets of the records of the data section: (opcode, offset, length of body).
fn data_records(bytes: &[u8]) -> Vec<(u8, usize, usize)> {
    let mut out = Vec::new();
    let mut at = 8;
    loop {
        let op = bytes[at];
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        out.push((op, at, len));
        if op == 0x0F {
            break; // DataEnd
        }
        at += 9 + len;
    }
    out
}

#[test]
fn corrupted_chunk_is_caught_by_its_crc() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = good_shard(dir.path());
    let bytes = std::fs::read(&path).unwrap();
    let chunks: Vec<_> = data_records(&bytes)
        .into_iter()
        .filter(|r| r.0 == 0x06)
        .collect();
    assert!(chunks.len() > 2);
    // A byte in the middle of the second chunk's compressed data.
    let (_, at, len) = chunks[1];
    let mut bad = bytes.clone();
    bad[at + len / 2 + 40] ^= 0x10;
    let p = dir.path().join("flip.mcap");
    std::fs::write(&p, &bad).unwrap();
    let err = read_err(&p);
    names_file(&err, &p);
    match &err {
        ShardError::ChunkCrc { chunk_offset, .. } | ShardError::Chunk { chunk_offset, .. } => {
            assert_eq!(*chunk_offset, at as u64, "{err}")
        }
        other => panic!("expected a chunk error, got {other}"),
    }
    // The frames before the bad chunk still read: the reader only decompresses the
    // chunks it needs.
    let mut reader = ShardReader::open([&p]).unwrap();
    assert!(reader.next().unwrap().is_ok());
}

#[test]
fn corrupted_summary_and_index() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = good_shard(dir.path());
    let bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    let summary_start =
        u64::from_le_bytes(bytes[n - 8 - 20..n - 8 - 12].try_into().unwrap()) as usize;

    // A byte of the summary: the summary CRC catches it.
    let mut bad = bytes.clone();
    bad[summary_start + 30] ^= 0x01;
    let p = dir.path().join("summary.mcap");
    std::fs::write(&p, &bad).unwrap();
    let err = read_err(&p);
    assert!(
        matches!(&err, ShardError::BadIndex { offset, .. } if *offset == summary_start as u64),
        "{err}"
    );
    assert!(err.to_string().contains("summary CRC"), "{err}");

    // The footer pointing past the end.
    let mut bad = bytes.clone();
    bad[n - 8 - 20..n - 8 - 12].copy_from_slice(&(n as u64 * 2).to_le_bytes());
    std::fs::write(&p, &bad).unwrap();
    let err = read_err(&p);
    assert!(err.to_string().contains("outside the file"), "{err}");

    // A /labels message index entry pointing at the wrong record (its offset, within
    // the chunk): the message found there is not the indexed one. Channel ids follow
    // the writer's order: calibration 1, tf 2, image 3, labels 4.
    let (_, at, _) = data_records(&bytes)
        .into_iter()
        .find(|r| r.0 == 0x07 && bytes[r.1 + 9..r.1 + 11] == 4u16.to_le_bytes())
        .unwrap();
    let mut bad = bytes.clone();
    // MessageIndex body: channel id u16, u32 byte length, then (log_time, offset).
    let entry_offset = at + 9 + 2 + 4 + 8;
    let o = u64::from_le_bytes(bad[entry_offset..entry_offset + 8].try_into().unwrap());
    bad[entry_offset..entry_offset + 8].copy_from_slice(&(o + 1).to_le_bytes());
    std::fs::write(&p, &bad).unwrap();
    let err = read_err(&p);
    assert!(matches!(err, ShardError::Record { .. }), "{err}");
    names_file(&err, &p);
    assert!(
        err.to_string().contains(&format!("offset {}", o + 1)),
        "{err}"
    );
}

#[test]
fn no_byte_flip_panics_or_passes_silently() {
    // Flip one byte at a time across the whole file: opening and reading must never
    // panic, and whenever it succeeds the frames must be the ones written (a flip in
    // a part the reader does not use, e.g. the header's library string, is harmless;
    // one in anything it uses must be detected).
    let dir = tempfile::tempdir().unwrap();
    let (path, frames) = good_shard(dir.path());
    let bytes = std::fs::read(&path).unwrap();
    let p = dir.path().join("flip.mcap");
    let stride = (bytes.len() / 1500).max(1);
    let (mut ok, mut failed) = (0, 0);
    for at in (0..bytes.len()).step_by(stride) {
        let mut bad = bytes.clone();
        bad[at] ^= 0xA5;
        std::fs::write(&p, &bad).unwrap();
        match read_all(&p) {
            Ok(back) => {
                assert_eq!(back.len(), frames.len(), "flip at {at}");
                for (a, b) in frames.iter().zip(&back) {
                    assert_bitwise_eq(a, b);
                }
                ok += 1;
            }
            Err(e) => {
                names_file(&e, &p);
                failed += 1;
            }
        }
    }
    assert!(failed > ok, "{failed} detected, {ok} harmless");
}

#[test]
fn writer_refuses_bad_frames_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.mcap");
    let good: Vec<FrameRecord> = (0..3).map(|i| frame(i, 10, 2, 8, 8)).collect();
    let assert_nothing_written = || {
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(names.is_empty(), "left behind: {names:?}");
    };

    let unsorted = [&good[1], &good[0]];
    let err = write_shard(&out, unsorted, &small_chunks()).unwrap_err();
    assert!(
        matches!(
            err,
            ShardError::FramesNotSorted {
                previous: 1,
                next: 0
            }
        ),
        "{err}"
    );
    assert_nothing_written();

    let mut broken = good[2].clone();
    broken.line_valid.push(true);
    let err = write_shard(&out, [&good[0], &broken], &small_chunks()).unwrap_err();
    assert_eq!(err.to_string(), "frame 2: 2 segments but 3 line_valid");
    assert_nothing_written();

    let err = write_shard(&out, [], &small_chunks()).unwrap_err();
    assert!(matches!(err, ShardError::EmptyShard { .. }), "{err}");
    assert_nothing_written();

    let mut huge = good[0].clone();
    huge.frame_id = u64::MAX;
    let err = write_shard(&out, [&huge], &small_chunks()).unwrap_err();
    assert!(
        err.to_string().contains("too large for a log time"),
        "{err}"
    );
    assert_nothing_written();

    // A frame source failing mid-shard, or returning the wrong frame.
    let plans = plan_shards(&[0, 1, 2], 3).unwrap();
    let job = ShardJob {
        out_dir: dir.path(),
        plans: &plans,
        config: &small_chunks(),
        config_hash: String::new(),
        inputs: BTreeMap::new(),
        digests: None,
    };
    let failing = |id: u64| -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        if id == 2 {
            Err("image file missing".into())
        } else {
            Ok(good[id as usize].clone())
        }
    };
    let err = write_shards(&job, 0..1, &failing).unwrap_err();
    assert_eq!(err.to_string(), "loading frame 2: image file missing");
    assert_nothing_written();
    let wrong = |_id: u64| -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        Ok(good[1].clone())
    };
    let err = write_shards(&job, 0..1, &wrong).unwrap_err();
    assert!(
        matches!(
            err,
            ShardError::SourceMismatch {
                expected: 0,
                got: 1
            }
        ),
        "{err}"
    );
    let err = write_shards(&job, 0..2, &failing).unwrap_err();
    assert!(
        matches!(
            err,
            ShardError::ShardRange {
                start: 0,
                end: 2,
                count: 1
            }
        ),
        "{err}"
    );
    assert_nothing_written();
}

#[test]
fn not_a_shard() {
    let dir = tempfile::tempdir().unwrap();
    // A valid MCAP file written by someone else, without our channels.
    let p = dir.path().join("other.mcap");
    {
        let f = std::io::BufWriter::new(std::fs::File::create(&p).unwrap());
        let mut w = mcap::Writer::new(f).unwrap();
        let ch = w
            .add_channel(0, "/chatter", "json", &BTreeMap::new())
            .unwrap();
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: ch,
                sequence: 0,
                log_time: 1,
                publish_time: 1,
            },
            b"{}",
        )
        .unwrap();
        w.finish().unwrap();
    }
    let err = read_err(&p);
    assert!(
        matches!(&err, ShardError::Channel { topic, .. } if topic == "/labels"),
        "{err}"
    );
    names_file(&err, &p);

    std::fs::write(&p, vec![0x42; 4096]).unwrap();
    let err = read_err(&p);
    assert!(
        err.to_string()
            .contains("does not start with the MCAP magic"),
        "{err}"
    );
}
