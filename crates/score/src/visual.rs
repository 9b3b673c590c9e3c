//! `visual.mcap`: what a localisation run saw and found, for Foxglove (docs/formats.md,
//! "Localisation outputs"). Written by `pl2map localize --visual` and by the score stage
//! with `visual = true`. One message per channel and query, at log time
//! `(id + 1) * 0.1 s` (`id`: the query's position or the frame id):
//!
//! | topic | schema | frame | what |
//! |---|---|---|---|
//! | `/camera/image` | `foxglove.CompressedImage` | `camera` | the image file as read |
//! | `/camera/calibration` | `foxglove.CameraCalibration` | `camera` | its camera |
//! | `/tf` | `foxglove.FrameTransform` | `world` -> `camera` | the estimated pose (none without one) |
//! | `/tf` | `foxglove.FrameTransform` | `world` -> `camera_gt` | the ground truth, where known |
//! | `/predictions/points` | `foxglove.PointCloud` | `world` | predicted 3D points: x y z, reliability (float32), red green blue alpha (uint8) |
//! | `/predictions/lines` | `foxglove.SceneUpdate` | `world` | predicted 3D lines, one LINE_LIST, a colour per endpoint |
//!
//! Colours: green for an inlier of the pose, red for a kept correspondence that is not
//! one, grey for a prediction under the reliability threshold; alpha grows with the
//! reliability (0.25 + 0.75 r). The pose shown is the points + lines one when it exists,
//! else the points one.

use crate::error::ScoreError;
use crate::evaluate::{Localised, ScoreConfig, Variant};
use crate::localiser::TestFrame;
use foxglove::Encode;
use foxglove::messages::{
    CameraCalibration, Color, CompressedImage, FrameTransform, LinePrimitive, PackedElementField,
    Point3, PointCloud, SceneEntity, SceneUpdate, Timestamp, line_primitive, packed_element_field,
};
use geometry::Pose;
use mcap::records::MessageHeader;
use std::collections::BTreeMap;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

pub const VISUAL_FILE: &str = "visual.mcap";
pub const TOPIC_IMAGE: &str = "/camera/image";
pub const TOPIC_CALIBRATION: &str = "/camera/calibration";
pub const TOPIC_TF: &str = "/tf";
pub const TOPIC_POINTS: &str = "/predictions/points";
pub const TOPIC_LINES: &str = "/predictions/lines";
/// The shards' frames of reference: one scene looks the same in both files.
pub use shards::{CAMERA_FRAME, WORLD_FRAME};
pub const GT_FRAME: &str = "camera_gt";
/// Bytes per point of `/predictions/points`: x y z reliability (float32), r g b a (u8).
pub const POINT_STRIDE: u32 = 20;
const PERIOD_NS: u64 = 100_000_000;

/// An [`stage::AtomicFile`] the MCAP writer can seek in.
struct Seekable(stage::AtomicFile);

impl Write for Seekable {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

impl Seek for Seekable {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.0.file().seek(pos)
    }
}

struct Channels {
    image: u16,
    calibration: u16,
    tf: u16,
    points: u16,
    lines: u16,
}

/// The MCAP file being written; [`VisualWriter::finish`] renames it into place.
pub struct VisualWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<Seekable>>,
    channels: Channels,
    sequence: u32,
    buf: Vec<u8>,
}

impl VisualWriter {
    pub fn create(path: &Path) -> Result<Self, ScoreError> {
        let file = stage::AtomicFile::create(path)?;
        let werr = mcap_err(path, "creating the file");
        let mut writer = mcap::WriteOptions::new()
            .profile("")
            .library("pl2map")
            .compression(Some(mcap::Compression::Zstd))
            .compression_threads(0)
            .create(BufWriter::with_capacity(1 << 20, Seekable(file)))
            .map_err(werr)?;
        let mut add = |schema: Option<foxglove::Schema>, topic: &str| -> Result<u16, ScoreError> {
            let schema = schema.ok_or_else(|| ScoreError::Visual {
                path: path.to_path_buf(),
                reason: format!("the foxglove crate gave no schema for {topic}"),
            })?;
            let werr = mcap_err(path, "adding a channel");
            let sid = writer
                .add_schema(&schema.name, &schema.encoding, &schema.data)
                .map_err(werr)?;
            let werr = mcap_err(path, "adding a channel");
            writer
                .add_channel(sid, topic, "protobuf", &BTreeMap::new())
                .map_err(werr)
        };
        let channels = Channels {
            image: add(CompressedImage::get_schema(), TOPIC_IMAGE)?,
            calibration: add(CameraCalibration::get_schema(), TOPIC_CALIBRATION)?,
            tf: add(FrameTransform::get_schema(), TOPIC_TF)?,
            points: add(PointCloud::get_schema(), TOPIC_POINTS)?,
            lines: add(SceneUpdate::get_schema(), TOPIC_LINES)?,
        };
        Ok(VisualWriter {
            path: path.to_path_buf(),
            writer,
            channels,
            sequence: 0,
            buf: Vec::new(),
        })
    }

