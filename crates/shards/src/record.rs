//! The per-frame record the shard stage hands to the writer and the reader gives back.

use crate::error::ShardError;
use bytes::Bytes;
use geometry::{Camera, Pose};
use serde::{Deserialize, Serialize};
pub use tables::{LabelSource, Split};

/// Encoding of the image file, as foxglove.CompressedImage names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ImageFormat {
    Png,
    Jpeg,
}

const PNG_SIGNATURE: &[u8] = &[0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
const JPEG_SOI: &[u8] = &[0xFF, 0xD8, 0xFF];

impl ImageFormat {
    /// The `format` string of foxglove.CompressedImage.
    pub fn as_str(self) -> &'static str {
        match self {
            ImageFormat::Png => "png",
            ImageFormat::Jpeg => "jpeg",
        }
    }

    /// Parses `png`, `jpeg` (and `jpg`, which some tools write).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "png" => Some(ImageFormat::Png),
            "jpeg" | "jpg" => Some(ImageFormat::Jpeg),
            _ => None,
        }
    }

    /// The format whose signature starts `bytes`.
    pub fn sniff(bytes: &[u8]) -> Option<Self> {
        if bytes.starts_with(PNG_SIGNATURE) {
            Some(ImageFormat::Png)
        } else if bytes.starts_with(JPEG_SOI) {
            Some(ImageFormat::Jpeg)
        } else {
            None
        }
    }
}

impl From<tables::image_file::Encoding> for ImageFormat {
    /// The format `tables::image_file::check_complete` found whole.
    fn from(e: tables::image_file::Encoding) -> Self {
        match e {
            tables::image_file::Encoding::Png => ImageFormat::Png,
            tables::image_file::Encoding::Jpeg => ImageFormat::Jpeg,
        }
    }
}

/// One frame of a shard: image file, camera, pose and its point and line labels.
///
/// Points: `keypoints`, `point3d_ids`, `points3d` and `point_valid` have one entry per
/// keypoint. Lines: `segments` (x1, y1, x2, y2), `track_ids`, `lines3d` (X1, Y1, Z1,
/// X2, Y2, Z2) and `line_valid` have one entry per segment. 3D values are meaningful
/// (and must be finite) only where the matching validity flag is set.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRecord {
    pub frame_id: u64,
    /// Image path relative to the dataset root.
    pub name: String,
    pub split: Split,
    pub camera: Camera,
    /// World-to-camera.
    pub pose: Pose,
    /// The original image file's bytes, never re-encoded. A [`Bytes`]: a frame read
    /// from a shard holds a slice of its decompressed chunk instead of a copy (the
    /// trainer's reader thread spent half its time copying images it then did not
    /// decode); `Vec<u8>::into()` makes one.
    pub image_bytes: Bytes,
    pub image_format: ImageFormat,
    /// COLMAP pixels (centre of the top-left pixel at (0.5, 0.5)).
    pub keypoints: Vec<[f64; 2]>,
    /// COLMAP point3D id, -1 = none.
    pub point3d_ids: Vec<i64>,
    pub points3d: Vec<[f64; 3]>,
    pub point_valid: Vec<bool>,
    pub segments: Vec<[f64; 4]>,
    /// LIMAP track id, -1 = none.
    pub track_ids: Vec<i64>,
    /// 3D endpoints, the first matching the segment's (x1, y1) when
    /// `endpoints_aligned`.
    pub lines3d: Vec<[f64; 6]>,
    pub line_valid: Vec<bool>,
    pub label_source: LabelSource,
    pub endpoints_aligned: bool,
}

