//! Extracting everything the network needs from one image ([`ImageFeatures`]) with SIFT
//! and LSD, and the parallel batch driver.

use crate::config::{DescriptorMethod, FrontEndConfig};
use crate::dense::OrientedGradients;
use crate::error::FeatureError;
use crate::image_features::ImageFeatures;
use crate::{SIFT_DIM, describe_lines, describe_points, detect_keypoints, detect_segments};
use image::GrayImage;
use rayon::prelude::*;

/// Detects and describes keypoints and lines of one image (the query path).
///
/// The same output as [`extract_per_call`] (detect, [`describe_points`],
/// [`detect_segments`], [`describe_lines`]), bit for bit, computed faster: SIFT
/// detection and LSD side by side (`rayon::join`), then the descriptors of the
/// keypoints and of every line sample in one pass over one scale-space pyramid level
/// ([`describe_points_and_lines`]; on more than one thread, one chunk per thread). A
/// descriptor depends only on the image's first pyramid level and its own keypoint, so
/// neither the pass nor the chunking changes a value (the test
/// `extract_equals_the_per_call_path` checks it).
pub fn extract(img: &GrayImage, cfg: &FrontEndConfig) -> Result<ImageFeatures, FeatureError> {
    cfg.validate()?;
    // The dense map's gradients need neither detection: they are built beside them.
    let dense = cfg.descriptor.method == DescriptorMethod::Dense;
    let ((kps, segments), gradients) = rayon::join(
        || {
            rayon::join(
                || detect_keypoints(img, &cfg.sift),
                || detect_segments(img, &cfg.lsd),
            )
        },
        || dense.then(|| OrientedGradients::new(img)),
    );
    let keypoints: Vec<[f64; 2]> = kps?.into_iter().map(|k| k.xy).collect();
    let segments = segments?;
    let (descriptors, line_descriptors) =
        describe_with(img, gradients.as_ref(), &keypoints, &segments, cfg)?;
    Ok(ImageFeatures {
        keypoints,
        descriptors,
        segments,
        line_descriptors,
        samples_per_line: cfg.samples_per_line,
        dim: SIFT_DIM,
    })
}

/// [`describe_points`] and [`describe_lines`] of one image in one pass: every
/// descriptor from one scale-space pyramid level (`sift::describe_all`; one chunk per
/// thread of the rayon pool, side by side), the same values bit for bit. Returns
/// (N x 128, M x T x 128).
pub fn describe_points_and_lines(
    img: &GrayImage,
    keypoints: &[[f64; 2]],
    segments: &[[f64; 4]],
    cfg: &FrontEndConfig,
) -> Result<(Vec<f32>, Vec<f32>), FeatureError> {
    describe_with(img, None, keypoints, segments, cfg)
}

fn describe_with(
    img: &GrayImage,
    gradients: Option<&OrientedGradients>,
    keypoints: &[[f64; 2]],
    segments: &[[f64; 4]],
    cfg: &FrontEndConfig,
) -> Result<(Vec<f32>, Vec<f32>), FeatureError> {
    let mut all = crate::sift::point_keypoints(keypoints, &cfg.descriptor);
    all.extend(crate::lines::line_keypoints(
        segments,
        cfg.samples_per_line,
        &cfg.descriptor,
    ));
    let mut descriptors =
        crate::sift::describe_specs(img, gradients, &all, &cfg.sift, &cfg.descriptor)?;
    let line_descriptors = descriptors.split_off(keypoints.len() * SIFT_DIM);
    Ok((descriptors, line_descriptors))
}

/// [`extract`] as one public call after the other, each describing on its own
/// pyramid: the reference that [`extract`] must equal bit for bit.
pub fn extract_per_call(
    img: &GrayImage,
    cfg: &FrontEndConfig,
) -> Result<ImageFeatures, FeatureError> {
    cfg.validate()?;
    let keypoints: Vec<[f64; 2]> = detect_keypoints(img, &cfg.sift)?
        .into_iter()
        .map(|k| k.xy)
        .collect();
    let descriptors = describe_points(img, &keypoints, &cfg.sift, &cfg.descriptor)?;
    let segments = detect_segments(img, &cfg.lsd)?;
    let line_descriptors = describe_lines(
        img,
        &segments,
        cfg.samples_per_line,
        &cfg.sift,
        &cfg.descriptor,
    )?;
    Ok(ImageFeatures {
        keypoints,
        descriptors,
        segments,
        line_descriptors,
        samples_per_line: cfg.samples_per_line,
        dim: SIFT_DIM,
    })
}

/// Runs `f` over items in parallel (rayon) with results in input order, so the output
/// does not depend on the thread count. A progress bar counts finished items.
pub fn extract_batch<T, F>(
    items: &[T],
    progress: &indicatif::ProgressBar,
    f: F,
) -> Vec<Result<ImageFeatures, FeatureError>>
where
    T: Sync,
    F: Fn(&T) -> Result<ImageFeatures, FeatureError> + Sync,
{
    items
        .par_iter()
        .map(|item| {
            let r = f(item);
            progress.inc(1);
            r
        })
        .collect()
}
