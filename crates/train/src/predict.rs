//! Prediction with a trained network: the API the score stage calls.
//!
//! ```ignore
//! let predictor = train::Predictor::load(Path::new("out/model.ckpt"))?;
//! let p = predictor.predict(&gray_image, &camera)?;
//! for k in &p.points { /* k.xy (COLMAP pixels), k.xyz (world), k.reliability */ }
//! for l in &p.lines  { /* l.segment [x1 y1 x2 y2], l.start / l.end (world), l.reliability */ }
//! ```
//!
//! - [`Predictor::load`] reads a checkpoint (`model.ckpt` or `checkpoint.ckpt`); the
//!   training configuration inside it fixes the network and the front-end.
//! - [`Predictor::predict`] runs the front-end exactly as training describes its inputs
//!   (SIFT keypoints, top `query_max_keypoints` by response; upright fixed-scale SIFT
//!   descriptors at them; LSD segments; descriptors at T samples along each segment) and
//!   the network in evaluation mode (no dropout), on the CPU backend, or on a CUDA GPU
//!   with [`Predictor::load_on`] (builds with the `cuda` feature; SuperPoint's network
//!   then runs there too).
//! - Outputs are in input order, world coordinates, pixels in COLMAP's convention (centre
//!   of the top-left pixel at (0.5, 0.5)). Filter by reliability as the caller needs
//!   (docs/method.md section 6: r >= 0.5 for points, r >= 0.02 for lines).
//! - The camera is only checked against the image size: the network needs no intrinsics.
//!   A `Predictor` is `Send + Sync`; `predict` takes `&self`.

use crate::checkpoint::CheckpointFile;
use crate::config::TrainConfig;
use crate::error::TrainError;
use features::{FrontEnd, ImageFeatures};
use geometry::Camera;
use image::GrayImage;
use model::buckets::BucketLimits;
use model::{CpuBackend, Device, HostPrediction, Pl2Map};
use std::path::Path;
use std::sync::Arc;

/// A keypoint and what the network says about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PredictedPoint {
    pub xy: [f64; 2],
    pub xyz: [f64; 3],
    pub reliability: f64,
}

/// A segment and its predicted 3D endpoints (`start` belongs to (x1, y1)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PredictedLine {
    pub segment: [f64; 4],
    pub start: [f64; 3],
    pub end: [f64; 3],
    pub reliability: f64,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImagePrediction {
    pub points: Vec<PredictedPoint>,
    pub lines: Vec<PredictedLine>,
}

/// The network on the device it runs on.
enum Network {
    Cpu(Pl2Map<CpuBackend>),
    #[cfg(feature = "cuda")]
    Cuda(Pl2Map<model::CudaBackend>),
    #[cfg(feature = "tch")]
    LibTorch(Pl2Map<model::LibTorchBackend>),
}

impl Network {
    /// `buckets`: pad the image to shape buckets (crates/model/src/buckets.rs).
    fn predict(
        &self,
        points: &[f32],
        lines: &[f32],
        buckets: Option<BucketLimits>,
    ) -> Result<HostPrediction, TrainError> {
        Ok(match self {
            Network::Cpu(n) => n.predict_bucketed(points, lines, buckets)?,
            #[cfg(feature = "cuda")]
            Network::Cuda(n) => n.predict_bucketed(points, lines, buckets)?,
            #[cfg(feature = "tch")]
            Network::LibTorch(n) => n.predict_bucketed(points, lines, buckets)?,
        })
    }
}

pub struct Predictor {
    network: Network,
    config: TrainConfig,
    front_end: Arc<dyn FrontEnd>,
    /// Added to every predicted coordinate (the training's `scene_centre`).
    centre: [f64; 3],
    /// Shape buckets of the query path (`TrainConfig::shape_buckets`: on a JIT engine
    /// each new (N, M) would compile new kernels).
    buckets: Option<BucketLimits>,
}

impl Predictor {
    pub fn load(checkpoint: &Path) -> Result<Self, TrainError> {
        Self::load_on(checkpoint, Device::Cpu)
    }

    /// [`Predictor::load`] with the network on `device` (whatever device trained it:
    /// a checkpoint holds plain f32 weights). SuperPoint runs there too; SIFT and LSD on the CPU.
    pub fn load_on(checkpoint: &Path, device: Device) -> Result<Self, TrainError> {
        device.check_usable()?;
        model::device::explain_gpu_panics(device);
        let ck = CheckpointFile::read(checkpoint)?;
        let network = match device {
            Device::Cpu => Network::Cpu(ck.model::<CpuBackend>(&Default::default())?),
            #[cfg(feature = "cuda")]
            Device::Cuda(i) => Network::Cuda(ck.model::<model::CudaBackend>(&Device::cuda(i))?),
            #[cfg(not(feature = "cuda"))]
            Device::Cuda(_) => return Err(device.not_built().into()),
            #[cfg(feature = "tch")]
            Device::LibTorchCpu | Device::LibTorchCuda(_) => {
                Network::LibTorch(ck.model::<model::LibTorchBackend>(&device.libtorch())?)
            }
            #[cfg(not(feature = "tch"))]
            Device::LibTorchCpu | Device::LibTorchCuda(_) => {
                return Err(device.not_built().into());
            }
        };
        let mut p = Self::with_network(network, ck.header.config, device)?;
        p.centre = ck.header.scene_centre;
        Ok(p)
    }

