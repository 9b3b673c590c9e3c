//! Training augmentation (docs/method.md section 5): brightness, contrast, scale and
//! in-plane rotation, with keypoints, segments, intrinsics and pose following the image.
//!
//! Geometry. Scaling the image by `s` maps a pixel `p` to `s p` (COLMAP corner origin)
//! and the camera to `Camera::scaled(s)`. Rotating the image by `theta` about the
//! principal point `c` is the image of the camera turning about its optical axis:
//! `X_cam' = Rz X_cam` with `Rz = [[cos, -sin, 0], [sin, cos, 0], [0, 0, 1]]`, so the
//! world-to-camera pose becomes `R' = Rz R`, `t' = Rz t` (the reference multiplies on
//! the other side, which leaves rotated samples 2-34 px off). This holds exactly when
//! the projection commutes with rotations about the optical axis: equal focal lengths and
//! a radially symmetric distortion. For other models the rotation is skipped (scale and
//! photometric changes still apply) and `AugmentParams::rotation_rad` says 0.
//!
//! Keypoints are not re-detected: their positions are transformed (those leaving the
//! image are dropped, with their index kept for the labels), segments are clipped to the
//! image, and the caller re-samples descriptors on the augmented image.

use geometry::lines::{Segment2, clip_segment_to_image};
use geometry::{Camera, CameraModel, Pose, UnitQuaternion, Vector2, Vector3};
use image::{GrayImage, Luma};
use rand::Rng;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AugmentConfig {
    /// Probability that a sample is augmented at all (0.5 in the reference).
    pub probability: f64,
    /// Brightness factor drawn from [1 - b, 1 + b] (paper: 0.15).
    pub brightness: f64,
    /// Contrast factor drawn from [1 - c, 1 + c] about the mean grey (paper: 0.10).
    pub contrast: f64,
    pub scale_min: f64,
    pub scale_max: f64,
    /// Rotation drawn from [-r, r] degrees.
    pub max_rotation_deg: f64,
    /// Not in the reference: every descriptor of every training sample (augmented or
    /// not) gets isotropic Gaussian noise of about this L2 norm, then is L2-normalised
    /// again (SIFT rows have norm 1). A cheap stand-in for the viewpoint changes that
    /// image augmentation brings, which on a CPU budget costs too much (two SIFT
    /// pyramids per augmented image). 0: off, and the sample stream is unchanged.
    pub descriptor_noise: f64,
}

impl Default for AugmentConfig {
    fn default() -> Self {
        AugmentConfig {
            probability: 0.5,
            brightness: 0.15,
            contrast: 0.10,
            scale_min: 2.0 / 3.0,
            scale_max: 1.5,
            max_rotation_deg: 30.0,
            descriptor_noise: 0.0,
        }
    }
}

/// Adds Gaussian noise of expected L2 norm about `norm` to each `dim`-wide row of `rows`
/// and L2-normalises the row again (see [`AugmentConfig::descriptor_noise`]). Draws
/// nothing from `rng` when `norm` is 0.
pub fn jitter_descriptors<R: Rng>(rows: &mut [f32], dim: usize, norm: f64, rng: &mut R) {
    if norm <= 0.0 || dim == 0 {
        return;
    }
    // f32 and the ziggurat normal (mostly a table lookup, where Box-Muller takes a
    // logarithm, a square root and a cosine): this runs on the reader thread for every
    // descriptor of every sample, about 200,000 values a step at 16 x (32 + 6 x 12).
    let sigma = (norm / (dim as f64).sqrt()) as f32;
    for row in rows.chunks_mut(dim) {
        let mut sq = 0.0f32;
        for v in row.iter_mut() {
            let z: f32 = rng.sample(rand_distr::StandardNormal);
            *v += sigma * z;
            sq += *v * *v;
        }
        let n = sq.sqrt();
        if n > 0.0 {
            row.iter_mut().for_each(|v| *v /= n);
        }
    }
}

/// What was applied to a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AugmentParams {
    pub brightness: f64,
    pub contrast: f64,
    pub scale: f64,
    pub rotation_rad: f64,
}

impl AugmentParams {
    pub const IDENTITY: AugmentParams = AugmentParams {
        brightness: 1.0,
        contrast: 1.0,
        scale: 1.0,
        rotation_rad: 0.0,
    };
}

/// A training sample before augmentation.
#[derive(Clone, Debug)]
pub struct Sample {
    pub image: GrayImage,
    pub camera: Camera,
    /// World-to-camera.
    pub pose: Pose,
    /// COLMAP pixels.
    pub keypoints: Vec<[f64; 2]>,
    pub segments: Vec<[f64; 4]>,
}

