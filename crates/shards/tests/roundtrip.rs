//! Frames written to shards come back from the reader bit for bit: in order, after a
//! seek, from a subset of shards, and one by one.

use shards::{
    FrameRecord, FrameSource, ShardError, ShardFile, ShardJob, ShardReader, plan_shards,
    write_shard, write_shards,
};
use std::collections::BTreeMap;
use testkit::shard_frames::{assert_bitwise_eq, frame, small_chunks};

fn frames(ids: impl IntoIterator<Item = u64>) -> Vec<FrameRecord> {
    ids.into_iter()
        .map(|id| frame(id, 300, 40, 48, 32))
        .collect()
}

#[test]
fn round_trip_is_bitwise_and_in_order() {
    let dir = tempfile::tempdir().unwrap();
    // Ids with gaps, and more frames than fit in one 16 KiB chunk.
    let input = frames((0..23).map(|i| 1000 + 3 * i));
    let path = dir.path().join("s.mcap");
    let info = write_shard(&path, &input, &small_chunks()).unwrap();
    assert_eq!(
        (info.first_frame, info.last_frame, info.frame_count),
        (1000, 1066, 23)
    );
    assert_eq!(info.bytes, std::fs::metadata(&path).unwrap().len());
    assert_eq!(info.sha256, stage::sha256_file(&path).unwrap());

    let shard = ShardFile::open(&path).unwrap();
    assert!(shard.chunk_count() > 3, "chunks: {}", shard.chunk_count());
    let counts = shard.channel_message_counts();
    for topic in [
        "/camera/image",
        "/camera/calibration",
        "/tf",
        "/labels",
        "/labels/points",
        "/labels/lines",
    ] {
        assert_eq!(counts.get(topic), Some(&23), "{topic}: {counts:?}");
    }

    let reader = ShardReader::open([&path]).unwrap();
    assert_eq!(reader.frame_count(), 23);
    let back: Vec<FrameRecord> = reader.map(|r| r.unwrap()).collect();
    assert_eq!(back.len(), input.len());
    for (a, b) in input.iter().zip(&back) {
        assert_bitwise_eq(a, b);
    }
}

/// `input` written to `dir/s.mcap` in 16 KiB chunks.
fn small_chunked_shard(dir: &std::path::Path, input: &[FrameRecord]) -> std::path::PathBuf {
    let path = dir.join("s.mcap");
    write_shard(&path, input, &small_chunks()).unwrap();
    path
}

#[test]
fn seek_and_random_access() {
    let dir = tempfile::tempdir().unwrap();
    let input = frames(0..30);
    let path = small_chunked_shard(dir.path(), &input);
    let mut reader = ShardReader::open([&path]).unwrap();

    reader.seek(17).unwrap();
    let rest: Vec<u64> = reader.by_ref().map(|r| r.unwrap().frame_id).collect();
    assert_eq!(rest, (17..30).collect::<Vec<_>>());
    // Seeking backwards, then reading one frame.
    reader.seek(4).unwrap();
    assert_bitwise_eq(&reader.next().unwrap().unwrap(), &input[4]);
    // Random access leaves the cursor alone.
    assert_bitwise_eq(&reader.read_frame(29).unwrap(), &input[29]);
    assert_bitwise_eq(&reader.read_frame(0).unwrap(), &input[0]);
    assert_eq!(reader.next().unwrap().unwrap().frame_id, 5);
    assert!(matches!(
        reader.seek(30),
        Err(ShardError::FrameNotFound { frame_id: 30 })
    ));
    reader.rewind();
    assert_eq!(reader.next().unwrap().unwrap().frame_id, 0);
}

/// A chunk cache changes how often chunks are decompressed, never what is read.
#[test]
fn chunk_cache_decompresses_each_chunk_of_a_window_once() {
    let dir = tempfile::tempdir().unwrap();
    let input = frames(0..30);
    let path = small_chunked_shard(dir.path(), &input);
    let chunks = ShardFile::open(&path).unwrap().chunk_count() as u64;
    assert!(chunks > 3, "chunks: {chunks}");
    // Random access hopping over the whole shard, three times.
    let order: Vec<u64> = (0..90).map(|i| (i * 17 + i / 30) % 30).collect();
    let read = |cache_bytes: u64| {
        let options = shards::ReaderOptions {
            cache_bytes,
            ..Default::default()
        };
        let mut r = ShardReader::open_with([&path], options).unwrap();
        for &id in &order {
            assert_bitwise_eq(&r.read_frame(id).unwrap(), &input[id as usize]);
        }
        r.chunks_decompressed()
    };
    // The chunks that hold frames: a sequential read decompresses each of them once.
    let mut seq = ShardReader::open([&path]).unwrap();
    assert_eq!(seq.by_ref().count(), 30);
    let used = seq.chunks_decompressed();
    assert!(used > 3 && used <= chunks, "{used} of {chunks}");
    let uncached = read(0);
    let cached = read(1 << 30);
    assert_eq!(
        cached, used,
        "a cache holding the shard decompresses each chunk once"
    );
    assert!(
        uncached > 2 * used,
        "without a cache: {uncached} decompressions"
    );
    // A budget of about two chunks behaves like none; it never drops below two.
    assert!(read(1) >= cached);
}

