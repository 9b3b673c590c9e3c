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
//! `superpoint` crate, and the `frontends` crate builds a front-end of either kind from a
//! [`FrontEndConfig`] (`frontends::build`), so that this crate needs no burn.

use crate::config::FrontEndConfig;
use crate::error::FeatureError;
use crate::image_features::{Detections, ImageFeatures};
use crate::kind::FrontEndKind;
use crate::{SIFT_DIM, describe_lines, describe_points, detect_keypoints, detect_segments};
use image::GrayImage;
use rayon::prelude::*;

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
    fn extract(&self, img: &GrayImage) -> Result<ImageFeatures, FeatureError> {
        let det = self.detect(img)?;
        let segments = self.segments(img)?;
        let line_descriptors = self.describe_lines(img, &segments)?;
        Ok(ImageFeatures::from_detections(
            det,
            segments,
            line_descriptors,
            self.samples_per_line(),
        ))
    }

    /// [`FrontEnd::extract`] over a batch, results in input order.
    fn extract_batch(&self, images: &[&GrayImage]) -> Vec<Result<ImageFeatures, FeatureError>> {
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

    fn extract(&self, img: &GrayImage) -> Result<ImageFeatures, FeatureError> {
        crate::extract(img, &self.config)
    }
}