/// A sample after augmentation; `*_index[k]` is the index in the original sample of the
/// k-th kept keypoint / segment (to pick their labels).
#[derive(Clone, Debug)]
pub struct Augmented {
    pub image: GrayImage,
    /// Camera, pose, kept keypoints and segments ([`transform`]).
    pub geometry: Geometry,
    pub params: AugmentParams,
}

/// Whether rotating the image about the principal point is a rotation of the camera
/// about its optical axis for this camera (see the module comment).
pub fn rotation_is_exact(camera: &Camera) -> bool {
    use CameraModel::*;
    let (fx, fy) = camera.focal_xy();
    let p = &camera.params;
    let symmetric = match camera.model {
        SimplePinhole | SimpleRadial | Radial | SimpleRadialFisheye | RadialFisheye
        | SimpleDivision | SimpleFisheye => true,
        Pinhole | OpenCvFisheye | Fov | Division | Fisheye | Eucm => true,
        // Tangential / thin-prism terms break the symmetry unless they are zero.
        OpenCv => p[6] == 0.0 && p[7] == 0.0,
        FullOpenCv => p[6] == 0.0 && p[7] == 0.0,
        ThinPrismFisheye => p[6..8].iter().chain(&p[10..12]).all(|v| *v == 0.0),
        RadTanThinPrismFisheye => p[10..16].iter().all(|v| *v == 0.0),
        Equirectangular => false,
    };
    symmetric && (fx - fy).abs() <= 1e-12 * fx.abs().max(1.0)
}

/// The image-plane similarity `p -> s R(theta) (p - c) + s c` about the principal point
/// `c` of the original camera.
#[derive(Clone, Copy, Debug)]
pub struct Similarity {
    pub scale: f64,
    pub theta: f64,
    pub centre: Vector2<f64>,
}

impl Similarity {
    fn is_identity(&self) -> bool {
        self.scale == 1.0 && self.theta == 0.0
    }

    pub fn apply(&self, p: &Vector2<f64>) -> Vector2<f64> {
        // Exactly the identity (p - c + c is not p in floating point): an unaugmented
        // sample keeps its positions bit for bit, which the descriptor cache relies on.
        if self.is_identity() {
            return *p;
        }
        let (s, c) = self.theta.sin_cos();
        let d = p - self.centre;
        self.scale * Vector2::new(c * d.x - s * d.y, s * d.x + c * d.y) + self.scale * self.centre
    }

    pub fn inverse_apply(&self, q: &Vector2<f64>) -> Vector2<f64> {
        if self.is_identity() {
            return *q;
        }
        let (s, c) = self.theta.sin_cos();
        let d = (q - self.scale * self.centre) / self.scale;
        Vector2::new(c * d.x + s * d.y, -s * d.x + c * d.y) + self.centre
    }
}

/// Draws the augmentation of one sample: identity with probability `1 - probability`.
pub fn draw_params<R: Rng>(cfg: &AugmentConfig, camera: &Camera, rng: &mut R) -> AugmentParams {
    // Always draw the same number of values so the random stream does not depend on
    // which branch was taken (reproducible sequences when the config changes a range).
    let apply = rng.random::<f64>() < cfg.probability;
    let u: [f64; 4] = rng.random();
    if !apply {
        return AugmentParams::IDENTITY;
    }
    let lerp = |lo: f64, hi: f64, t: f64| lo + (hi - lo) * t;
    let rotation = if rotation_is_exact(camera) {
        lerp(-cfg.max_rotation_deg, cfg.max_rotation_deg, u[3]).to_radians()
    } else {
        0.0
    };
    AugmentParams {
        brightness: lerp(1.0 - cfg.brightness, 1.0 + cfg.brightness, u[0]),
        contrast: lerp(1.0 - cfg.contrast, 1.0 + cfg.contrast, u[1]),
        // Log-uniform, so that x and 1/x are equally likely.
        scale: lerp(cfg.scale_min.ln(), cfg.scale_max.ln(), u[2]).exp(),
        rotation_rad: rotation,
    }
}

/// Where an augmentation moves a sample's camera, pose, keypoints and segments.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    pub camera: Camera,
    pub pose: Pose,
    /// Transformed keypoints inside the new image, and their indexes in the input.
    pub keypoints: Vec<[f64; 2]>,
    pub keypoint_index: Vec<usize>,
    /// Transformed segments clipped to the new image (at least 1 px long), and their
    /// indexes in the input.
    pub segments: Vec<[f64; 4]>,
    pub segment_index: Vec<usize>,
}

