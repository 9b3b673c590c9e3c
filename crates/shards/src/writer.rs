//! Writes one MCAP shard: six channels, one log time per frame, zstd chunks and the
//! full index, through a temp file and a rename.
//!
//! Determinism: no wall-clock time is written (log and publish times derive from
//! the frame id, the header's library string is fixed), zstd runs single-threaded at
//! a fixed level (multi-threaded zstd frames differ from single-threaded ones), and
//! the mcap writer emits schemas, channels and indexes in id order. Same frames and
//! config => same bytes.

use crate::error::ShardError;
use crate::record::FrameRecord;
use crate::schema::{FRAME_LABELS_DESCRIPTOR_SET, FRAME_LABELS_SCHEMA_NAME, to_proto};
use crate::visual;
use fileio::io_err;
use foxglove::Encode;
use mcap::records::{MessageHeader, Metadata};
use serde::{Deserialize, Serialize};
use std::borrow::Borrow;
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

pub const TOPIC_CALIBRATION: &str = "/camera/calibration";
pub const TOPIC_TF: &str = "/tf";
pub const TOPIC_IMAGE: &str = "/camera/image";
pub const TOPIC_LABELS: &str = "/labels";
pub const TOPIC_POINTS: &str = "/labels/points";
pub const TOPIC_LINES: &str = "/labels/lines";

/// Log time of a frame: `frame_id * FRAME_PERIOD_NS`, so Foxglove plays a shard at
/// 10 frames per second and a frame id is recovered exactly from its log time.
pub const FRAME_PERIOD_NS: u64 = 100_000_000;

/// Name of the MCAP metadata record describing the shard.
pub const SHARD_METADATA_NAME: &str = "pl2map.shard";
/// Version of the shard layout (channels, schema, log time mapping).
pub const SHARD_FORMAT_VERSION: u32 = 1;
/// The MCAP header's library string: fixed (no build details), so bytes do not
/// depend on who built the tool.
pub const LIBRARY: &str = concat!("pl2map-shards/", env!("CARGO_PKG_VERSION"));

/// The log time of `frame_id`, or None past what a Foxglove timestamp (u32 seconds)
/// holds (frame ids up to about 4.3e10).
pub fn frame_log_time(frame_id: u64) -> Option<u64> {
    let t = frame_id.checked_mul(FRAME_PERIOD_NS)?;
    visual::timestamp(t).map(|_| t)
}

/// The frame id of a log time written by this crate, None if it is not a multiple of
/// the frame period.
pub fn frame_id_of_log_time(log_time: u64) -> Option<u64> {
    log_time
        .is_multiple_of(FRAME_PERIOD_NS)
        .then_some(log_time / FRAME_PERIOD_NS)
}

/// How shards are written. Part of the shard stage's configuration hash.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardConfig {
    /// Frames per shard file (the last shard may hold fewer).
    pub frames_per_shard: usize,
    /// Target uncompressed chunk size in bytes: a chunk is closed after the message
    /// that crosses it. Smaller chunks make seeking cheaper, larger ones compress better.
    pub chunk_size: u64,
    /// zstd level of the chunks (1-22).
    pub zstd_level: u32,
}

impl Default for ShardConfig {
    fn default() -> Self {
        ShardConfig {
            frames_per_shard: 500,
            chunk_size: 4 << 20,
            zstd_level: 3,
        }
    }
}

/// What one written shard holds.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardInfo {
    pub file: PathBuf,
    pub first_frame: u64,
    pub last_frame: u64,
    pub frame_count: u64,
    /// sha256 of the file, hex.
    pub sha256: String,
    pub bytes: u64,
}

/// Writes `frames` (strictly increasing frame ids, at least one) into the MCAP file
/// `path`, atomically.
pub fn write_shard<'a>(
    path: impl AsRef<Path>,
    frames: impl IntoIterator<Item = &'a FrameRecord>,
    config: &ShardConfig,
) -> Result<ShardInfo, ShardError> {
    write_frames(path.as_ref(), frames.into_iter().map(Ok), config)
}