    /// A predictor over an in-memory network and its training configuration (network
    /// coordinates = world coordinates). The front-end is built from the configuration
    /// ([`query_front_end`]).
    pub fn from_parts(
        network: Pl2Map<CpuBackend>,
        config: TrainConfig,
    ) -> Result<Self, TrainError> {
        Self::with_network(Network::Cpu(network), config, Device::Cpu)
    }

    fn with_network(
        network: Network,
        config: TrainConfig,
        device: Device,
    ) -> Result<Self, TrainError> {
        let front_end = query_front_end_on(&config, device)?;
        Ok(Predictor {
            network,
            buckets: config.query_buckets(device),
            config,
            front_end,
            centre: [0.0; 3],
        })
    }

    /// Origin of the network's coordinates in the world (from the checkpoint).
    pub fn scene_centre(&self) -> [f64; 3] {
        self.centre
    }

    pub fn config(&self) -> &TrainConfig {
        &self.config
    }

    /// The front-end of the query path (training's, with the query's top-K).
    pub fn front_end(&self) -> &dyn FrontEnd {
        self.front_end.as_ref()
    }

    /// Detects, describes and predicts one grey image.
    pub fn predict(
        &self,
        image: &GrayImage,
        camera: &Camera,
    ) -> Result<ImagePrediction, TrainError> {
        if (image.width() as u64, image.height() as u64) != (camera.width, camera.height) {
            return Err(TrainError::Image(format!(
                "image is {}x{} but the camera says {}x{}",
                image.width(),
                image.height(),
                camera.width,
                camera.height
            )));
        }
        let f = self.front_end.extract(image)?;
        self.predict_features(&f)
    }

    /// Describes and predicts given positions (e.g. a labelled frame's keypoints and
    /// segments) instead of detecting them: for measuring a model on its labels.
    pub fn predict_at(
        &self,
        image: &GrayImage,
        keypoints: &[[f64; 2]],
        segments: &[[f64; 4]],
    ) -> Result<ImagePrediction, TrainError> {
        let fe = &self.front_end;
        let (descriptors, line_descriptors) = fe.describe(image, keypoints, segments)?;
        let f = ImageFeatures {
            keypoints: keypoints.to_vec(),
            descriptors,
            segments: segments.to_vec(),
            line_descriptors,
            samples_per_line: fe.samples_per_line(),
            dim: fe.dim(),
        };
        self.predict_features(&f)
    }

    /// The network on front-end output computed elsewhere (same configuration).
    pub fn predict_features(&self, f: &ImageFeatures) -> Result<ImagePrediction, TrainError> {
        let out = self
            .network
            .predict(&f.descriptors, &f.line_descriptors, self.buckets)?;
        let c = self.centre;
        let d3 = |v: [f32; 3]| [v[0] as f64 + c[0], v[1] as f64 + c[1], v[2] as f64 + c[2]];
        Ok(ImagePrediction {
            points: f
                .keypoints
                .iter()
                .zip(&out.points)
                .map(|(xy, p)| PredictedPoint {
                    xy: *xy,
                    xyz: d3(p.xyz),
                    reliability: p.reliability as f64,
                })
                .collect(),
            lines: f
                .segments
                .iter()
                .zip(&out.lines)
                .map(|(s, l)| PredictedLine {
                    segment: *s,
                    start: d3(l.start),
                    end: d3(l.end),
                    reliability: l.reliability as f64,
                })
                .collect(),
        })
    }
}

/// The query path's front-end of a training configuration: the checkpoint's front-end
/// with the query's top-K. A SuperPoint front-end reads the weights file the checkpoint
/// names, or `PL2MAP_SUPERPOINT_WEIGHTS` when that file is not there (another machine),
/// and refuses a file whose sha256 is not the recorded one.
pub fn query_front_end(config: &TrainConfig) -> Result<Arc<dyn FrontEnd>, TrainError> {
    query_front_end_on(config, Device::Cpu)
}