fn similarity(camera: &Camera, params: &AugmentParams) -> Similarity {
    let (cx, cy) = camera.principal_point();
    Similarity {
        scale: params.scale,
        theta: params.rotation_rad,
        centre: Vector2::new(cx, cy),
    }
}

/// The geometric part of [`apply`], without touching the image (an unaugmented sample
/// whose descriptors are cached needs no decoded image).
pub fn transform(
    camera: &Camera,
    pose: &Pose,
    keypoints: &[[f64; 2]],
    segments: &[[f64; 4]],
    params: &AugmentParams,
) -> Result<Geometry, geometry::GeometryError> {
    let new_camera = camera.scaled(params.scale)?;
    let sim = similarity(camera, params);
    let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), params.rotation_rad);
    let new_pose = Pose::new(rz * pose.rotation, rz * pose.translation);
    let (w, h) = (new_camera.width as f64, new_camera.height as f64);

    let mut out_keypoints = Vec::with_capacity(keypoints.len());
    let mut keypoint_index = Vec::with_capacity(keypoints.len());
    for (i, k) in keypoints.iter().enumerate() {
        let q = sim.apply(&Vector2::new(k[0], k[1]));
        if q.x >= 0.0 && q.y >= 0.0 && q.x < w && q.y < h {
            out_keypoints.push([q.x, q.y]);
            keypoint_index.push(i);
        }
    }
    let mut out_segments = Vec::with_capacity(segments.len());
    let mut segment_index = Vec::with_capacity(segments.len());
    for (j, s) in segments.iter().enumerate() {
        let a = sim.apply(&Vector2::new(s[0], s[1]));
        let b = sim.apply(&Vector2::new(s[2], s[3]));
        if let Some(c) = clip_segment_to_image(&Segment2::new(a, b), w, h) {
            // A segment clipped to (almost) a point carries no line.
            if c.length() >= 1.0 {
                out_segments.push(c.to_array());
                segment_index.push(j);
            }
        }
    }
    Ok(Geometry {
        camera: new_camera,
        pose: new_pose,
        keypoints: out_keypoints,
        keypoint_index,
        segments: out_segments,
        segment_index,
    })
}

/// Applies `params` to a sample.
pub fn apply(
    sample: &Sample,
    params: &AugmentParams,
) -> Result<Augmented, geometry::GeometryError> {
    Ok(Augmented {
        image: warp_image(&sample.image, &sample.camera, params)?,
        geometry: transform(
            &sample.camera,
            &sample.pose,
            &sample.keypoints,
            &sample.segments,
            params,
        )?,
        params: *params,
    })
}

/// The image part of [`apply`]: `image` (taken with `camera`) as the augmented camera
/// sees it.
pub fn warp_image(
    image: &GrayImage,
    camera: &Camera,
    params: &AugmentParams,
) -> Result<GrayImage, geometry::GeometryError> {
    let out = camera.scaled(params.scale)?;
    Ok(warp(
        image,
        &similarity(camera, params),
        out.width as u32,
        out.height as u32,
        params,
    ))
}