struct Channels {
    calibration: u16,
    tf: u16,
    image: u16,
    labels: u16,
    points: u16,
    lines: u16,
}

fn foxglove_schema<T: Encode>(path: &Path, topic: &str) -> Result<foxglove::Schema, ShardError> {
    T::get_schema().ok_or_else(|| ShardError::Channel {
        path: path.to_path_buf(),
        topic: topic.into(),
        reason: "the foxglove crate gave no schema".into(),
    })
}

impl Channels {
    /// Registers the six channels, in a fixed order (schema and channel ids 1-6).
    fn add<W: Write + std::io::Seek>(
        w: &mut mcap::Writer<W>,
        path: &Path,
    ) -> Result<Self, ShardError> {
        use foxglove::messages as fg;
        let mut add = |schema: foxglove::Schema, topic: &str| -> Result<u16, ShardError> {
            let werr = |source| ShardError::Write {
                path: path.to_path_buf(),
                context: format!("adding channel {topic}"),
                source,
            };
            let sid = w
                .add_schema(&schema.name, &schema.encoding, &schema.data)
                .map_err(werr)?;
            w.add_channel(sid, topic, "protobuf", &BTreeMap::new())
                .map_err(werr)
        };
        let labels_schema = foxglove::Schema::new(
            FRAME_LABELS_SCHEMA_NAME,
            "protobuf",
            FRAME_LABELS_DESCRIPTOR_SET,
        );
        Ok(Channels {
            calibration: add(
                foxglove_schema::<fg::CameraCalibration>(path, TOPIC_CALIBRATION)?,
                TOPIC_CALIBRATION,
            )?,
            tf: add(
                foxglove_schema::<fg::FrameTransform>(path, TOPIC_TF)?,
                TOPIC_TF,
            )?,
            image: add(
                foxglove_schema::<fg::CompressedImage>(path, TOPIC_IMAGE)?,
                TOPIC_IMAGE,
            )?,
            labels: add(labels_schema, TOPIC_LABELS)?,
            points: add(
                foxglove_schema::<fg::PointCloud>(path, TOPIC_POINTS)?,
                TOPIC_POINTS,
            )?,
            lines: add(
                foxglove_schema::<fg::SceneUpdate>(path, TOPIC_LINES)?,
                TOPIC_LINES,
            )?,
        })
    }
}

fn write_options(config: &ShardConfig) -> mcap::WriteOptions {
    mcap::WriteOptions::new()
        .profile("")
        .library(LIBRARY)
        .compression(Some(mcap::Compression::Zstd))
        .compression_level(config.zstd_level)
        .compression_threads(0)
        .chunk_size(Some(config.chunk_size))
}

