//! The front-end abstraction: what turns an image into the network's input, whatever
//! the detector and descriptor (ARCHITECTURE.md, "... a front-end").
//!
//! A [`FrontEnd`] names its kind, its settings and its descriptor width D, and gives
//! for one image or a batch: keypoints with scores and descriptors ([`FrontEnd::detect`]),
//! descriptors at given keypoints ([`FrontEnd::describe_points`]; the labelled SfM
//! keypoints of a training image), line segments ([`FrontEnd::segments`]) and
//! descriptors at T samples along given segments ([`FrontEnd::describe_lines`]). Every
//! coordinate is in COLMAP's convention (centre of the top-left pixel at (0.5, 0.5)).
//!
//! [`SiftFrontEnd`] wraps the OpenCV SIFT + LSD functions of this crate unchanged: its
//! outputs are byte for byte those of [`crate::extract`], [`crate::describe_points`]
//! and [`crate::describe_lines`]. The SuperPoint front-end (a burn network) lives in the
//! `superpoint` crate, which also builds a front-end of either kind from a
//! [`FrontEndConfig`] (`superpoint::front_end`), so that this crate needs no burn.

use crate::config::FrontEndConfig;
use crate::error::FeatureError;
use crate::{SIFT_DIM, describe_lines, describe_points, detect_keypoints, detect_segments};
use image::GrayImage;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Which detector and descriptor a front-end runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrontEndKind {
    /// OpenCV SIFT keypoints, upright fixed-scale SIFT descriptors (D = 128), LSD lines.
    #[default]
    Sift,
    /// SuperPoint keypoints and bilinearly sampled dense descriptors (D = 256), LSD lines
    /// (docs/method.md section 2b).
    Superpoint,
}

impl FrontEndKind {
    pub fn name(self) -> &'static str {
        match self {
            FrontEndKind::Sift => "sift",
            FrontEndKind::Superpoint => "superpoint",
        }
    }

    /// The descriptor width of this kind.
    pub fn dim(self) -> usize {
        match self {
            FrontEndKind::Sift => SIFT_DIM,
            FrontEndKind::Superpoint => SUPERPOINT_DIM,
        }
    }

    pub fn is_sift(&self) -> bool {
        *self == FrontEndKind::Sift
    }
}

impl std::fmt::Display for FrontEndKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for FrontEndKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "sift" => Ok(FrontEndKind::Sift),
            "superpoint" => Ok(FrontEndKind::Superpoint),
            _ => Err(format!("expected sift or superpoint, got {s:?}")),
        }
    }
}

/// SuperPoint's descriptor width.
pub const SUPERPOINT_DIM: usize = 256;

/// The environment variable naming the SuperPoint weights file when neither the
/// configuration nor a flag does.
pub const SUPERPOINT_WEIGHTS_ENV: &str = "PL2MAP_SUPERPOINT_WEIGHTS";

/// SuperPoint's settings (docs/method.md section 2b). Plain data: the network is in the
/// `superpoint` crate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SuperPointConfig {
    /// The released state-dict file (`superpoint_v1.pth`), supplied by the user. None:
    /// the `PL2MAP_SUPERPOINT_WEIGHTS` environment variable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weights: Option<PathBuf>,
    /// sha256 of the weights file the front-end was built with. Filled by the trainer
    /// and stored in every checkpoint; a front-end built from a checkpoint refuses a
    /// weights file with another hash.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weights_sha256: Option<String>,
    /// Non-maximum suppression radius in pixels (a max-pool of size 2r + 1).
    pub nms_radius: usize,
    /// Scores at or below this are not keypoints.
    pub detection_threshold: f32,
    /// Keypoints closer than this to the image border (pixels) are dropped.
    pub remove_borders: usize,
    /// Keep the K strongest keypoints (the query's top-K).
    pub max_keypoints: usize,
    /// Resize so that the longer side is at most this many pixels (area interpolation)
    /// before the network; 0: never. Keypoints and given positions are mapped between
    /// the original and the resized image.
    pub resize_max: usize,
}

impl Default for SuperPointConfig {
    fn default() -> Self {
        SuperPointConfig {
            weights: None,
            weights_sha256: None,
            nms_radius: 3,
            detection_threshold: 0.005,
            remove_borders: 4,
            max_keypoints: 2048,
            resize_max: 1024,
        }
    }
}

impl SuperPointConfig {
    pub fn is_default(&self) -> bool {
        *self == SuperPointConfig::default()
    }

    /// The weights file: the configured one, else `PL2MAP_SUPERPOINT_WEIGHTS`.
    pub fn weights_path(&self) -> Option<PathBuf> {
        self.weights.clone().or_else(|| {
            std::env::var_os(SUPERPOINT_WEIGHTS_ENV)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        })
    }
}

/// Keypoints detected in one image, strongest first, with their descriptors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Detections {
    /// N x 2, COLMAP pixels.
    pub keypoints: Vec<[f64; 2]>,
    /// N: the detector's score (SIFT response, SuperPoint probability).
    pub scores: Vec<f32>,
    /// N x D, rows L2-normalised.
    pub descriptors: Vec<f32>,
    /// D.
    pub dim: usize,
}

/// Descriptors of given positions: (points N x D, line samples M x T x D).
pub type Described = (Vec<f32>, Vec<f32>);

