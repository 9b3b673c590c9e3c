//! Where the 2D-3D correspondences of a frame come from: the network
//! ([`crate::network`], when built) or the shard labels ([`crate::oracle`]).

use crate::error::ScoreError;
use geometry::lines::{Segment2, Segment3};
use geometry::{Camera, Pose};
use nalgebra::{Vector2, Vector3};
use pose::{LineMatch, PointMatch};
use shards::{FrameRecord, Split};

/// One frame to localise, as read from a shard: image file bytes, camera, ground-truth
/// pose and (training shards only) its labels. A localiser may use anything but the
/// pose; the oracle uses the labels, which were made with that pose.
#[derive(Clone, Debug)]
pub struct TestFrame {
    pub record: FrameRecord,
}

impl TestFrame {
    pub fn frame_id(&self) -> u64 {
        self.record.frame_id
    }

    /// Dataset-relative image name (the hloc result files' key).
    pub fn name(&self) -> &str {
        &self.record.name
    }

    pub fn camera(&self) -> &Camera {
        &self.record.camera
    }

    /// World-to-camera ground truth the errors are measured against.
    pub fn gt_pose(&self) -> &Pose {
        &self.record.pose
    }

    pub fn split(&self) -> Split {
        self.record.split
    }

    /// Decodes the image file (PNG or JPEG, as stored) to 8-bit grey exactly as OpenCV's
    /// grey reader does (`features::decode_gray`), as the network was trained.
    #[cfg(feature = "network")]
    pub fn gray_image(&self) -> Result<image::GrayImage, ScoreError> {
        features::decode_gray(&self.record.image_bytes).map_err(|e| ScoreError::Frame {
            frame_id: self.frame_id(),
            name: self.name().to_string(),
            reason: e.to_string(),
        })
    }
}

/// A keypoint (COLMAP pixels) and its predicted 3D world point, as the pose crate
/// takes them, with the prediction's reliability.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointCorrespondence {
    pub point: PointMatch,
    /// Predicted reliability in [0, 1]; predictions under the threshold are dropped.
    pub reliability: f64,
}

impl PointCorrespondence {
    /// A keypoint `[x, y]` and its world point `[X, Y, Z]`.
    pub fn new(pixel: [f64; 2], world: [f64; 3], reliability: f64) -> Self {
        PointCorrespondence {
            point: PointMatch {
                pixel: Vector2::from(pixel),
                world: Vector3::from(world),
            },
            reliability,
        }
    }
}

/// A detected segment (COLMAP pixels) and predicted 3D endpoints on the same world
/// line, as the pose crate takes them, with the prediction's reliability.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineCorrespondence {
    pub line: LineMatch,
    pub reliability: f64,
}

impl LineCorrespondence {
    /// A segment `[x1, y1, x2, y2]` and the world endpoints `start` (of (x1, y1)) and
    /// `end`.
    pub fn new(segment: [f64; 4], start: [f64; 3], end: [f64; 3], reliability: f64) -> Self {
        LineCorrespondence {
            line: LineMatch {
                segment: Segment2 {
                    start: Vector2::new(segment[0], segment[1]),
                    end: Vector2::new(segment[2], segment[3]),
                },
                world: Segment3 {
                    start: Vector3::from(start),
                    end: Vector3::from(end),
                },
            },
            reliability,
        }
    }
}

/// Time one step of a localiser took on a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Timing {
    /// Short snake_case name (`detect`, `network`, ...): a column `time_<step>_ms` of
    /// the per-frame table.
    pub step: String,
    pub ms: f64,
}

/// Everything a localiser proposes for one frame, before any filtering.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Correspondences {
    pub points: Vec<PointCorrespondence>,
    pub lines: Vec<LineCorrespondence>,
    pub timings: Vec<Timing>,
}

/// A source of 2D-3D correspondences.
pub trait Localiser {
    /// One line for the summary: what the correspondences come from.
    fn describe(&self) -> String;

    /// The split whose shards are scored. Test frames by default; the oracle needs
    /// labels, which only training shards carry.
    fn split(&self) -> Split {
        Split::Test
    }

    /// Correspondences of one frame. An error stops the run: it means the localiser
    /// cannot work (unreadable image, broken model), not that the frame is hard.
    fn correspond(&mut self, frame: &TestFrame) -> Result<Correspondences, ScoreError>;

    /// Correspondences of several frames, in their order, each with its own result: a
    /// frame that cannot be read does not stop the others (`pl2map localize`). The
    /// default corresponds one frame after the other; a localiser with per-frame work
    /// that can run side by side (the network's front-end) overrides it, with the same
    /// results.
    fn correspond_each(
        &mut self,
        frames: &[TestFrame],
    ) -> Vec<Result<Correspondences, ScoreError>> {
        frames.iter().map(|f| self.correspond(f)).collect()
    }

    /// Correspondences of several frames, in their order; the first error (in frame
    /// order) stops the run (the score stage).
    fn correspond_many(
        &mut self,
        frames: &[TestFrame],
    ) -> Result<Vec<Correspondences>, ScoreError> {
        self.correspond_each(frames).into_iter().collect()
    }
}

pub(crate) fn split_name(s: Split) -> &'static str {
    match s {
        Split::Train => "train",
        Split::Test => "test",
    }
}
