//! SIFT keypoints and descriptors through OpenCV.

use crate::SIFT_DIM;
use crate::config::{DescriptorConfig, DescriptorMethod, SiftConfig};
use crate::convert::{from_cv, mat_view, to_cv};
use crate::dense::OrientedGradients;
use crate::error::{CvContext, FeatureError};
use image::GrayImage;
use opencv::core::{
    KeyPoint, KeyPointTraitConst, Mat, MatTraitConst, MatTraitConstManual, Vector, no_array,
};
use opencv::features2d::{Feature2DTrait, SIFT};

/// A detected keypoint, COLMAP pixel convention.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    pub xy: [f64; 2],
    pub response: f32,
    /// OpenCV's keypoint size (diameter in pixels) and orientation (degrees): kept for
    /// inspection; descriptors use the fixed scale of `DescriptorConfig`.
    pub size: f32,
    pub angle: f32,
}

/// OpenCV runs its own loops in parallel and gathers their results in scheduling
/// order; we parallelise over images instead and keep OpenCV single-threaded so that
/// its output is a pure function of the image.
pub(crate) fn single_threaded_opencv() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = opencv::core::set_num_threads(1);
    });
}

/// OpenCV 4.6's SIFT detector starts from the image upsampled x2 (octave -1) and maps
/// positions back with `x / 2`, but its bilinear upsampling puts the doubled image's
/// pixel `i` at source position `(i + 0.5) / 2 - 0.5`, so every detected position comes
/// out `+0.25` px too far right and down (OpenCV >= 4.8 has `enable_precise_upscale`
/// for this). The test `gaussian_blob_is_found_at_its_colmap_centre` measures it.
/// Descriptors at given positions are not affected: they are computed on a pyramid
/// that starts at octave 0 (no upsampling).
const UPSAMPLING_BIAS: f64 = 0.25;

fn sift(cfg: &SiftConfig) -> Result<opencv::core::Ptr<SIFT>, FeatureError> {
    // nfeatures = 0: OpenCV's own top-K uses nth_element, whose choice among equal
    // responses is unspecified. We cut after a total order instead.
    SIFT::create(
        0,
        cfg.n_octave_layers,
        cfg.contrast_threshold,
        cfg.edge_threshold,
        cfg.sigma,
    )
    .cv("SIFT::create")
}

/// Detects SIFT keypoints and keeps the `max_keypoints` strongest.
///
/// Keypoints that OpenCV reports several times at one position (one per dominant
/// orientation) are merged: descriptors are computed upright, so the copies would be
/// identical inputs. Order: response descending, then y, then x (a total order).
pub fn detect_keypoints(img: &GrayImage, cfg: &SiftConfig) -> Result<Vec<Keypoint>, FeatureError> {
    single_threaded_opencv();
    let mat = mat_view(img)?;
    let mut detector = sift(cfg)?;
    let mut kps = Vector::<KeyPoint>::new();
    detector
        .detect(&mat, &mut kps, &no_array())
        .cv("SIFT detect")?;
    let mut out: Vec<Keypoint> = kps
        .iter()
        .map(|k| Keypoint {
            xy: [
                from_cv(k.pt().x) - UPSAMPLING_BIAS,
                from_cv(k.pt().y) - UPSAMPLING_BIAS,
            ],
            response: k.response(),
            size: k.size(),
            angle: k.angle(),
        })
        .filter(|k| k.response.is_finite() && k.xy.iter().all(|v| v.is_finite()))
        .collect();
    out.sort_by(|a, b| {
        b.response
            .total_cmp(&a.response)
            .then(a.xy[1].total_cmp(&b.xy[1]))
            .then(a.xy[0].total_cmp(&b.xy[0]))
            .then(b.size.total_cmp(&a.size))
    });
    // Merge positions repeated with another orientation (keep the strongest).
    let mut seen = std::collections::HashSet::with_capacity(out.len());
    out.retain(|k| seen.insert((k.xy[0].to_bits(), k.xy[1].to_bits())));
    out.truncate(cfg.max_keypoints);
    Ok(out)
}

/// A keypoint for OpenCV's descriptor at a COLMAP position with a fixed size and angle.
/// `octave = 0` makes OpenCV describe on the first layer of the first octave (the input
/// at its own resolution), whatever the size.
pub(crate) fn cv_keypoint(
    xy: [f64; 2],
    size: f32,
    angle_deg: f32,
) -> Result<KeyPoint, FeatureError> {
    KeyPoint::new_coords(to_cv(xy[0]), to_cv(xy[1]), size, angle_deg, 0.0, 0, -1)
        .cv("KeyPoint::new")
}

/// SIFT descriptors at given keypoints (each with its own angle), L2-normalised rows.
pub(crate) fn describe_keypoints(
    img: &GrayImage,
    keypoints: Vector<KeyPoint>,
    sift_cfg: &SiftConfig,
) -> Result<Vec<f32>, FeatureError> {
    single_threaded_opencv();
    let n = keypoints.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    let mat = mat_view(img)?;
    let mut extractor = sift(sift_cfg)?;
    let mut kps = keypoints;
    let mut desc = Mat::default();
    extractor
        .compute(&mat, &mut kps, &mut desc)
        .cv("SIFT compute")?;
    // OpenCV may drop keypoints it cannot describe; our labels are index-aligned with
    // the positions, so any drop is an error rather than a silent shift.
    if kps.len() != n || desc.rows() as usize != n || desc.cols() as usize != SIFT_DIM {
        return Err(FeatureError::DescriptorCount {
            expected: n,
            got: desc.rows().max(0) as usize,
        });
    }
    let data = desc.data_typed::<f32>().cv("descriptor data")?;
    let mut out = data.to_vec();
    for row in out.chunks_exact_mut(SIFT_DIM) {
        let norm = row.iter().map(|v| v * v).sum::<f32>().sqrt();
        if norm > 0.0 {
            row.iter_mut().for_each(|v| *v /= norm);
        }
    }
    Ok(out)
}

