//! A shard frame (+ augmentation) -> the network's training sample ([`model::Sample`]).
//!
//! Steps: draw the augmentation, decode the image to grey (the front-end's luma) and
//! apply it (keypoints and segments move with the image, pose and intrinsics follow,
//! see `augment.rs`; an unaugmented frame whose descriptors are cached skips the
//! image), keep at most `max_keypoints` / `max_lines` of what stayed in the
//! image (seeded draw, original order kept), and describe the kept positions ON THE
//! AUGMENTED IMAGE with the front-end's fixed-scale SIFT (points) and oriented samples
//! along each segment (lines): exactly what the predictor computes at query time.

use crate::augment::{self, AugmentConfig, AugmentParams};
pub use crate::config::Limits;
pub use crate::descriptor_cache::DescriptorCache;
use crate::descriptor_cache::select;
use crate::error::TrainError;
use features::FrontEnd;
use geometry::{Camera, Pose};
use image::GrayImage;
use rand::Rng;
use shards::FrameRecord;

/// A training sample and what was done to the frame to make it.
#[derive(Clone, Debug)]
pub struct Prepared {
    pub frame_id: u64,
    pub sample: model::Sample,
    pub params: AugmentParams,
    /// Index in the frame's arrays of each of the sample's keypoints / segments.
    pub keypoint_index: Vec<usize>,
    pub segment_index: Vec<usize>,
    /// The camera and pose of the augmented image.
    pub camera: Camera,
    pub pose: Pose,
}

/// Decodes a frame's image to 8-bit grey exactly as OpenCV's grey reader does
/// (`features::decode_gray`), as the reference implementation reads its images.
pub fn decode_gray(frame: &FrameRecord) -> Result<GrayImage, TrainError> {
    features::decode_gray(&frame.image_bytes)
        .map_err(|e| frame_err(frame, format!("decoding the image: {e}")))
}

/// [`decode_gray`], checking the image against the frame's camera.
pub(crate) fn decode_checked(frame: &FrameRecord) -> Result<GrayImage, TrainError> {
    let gray = decode_gray(frame)?;
    if (gray.width() as u64, gray.height() as u64) != (frame.camera.width, frame.camera.height) {
        return Err(frame_err(
            frame,
            format!(
                "image is {}x{} but the camera says {}x{}",
                gray.width(),
                gray.height(),
                frame.camera.width,
                frame.camera.height
            ),
        ));
    }
    Ok(gray)
}

fn frame_err(frame: &FrameRecord, reason: String) -> TrainError {
    TrainError::Frame {
        frame_id: frame.frame_id,
        name: frame.name.clone(),
        reason,
    }
}

/// The pinhole part of a camera (distortion, if any, is left out of the reprojection
/// loss; the synthetic and 7-Scenes cameras have none).
pub fn pinhole(camera: &Camera) -> model::Pinhole {
    let (fx, fy) = camera.focal_xy();
    let (cx, cy) = camera.principal_point();
    model::Pinhole { fx, fy, cx, cy }
}

/// Up to `max` of `0..len`, drawn from `rng`, in increasing order.
fn subsample<R: Rng>(len: usize, max: usize, rng: &mut R) -> Vec<usize> {
    if len <= max {
        return (0..len).collect();
    }
    let mut picked = rand::seq::index::sample(rng, len, max).into_vec();
    picked.sort_unstable();
    picked
}

/// Builds the sample of `frame`. With `augment = None` the frame is used as it is (the
/// limits still apply).
pub fn prepare<R: Rng>(
    frame: &FrameRecord,
    front_end: &dyn FrontEnd,
    augment: Option<&AugmentConfig>,
    limits: &Limits,
    rng: &mut R,
) -> Result<Prepared, TrainError> {
    prepare_with_cache(frame, front_end, augment, limits, rng, None)
}

/// Whether every unaugmented sample of `frame` keeps its positions exactly, so that a
/// described frame's samples never decode its image (the test `unchanged` in
/// [`prepare_with_cache`] passes for any subset). Not so for a frame with a segment
/// reaching out of the image: the identity clips it.
pub(crate) fn unaugmented_needs_no_image(frame: &FrameRecord) -> bool {
    let Ok(geo) = augment::transform(
        &frame.camera,
        &frame.pose,
        &frame.keypoints,
        &frame.segments,
        &AugmentParams::IDENTITY,
    ) else {
        return false;
    };
    geo.keypoint_index
        .iter()
        .zip(&geo.keypoints)
        .all(|(&i, k)| frame.keypoints[i] == *k)
        && geo
            .segment_index
            .iter()
            .zip(&geo.segments)
            .all(|(&j, s)| frame.segments[j] == *s)
}