    fn put(
        &mut self,
        channel_id: u16,
        log_time: u64,
        msg: &impl prost::Message,
    ) -> Result<(), ScoreError> {
        self.buf.clear();
        msg.encode(&mut self.buf).map_err(|e| ScoreError::Visual {
            path: self.path.clone(),
            reason: format!("encoding a message: {e}"),
        })?;
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.writer
            .write_to_known_channel(&header, &self.buf)
            .map_err(mcap_err(&self.path, "writing a message"))
    }

    /// One localised frame: its image, camera, poses and predictions. `gt`: the ground
    /// truth, where known.
    pub fn add(
        &mut self,
        frame: &TestFrame,
        l: &Localised,
        gt: Option<&Pose>,
        config: &ScoreConfig,
    ) -> Result<(), ScoreError> {
        let id = frame.frame_id();
        let log_time = id
            .checked_add(1)
            .and_then(|n| n.checked_mul(PERIOD_NS))
            .filter(|t| t / 1_000_000_000 <= u64::from(u32::MAX))
            .ok_or_else(|| ScoreError::Visual {
                path: self.path.clone(),
                reason: format!("frame id {id} is too large for a log time"),
            })?;
        let ts = Timestamp::new(
            (log_time / 1_000_000_000) as u32,
            (log_time % 1_000_000_000) as u32,
        );
        let r = &frame.record;
        let ch = self.channels.image;
        self.put(
            ch,
            log_time,
            &CompressedImage {
                timestamp: Some(ts),
                frame_id: CAMERA_FRAME.into(),
                data: r.image_bytes.clone(),
                format: r.image_format.as_str().into(),
            },
        )?;
        let ch = self.channels.calibration;
        self.put(ch, log_time, &shards::camera_calibration(&r.camera, ts))?;
        let shown = [Variant::PointsLines, Variant::Points]
            .into_iter()
            .find(|&v| l.result.variant(v).pose.is_some());
        let ch = self.channels.tf;
        if let Some(v) = shown {
            let pose = l.result.variant(v).pose.as_ref().expect("found above");
            self.put(
                ch,
                log_time,
                &shards::camera_transform(pose, CAMERA_FRAME, ts),
            )?;
        }
        if let Some(gt) = gt {
            self.put(ch, log_time, &shards::camera_transform(gt, GT_FRAME, ts))?;
        }
        let vr = shown.map(|v| l.result.variant(v));
        let (pmask, lmask) = match vr {
            Some(vr) => (&vr.point_inlier_mask[..], &vr.line_inlier_mask[..]),
            None => (&[][..], &[][..]),
        };
        let ch = self.channels.points;
        self.put(ch, log_time, &points(l, pmask, config, ts))?;
        let ch = self.channels.lines;
        self.put(ch, log_time, &lines(l, lmask, config, ts))?;
        Ok(())
    }

    /// Finishes the file (summary and index) and moves it into place.
    pub fn finish(mut self) -> Result<PathBuf, ScoreError> {
        self.writer
            .finish()
            .map_err(mcap_err(&self.path, "finishing the file"))?;
        let buffered = self.writer.into_inner();
        let Seekable(file) = buffered
            .into_inner()
            .map_err(|e| fileio::IoError::new(&self.path, e.into_error()))?;
        file.commit()?;
        Ok(self.path)
    }
}

fn mcap_err(path: &Path, what: &'static str) -> impl Fn(mcap::McapError) -> ScoreError {
    let path = path.to_path_buf();
    move |e| ScoreError::Visual {
        path: path.clone(),
        reason: format!("{what}: {e}"),
    }
}