/// 128-d SIFT descriptors at given positions (COLMAP convention), upright, at the fixed
/// size of `DescriptorConfig::point_size`. Row i describes position i; rows are
/// L2-normalised. Positions outside the image are described from the clamped border
/// (OpenCV skips samples outside), never dropped.
pub fn describe_points(
    img: &GrayImage,
    positions: &[[f64; 2]],
    sift_cfg: &SiftConfig,
    desc_cfg: &DescriptorConfig,
) -> Result<Vec<f32>, FeatureError> {
    describe_specs(
        img,
        None,
        &point_keypoints(positions, desc_cfg),
        sift_cfg,
        desc_cfg,
    )
}

/// Descriptors of `specs` by the configured method: OpenCV's ([`describe_all`]) or the
/// dense map's (`dense.rs`), built from `gradients` when the caller already has them.
pub(crate) fn describe_specs(
    img: &GrayImage,
    gradients: Option<&OrientedGradients>,
    specs: &[KeySpec],
    sift_cfg: &SiftConfig,
    desc_cfg: &DescriptorConfig,
) -> Result<Vec<f32>, FeatureError> {
    match desc_cfg.method {
        DescriptorMethod::Opencv => describe_all(img, specs, sift_cfg),
        DescriptorMethod::Dense => {
            if specs.is_empty() {
                return Ok(Vec::new());
            }
            let own;
            let gradients = match gradients {
                Some(g) => g,
                None => {
                    own = OrientedGradients::new(img);
                    &own
                }
            };
            Ok(describe_dense(gradients, specs))
        }
    }
}

/// Dense-map descriptors of `specs`, one pooled map per distinct size; rows in input
/// order, computed in chunks side by side (a row depends on its map and spec alone).
fn describe_dense(gradients: &OrientedGradients, specs: &[KeySpec]) -> Vec<f32> {
    use rayon::prelude::*;
    let mut maps: Vec<(u32, crate::dense::DenseMap)> = Vec::new();
    for s in specs {
        if !maps.iter().any(|(b, _)| *b == s.size.to_bits()) {
            maps.push((s.size.to_bits(), gradients.pool(s.size)));
        }
    }
    const CHUNK: usize = 256;
    let mut out = vec![0f32; specs.len() * SIFT_DIM];
    out.par_chunks_mut(CHUNK * SIFT_DIM)
        .zip(specs.par_chunks(CHUNK))
        .for_each(|(rows, specs)| {
            for (row, s) in rows.chunks_exact_mut(SIFT_DIM).zip(specs) {
                if !(s.xy.iter().all(|v| v.is_finite()) && s.angle.is_finite()) {
                    continue;
                }
                let map = &maps
                    .iter()
                    .find(|(b, _)| *b == s.size.to_bits())
                    .expect("a map per size")
                    .1;
                map.describe(s.xy, s.angle, row);
            }
        });
    out
}

/// A keypoint to describe, before it becomes an OpenCV `KeyPoint` (which is not
/// `Sync`): COLMAP position, size and OpenCV angle (degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct KeySpec {
    pub xy: [f64; 2],
    pub size: f32,
    pub angle: f32,
}

pub(crate) fn to_cv_keypoints(specs: &[KeySpec]) -> Result<Vector<KeyPoint>, FeatureError> {
    let mut kps = Vector::<KeyPoint>::with_capacity(specs.len());
    for k in specs {
        kps.push(cv_keypoint(k.xy, k.size, k.angle)?);
    }
    Ok(kps)
}

/// The OpenCV keypoints [`describe_points`] describes: upright, at the fixed point
/// size.
pub(crate) fn point_keypoints(positions: &[[f64; 2]], desc_cfg: &DescriptorConfig) -> Vec<KeySpec> {
    positions
        .iter()
        .map(|&xy| KeySpec {
            xy,
            size: desc_cfg.point_size,
            angle: 0.0,
        })
        .collect()
}

/// Fewest keypoints per OpenCV call in [`describe_all`]: each call builds its own first
/// pyramid level (a few ms on 640x480), small next to describing this many keypoints
/// (about 0.1 ms each at the default sizes).
const MIN_CHUNK: usize = 256;

/// Descriptors of all `keypoints` (points and line samples alike): one OpenCV call, so
/// one pyramid level for all, on a pool of one thread; on more threads, as many equal
/// chunks as threads (of at least [`MIN_CHUNK`]) side by side. The rows are those of
/// one [`describe_keypoints`] call whatever the chunks: OpenCV describes every keypoint
/// of octave 0 from the same first pyramid level and its own position, size and angle
/// alone.
pub(crate) fn describe_all(
    img: &GrayImage,
    keypoints: &[KeySpec],
    sift_cfg: &SiftConfig,
) -> Result<Vec<f32>, FeatureError> {
    use rayon::prelude::*;
    let threads = rayon::current_num_threads().max(1);
    let chunk = keypoints.len().div_ceil(threads).max(MIN_CHUNK);
    let parts: Vec<Result<Vec<f32>, FeatureError>> = keypoints
        .par_chunks(chunk)
        .map(|chunk| describe_keypoints(img, to_cv_keypoints(chunk)?, sift_cfg))
        .collect();
    let mut out = Vec::with_capacity(keypoints.len() * SIFT_DIM);
    for p in parts {
        out.extend(p?);
    }
    Ok(out)
}