impl FrameRecord {
    /// A frame without labels (a test frame, or one to be filled in): no keypoints, no
    /// segments, label source `sfm`, endpoints aligned.
    pub fn unlabelled(
        frame_id: u64,
        name: String,
        split: Split,
        camera: Camera,
        pose: Pose,
        image_bytes: impl Into<Bytes>,
        image_format: ImageFormat,
    ) -> Self {
        FrameRecord {
            frame_id,
            name,
            split,
            camera,
            pose,
            image_bytes: image_bytes.into(),
            image_format,
            keypoints: Vec::new(),
            point3d_ids: Vec::new(),
            points3d: Vec::new(),
            point_valid: Vec::new(),
            segments: Vec::new(),
            track_ids: Vec::new(),
            lines3d: Vec::new(),
            line_valid: Vec::new(),
            label_source: LabelSource::Sfm,
            endpoints_aligned: true,
        }
    }

    /// Checks that the per-keypoint and per-segment arrays have equal lengths, that
    /// every coordinate that is used is finite, that ids are >= -1, and that the image
    /// bytes start with the signature of `image_format`.
    pub fn validate(&self) -> Result<(), ShardError> {
        let bad = |reason: String| ShardError::InvalidFrame {
            frame_id: self.frame_id,
            reason,
        };
        if self.name.is_empty() {
            return Err(bad("empty image name".into()));
        }
        self.camera
            .validate()
            .map_err(|e| bad(format!("camera: {e}")))?;
        if !self.pose.is_finite() {
            return Err(bad("pose is not finite".into()));
        }
        match ImageFormat::sniff(&self.image_bytes) {
            Some(f) if f == self.image_format => {}
            Some(f) => {
                return Err(bad(format!(
                    "image bytes are {} but image_format says {}",
                    f.as_str(),
                    self.image_format.as_str()
                )));
            }
            None => {
                return Err(bad(format!(
                    "image bytes ({} bytes) do not start with a PNG or JPEG signature",
                    self.image_bytes.len()
                )));
            }
        }

        let n = self.keypoints.len();
        let point_lens = [
            ("point3d_ids", self.point3d_ids.len()),
            ("points3d", self.points3d.len()),
            ("point_valid", self.point_valid.len()),
        ];
        for (what, len) in point_lens {
            if len != n {
                return Err(bad(format!("{n} keypoints but {len} {what}")));
            }
        }
        let m = self.segments.len();
        let line_lens = [
            ("track_ids", self.track_ids.len()),
            ("lines3d", self.lines3d.len()),
            ("line_valid", self.line_valid.len()),
        ];
        for (what, len) in line_lens {
            if len != m {
                return Err(bad(format!("{m} segments but {len} {what}")));
            }
        }

        for (i, kp) in self.keypoints.iter().enumerate() {
            if !all_finite(kp) {
                return Err(bad(format!("keypoint {i} is not finite: {kp:?}")));
            }
            if self.point3d_ids[i] < -1 {
                return Err(bad(format!(
                    "keypoint {i}: point3D id {} (ids are >= 0, or -1 for none)",
                    self.point3d_ids[i]
                )));
            }
            if self.point_valid[i] && !all_finite(&self.points3d[i]) {
                return Err(bad(format!(
                    "keypoint {i}: valid 3D point is not finite: {:?}",
                    self.points3d[i]
                )));
            }
        }
        for (i, seg) in self.segments.iter().enumerate() {
            if !all_finite(seg) {
                return Err(bad(format!("segment {i} is not finite: {seg:?}")));
            }
            if self.track_ids[i] < -1 {
                return Err(bad(format!(
                    "segment {i}: track id {} (ids are >= 0, or -1 for none)",
                    self.track_ids[i]
                )));
            }
            if self.line_valid[i] && !all_finite(&self.lines3d[i]) {
                return Err(bad(format!(
                    "segment {i}: valid 3D line is not finite: {:?}",
                    self.lines3d[i]
                )));
            }
        }
        Ok(())
    }

    /// Number of keypoints with a valid 3D label.
    pub fn valid_points(&self) -> usize {
        self.point_valid.iter().filter(|&&v| v).count()
    }

