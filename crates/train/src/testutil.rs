//! Synthetic shards for the tests: textured images with exact labels (keypoints and
//! segment endpoints back-projected at known depths).

use geometry::{Camera, CameraModel, Pose, UnitQuaternion, Vector2, Vector3};
use image::{GrayImage, Luma};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shards::{FrameRecord, ImageFormat, LabelSource, ShardConfig, Split, write_shard};
use std::path::{Path, PathBuf};

pub const WIDTH: u64 = 160;
pub const HEIGHT: u64 = 120;

pub fn camera() -> Camera {
    Camera::new(
        CameraModel::SimplePinhole,
        WIDTH,
        HEIGHT,
        vec![120.0, 80.0, 60.0],
    )
    .unwrap()
}

fn texture(rng: &mut ChaCha8Rng) -> GrayImage {
    let blobs: Vec<(f64, f64, f64, f64)> = (0..40)
        .map(|_| {
            (
                rng.random_range(0.0..WIDTH as f64),
                rng.random_range(0.0..HEIGHT as f64),
                rng.random_range(2.0..8.0),
                rng.random_range(-120.0..120.0),
            )
        })
        .collect();
    GrayImage::from_fn(WIDTH as u32, HEIGHT as u32, |x, y| {
        let v: f64 = blobs
            .iter()
            .map(|(bx, by, s, a)| {
                let d2 = (x as f64 - bx).powi(2) + (y as f64 - by).powi(2);
                a * (-d2 / (2.0 * s * s)).exp()
            })
            .sum();
        Luma([(128.0 + v).clamp(0.0, 255.0) as u8])
    })
}

fn png(img: &GrayImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// One frame with `n` keypoints (every third unlabelled) and `m` segments.
pub fn frame(frame_id: u64, n: usize, m: usize, label_noise_m: f64) -> FrameRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(frame_id);
    let cam = camera();
    let pose = Pose::new(
        UnitQuaternion::from_euler_angles(
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
            rng.random_range(-3.0..3.0),
        ),
        Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ),
    );
    let inv = pose.inverse();
    let lift = |x: f64, y: f64, rng: &mut ChaCha8Rng| -> [f64; 3] {
        let ray = cam.unproject(&Vector2::new(x, y)).unwrap();
        let depth = rng.random_range(1.0..5.0);
        let p = inv.transform_point(&(ray * depth));
        let mut noise = || rng.random_range(-label_noise_m..=label_noise_m);
        [p.x + noise(), p.y + noise(), p.z + noise()]
    };
    let mut keypoints = Vec::new();
    let mut points3d = Vec::new();
    let mut point_valid = Vec::new();
    for i in 0..n {
        let x = rng.random_range(4.0..WIDTH as f64 - 4.0);
        let y = rng.random_range(4.0..HEIGHT as f64 - 4.0);
        keypoints.push([x, y]);
        let valid = i % 3 != 2;
        points3d.push(if valid {
            lift(x, y, &mut rng)
        } else {
            [f64::NAN; 3]
        });
        point_valid.push(valid);
    }
    let mut segments = Vec::new();
    let mut lines3d = Vec::new();
    let mut line_valid = Vec::new();
    for j in 0..m {
        let s = [
            rng.random_range(5.0..WIDTH as f64 - 5.0),
            rng.random_range(5.0..HEIGHT as f64 - 5.0),
            rng.random_range(5.0..WIDTH as f64 - 5.0),
            rng.random_range(5.0..HEIGHT as f64 - 5.0),
        ];
        segments.push(s);
        let a = lift(s[0], s[1], &mut rng);
        let b = lift(s[2], s[3], &mut rng);
        lines3d.push([a[0], a[1], a[2], b[0], b[1], b[2]]);
        line_valid.push(j % 4 != 3);
    }
    FrameRecord {
        frame_id,
        name: format!("seq-01/frame-{frame_id:06}.color.png"),
        split: Split::Train,
        camera: cam,
        pose,
        image_bytes: png(&texture(&mut rng)).into(),
        image_format: ImageFormat::Png,
        point3d_ids: (0..n as i64).collect(),
        keypoints,
        points3d,
        point_valid,
        track_ids: (0..m as i64).collect(),
        segments,
        lines3d,
        line_valid,
        label_source: LabelSource::SyntheticExact,
        endpoints_aligned: true,
    }
}

/// `shards` shard files of `per_shard` frames each (40 keypoints, 6 segments per frame).
pub fn write_synthetic_shards(
    dir: &Path,
    shards: usize,
    per_shard: usize,
    label_noise_m: f64,
) -> Vec<PathBuf> {
    (0..shards)
        .map(|s| {
            let frames: Vec<FrameRecord> = (0..per_shard)
                .map(|k| frame((s * per_shard + k) as u64, 40, 6, label_noise_m))
                .collect();
            let path = dir.join(format!("train-{s:05}.mcap"));
            write_shard(&path, &frames, &ShardConfig::default()).unwrap();
            path
        })
        .collect()
}

/// The SIFT + LSD front-end of the tests: 4 descriptor samples per segment.
pub fn sift_front_end() -> features::SiftFrontEnd {
    features::SiftFrontEnd::new(features::FrontEndConfig {
        samples_per_line: 4,
        ..Default::default()
    })
    .unwrap()
}
