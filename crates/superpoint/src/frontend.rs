//! The SuperPoint front-end ([`features::FrontEnd`]). The builder of a front-end of either
//! kind from its configuration is `frontends::build` (crates/frontends/src/lib.rs).
//!
//! Coordinates: the caller's are COLMAP pixels of the original image. The network sees
//! the image resized so that its longer side is at most `resize_max` (area
//! interpolation); with per-axis factors s = original / resized, a COLMAP position p of
//! the original image is the pixel index p / s - 0.5 of the resized one, and a detected
//! pixel index q maps back to (q + 0.5) s.

use crate::error::SuperPointError;
use crate::keypoints::{sample_descriptor, select};
use crate::net::{DenseMaps, SuperPointBackend, SuperPointNet};
use crate::weights::{Weights, file_sha256};
use features::{
    Described, Detections, FeatureError, FrontEnd, FrontEndConfig, FrontEndKind, SUPERPOINT_DIM,
    sample_points,
};
use image::GrayImage;

/// The sha256 of the weights file `config` names, or None for SIFT (which has no
/// weights) or when no file is named.
pub fn weights_sha256(config: &FrontEndConfig) -> Result<Option<String>, SuperPointError> {
    match (config.kind, config.superpoint.weights_path()) {
        (FrontEndKind::Superpoint, Some(p)) => file_sha256(&p).map(Some),
        _ => Ok(None),
    }
}

/// SuperPoint keypoints and descriptors, LSD segments (docs/method.md section 2b).
pub struct SuperPointFrontEnd {
    config: FrontEndConfig,
    net: Net,
}

/// The network on the device it runs on.
enum Net {
    Cpu(SuperPointNet<SuperPointBackend>),
    #[cfg(feature = "cuda")]
    Cuda(
        SuperPointNet<burn::backend::Cuda>,
        burn::backend::cuda::CudaDevice,
    ),
}

impl Net {
    fn new(weights: &Weights, gpu: Option<usize>) -> Result<Self, SuperPointError> {
        match gpu {
            None => Ok(Net::Cpu(SuperPointNet::new(weights, &Default::default()))),
            #[cfg(feature = "cuda")]
            Some(i) => {
                let device = burn::backend::cuda::CudaDevice::new(i);
                Ok(Net::Cuda(SuperPointNet::new(weights, &device), device))
            }
            #[cfg(not(feature = "cuda"))]
            Some(i) => Err(SuperPointError::NoCuda(i)),
        }
    }

    fn dense(&self, pixels: &[&[f32]], width: usize, height: usize) -> Vec<DenseMaps> {
        match self {
            Net::Cpu(net) => net.dense(pixels, width, height, &Default::default()),
            #[cfg(feature = "cuda")]
            Net::Cuda(net, device) => net.dense(pixels, width, height, device),
        }
    }
}

/// One image as the network sees it.
struct Prepared {
    pixels: Vec<f32>,
    width: usize,
    height: usize,
    /// original / resized, per axis.
    scale: [f64; 2],
}

impl SuperPointFrontEnd {
    /// Reads the weights the configuration names and checks their hash when it records
    /// one.
    pub fn from_config(config: &FrontEndConfig) -> Result<Self, SuperPointError> {
        Self::from_config_on(config, None)
    }

    /// [`SuperPointFrontEnd::from_config`] with the network on CUDA GPU `gpu`.
    pub fn from_config_on(
        config: &FrontEndConfig,
        gpu: Option<usize>,
    ) -> Result<Self, SuperPointError> {
        let path = config
            .superpoint
            .weights_path()
            .ok_or(SuperPointError::NoWeights)?;
        let weights = Weights::read(&path)?;
        if let (Some(expected), Some(found)) = (&config.superpoint.weights_sha256, &weights.sha256)
            && expected != found
        {
            return Err(SuperPointError::WeightsMismatch {
                path,
                expected: expected.clone(),
                found: found.clone(),
            });
        }
        let mut config = config.clone();
        config.superpoint.weights = Some(std::path::absolute(&path).unwrap_or(path));
        Self::from_weights_on(config, &weights, gpu)
    }