    /// Number of segments with a valid 3D line.
    pub fn valid_lines(&self) -> usize {
        self.line_valid.iter().filter(|&&v| v).count()
    }
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::CameraModel;

    fn frame() -> FrameRecord {
        let mut png = PNG_SIGNATURE.to_vec();
        png.extend_from_slice(b"rest");
        FrameRecord {
            frame_id: 7,
            name: "seq-01/frame-000007.color.png".into(),
            split: Split::Train,
            camera: Camera::new(
                CameraModel::SimplePinhole,
                640,
                480,
                vec![525.0, 320.0, 240.0],
            )
            .unwrap(),
            pose: Pose::identity(),
            image_bytes: png.into(),
            image_format: ImageFormat::Png,
            keypoints: vec![[1.5, 2.5], [3.0, 4.0]],
            point3d_ids: vec![4, -1],
            points3d: vec![[0.1, 0.2, 0.3], [f64::NAN; 3]],
            point_valid: vec![true, false],
            segments: vec![[0.0, 0.0, 10.0, 10.0]],
            track_ids: vec![2],
            lines3d: vec![[0.0, 0.0, 1.0, 1.0, 1.0, 1.0]],
            line_valid: vec![true],
            label_source: LabelSource::Sfm,
            endpoints_aligned: true,
        }
    }

    #[test]
    fn valid_frame_passes_and_invalid_entries_may_hold_nan() {
        frame().validate().unwrap();
    }

    #[test]
    fn rejects_each_inconsistency() {
        type Mutation = Box<dyn Fn(&mut FrameRecord)>;
        let cases: Vec<(&str, Mutation)> = vec![
            (
                "1 segments but 0 track_ids",
                Box::new(|f| f.track_ids.clear()),
            ),
            (
                "2 keypoints but 1 point_valid",
                Box::new(|f| {
                    f.point_valid.pop();
                }),
            ),
            (
                "valid 3D point is not finite",
                Box::new(|f| f.point_valid[1] = true),
            ),
            (
                "keypoint 0 is not finite",
                Box::new(|f| f.keypoints[0][1] = f64::INFINITY),
            ),
            (
                "valid 3D line is not finite",
                Box::new(|f| f.lines3d[0][5] = f64::NAN),
            ),
            ("track id -2", Box::new(|f| f.track_ids[0] = -2)),
            ("point3D id -5", Box::new(|f| f.point3d_ids[0] = -5)),
            (
                "image bytes are png but image_format says jpeg",
                Box::new(|f| f.image_format = ImageFormat::Jpeg),
            ),
            (
                "do not start with a PNG or JPEG",
                Box::new(|f| f.image_bytes = Bytes::from_static(b"GIF89a")),
            ),
            (
                "camera:",
                Box::new(|f| f.camera.params.pop().map(|_| ()).unwrap_or(())),
            ),
            (
                "pose is not finite",
                Box::new(|f| f.pose.translation.x = f64::NAN),
            ),
            ("empty image name", Box::new(|f| f.name.clear())),
        ];
        for (want, mutate) in cases {
            let mut f = frame();
            mutate(&mut f);
            let err = f.validate().expect_err(want).to_string();
            assert!(err.contains(want), "expected {want:?} in {err:?}");
            assert!(err.starts_with("frame 7:"), "{err}");
        }
    }

    #[test]
    fn sniffs_formats() {
        assert_eq!(
            ImageFormat::sniff(&[0xFF, 0xD8, 0xFF, 0xE0]),
            Some(ImageFormat::Jpeg)
        );
        assert_eq!(ImageFormat::sniff(PNG_SIGNATURE), Some(ImageFormat::Png));
        assert_eq!(ImageFormat::sniff(b"\x89PN"), None);
        assert_eq!(ImageFormat::from_name("jpg"), Some(ImageFormat::Jpeg));
        assert_eq!(ImageFormat::from_name("webp"), None);
    }
}
