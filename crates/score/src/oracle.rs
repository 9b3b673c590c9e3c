//! The oracle localiser: correspondences from the shard labels instead of the network,
//! an upper bound of the network's accuracy and a check of the solvers.
//!
//! Which frames: the shard stage writes labels for training frames only (test frames
//! have no SfM labels in real datasets, see `shards::shard_stage`), so the oracle scores the
//! training shards and says so in the summary. Its ground truth is the pose the labels
//! were made with (the shard's pose), so on exact labels (the synthetic scene) the
//! errors measure the solvers and refinement alone. Building labels for test frames
//! from their depth maps was left aside: it needs the frames table (the shards do not
//! carry depth) and a detector, and its 3D points would be made with the very pose
//! they are scored against, so it would check nothing the training frames do not.

use crate::error::ScoreError;
use crate::localiser::{
    Correspondences, LineCorrespondence, Localiser, PointCorrespondence, TestFrame, Timing,
};
use shards::Split;
use std::time::Instant;

/// Points with a valid 3D label and lines with valid 3D endpoints, reliability 1.
#[derive(Clone, Debug, Default)]
pub struct OracleLocaliser;

impl Localiser for OracleLocaliser {
    fn describe(&self) -> String {
        "oracle: label correspondences of the training shards (test frames carry no labels)"
            .to_string()
    }

    fn split(&self) -> Split {
        Split::Train
    }

    fn correspond(&mut self, frame: &TestFrame) -> Result<Correspondences, ScoreError> {
        let t = Instant::now();
        let r = &frame.record;
        let points = r
            .keypoints
            .iter()
            .zip(&r.points3d)
            .zip(&r.point_valid)
            .filter(|(_, valid)| **valid)
            .map(|((xy, xyz), _)| PointCorrespondence::new(*xy, *xyz, 1.0))
            .collect();
        let lines = r
            .segments
            .iter()
            .zip(&r.lines3d)
            .zip(&r.line_valid)
            .filter(|(_, valid)| **valid)
            .map(|((seg, e), _)| {
                LineCorrespondence::new(*seg, [e[0], e[1], e[2]], [e[3], e[4], e[5]], 1.0)
            })
            .collect();
        Ok(Correspondences {
            points,
            lines,
            timings: vec![Timing {
                step: "labels".into(),
                ms: t.elapsed().as_secs_f64() * 1e3,
            }],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::{Camera, CameraModel, Pose};
    use nalgebra::{Vector2, Vector3};
    use shards::{FrameRecord, ImageFormat, LabelSource};

    fn record() -> FrameRecord {
        FrameRecord {
            frame_id: 3,
            name: "seq-01/frame-000003.color.png".into(),
            split: Split::Train,
            camera: Camera::new(CameraModel::Pinhole, 64, 48, vec![50.0, 50.0, 32.0, 24.0])
                .unwrap(),
            pose: Pose::identity(),
            image_bytes: vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A].into(),
            image_format: ImageFormat::Png,
            keypoints: vec![[1.0, 2.0], [3.0, 4.0]],
            point3d_ids: vec![7, -1],
            points3d: vec![[1.0, 1.0, 5.0], [f64::NAN; 3]],
            point_valid: vec![true, false],
            segments: vec![[0.0, 0.0, 10.0, 10.0], [5.0, 5.0, 6.0, 6.0]],
            track_ids: vec![-1, 2],
            lines3d: vec![[f64::NAN; 6], [0.0, 0.0, 4.0, 1.0, 1.0, 4.0]],
            line_valid: vec![false, true],
            label_source: LabelSource::SyntheticExact,
            endpoints_aligned: true,
        }
    }

    #[test]
    fn keeps_only_valid_labels() {
        let c = OracleLocaliser
            .correspond(&TestFrame { record: record() })
            .unwrap();
        assert_eq!(c.points.len(), 1);
        assert_eq!(c.points[0].point.pixel, Vector2::new(1.0, 2.0));
        assert_eq!(c.points[0].point.world, Vector3::new(1.0, 1.0, 5.0));
        assert_eq!(c.points[0].reliability, 1.0);
        assert_eq!(c.lines.len(), 1);
        assert_eq!(c.lines[0].line.world.start, Vector3::new(0.0, 0.0, 4.0));
        assert_eq!(c.lines[0].line.world.end, Vector3::new(1.0, 1.0, 4.0));
        assert_eq!(c.timings.len(), 1);
        assert_eq!(OracleLocaliser.split(), Split::Train);
    }
}
