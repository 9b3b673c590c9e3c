//! The network localiser: a trained checkpoint through `train::Predictor` (the
//! front-end on the CPU, the PL2Map network on the CPU backend or a CUDA GPU). Behind
//! the `network` feature (on by default) so the rest of the crate builds without burn.

use crate::error::ScoreError;
use crate::localiser::{
    Correspondences, LineCorrespondence, Localiser, PointCorrespondence, TestFrame, Timing,
};
use crate::query_lines::QuerySegments;
use std::path::{Path, PathBuf};
use std::time::Instant;
use train::Predictor;

/// Correspondences predicted by a trained network for each test frame.
pub struct NetworkLocaliser {
    predictor: Predictor,
    checkpoint: PathBuf,
    /// Query segments from files instead of the front-end's line detector.
    query_segments: Option<QuerySegments>,
}

impl NetworkLocaliser {
    /// Loads a checkpoint (`model.ckpt` or `checkpoint.ckpt` of `pl2map train`).
    pub fn load(checkpoint: &Path) -> Result<Self, ScoreError> {
        Self::load_on(checkpoint, train::Device::Cpu)
    }

    /// [`NetworkLocaliser::load`] with the network on `device`.
    pub fn load_on(checkpoint: &Path, device: train::Device) -> Result<Self, ScoreError> {
        // The model crate's errors name the checkpoint file already.
        let predictor = Predictor::load_on(checkpoint, device).map_err(|e| ScoreError::Model {
            reason: e.to_string(),
        })?;
        Ok(NetworkLocaliser {
            predictor,
            checkpoint: checkpoint.to_path_buf(),
            query_segments: None,
        })
    }

    /// Takes each test frame's segments from `segments` (by image name) instead of the
    /// front-end's line detector; a frame without segments there fails with a reason.
    pub fn with_query_segments(mut self, segments: QuerySegments) -> Self {
        self.query_segments = Some(segments);
        self
    }

    /// A localiser over a predictor built elsewhere (`name` stands for the checkpoint in
    /// the summary).
    pub fn from_predictor(predictor: Predictor, name: impl Into<PathBuf>) -> Self {
        NetworkLocaliser {
            predictor,
            checkpoint: name.into(),
            query_segments: None,
        }
    }

    fn frame_err(frame: &TestFrame, reason: String) -> ScoreError {
        ScoreError::Frame {
            frame_id: frame.frame_id(),
            name: frame.name().to_string(),
            reason,
        }
    }
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

impl Localiser for NetworkLocaliser {
    fn describe(&self) -> String {
        let lines = match &self.query_segments {
            // Said only when not the default, so default summaries keep their bytes.
            Some(q) => format!(
                "; query lines from the segment files in {}",
                q.segments_dir.display()
            ),
            None => String::new(),
        };
        format!("network: checkpoint {}{lines}", self.checkpoint.display())
    }

    fn correspond(&mut self, frame: &TestFrame) -> Result<Correspondences, ScoreError> {
        let front = front_end(
            self.predictor.front_end(),
            self.query_segments.as_ref(),
            frame,
        )?;
        self.finish(frame, front)
    }

    /// The front-ends of all frames side by side on the rayon pool (each is one
    /// single-threaded OpenCV call chain), then the network frame by frame.
    fn correspond_each(
        &mut self,
        frames: &[TestFrame],
    ) -> Vec<Result<Correspondences, ScoreError>> {
        use rayon::prelude::*;
        let fe = self.predictor.front_end();
        let q = self.query_segments.as_ref();
        let fronts: Vec<Result<FrontEnd, ScoreError>> =
            frames.par_iter().map(|f| front_end(fe, q, f)).collect();
        frames
            .iter()
            .zip(fronts)
            .map(|(f, front)| self.finish(f, front?))
            .collect()
    }
}

/// A frame's detected and described features, with what they took.
struct FrontEnd {
    features: features::ImageFeatures,
    decode_ms: f64,
    front_end_ms: f64,
}

fn front_end(
    fe: &dyn features::FrontEnd,
    query_segments: Option<&QuerySegments>,
    frame: &TestFrame,
) -> Result<FrontEnd, ScoreError> {
    let t = Instant::now();
    let gray = frame.gray_image()?;
    let decode_ms = ms_since(t);
    let cam = frame.camera();
    if (u64::from(gray.width()), u64::from(gray.height())) != (cam.width, cam.height) {
        return Err(NetworkLocaliser::frame_err(
            frame,
            format!(
                "image is {}x{} but the camera says {}x{}",
                gray.width(),
                gray.height(),
                cam.width,
                cam.height
            ),
        ));
    }
    // Front-end and network timed apart: `Predictor::predict` is exactly these two.
    let t = Instant::now();
    let fe_err =
        |e: features::FeatureError| NetworkLocaliser::frame_err(frame, format!("front-end: {e}"));
    let features = match query_segments {
        None => fe.extract(&gray).map_err(fe_err)?,
        // The keypoints as always; the lines the map's detector found on this image.
        Some(q) => {
            let segments = q
                .get(frame.name())
                .map_err(|reason| NetworkLocaliser::frame_err(frame, reason))?
                .to_vec();
            let det = fe.detect(&gray).map_err(fe_err)?;
            let line_descriptors = fe.describe_lines(&gray, &segments).map_err(fe_err)?;
            features::ImageFeatures::from_detections(
                det,
                segments,
                line_descriptors,
                fe.samples_per_line(),
            )
        }
    };
    Ok(FrontEnd {
        features,
        decode_ms,
        front_end_ms: ms_since(t),
    })
}

impl NetworkLocaliser {
    fn finish(&self, frame: &TestFrame, front: FrontEnd) -> Result<Correspondences, ScoreError> {
        let FrontEnd {
            features,
            decode_ms,
            front_end_ms,
        } = front;
        let t = Instant::now();
        let pred = self
            .predictor
            .predict_features(&features)
            .map_err(|e| Self::frame_err(frame, format!("network: {e}")))?;
        let network_ms = ms_since(t);
        let timing = |step: &str, ms| Timing {
            step: step.into(),
            ms,
        };
        let (points, lines) = correspondences(&pred);
        Ok(Correspondences {
            points,
            lines,
            timings: vec![
                timing("decode", decode_ms),
                timing("front_end", front_end_ms),
                timing("network", network_ms),
            ],
        })
    }