/// A frame's image is a view of its decompressed chunk, not a copy: reading the same
/// frame twice through the chunk cache gives the same bytes at the same address, and a
/// record keeps its chunk alive after the reader is gone.
#[test]
fn images_are_views_of_the_cached_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let input = frames(0..6);
    let path = small_chunked_shard(dir.path(), &input);
    let options = shards::ReaderOptions {
        cache_bytes: 1 << 30,
        ..Default::default()
    };
    let mut reader = ShardReader::open_with([&path], options).unwrap();
    let first = reader.read_frame(3).unwrap();
    let again = reader.read_frame(3).unwrap();
    assert_eq!(reader.chunks_decompressed(), first_chunks(&path, 3));
    assert_eq!(first.image_bytes.as_ptr(), again.image_bytes.as_ptr());
    // Another reader decompresses its own chunk: equal bytes elsewhere.
    let other = ShardReader::open([&path]).unwrap().read_frame(3).unwrap();
    assert_ne!(first.image_bytes.as_ptr(), other.image_bytes.as_ptr());
    drop(reader);
    assert_bitwise_eq(&first, &input[3]);
    assert_bitwise_eq(&other, &input[3]);
}

/// Chunks a fresh reader decompresses to read `frame` (its image's and its labels').
fn first_chunks(path: &std::path::Path, frame: u64) -> u64 {
    let mut r = ShardReader::open([path]).unwrap();
    r.read_frame(frame).unwrap();
    r.chunks_decompressed()
}

fn source(all: &[FrameRecord]) -> impl FrameSource + '_ {
    move |id: u64| -> Result<FrameRecord, Box<dyn std::error::Error + Send + Sync>> {
        all.iter()
            .find(|f| f.frame_id == id)
            .cloned()
            .ok_or_else(|| format!("no frame {id}").into())
    }
}

#[test]
fn subset_of_shards_in_the_given_order() {
    let dir = tempfile::tempdir().unwrap();
    let input = frames(0..25);
    let ids: Vec<u64> = input.iter().map(|f| f.frame_id).collect();
    let plans = plan_shards(&ids, 10).unwrap();
    let job = ShardJob {
        out_dir: dir.path(),
        plans: &plans,
        config: &small_chunks(),
        config_hash: "test".into(),
        inputs: BTreeMap::new(),
        digests: None,
    };
    let manifest = write_shards(&job, 0..plans.len(), &source(&input))
        .unwrap()
        .manifest;
    assert!(manifest.is_complete());
    let paths = manifest.shard_paths(dir.path());
    assert_eq!(paths.len(), 3);

    // Shards 2 then 0: frames 20..25 then 0..10.
    let reader = ShardReader::open([&paths[2], &paths[0]]).unwrap();
    let got: Vec<FrameRecord> = reader.map(|r| r.unwrap()).collect();
    let want: Vec<&FrameRecord> = input[20..25].iter().chain(&input[0..10]).collect();
    assert_eq!(got.len(), want.len());
    for (a, b) in want.iter().zip(&got) {
        assert_bitwise_eq(a, b);
    }
    // A frame of a shard that is not open.
    let mut reader = ShardReader::open([&paths[2], &paths[0]]).unwrap();
    assert!(!reader.contains(15));
    assert!(matches!(
        reader.seek(15),
        Err(ShardError::FrameNotFound { .. })
    ));
    reader.seek(3).unwrap();
    assert_eq!(reader.next().unwrap().unwrap().frame_id, 3);

    // The same shard twice is refused: a frame would be read twice.
    let err = ShardReader::open([&paths[1], &paths[1]]).unwrap_err();
    assert!(
        matches!(err, ShardError::DuplicateFrame { frame_id: 10, .. }),
        "{err}"
    );
}