/// One image of a batch with the keypoints and segments to describe in it (a training
/// image's labelled SfM keypoints and LIMAP segments).
pub type LabelledImage<'a> = (&'a GrayImage, &'a [[f64; 2]], &'a [[f64; 4]]);

/// A front-end (see the module documentation). Implementations are deterministic: the
/// same image gives the same bytes for any thread count.
pub trait FrontEnd: Send + Sync {
    fn kind(&self) -> FrontEndKind;

    /// The settings it was built from (with the weights' hash for SuperPoint).
    fn config(&self) -> &FrontEndConfig;

    /// Descriptor width D.
    fn dim(&self) -> usize {
        self.kind().dim()
    }

    /// T: descriptors per segment.
    fn samples_per_line(&self) -> usize {
        self.config().samples_per_line
    }

    /// Keypoints, scores and descriptors of one image, strongest first.
    fn detect(&self, img: &GrayImage) -> Result<Detections, FeatureError>;

    /// Descriptors at given positions (COLMAP pixels), row i for position i.
    fn describe_points(
        &self,
        img: &GrayImage,
        keypoints: &[[f64; 2]],
    ) -> Result<Vec<f32>, FeatureError>;

    /// Line segments (x1 y1 x2 y2, COLMAP pixels).
    fn segments(&self, img: &GrayImage) -> Result<Vec<[f64; 4]>, FeatureError> {
        detect_segments(img, &self.config().lsd)
    }

    /// T descriptors along each segment (`crate::sample_points`, endpoints included),
    /// M x T x D.
    fn describe_lines(
        &self,
        img: &GrayImage,
        segments: &[[f64; 4]],
    ) -> Result<Vec<f32>, FeatureError>;

    /// Points and line samples of one image together (SuperPoint runs its network once).
    fn describe(
        &self,
        img: &GrayImage,
        keypoints: &[[f64; 2]],
        segments: &[[f64; 4]],
    ) -> Result<Described, FeatureError> {
        Ok((
            self.describe_points(img, keypoints)?,
            self.describe_lines(img, segments)?,
        ))
    }

    /// [`FrontEnd::describe`] over a batch, results in input order.
    fn describe_batch(&self, items: &[LabelledImage<'_>]) -> Vec<Result<Described, FeatureError>> {
        items
            .par_iter()
            .map(|(img, k, s)| self.describe(img, k, s))
            .collect()
    }

    /// Everything the network needs from one image (the query path): detections,
    /// segments and their descriptors.
    fn extract(&self, img: &GrayImage) -> Result<crate::ImageFeatures, FeatureError> {
        let det = self.detect(img)?;
        let segments = self.segments(img)?;
        let line_descriptors = self.describe_lines(img, &segments)?;
        Ok(crate::ImageFeatures::from_detections(
            det,
            segments,
            line_descriptors,
            self.samples_per_line(),
        ))
    }

    /// [`FrontEnd::extract`] over a batch, results in input order.
    fn extract_batch(
        &self,
        images: &[&GrayImage],
    ) -> Vec<Result<crate::ImageFeatures, FeatureError>> {
        images.par_iter().map(|img| self.extract(img)).collect()
    }

    /// [`FrontEnd::detect`] over a batch, results in input order.
    fn detect_batch(&self, images: &[&GrayImage]) -> Vec<Result<Detections, FeatureError>> {
        images.par_iter().map(|img| self.detect(img)).collect()
    }
}

/// The SIFT + LSD front-end: this crate's OpenCV functions, unchanged.
#[derive(Clone, Debug)]
pub struct SiftFrontEnd {
    config: FrontEndConfig,
}

impl SiftFrontEnd {
    pub fn new(config: FrontEndConfig) -> Result<Self, FeatureError> {
        config.validate()?;
        if !config.kind.is_sift() {
            return Err(FeatureError::Config(format!(
                "a SIFT front-end was asked for a {} configuration",
                config.kind
            )));
        }
        Ok(SiftFrontEnd { config })
    }
}

impl FrontEnd for SiftFrontEnd {
    fn kind(&self) -> FrontEndKind {
        FrontEndKind::Sift
    }

    fn config(&self) -> &FrontEndConfig {
        &self.config
    }

    fn detect(&self, img: &GrayImage) -> Result<Detections, FeatureError> {
        let kps = detect_keypoints(img, &self.config.sift)?;
        let keypoints: Vec<[f64; 2]> = kps.iter().map(|k| k.xy).collect();
        let descriptors = self.describe_points(img, &keypoints)?;
        Ok(Detections {
            keypoints,
            scores: kps.iter().map(|k| k.response).collect(),
            descriptors,
            dim: SIFT_DIM,
        })
    }

    fn describe_points(
        &self,
        img: &GrayImage,
        keypoints: &[[f64; 2]],
    ) -> Result<Vec<f32>, FeatureError> {
        describe_points(img, keypoints, &self.config.sift, &self.config.descriptor)
    }

    fn describe_lines(
        &self,
        img: &GrayImage,
        segments: &[[f64; 4]],
    ) -> Result<Vec<f32>, FeatureError> {
        describe_lines(
            img,
            segments,
            self.config.samples_per_line,
            &self.config.sift,
            &self.config.descriptor,
        )
    }

    fn extract(&self, img: &GrayImage) -> Result<crate::ImageFeatures, FeatureError> {
        crate::extract(img, &self.config)
    }
}