/// [`query_front_end`] with SuperPoint's network on `device`.
pub fn query_front_end_on(
    config: &TrainConfig,
    device: Device,
) -> Result<Arc<dyn FrontEnd>, TrainError> {
    let mut fe = config.front_end.clone();
    fe.set_max_keypoints(config.query_max_keypoints);
    if let Some(w) = &fe.superpoint.weights
        && !w.is_file()
        && let Some(env) =
            std::env::var_os(features::SUPERPOINT_WEIGHTS_ENV).filter(|v| !v.is_empty())
    {
        fe.superpoint.weights = Some(env.into());
    }
    Ok(frontends::build_on(&fe, device.gpu())?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::{Limits, decode_gray, prepare};
    use crate::seeds::{self, Purpose};
    use crate::testutil::{camera, frame};

    fn config() -> TrainConfig {
        TrainConfig::tiny()
    }

    /// Training describes given positions the way the predictor describes detections:
    /// at the same positions both give the same network outputs.
    #[test]
    fn prediction_agrees_with_the_training_inputs() {
        let cfg = config();
        let net = cfg
            .model
            .init::<CpuBackend>(4, &Default::default())
            .unwrap();
        let p = Predictor::from_parts(net.clone(), cfg.clone()).unwrap();
        let f = frame(9, 30, 4, 0.0);
        let gray = decode_gray(&f).unwrap();
        let pred = p.predict(&gray, &camera()).unwrap();
        assert!(!pred.points.is_empty() && pred.points.len() <= 50);
        for k in &pred.points {
            assert!(k.reliability > 0.0 && k.reliability <= 1.0);
            assert!(k.xyz.iter().all(|v| v.is_finite()));
        }
        // The same keypoints and segments as labels of a frame, through the training path.
        let mut g = f.clone();
        g.keypoints = pred.points.iter().map(|k| k.xy).collect();
        let n = g.keypoints.len();
        g.point3d_ids = vec![-1; n];
        g.points3d = vec![[0.0; 3]; n];
        g.point_valid = vec![false; n];
        g.segments = pred.lines.iter().map(|l| l.segment).collect();
        let m = g.segments.len();
        g.track_ids = vec![-1; m];
        g.lines3d = vec![[0.0; 6]; m];
        g.line_valid = vec![false; m];
        let limits = Limits {
            max_keypoints: 10_000,
            max_lines: 10_000,
        };
        let s = prepare(
            &g,
            p.front_end(),
            None,
            &limits,
            &mut seeds::rng(0, Purpose::Sample, 0),
        )
        .unwrap()
        .sample;
        let direct = net
            .predict(&s.point_descriptors, &s.line_descriptors)
            .unwrap();
        for (a, b) in pred.points.iter().zip(&direct.points) {
            for k in 0..3 {
                assert!((a.xyz[k] - b.xyz[k] as f64).abs() < 1e-4);
            }
        }
        // Describing the given positions is the detection path without the detection.
        let at = p.predict_at(&gray, &g.keypoints, &g.segments).unwrap();
        assert_eq!(at, pred);
    }

    /// With shape buckets on (a JIT engine's query path) the detections are padded to a
    /// bucket and the padded rows dropped: the same predictions up to float rounding.
    #[test]
    fn shape_buckets_leave_predictions_as_they_are() {
        let cfg = config();
        let net = cfg
            .model
            .init::<CpuBackend>(4, &Default::default())
            .unwrap();
        let on = TrainConfig {
            shape_buckets: crate::config::ShapeBuckets::On,
            ..cfg.clone()
        };
        let plain = Predictor::from_parts(net.clone(), cfg).unwrap();
        let padded = Predictor::from_parts(net, on).unwrap();
        assert!(plain.buckets.is_none() && padded.buckets.is_some());
        let gray = decode_gray(&frame(9, 30, 4, 0.0)).unwrap();
        let a = plain.predict(&gray, &camera()).unwrap();
        let b = padded.predict(&gray, &camera()).unwrap();
        assert_eq!(
            (a.points.len(), a.lines.len()),
            (b.points.len(), b.lines.len())
        );
        // Not a bucket's size, so padding happened.
        assert_ne!(
            model::buckets::bucket(a.points.len(), 50),
            a.points.len(),
            "{} keypoints",
            a.points.len()
        );
        for (x, y) in a.points.iter().zip(&b.points) {
            assert_eq!(x.xy, y.xy);
            for k in 0..3 {
                assert!((x.xyz[k] - y.xyz[k]).abs() < 1e-4);
            }
            assert!((x.reliability - y.reliability).abs() < 1e-4);
        }
        for (x, y) in a.lines.iter().zip(&b.lines) {
            assert_eq!(x.segment, y.segment);
            assert!((x.start[0] - y.start[0]).abs() < 1e-4 && (x.end[2] - y.end[2]).abs() < 1e-4);
        }
    }

    #[test]
    fn image_and_camera_must_agree() {
        let cfg = config();
        let net = cfg
            .model
            .init::<CpuBackend>(4, &Default::default())
            .unwrap();
        let p = Predictor::from_parts(net, cfg).unwrap();
        let e = p.predict(&GrayImage::new(10, 10), &camera()).unwrap_err();
        assert!(e.to_string().contains("10x10"), "{e}");
    }
}