    /// A front-end over weights in memory (their hash, if any, is recorded).
    pub fn from_weights(
        config: FrontEndConfig,
        weights: &Weights,
    ) -> Result<Self, SuperPointError> {
        Self::from_weights_on(config, weights, None)
    }

    fn from_weights_on(
        mut config: FrontEndConfig,
        weights: &Weights,
        gpu: Option<usize>,
    ) -> Result<Self, SuperPointError> {
        config.kind = FrontEndKind::Superpoint;
        config.validate()?;
        if weights.sha256.is_some() {
            config.superpoint.weights_sha256 = weights.sha256.clone();
        }
        Ok(SuperPointFrontEnd {
            net: Net::new(weights, gpu)?,
            config,
        })
    }

    /// Grey [0, 1], resized when the longer side exceeds `resize_max`.
    fn prepare(&self, img: &GrayImage) -> Result<Prepared, FeatureError> {
        let (w, h) = (img.width() as usize, img.height() as usize);
        if w < 8 || h < 8 {
            return Err(FeatureError::ImageSize {
                width: img.width(),
                height: img.height(),
            });
        }
        let pixels = features::gray_f32(img);
        let max = self.config.superpoint.resize_max;
        if max == 0 || w.max(h) <= max {
            return Ok(Prepared {
                pixels,
                width: w,
                height: h,
                scale: [1.0, 1.0],
            });
        }
        let f = max as f64 / w.max(h) as f64;
        let (nw, nh) = (
            ((w as f64 * f).round() as usize).max(8),
            ((h as f64 * f).round() as usize).max(8),
        );
        let pixels = features::resize_area(&pixels, w, h, nw, nh)?;
        Ok(Prepared {
            pixels,
            width: nw,
            height: nh,
            scale: [w as f64 / nw as f64, h as f64 / nh as f64],
        })
    }

    /// The dense maps of prepared images, equal sizes batched together.
    fn dense_of(&self, prepared: &[Prepared]) -> Vec<DenseMaps> {
        let mut out: Vec<Option<DenseMaps>> = vec![None; prepared.len()];
        let mut sizes: Vec<(usize, usize)> = prepared.iter().map(|p| (p.width, p.height)).collect();
        sizes.sort_unstable();
        sizes.dedup();
        for (w, h) in sizes {
            let idx: Vec<usize> = (0..prepared.len())
                .filter(|&i| (prepared[i].width, prepared[i].height) == (w, h))
                .collect();
            let pix: Vec<&[f32]> = idx.iter().map(|&i| prepared[i].pixels.as_slice()).collect();
            for (i, m) in idx.iter().zip(self.net.dense(&pix, w, h)) {
                out[*i] = Some(m);
            }
        }
        out.into_iter().flatten().collect()
    }

    /// The dense score and descriptor maps of one image (of the resized image when it is
    /// resized) and its original / resized factors.
    pub fn dense(&self, img: &GrayImage) -> Result<(DenseMaps, [f64; 2]), FeatureError> {
        let p = self.prepare(img)?;
        let maps = self.dense_of(std::slice::from_ref(&p)).remove(0);
        Ok((maps, p.scale))
    }

    fn detections(&self, maps: &DenseMaps, scale: [f64; 2]) -> Detections {
        let sp = &self.config.superpoint;
        let kps = select(
            maps,
            sp.nms_radius,
            sp.detection_threshold,
            sp.remove_borders,
            sp.max_keypoints,
        );
        let mut descriptors = Vec::with_capacity(kps.len() * SUPERPOINT_DIM);
        for &(x, y, _) in &kps {
            sample_descriptor(maps, x as f64, y as f64, &mut descriptors);
        }
        Detections {
            keypoints: kps
                .iter()
                .map(|&(x, y, _)| [(x as f64 + 0.5) * scale[0], (y as f64 + 0.5) * scale[1]])
                .collect(),
            scores: kps.iter().map(|k| k.2).collect(),
            descriptors,
            dim: SUPERPOINT_DIM,
        }
    }