/// Resamples the image under `sim` (bilinear, black outside) and applies contrast about
/// the mean grey, then brightness.
fn warp(src: &GrayImage, sim: &Similarity, w: u32, h: u32, params: &AugmentParams) -> GrayImage {
    let (sw, sh) = src.dimensions();
    let raw = src.as_raw();
    let mean = if raw.is_empty() {
        0.0
    } else {
        raw.iter().map(|&v| v as f64).sum::<f64>() / raw.len() as f64
    };
    let identity_geometry = sim.scale == 1.0 && sim.theta == 0.0 && (w, h) == (sw, sh);
    let sample_at = |x: u32, y: u32| -> f64 {
        if identity_geometry {
            return raw[(y * sw + x) as usize] as f64;
        }
        // Output pixel centre (COLMAP) -> source position -> OpenCV-style grid coords.
        let p = sim.inverse_apply(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
        let (fx, fy) = (p.x - 0.5, p.y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        let get = |xi: f64, yi: f64| -> f64 {
            if xi < 0.0 || yi < 0.0 || xi >= sw as f64 || yi >= sh as f64 {
                0.0
            } else {
                raw[(yi as u32 * sw + xi as u32) as usize] as f64
            }
        };
        (1.0 - ay) * ((1.0 - ax) * get(x0, y0) + ax * get(x0 + 1.0, y0))
            + ay * ((1.0 - ax) * get(x0, y0 + 1.0) + ax * get(x0 + 1.0, y0 + 1.0))
    };
    GrayImage::from_fn(w, h, |x, y| {
        let v = sample_at(x, y);
        let v = ((v - mean) * params.contrast + mean) * params.brightness;
        Luma([v.round().clamp(0.0, 255.0) as u8])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn random_scene(
        rng: &mut ChaCha8Rng,
        camera: &Camera,
        pose: &Pose,
    ) -> (Vec<Vector3<f64>>, Vec<[f64; 2]>) {
        let inv = pose.inverse();
        let mut pts = Vec::new();
        let mut kps = Vec::new();
        while pts.len() < 300 {
            let px = Vector2::new(
                rng.random_range(0.0..camera.width as f64),
                rng.random_range(0.0..camera.height as f64),
            );
            let ray = camera.unproject(&px).unwrap();
            let depth = rng.random_range(0.5..6.0);
            let x_world = inv.transform_point(&(ray * depth));
            pts.push(x_world);
            kps.push([px.x, px.y]);
        }
        (pts, kps)
    }

    /// Every labelled point reprojects, with the augmented pose and intrinsics, onto its
    /// transformed keypoint (the check the reference fails on rotated samples).
    #[test]
    fn labels_reproject_onto_transformed_keypoints() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let cameras = [
            Camera::new(
                CameraModel::SimplePinhole,
                640,
                480,
                vec![525.0, 320.0, 240.0],
            )
            .unwrap(),
            Camera::new(
                CameraModel::SimpleRadial,
                1024,
                576,
                vec![800.0, 500.0, 290.0, -0.05],
            )
            .unwrap(),
        ];
        let cfg = AugmentConfig {
            probability: 1.0,
            ..Default::default()
        };
        let mut worst: f64 = 0.0;
        let mut kept = 0usize;
        for trial in 0..200 {
            let camera = &cameras[trial % 2];
            let pose = Pose::new(
                UnitQuaternion::from_euler_angles(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-3.0..3.0),
                ),
                Vector3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                ),
            );
            let (pts, kps) = random_scene(&mut rng, camera, &pose);
            let sample = Sample {
                image: GrayImage::new(camera.width as u32, camera.height as u32),
                camera: camera.clone(),
                pose,
                keypoints: kps,
                segments: vec![],
            };
            let params = draw_params(&cfg, camera, &mut rng);
            assert!(params.rotation_rad != 0.0 && params.scale != 1.0);
            let aug = apply(&sample, &params).unwrap();
            for (k, &i) in aug.geometry.keypoint_index.iter().enumerate() {
                let proj = aug
                    .geometry
                    .camera
                    .project(&aug.geometry.pose.transform_point(&pts[i]))
                    .unwrap();
                let err = (proj
                    - Vector2::new(aug.geometry.keypoints[k][0], aug.geometry.keypoints[k][1]))
                .norm();
                worst = worst.max(err);
            }
            kept += aug.geometry.keypoints.len();
            for k in &aug.geometry.keypoints {
                assert!(
                    k[0] >= 0.0
                        && k[1] >= 0.0
                        && k[0] < aug.geometry.camera.width as f64
                        && k[1] < aug.geometry.camera.height as f64
                );
            }
        }
        assert!(kept > 200 * 100, "most keypoints stay in the image: {kept}");
        assert!(worst < 1e-3, "worst reprojection error {worst} px");
    }

    /// The pose update on the other side (the reference's T * Rz) is measurably wrong:
    /// this guards the test above against a vacuous pass.
    #[test]
    fn right_multiplied_rotation_would_fail() {
        let camera = Camera::new(
            CameraModel::SimplePinhole,
            640,
            480,
            vec![525.0, 320.0, 240.0],
        )
        .unwrap();
        let pose = Pose::new(
            UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0),
            Vector3::new(0.5, -0.3, 2.0),
        );
        let x = pose.inverse().transform_point(&Vector3::new(0.2, 0.1, 3.0));
        let params = AugmentParams {
            rotation_rad: 20f64.to_radians(),
            ..AugmentParams::IDENTITY
        };
        let kp = camera.project(&pose.transform_point(&x)).unwrap();
        let sample = Sample {
            image: GrayImage::new(640, 480),
            camera: camera.clone(),
            pose,
            keypoints: vec![[kp.x, kp.y]],
            segments: vec![],
        };
        let aug = apply(&sample, &params).unwrap();
        let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), params.rotation_rad);
        let wrong = Pose::new(pose.rotation * rz, pose.translation);
        let good = aug
            .geometry
            .camera
            .project(&aug.geometry.pose.transform_point(&x))
            .unwrap();
        let bad = aug
            .geometry
            .camera
            .project(&wrong.transform_point(&x))
            .unwrap();
        let target = Vector2::new(aug.geometry.keypoints[0][0], aug.geometry.keypoints[0][1]);
        assert!((good - target).norm() < 1e-9);
        assert!((bad - target).norm() > 1.0);
    }

    #[test]
    fn image_follows_the_keypoints() {
        // A bright dot at a known position lands where its keypoint goes.
        let mut img = GrayImage::new(200, 100);
        for y in 58..62 {
            for x in 148..152 {
                img.put_pixel(x, y, Luma([255]));
            }
        }
        let camera = Camera::new(
            CameraModel::SimplePinhole,
            200,
            100,
            vec![150.0, 100.0, 50.0],
        )
        .unwrap();
        let sample = Sample {
            image: img,
            camera,
            pose: Pose::identity(),
            keypoints: vec![[150.0, 60.0]],
            segments: vec![[10.0, 10.0, 190.0, 90.0]],
        };
        let params = AugmentParams {
            brightness: 1.0,
            contrast: 1.0,
            scale: 1.3,
            rotation_rad: 25f64.to_radians(),
        };
        let aug = apply(&sample, &params).unwrap();
        let k = aug.geometry.keypoints[0];
        let v = aug.image.get_pixel(k[0] as u32, k[1] as u32)[0];
        assert!(v > 200, "pixel under the moved keypoint is {v}");
        // Segments are clipped into the new image.
        for s in &aug.geometry.segments {
            for (i, v) in s.iter().enumerate() {
                let lim = if i % 2 == 0 {
                    aug.geometry.camera.width
                } else {
                    aug.geometry.camera.height
                } as f64;
                assert!(*v >= -1e-9 && *v <= lim + 1e-9);
            }
        }
    }

    #[test]
    fn asymmetric_cameras_are_not_rotated() {
        let cam = Camera::new(
            CameraModel::Pinhole,
            640,
            480,
            vec![500.0, 520.0, 320.0, 240.0],
        )
        .unwrap();
        assert!(!rotation_is_exact(&cam));
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let cfg = AugmentConfig {
            probability: 1.0,
            ..Default::default()
        };
        assert_eq!(draw_params(&cfg, &cam, &mut rng).rotation_rad, 0.0);
    }

    #[test]
    fn photometric_change_is_bounded() {
        let img = GrayImage::from_fn(64, 64, |x, y| Luma([((x * 4 + y) % 256) as u8]));
        let sample = Sample {
            image: img.clone(),
            camera: Camera::new(CameraModel::SimplePinhole, 64, 64, vec![50.0, 32.0, 32.0])
                .unwrap(),
            pose: Pose::identity(),
            keypoints: vec![],
            segments: vec![],
        };
        let same = apply(&sample, &AugmentParams::IDENTITY).unwrap();
        assert_eq!(same.image, img);
        let brighter = apply(
            &sample,
            &AugmentParams {
                brightness: 1.15,
                ..AugmentParams::IDENTITY
            },
        )
        .unwrap();
        let m0: f64 = img.as_raw().iter().map(|&v| v as f64).sum();
        let m1: f64 = brighter.image.as_raw().iter().map(|&v| v as f64).sum();
        assert!(m1 > m0 * 1.05);
    }

    #[test]
    fn jittered_descriptors_stay_unit_rows_near_the_originals() {
        let dim = 128;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let rows: Vec<f32> = (0..dim * 200)
            .map(|i| ((i * 7919) % 13) as f32 - 6.0)
            .collect::<Vec<_>>()
            .chunks(dim)
            .flat_map(|r| {
                let n = r.iter().map(|v| v * v).sum::<f32>().sqrt();
                r.iter().map(move |v| v / n).collect::<Vec<_>>()
            })
            .collect();
        let mut j = rows.clone();
        jitter_descriptors(&mut j, dim, 0.2, &mut rng);
        let mut dist = 0.0;
        for (a, b) in rows.chunks(dim).zip(j.chunks(dim)) {
            let n: f32 = b.iter().map(|v| v * v).sum::<f32>().sqrt();
            assert!((n - 1.0).abs() < 1e-5);
            dist += a
                .iter()
                .zip(b)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f32>()
                .sqrt() as f64;
        }
        // Noise of norm 0.2 on a unit row, renormalised: about 0.2 away.
        let mean = dist / 200.0;
        assert!((0.17..0.23).contains(&mean), "{mean}");
        let mut same = rows.clone();
        jitter_descriptors(&mut same, dim, 0.0, &mut rng);
        assert_eq!(same, rows);
    }
}