    /// The predictor behind this localiser.
    pub fn predictor(&self) -> &Predictor {
        &self.predictor
    }
}

/// A prediction as correspondences, in its order.
pub fn correspondences(
    pred: &train::ImagePrediction,
) -> (Vec<PointCorrespondence>, Vec<LineCorrespondence>) {
    (
        pred.points
            .iter()
            .map(|p| PointCorrespondence::new(p.xy, p.xyz, p.reliability))
            .collect(),
        pred.lines
            .iter()
            .map(|l| LineCorrespondence::new(l.segment, l.start, l.end, l.reliability))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use geometry::{Camera, CameraModel, Pose};
    use model::CpuBackend;
    use shards::{FrameRecord, ImageFormat, LabelSource, Split};

    /// A textured 160x120 PNG: bright squares and bars on a gradient, so SIFT and LSD
    /// find something.
    fn frame(w: u32, h: u32, cam_w: u64) -> TestFrame {
        let img = image::GrayImage::from_fn(w, h, |x, y| {
            let square = (x / 20 + y / 20) % 2 == 0 && (x % 20) > 4 && (y % 20) > 4;
            let bar = (40..44).contains(&x) || (70..73).contains(&y);
            image::Luma([if square || bar {
                230
            } else {
                (x + y) as u8 / 4
            }])
        });
        let mut png = std::io::Cursor::new(Vec::new());
        img.write_to(&mut png, image::ImageFormat::Png).unwrap();
        TestFrame {
            record: FrameRecord {
                label_source: LabelSource::SyntheticExact,
                ..FrameRecord::unlabelled(
                    1,
                    "q.png".into(),
                    Split::Test,
                    Camera::new(
                        CameraModel::Pinhole,
                        cam_w,
                        u64::from(h),
                        vec![100.0, 100.0, 80.0, 60.0],
                    )
                    .unwrap(),
                    Pose::identity(),
                    png.into_inner(),
                    ImageFormat::Png,
                )
            },
        }
    }

    fn localiser() -> NetworkLocaliser {
        let c = train::TrainConfig::tiny();
        let net = c.model.init::<CpuBackend>(4, &Default::default()).unwrap();
        NetworkLocaliser::from_predictor(Predictor::from_parts(net, c).unwrap(), "tiny")
    }

    #[test]
    fn predictions_become_correspondences_in_order() {
        let mut loc = localiser();
        let f = frame(160, 120, 160);
        let c = loc.correspond(&f).unwrap();
        let expected = loc
            .predictor
            .predict(&f.gray_image().unwrap(), f.camera())
            .unwrap();
        assert_eq!(c.points.len(), expected.points.len());
        assert_eq!(c.lines.len(), expected.lines.len());
        assert!(!c.points.is_empty(), "the test image should have keypoints");
        for (a, b) in c.points.iter().zip(&expected.points) {
            assert_eq!(a.point.pixel.as_slice(), b.xy);
            assert_eq!(a.point.world.as_slice(), b.xyz);
            assert_eq!(a.reliability, b.reliability);
        }
        for (a, b) in c.lines.iter().zip(&expected.lines) {
            let s = &a.line.segment;
            assert_eq!([s.start.x, s.start.y, s.end.x, s.end.y], b.segment);
            assert_eq!(a.line.world.start.as_slice(), b.start);
            assert_eq!(a.line.world.end.as_slice(), b.end);
            assert_eq!(a.reliability, b.reliability);
        }
        let steps: Vec<_> = c.timings.iter().map(|t| t.step.as_str()).collect();
        assert_eq!(steps, vec!["decode", "front_end", "network"]);
        assert!(loc.describe().contains("tiny"));
        assert_eq!(loc.split(), Split::Test);
    }

    /// Front-ends side by side give what frame by frame gives, in frame order, and the
    /// first bad frame (in order) is the error reported.
    #[test]
    fn many_frames_at_once_equal_one_by_one() {
        let mut loc = localiser();
        let frames = vec![
            frame(160, 120, 160),
            frame(120, 160, 120),
            frame(160, 120, 160),
        ];
        let many = loc.correspond_many(&frames).unwrap();
        assert_eq!(many.len(), 3);
        for (f, m) in frames.iter().zip(&many) {
            let one = loc.correspond(f).unwrap();
            assert_eq!((&m.points, &m.lines), (&one.points, &one.lines));
        }
        assert_ne!(
            many[0].points, many[1].points,
            "different images, different output"
        );
        let bad = vec![
            frame(160, 120, 160),
            frame(160, 120, 320),
            frame(160, 120, 200),
        ];
        let e = loc.correspond_many(&bad).unwrap_err().to_string();
        assert!(e.contains("320x120"), "{e}");
    }

    #[test]
    fn camera_size_must_match_the_image() {
        let e = localiser()
            .correspond(&frame(160, 120, 320))
            .unwrap_err()
            .to_string();
        assert!(e.contains("160x120") && e.contains("320x120"), "{e}");
    }
}