/// [`prepare`], taking the descriptors of an unaugmented sample from `cache`.
pub fn prepare_with_cache<R: Rng>(
    frame: &FrameRecord,
    front_end: &dyn FrontEnd,
    augment: Option<&AugmentConfig>,
    limits: &Limits,
    rng: &mut R,
    cache: Option<&DescriptorCache>,
) -> Result<Prepared, TrainError> {
    let params = match augment {
        Some(cfg) => augment::draw_params(cfg, &frame.camera, rng),
        None => AugmentParams::IDENTITY,
    };
    let geo = augment::transform(
        &frame.camera,
        &frame.pose,
        &frame.keypoints,
        &frame.segments,
        &params,
    )
    .map_err(|e| frame_err(frame, format!("augmentation: {e}")))?;

    let kp_pick = subsample(geo.keypoints.len(), limits.max_keypoints, rng);
    let seg_pick = subsample(geo.segments.len(), limits.max_lines, rng);
    let keypoints: Vec<[f64; 2]> = kp_pick.iter().map(|&k| geo.keypoints[k]).collect();
    let keypoint_index: Vec<usize> = kp_pick.iter().map(|&k| geo.keypoint_index[k]).collect();
    let segments: Vec<[f64; 4]> = seg_pick.iter().map(|&k| geo.segments[k]).collect();
    let segment_index: Vec<usize> = seg_pick.iter().map(|&k| geo.segment_index[k]).collect();

    // The identity leaves every position exactly as it was (checked, not assumed: a
    // segment reaching out of the image is clipped).
    let unchanged = params == AugmentParams::IDENTITY
        && keypoint_index
            .iter()
            .zip(&keypoints)
            .all(|(&i, k)| frame.keypoints[i] == *k)
        && segment_index
            .iter()
            .zip(&segments)
            .all(|(&j, s)| frame.segments[j] == *s);
    // Only a sample at the frame's own positions can use the whole frame's rows.
    let cache = cache.filter(|_| unchanged);
    let held =
        cache.and_then(|c| c.rows(frame.frame_id, &keypoint_index, &segment_index, front_end));
    let (mut point_descriptors, mut line_descriptors) = match held {
        // A cached frame needs no image at all: decoding it was most of the sample's
        // cost (the frame was checked when it was cached).
        Some(rows) => rows?,
        None => {
            let gray = decode_checked(frame)?;
            let image = augment::warp_image(&gray, &frame.camera, &params)
                .map_err(|e| frame_err(frame, format!("augmentation: {e}")))?;
            let kept = match cache {
                Some(c) => c.describe_and_keep(frame, &image, front_end)?,
                None => None,
            };
            match kept {
                Some(all) => select(&all, &keypoint_index, &segment_index, front_end),
                None => front_end.describe(&image, &keypoints, &segments)?,
            }
        }
    };

    // Drawn after everything else, and nothing is drawn when it is off: without it the
    // stream is the same.
    if let Some(cfg) = augment {
        let d = front_end.dim();
        augment::jitter_descriptors(&mut point_descriptors, d, cfg.descriptor_noise, rng);
        augment::jitter_descriptors(&mut line_descriptors, d, cfg.descriptor_noise, rng);
    }

    let f32x = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| x as f32).collect() };
    let point_valid: Vec<bool> = keypoint_index
        .iter()
        .map(|&i| frame.point_valid[i])
        .collect();
    let point_labels = keypoint_index
        .iter()
        .map(|&i| {
            let p = &frame.points3d[i];
            if frame.point_valid[i] {
                [p[0] as f32, p[1] as f32, p[2] as f32]
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let line_valid: Vec<bool> = segment_index.iter().map(|&j| frame.line_valid[j]).collect();
    let line_labels = segment_index
        .iter()
        .map(|&j| {
            if frame.line_valid[j] {
                let v = f32x(&frame.lines3d[j]);
                [v[0], v[1], v[2], v[3], v[4], v[5]]
            } else {
                [0.0; 6]
            }
        })
        .collect();
    let r = geo.pose.rotation_matrix();
    let t = geo.pose.translation;
    let sample = model::Sample {
        point_descriptors,
        line_descriptors,
        keypoints: keypoints
            .iter()
            .map(|k| [k[0] as f32, k[1] as f32])
            .collect(),
        segments: segments
            .iter()
            .map(|s| [s[0] as f32, s[1] as f32, s[2] as f32, s[3] as f32])
            .collect(),
        point_labels,
        point_valid,
        line_labels,
        line_valid,
        rotation: [
            [r[(0, 0)], r[(0, 1)], r[(0, 2)]],
            [r[(1, 0)], r[(1, 1)], r[(1, 2)]],
            [r[(2, 0)], r[(2, 1)], r[(2, 2)]],
        ],
        translation: [t.x, t.y, t.z],
        camera: pinhole(&geo.camera),
    };
    Ok(Prepared {
        frame_id: frame.frame_id,
        sample,
        params,
        keypoint_index,
        segment_index,
        camera: geo.camera,
        pose: geo.pose,
    })
}

/// Moves a sample into a world frame whose origin is `centre` (of the old frame):
/// labels `X' = X - c`, pose `t' = t + R c`, so camera-frame coordinates (and every
/// reprojection) are unchanged. The network then regresses coordinates near zero, which
/// Adam reaches in far fewer steps than a scene sitting metres from its origin.
pub fn recentre(sample: &mut model::Sample, centre: &[f64; 3]) {
    if *centre == [0.0; 3] {
        return;
    }
    let shift = |v: &mut [f32]| {
        for (k, x) in v.iter_mut().enumerate() {
            *x = (*x as f64 - centre[k % 3]) as f32;
        }
    };
    for (l, valid) in sample.point_labels.iter_mut().zip(&sample.point_valid) {
        if *valid {
            shift(l);
        }
    }
    for (l, valid) in sample.line_labels.iter_mut().zip(&sample.line_valid) {
        if *valid {
            shift(l);
        }
    }
    for (t, row) in sample.translation.iter_mut().zip(&sample.rotation) {
        *t += row.iter().zip(centre).map(|(r, c)| r * c).sum::<f64>();
    }
}

/// Mean of the valid 3D point labels of every frame of `paths` (the origin of the
/// network's coordinates, see [`recentre`]); zero when there is none.
pub fn label_centre(paths: &[std::path::PathBuf]) -> Result<[f64; 3], TrainError> {
    let mut sum = [0.0f64; 3];
    let mut n = 0u64;
    for frame in shards::ShardReader::open(paths)? {
        let frame = frame?;
        for (p, v) in frame.points3d.iter().zip(&frame.point_valid) {
            if *v {
                for k in 0..3 {
                    sum[k] += p[k];
                }
                n += 1;
            }
        }
    }
    if n == 0 {
        return Ok([0.0; 3]);
    }
    Ok(sum.map(|s| s / n as f64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seeds::{self, Purpose};
    use crate::stream::{FrameStream, StreamConfig};
    use crate::testutil::{frame, sift_front_end, write_synthetic_shards};

    /// On shards without label noise, every labelled point of many augmented samples
    /// reprojects, with the sample's pose and intrinsics, onto its keypoint; and line
    /// labels onto their (clipped) segment's line. Runs through the shard reader and the
    /// stream, as training does.
    #[test]
    fn augmented_samples_reproject_onto_their_keypoints() {
        let dir = tempfile::tempdir().unwrap();
        let paths = write_synthetic_shards(dir.path(), 2, 10, 0.0);
        let fe = sift_front_end();
        let aug = AugmentConfig {
            probability: 1.0,
            ..Default::default()
        };
        let limits = Limits {
            max_keypoints: 30,
            max_lines: 5,
        };
        let cfg = StreamConfig {
            shuffle_buffer: 4,
            prefetch: 2,
            seed: 1,
            chunk_cache_bytes: 0,
            workers: 1,
        };
        let mut stream = FrameStream::start(&paths, cfg, 0, move |at, f| {
            let mut rng = seeds::rng(1, Purpose::Sample, at.position);
            prepare(&f, &fe, Some(&aug), &limits, &mut rng)
        })
        .unwrap();
        let (mut worst, mut worst_line, mut checked, mut rotated) = (0f64, 0f64, 0, 0);
        for _ in 0..60 {
            let (_, p) = stream.next_item().unwrap();
            let s = &p.sample;
            assert!(s.keypoints.len() <= 30 && s.segments.len() <= 5);
            assert_eq!(s.point_descriptors.len(), s.keypoints.len() * 128);
            assert_eq!(s.line_descriptors.len(), s.segments.len() * 4 * 128);
            if p.params.rotation_rad != 0.0 {
                rotated += 1;
            }
            let project = |x: [f32; 3]| -> [f64; 2] {
                let x = [x[0] as f64, x[1] as f64, x[2] as f64];
                let c: Vec<f64> = (0..3)
                    .map(|i| {
                        (0..3).map(|j| s.rotation[i][j] * x[j]).sum::<f64>() + s.translation[i]
                    })
                    .collect();
                [
                    s.camera.fx * c[0] / c[2] + s.camera.cx,
                    s.camera.fy * c[1] / c[2] + s.camera.cy,
                ]
            };
            for k in 0..s.keypoints.len() {
                if !s.point_valid[k] {
                    continue;
                }
                let q = project(s.point_labels[k]);
                let e = (q[0] - s.keypoints[k][0] as f64).hypot(q[1] - s.keypoints[k][1] as f64);
                worst = worst.max(e);
                checked += 1;
            }
            for j in 0..s.segments.len() {
                if !s.line_valid[j] {
                    continue;
                }
                let l = s.line_labels[j];
                let eq = model::sample::line_equation(&s.segments[j]).unwrap();
                for q in [project([l[0], l[1], l[2]]), project([l[3], l[4], l[5]])] {
                    let d = (eq[0] as f64 * q[0] + eq[1] as f64 * q[1] + eq[2] as f64).abs();
                    worst_line = worst_line.max(d);
                }
            }
        }
        assert!(checked > 60 * 10, "{checked}");
        assert!(rotated > 50, "{rotated}");
        assert!(worst < 1e-3, "worst point reprojection {worst} px");
        assert!(worst_line < 1e-2, "worst line distance {worst_line} px");
    }

    #[test]
    fn recentring_keeps_camera_coordinates() {
        let f = frame(5, 20, 3, 0.0);
        let mut rng = seeds::rng(0, Purpose::Sample, 0);
        let a = prepare(&f, &sift_front_end(), None, &Limits::default(), &mut rng)
            .unwrap()
            .sample;
        let mut b = a.clone();
        let c = [1.5, -2.0, 0.25];
        recentre(&mut b, &c);
        let cam = |s: &model::Sample, x: [f32; 3]| -> Vec<f64> {
            (0..3)
                .map(|i| {
                    (0..3).map(|j| s.rotation[i][j] * x[j] as f64).sum::<f64>() + s.translation[i]
                })
                .collect()
        };
        for k in 0..a.keypoints.len() {
            if a.point_valid[k] {
                assert!(
                    (b.point_labels[k][0] as f64 - (a.point_labels[k][0] as f64 - 1.5)).abs()
                        < 1e-5
                );
                let (p, q) = (cam(&a, a.point_labels[k]), cam(&b, b.point_labels[k]));
                for i in 0..3 {
                    assert!((p[i] - q[i]).abs() < 1e-5, "{p:?} {q:?}");
                }
            }
        }
    }

    #[test]
    fn limits_subsample_with_the_seed() {
        let f = frame(3, 40, 6, 0.0);
        let fe = sift_front_end();
        let limits = Limits {
            max_keypoints: 10,
            max_lines: 2,
        };
        let run = |seed: u64| {
            let mut rng = seeds::rng(seed, Purpose::Sample, 0);
            prepare(&f, &fe, None, &limits, &mut rng).unwrap()
        };
        let a = run(1);
        assert_eq!(a.keypoint_index.len(), 10);
        assert_eq!(a.segment_index.len(), 2);
        assert!(a.keypoint_index.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(a.sample, run(1).sample);
        assert_ne!(a.keypoint_index, run(2).keypoint_index);
        // Unaugmented: the sample's keypoints are the frame's.
        for (k, &i) in a.keypoint_index.iter().enumerate() {
            assert_eq!(a.sample.keypoints[k][0], f.keypoints[i][0] as f32);
        }
    }

    #[test]
    fn bad_images_are_errors_naming_the_frame() {
        let mut f = frame(4, 5, 1, 0.0);
        f.image_bytes.truncate(40);
        let mut rng = seeds::rng(0, Purpose::Sample, 0);
        let e = prepare(&f, &sift_front_end(), None, &Limits::default(), &mut rng)
            .unwrap_err()
            .to_string();
        assert!(e.contains("frame 4") && e.contains("decoding"), "{e}");
    }
}