#[test]
fn empty_labels_and_one_frame() {
    let dir = tempfile::tempdir().unwrap();
    let f = frame(42, 0, 0, 8, 8);
    let path = dir.path().join("one.mcap");
    write_shard(&path, [&f], &shards::ShardConfig::default()).unwrap();
    let back: Vec<FrameRecord> = ShardReader::open([&path])
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert_eq!(back.len(), 1);
    assert_bitwise_eq(&f, &back[0]);
}

#[test]
fn layout_as_the_mcap_crate_sees_it() {
    let dir = tempfile::tempdir().unwrap();
    let input = frames(10..33);
    let path = dir.path().join("s.mcap");
    write_shard(&path, &input, &small_chunks()).unwrap();
    let bytes = std::fs::read(&path).unwrap();

    // Header: fixed library string, no profile.
    let first = mcap::read::LinearReader::new(&bytes)
        .unwrap()
        .next()
        .unwrap()
        .unwrap();
    match first {
        mcap::records::Record::Header(h) => {
            assert_eq!(
                (h.profile.as_str(), h.library.as_str()),
                ("", shards::LIBRARY)
            )
        }
        other => panic!("first record is {other:?}"),
    }
    // Full index: statistics, chunk indexes with message indexes, metadata index,
    // summary offsets.
    let footer = mcap::read::footer(&bytes).unwrap();
    assert!(footer.summary_start > 0 && footer.summary_offset_start > footer.summary_start);
    assert_ne!(footer.summary_crc, 0);
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let stats = summary.stats.as_ref().unwrap();
    assert_eq!(stats.message_count, 6 * 23);
    assert_eq!(
        (
            stats.channel_count,
            stats.schema_count,
            stats.metadata_count
        ),
        (6, 6, 1)
    );
    assert_eq!(stats.chunk_count as usize, summary.chunk_indexes.len());
    assert_eq!(stats.message_start_time, 10 * shards::FRAME_PERIOD_NS);
    assert_eq!(stats.message_end_time, 32 * shards::FRAME_PERIOD_NS);
    for ci in &summary.chunk_indexes {
        assert_eq!(ci.compression, "zstd");
        assert!(!ci.message_index_offsets.is_empty());
        assert!(ci.compressed_size < ci.uncompressed_size);
    }
    for ch in summary.channels.values() {
        let schema = ch.schema.as_ref().unwrap();
        assert_eq!(
            (schema.encoding.as_str(), ch.message_encoding.as_str()),
            ("protobuf", "protobuf")
        );
        // Each schema is a FileDescriptorSet holding the message's file and its imports.
        let fds =
            <prost_types::FileDescriptorSet as prost::Message>::decode(&schema.data[..]).unwrap();
        let (package, message) = schema.name.split_once('.').unwrap();
        assert!(
            fds.file
                .iter()
                .any(|f| f.package() == package
                    && f.message_type.iter().any(|m| m.name() == message)),
            "{} not in its descriptor set",
            schema.name
        );
        if package == "foxglove" {
            assert!(
                fds.file
                    .iter()
                    .any(|f| f.name() == "google/protobuf/timestamp.proto")
            );
        }
    }
    let meta = mcap::read::metadata(&bytes, &summary.metadata_indexes[0]).unwrap();
    assert_eq!(meta.name, shards::SHARD_METADATA_NAME);
    assert_eq!(meta.metadata["frame_count"], "23");
    assert_eq!(meta.metadata["first_frame"], "10");
    assert_eq!(meta.metadata["frame_period_ns"], "100000000");

    // A linear pass with chunk CRCs checked: six messages per frame, at its log time.
    let mut per_time: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    let opts = mcap::read::Options::ValidateChunkCrcs.into();
    for m in mcap::MessageStream::new_with_options(&bytes, opts).unwrap() {
        let m = m.unwrap();
        assert_eq!(m.publish_time, m.log_time);
        per_time
            .entry(m.log_time)
            .or_default()
            .push(m.channel.topic.clone());
    }
    let times: Vec<u64> = per_time.keys().copied().collect();
    let want: Vec<u64> = (10..33).map(|i| i * shards::FRAME_PERIOD_NS).collect();
    assert_eq!(times, want);
    for topics in per_time.values() {
        assert_eq!(
            topics,
            &[
                "/camera/calibration",
                "/tf",
                "/camera/image",
                "/labels",
                "/labels/points",
                "/labels/lines"
            ]
        );
    }
}