/// RGBA of a prediction: kept (passes the reliability filter) and, if kept, its
/// inlier status (None: no pose).
pub fn colour(reliability: f64, kept: bool, inlier: Option<bool>) -> [u8; 4] {
    let r = if reliability.is_finite() {
        reliability.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let alpha = (255.0 * (0.25 + 0.75 * r)).round() as u8;
    let rgb = match (kept, inlier) {
        (false, _) => [150, 150, 150],
        (true, Some(true)) => [40, 220, 60],
        (true, Some(false)) => [230, 50, 40],
        (true, None) => [240, 200, 40],
    };
    [rgb[0], rgb[1], rgb[2], alpha]
}

/// Walks predictions in order: Some(index among the kept) for the kept ones.
fn kept_indices<'a>(
    rel: impl Iterator<Item = f64> + 'a,
    min: f64,
) -> impl Iterator<Item = Option<usize>> + 'a {
    let mut k = 0;
    rel.map(move |r| {
        (r >= min).then(|| {
            k += 1;
            k - 1
        })
    })
}

fn points(l: &Localised, mask: &[bool], config: &ScoreConfig, ts: Timestamp) -> PointCloud {
    let ps = &l.correspondences.points;
    let mut data = Vec::with_capacity(ps.len() * POINT_STRIDE as usize);
    let kept = kept_indices(
        ps.iter().map(|p| p.reliability),
        config.min_point_reliability,
    );
    for (p, k) in ps.iter().zip(kept) {
        for &c in p.point.world.iter() {
            data.extend_from_slice(&(c as f32).to_le_bytes());
        }
        data.extend_from_slice(&(p.reliability as f32).to_le_bytes());
        let inlier = k.and_then(|k| mask.get(k).copied());
        data.extend_from_slice(&colour(p.reliability, k.is_some(), inlier));
    }
    use packed_element_field::NumericType;
    let field = |name: &str, offset: u32, t: NumericType| PackedElementField {
        name: name.into(),
        offset,
        r#type: t as i32,
    };
    PointCloud {
        timestamp: Some(ts),
        frame_id: WORLD_FRAME.into(),
        pose: Some(shards::identity_pose()),
        point_stride: POINT_STRIDE,
        fields: vec![
            field("x", 0, NumericType::Float32),
            field("y", 4, NumericType::Float32),
            field("z", 8, NumericType::Float32),
            field("reliability", 12, NumericType::Float32),
            field("red", 16, NumericType::Uint8),
            field("green", 17, NumericType::Uint8),
            field("blue", 18, NumericType::Uint8),
            field("alpha", 19, NumericType::Uint8),
        ],
        data: data.into(),
    }
}

fn lines(l: &Localised, mask: &[bool], config: &ScoreConfig, ts: Timestamp) -> SceneUpdate {
    let ls = &l.correspondences.lines;
    let mut points = Vec::with_capacity(2 * ls.len());
    let mut colors = Vec::with_capacity(2 * ls.len());
    let kept = kept_indices(
        ls.iter().map(|l| l.reliability),
        config.min_line_reliability,
    );
    for (line, k) in ls.iter().zip(kept) {
        for end in [line.line.world.start, line.line.world.end] {
            points.push(Point3 {
                x: end.x,
                y: end.y,
                z: end.z,
            });
        }
        let inlier = k.and_then(|k| mask.get(k).copied());
        let c = colour(line.reliability, k.is_some(), inlier);
        let c = Color {
            r: f64::from(c[0]) / 255.0,
            g: f64::from(c[1]) / 255.0,
            b: f64::from(c[2]) / 255.0,
            a: f64::from(c[3]) / 255.0,
        };
        colors.push(c);
        colors.push(c);
    }
    SceneUpdate {
        deletions: vec![],
        entities: vec![SceneEntity {
            timestamp: Some(ts),
            frame_id: WORLD_FRAME.into(),
            id: "predictions/lines".into(),
            lifetime: None,
            frame_locked: false,
            lines: vec![LinePrimitive {
                r#type: line_primitive::Type::LineList as i32,
                pose: Some(shards::identity_pose()),
                thickness: 2.0,
                scale_invariant: true,
                points,
                color: None,
                colors,
                indices: vec![],
            }],
            ..Default::default()
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_follow_status_and_reliability() {
        assert_eq!(colour(1.0, true, Some(true)), [40, 220, 60, 255]);
        assert_eq!(colour(0.0, true, Some(false))[..3], [230, 50, 40]);
        assert_eq!(colour(0.0, true, Some(false))[3], 64);
        assert_eq!(colour(f64::NAN, false, None), [150, 150, 150, 64]);
        let k: Vec<_> = kept_indices([0.9, 0.1, 0.5, f64::NAN, 0.7].into_iter(), 0.5).collect();
        assert_eq!(k, [Some(0), None, Some(1), None, Some(2)]);
    }
}
