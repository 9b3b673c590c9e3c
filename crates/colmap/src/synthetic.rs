//! Seeded synthetic models of any size (benchmarks, stress tests). They satisfy every
//! invariant of a real model (consistent tracks, rigs, frames) but their geometry is
//! random: reprojection errors are meaningless.

use crate::model::{
    CameraRecord, INVALID_POINT3D_ID, Image, Point2D, Point3D, Reconstruction, TrackElement,
};
use geometry::{Camera, CameraModel};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyntheticSpec {
    pub num_points3d: usize,
    pub num_images: usize,
    /// Total track length; spread as evenly as possible over the points.
    pub num_observations: usize,
    /// 2D points per image that observe no 3D point (-1), as real keypoints mostly do.
    pub unmatched_per_image: usize,
    /// One camera per this many images.
    pub images_per_camera: usize,
    pub seed: u64,
}

impl SyntheticSpec {
    /// The benchmark model of the project: 1 M points, 5,000 images, 5 M observations.
    pub fn benchmark() -> Self {
        SyntheticSpec {
            num_points3d: 1_000_000,
            num_images: 5_000,
            num_observations: 5_000_000,
            unmatched_per_image: 1_000,
            images_per_camera: 10,
            seed: 0,
        }
    }
}

/// SplitMix64: tiny, seeded, identical on every platform.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Uniformly distributed rotation (Shoemake 1992), w first.
fn random_unit_quaternion(rng: &mut Rng) -> [f64; 4] {
    use std::f64::consts::TAU;
    let (u1, u2, u3) = (rng.unit(), rng.unit(), rng.unit());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    [
        b * (TAU * u3).cos(),
        a * (TAU * u2).sin(),
        a * (TAU * u2).cos(),
        b * (TAU * u3).sin(),
    ]
}

/// Builds the model. Panics only on a spec that cannot be satisfied (tracks longer than
/// the number of images, or observations without images or points).
pub fn large_model(spec: &SyntheticSpec) -> Reconstruction {
    let mut rng = Rng(spec.seed);
    let num_images = spec.num_images.max(1);
    let per_cam = spec.images_per_camera.max(1);
    let num_cameras = num_images.div_ceil(per_cam);
    let (width, height) = (1600u64, 1200u64);
    let cameras: Vec<CameraRecord> = (0..num_cameras)
        .map(|i| CameraRecord {
            camera_id: i as u32 + 1,
            camera: Camera {
                model: CameraModel::SimpleRadial,
                width,
                height,
                params: vec![
                    rng.range(1000.0, 1400.0),
                    800.0,
                    600.0,
                    rng.range(-0.05, 0.05),
                ],
            },
        })
        .collect();
    let per_image = spec.num_observations / num_images + spec.unmatched_per_image + 1;
    let mut images: Vec<Image> = (0..num_images)
        .map(|i| Image {
            image_id: i as u32 + 1,
            qvec: random_unit_quaternion(&mut rng),
            tvec: [
                rng.range(-10.0, 10.0),
                rng.range(-10.0, 10.0),
                rng.range(-10.0, 10.0),
            ],
            camera_id: (i / per_cam) as u32 + 1,
            name: format!("images/frame_{:06}.jpg", i + 1),
            points2d: Vec::with_capacity(per_image),
        })
        .collect();
    let np = spec.num_points3d;
    let (base, extra) = match (
        spec.num_observations.checked_div(np),
        spec.num_observations.checked_rem(np),
    ) {
        (Some(b), Some(e)) => (b, e),
        _ => (0, 0),
    };
    assert!(
        base + usize::from(extra > 0) <= num_images,
        "tracks longer than the number of images"
    );
    let mut points3d = Vec::with_capacity(np);
    let mut chosen: Vec<usize> = Vec::new();
    for k in 0..np {
        let id = k as u64 + 1;
        let len = base + usize::from(k < extra);
        chosen.clear();
        while chosen.len() < len {
            let ii = rng.below(num_images);
            if !chosen.contains(&ii) {
                chosen.push(ii);
            }
        }
        let mut track = Vec::with_capacity(len);
        for &ii in &chosen {
            let im = &mut images[ii];
            track.push(TrackElement {
                image_id: im.image_id,
                point2d_idx: im.points2d.len() as u32,
            });
            im.points2d.push(Point2D {
                xy: [rng.range(0.0, width as f64), rng.range(0.0, height as f64)],
                point3d_id: id,
            });
        }
        points3d.push(Point3D {
            id,
            xyz: [
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0),
                rng.range(0.0, 100.0),
            ],
            rgb: [
                rng.next_u64() as u8,
                rng.next_u64() as u8,
                rng.next_u64() as u8,
            ],
            error: rng.range(0.0, 2.0),
            track,
        });
    }
    for im in &mut images {
        for _ in 0..spec.unmatched_per_image {
            im.points2d.push(Point2D {
                xy: [rng.range(0.0, width as f64), rng.range(0.0, height as f64)],
                point3d_id: INVALID_POINT3D_ID,
            });
        }
    }
    let mut rec = Reconstruction {
        cameras,
        images,
        points3d,
        rigs: Vec::new(),
        frames: Vec::new(),
    };
    rec.add_trivial_rigs_and_frames();
    rec
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_synthetic_model_is_valid_and_seeded() {
        let spec = SyntheticSpec {
            num_points3d: 500,
            num_images: 20,
            num_observations: 1700,
            unmatched_per_image: 7,
            images_per_camera: 3,
            seed: 42,
        };
        let a = large_model(&spec);
        a.validate().unwrap();
        assert_eq!(a.points3d.len(), 500);
        assert_eq!(a.images.len(), 20);
        assert_eq!(a.cameras.len(), 7);
        assert_eq!(a.num_observations(), 1700);
        assert_eq!(a.num_points2d(), 1700 + 20 * 7);
        assert_eq!(a, large_model(&spec));
        let other = large_model(&SyntheticSpec { seed: 43, ..spec });
        assert_ne!(a, other);
    }
}