/// The writer behind [`write_shard`] and [`crate::write_shards`]: frames come from an
/// iterator of results so that a frame source can fail mid-shard (the temp file is
/// then removed and nothing appears under `path`).
pub(crate) fn write_frames<F: Borrow<FrameRecord>>(
    path: &Path,
    frames: impl Iterator<Item = Result<F, ShardError>>,
    config: &ShardConfig,
) -> Result<ShardInfo, ShardError> {
    let mut file = stage::AtomicFile::create(path)?;
    let werr = |context: String| {
        let path = path.to_path_buf();
        move |source| ShardError::Write {
            path,
            context,
            source,
        }
    };
    let (first, last, count) = {
        let out = BufWriter::with_capacity(1 << 20, file.file());
        let mut w = write_options(config)
            .create(out)
            .map_err(werr("creating the file".into()))?;
        let ch = Channels::add(&mut w, path)?;
        let mut buf = Vec::new();
        let mut range: Option<(u64, u64)> = None;
        let mut count: u32 = 0;
        for item in frames {
            let item = item?;
            let f: &FrameRecord = item.borrow();
            if let Some((_, prev)) = range
                && f.frame_id <= prev
            {
                return Err(ShardError::FramesNotSorted {
                    previous: prev,
                    next: f.frame_id,
                });
            }
            f.validate()?;
            let log_time = frame_log_time(f.frame_id).ok_or_else(|| ShardError::InvalidFrame {
                frame_id: f.frame_id,
                reason: format!(
                    "frame id too large for a log time of frame_id * {FRAME_PERIOD_NS} ns"
                ),
            })?;
            let ts = visual::timestamp(log_time).ok_or_else(|| ShardError::InvalidFrame {
                frame_id: f.frame_id,
                reason: "log time does not fit a timestamp".into(),
            })?;
            let mut put = |channel_id: u16, topic: &'static str, msg: &dyn EncodeTo| {
                buf.clear();
                msg.encode_to(&mut buf)
                    .map_err(|reason| ShardError::Encode {
                        frame_id: f.frame_id,
                        topic,
                        reason,
                    })?;
                let header = MessageHeader {
                    channel_id,
                    sequence: count,
                    log_time,
                    publish_time: log_time,
                };
                w.write_to_known_channel(&header, &buf)
                    .map_err(werr(format!("writing frame {} on {topic}", f.frame_id)))
            };
            put(
                ch.calibration,
                TOPIC_CALIBRATION,
                &visual::camera_calibration(&f.camera, ts),
            )?;
            put(
                ch.tf,
                TOPIC_TF,
                &visual::camera_transform(&f.pose, visual::CAMERA_FRAME, ts),
            )?;
            put(ch.image, TOPIC_IMAGE, &visual::compressed_image(f, ts))?;
            put(ch.labels, TOPIC_LABELS, &to_proto(f))?;
            put(ch.points, TOPIC_POINTS, &visual::point_cloud(f, ts))?;
            put(ch.lines, TOPIC_LINES, &visual::scene_update(f, ts))?;
            range = Some((range.map_or(f.frame_id, |r| r.0), f.frame_id));
            count = count
                .checked_add(1)
                .ok_or_else(|| ShardError::InvalidFrame {
                    frame_id: f.frame_id,
                    reason: "more than 2^32 frames in one shard".into(),
                })?;
        }
        let Some((first, last)) = range else {
            return Err(ShardError::EmptyShard {
                what: path.display().to_string(),
            });
        };
        let metadata = Metadata {
            name: SHARD_METADATA_NAME.into(),
            metadata: BTreeMap::from([
                ("format_version".into(), SHARD_FORMAT_VERSION.to_string()),
                ("frame_period_ns".into(), FRAME_PERIOD_NS.to_string()),
                ("first_frame".into(), first.to_string()),
                ("last_frame".into(), last.to_string()),
                ("frame_count".into(), count.to_string()),
                ("labels_schema".into(), FRAME_LABELS_SCHEMA_NAME.into()),
            ]),
        };
        w.write_metadata(&metadata)
            .map_err(werr("writing metadata".into()))?;
        w.finish().map_err(werr("finishing the file".into()))?;
        let mut out = w.into_inner();
        out.flush().map_err(io_err(path))?;
        (first, last, count)
    };
    file.commit()?;
    let sha256 = stage::sha256_file(path)?;
    let bytes = std::fs::metadata(path).map_err(io_err(path))?.len();
    Ok(ShardInfo {
        file: path.to_path_buf(),
        first_frame: first,
        last_frame: last,
        frame_count: u64::from(count),
        sha256,
        bytes,
    })
}

/// A protobuf message encoded into a reusable buffer.
trait EncodeTo {
    fn encode_to(&self, buf: &mut Vec<u8>) -> Result<(), String>;
}

impl<M: prost::Message> EncodeTo for M {
    fn encode_to(&self, buf: &mut Vec<u8>) -> Result<(), String> {
        self.encode(buf).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_time_mapping() {
        assert_eq!(frame_log_time(0), Some(0));
        assert_eq!(frame_log_time(7), Some(700_000_000));
        assert_eq!(frame_id_of_log_time(700_000_000), Some(7));
        assert_eq!(frame_id_of_log_time(700_000_001), None);
        // Largest id whose time fits u32 seconds: floor((2^32 - 1 + 0.999999999) * 10).
        assert!(frame_log_time(42_949_672_959).is_some());
        assert!(frame_log_time(42_949_672_960).is_none());
        assert!(frame_log_time(u64::MAX).is_none());
    }
}