    fn sample_at(&self, maps: &DenseMaps, scale: [f64; 2], positions: &[[f64; 2]]) -> Vec<f32> {
        let mut out = Vec::with_capacity(positions.len() * SUPERPOINT_DIM);
        for p in positions {
            sample_descriptor(maps, p[0] / scale[0] - 0.5, p[1] / scale[1] - 0.5, &mut out);
        }
        out
    }

    fn line_positions(&self, segments: &[[f64; 4]]) -> Vec<[f64; 2]> {
        let t = self.config.samples_per_line;
        segments.iter().flat_map(|s| sample_points(s, t)).collect()
    }

    fn check_positions(positions: &[[f64; 2]], what: &str) -> Result<(), FeatureError> {
        match positions
            .iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            Some(i) => Err(FeatureError::FrontEnd(format!(
                "{what} {i} is not a finite position: {:?}",
                positions[i]
            ))),
            None => Ok(()),
        }
    }
}

impl FrontEnd for SuperPointFrontEnd {
    fn kind(&self) -> FrontEndKind {
        FrontEndKind::Superpoint
    }

    fn config(&self) -> &FrontEndConfig {
        &self.config
    }

    fn detect(&self, img: &GrayImage) -> Result<Detections, FeatureError> {
        let (maps, scale) = self.dense(img)?;
        Ok(self.detections(&maps, scale))
    }

    fn describe_points(
        &self,
        img: &GrayImage,
        keypoints: &[[f64; 2]],
    ) -> Result<Vec<f32>, FeatureError> {
        Ok(self.describe(img, keypoints, &[])?.0)
    }

    fn describe_lines(
        &self,
        img: &GrayImage,
        segments: &[[f64; 4]],
    ) -> Result<Vec<f32>, FeatureError> {
        Ok(self.describe(img, &[], segments)?.1)
    }

    fn describe(
        &self,
        img: &GrayImage,
        keypoints: &[[f64; 2]],
        segments: &[[f64; 4]],
    ) -> Result<Described, FeatureError> {
        self.describe_batch(&[(img, keypoints, segments)]).remove(0)
    }

    /// One network run per image size for the whole batch.
    fn describe_batch(
        &self,
        items: &[features::LabelledImage<'_>],
    ) -> Vec<Result<Described, FeatureError>> {
        let mut prepared = Vec::with_capacity(items.len());
        let mut errors: Vec<Option<FeatureError>> = Vec::with_capacity(items.len());
        for (img, k, s) in items {
            let lines = self.line_positions(s);
            let r = Self::check_positions(k, "keypoint")
                .and_then(|_| Self::check_positions(&lines, "line sample"))
                .and_then(|_| self.prepare(img));
            match r {
                Ok(p) => {
                    prepared.push(p);
                    errors.push(None);
                }
                Err(e) => errors.push(Some(e)),
            }
        }
        let mut maps = self.dense_of(&prepared).into_iter().zip(prepared);
        items
            .iter()
            .zip(errors)
            .map(|((_, k, s), err)| {
                if let Some(e) = err {
                    return Err(e);
                }
                let (m, p) = maps.next().ok_or_else(|| {
                    FeatureError::FrontEnd("superpoint: a dense map is missing (a bug)".into())
                })?;
                Ok((
                    self.sample_at(&m, p.scale, k),
                    self.sample_at(&m, p.scale, &self.line_positions(s)),
                ))
            })
            .collect()
    }

    /// Detection and line sampling from one network run.
    fn extract(&self, img: &GrayImage) -> Result<features::ImageFeatures, FeatureError> {
        let (maps, scale) = self.dense(img)?;
        let det = self.detections(&maps, scale);
        let segments = self.segments(img)?;
        let line_descriptors = self.sample_at(&maps, scale, &self.line_positions(&segments));
        Ok(features::ImageFeatures::from_detections(
            det,
            segments,
            line_descriptors,
            self.config.samples_per_line,
        ))
    }

    fn extract_batch(
        &self,
        images: &[&GrayImage],
    ) -> Vec<Result<features::ImageFeatures, FeatureError>> {
        images.iter().map(|img| self.extract(img)).collect()
    }

    fn detect_batch(&self, images: &[&GrayImage]) -> Vec<Result<Detections, FeatureError>> {
        images.iter().map(|img| self.detect(img)).collect()
    }
}
