//! Random absolute-pose problems with known ground truth, for tests and benchmarks.
//!
//! A camera with a random orientation and centre looks at points and segments placed
//! in front of it: a random pixel and a random depth give a camera-frame point, mapped
//! to the world by the inverse pose. Observations are the projections with Gaussian
//! pixel noise. A detected segment covers a random part of its world segment (its
//! endpoints do not correspond to the world endpoints, as with a real detector).
//! Outliers pair an observation with an unrelated world point or segment.

use crate::matches::{LineMatch, PointMatch};
use geometry::lines::{Segment2, Segment3};
use geometry::{Camera, Pose};
use nalgebra::{Quaternion, UnitQuaternion, Vector2, Vector3};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticConfig {
    pub camera: Camera,
    pub num_points: usize,
    /// Fraction of the points that are outliers (rounded to a count).
    pub point_outlier_ratio: f64,
    pub num_lines: usize,
    pub line_outlier_ratio: f64,
    /// Standard deviation of the pixel noise on every observed coordinate.
    pub noise_px: f64,
    /// Depth range of the scene in front of the camera, metres.
    pub depth_range: (f64, f64),
    /// Shortest detected segment, pixels.
    pub min_segment_px: f64,
    /// The camera centre is uniform in `[-extent, extent]^3`, metres.
    pub centre_extent: f64,
    /// World segments along the world axes only (a man-made, "Manhattan" scene: many
    /// parallel lines, the hard case for line solvers).
    pub manhattan_lines: bool,
}

impl SyntheticConfig {
    /// A 640x480 pinhole camera (f = 525 px, as 7-Scenes) looking at a room-sized scene
    /// (1 to 8 m), 1 px noise, no correspondences yet.
    pub fn indoor(camera: Camera) -> Self {
        SyntheticConfig {
            camera,
            num_points: 0,
            point_outlier_ratio: 0.0,
            num_lines: 0,
            line_outlier_ratio: 0.0,
            noise_px: 1.0,
            depth_range: (1.0, 8.0),
            min_segment_px: 30.0,
            centre_extent: 5.0,
            manhattan_lines: false,
        }
    }

    /// The 7-Scenes pinhole camera.
    pub fn default_camera() -> Camera {
        Camera {
            model: geometry::CameraModel::Pinhole,
            width: 640,
            height: 480,
            params: vec![525.0, 525.0, 320.0, 240.0],
        }
    }

    /// Benchmark (a): 200 points, 40 % outliers, 1 px noise.
    pub fn bench_points() -> Self {
        SyntheticConfig {
            num_points: 200,
            point_outlier_ratio: 0.4,
            ..Self::indoor(Self::default_camera())
        }
    }

    /// Benchmark (b): 8 points (all correct) + 60 lines, 30 % bad lines, 1 px noise.
    pub fn bench_points_lines() -> Self {
        SyntheticConfig {
            num_points: 8,
            num_lines: 60,
            line_outlier_ratio: 0.3,
            ..Self::indoor(Self::default_camera())
        }
    }
}

/// One problem and its ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticProblem {
    pub camera: Camera,
    /// World-to-camera ground truth.
    pub gt: Pose,
    pub points: Vec<PointMatch>,
    pub lines: Vec<LineMatch>,
    pub point_is_inlier: Vec<bool>,
    pub line_is_inlier: Vec<bool>,
}

fn random_rotation(rng: &mut impl Rng) -> UnitQuaternion<f64> {
    // Normalised 4D Gaussian: uniform on the rotation group.
    let mut g = || -> f64 { StandardNormal.sample(rng) };
    let q = Quaternion::new(g(), g(), g(), g());
    UnitQuaternion::from_quaternion(q)
}

struct Generator<'a, R: Rng> {
    cfg: &'a SyntheticConfig,
    rng: &'a mut R,
    world_from_cam: Pose,
}

impl<R: Rng> Generator<'_, R> {
    fn pixel(&mut self) -> Vector2<f64> {
        let c = &self.cfg.camera;
        Vector2::new(
            self.rng.random_range(0.0..c.width as f64),
            self.rng.random_range(0.0..c.height as f64),
        )
    }

    /// A camera-frame point seen at a random pixel, at a random depth.
    fn cam_point(&mut self) -> Vector3<f64> {
        loop {
            let px = self.pixel();
            if let Some(ray) = self.cfg.camera.unproject(&px) {
                let (lo, hi) = self.cfg.depth_range;
                let depth = self.rng.random_range(lo..hi);
                return ray * (depth / ray.z);
            }
        }
    }

    fn noisy(&mut self, px: Vector2<f64>) -> Vector2<f64> {
        let s = self.cfg.noise_px;
        let nx: f64 = StandardNormal.sample(self.rng);
        let ny: f64 = StandardNormal.sample(self.rng);
        px + Vector2::new(nx, ny) * s
    }

    fn point(&mut self, inlier: bool) -> PointMatch {
        loop {
            let p = self.cam_point();
            let Some(px) = self.cfg.camera.project(&p) else {
                continue;
            };
            let world = if inlier {
                self.world_from_cam.transform_point(&p)
            } else {
                let other = self.cam_point();
                self.world_from_cam.transform_point(&other)
            };
            return PointMatch {
                pixel: self.noisy(px),
                world,
            };
        }
    }

    /// A camera-frame segment whose image is at least `min_segment_px` long.
    fn cam_segment(&mut self) -> (Vector3<f64>, Vector3<f64>) {
        loop {
            let a = self.cam_point();
            let b = if self.cfg.manhattan_lines {
                // 0.5 to 3 m along a world axis.
                let mut d = Vector3::zeros();
                d[self.rng.random_range(0..3)] = if self.rng.random() { 1.0 } else { -1.0 };
                let len = self.rng.random_range(0.5..3.0);
                let dir = self.world_from_cam.rotation.inverse() * d;
                a + dir * len
            } else {
                self.cam_point()
            };
            if b.z < 0.1 * self.cfg.depth_range.0 {
                continue;
            }
            let (Some(pa), Some(pb)) = (self.cfg.camera.project(&a), self.cfg.camera.project(&b))
            else {
                continue;
            };
            let inside = self.cfg.camera.contains(&pa) && self.cfg.camera.contains(&pb);
            if inside && (pa - pb).norm() >= self.cfg.min_segment_px {
                return (a, b);
            }
        }
    }

    fn line(&mut self, inlier: bool) -> LineMatch {
        loop {
            let (a, b) = self.cam_segment();
            // The detector sees most of the segment; the reconstructed world segment is
            // a little shorter or longer: the endpoints do not correspond.
            let s1 = self.rng.random_range(0.0..0.15);
            let s2 = self.rng.random_range(0.85..1.0);
            let (q1, q2) = (a + (b - a) * s1, a + (b - a) * s2);
            let (Some(p1), Some(p2)) = (self.cfg.camera.project(&q1), self.cfg.camera.project(&q2))
            else {
                continue;
            };
            let (wa, wb) = if inlier {
                let w1 = self.rng.random_range(-0.2..0.1);
                let w2 = self.rng.random_range(0.9..1.2);
                (a + (b - a) * w1, a + (b - a) * w2)
            } else {
                self.cam_segment()
            };
            let segment = Segment2::new(self.noisy(p1), self.noisy(p2));
            return LineMatch {
                segment,
                world: Segment3::new(
                    self.world_from_cam.transform_point(&wa),
                    self.world_from_cam.transform_point(&wb),
                ),
            };
        }
    }
}

/// Exactly `round(n * ratio)` of `n` flags false, at random positions.
fn inlier_flags(rng: &mut impl Rng, n: usize, outlier_ratio: f64) -> Vec<bool> {
    let outliers = ((n as f64 * outlier_ratio).round() as usize).min(n);
    let mut flags: Vec<bool> = (0..n).map(|i| i >= outliers).collect();
    flags.shuffle(rng);
    flags
}

/// Generates one problem.
pub fn generate(cfg: &SyntheticConfig, rng: &mut impl Rng) -> SyntheticProblem {
    let rot = random_rotation(rng);
    let e = cfg.centre_extent;
    let centre = Vector3::new(
        rng.random_range(-e..=e),
        rng.random_range(-e..=e),
        rng.random_range(-e..=e),
    );
    let gt = Pose::new(rot, -(rot * centre));
    let point_is_inlier = inlier_flags(rng, cfg.num_points, cfg.point_outlier_ratio);
    let line_is_inlier = inlier_flags(rng, cfg.num_lines, cfg.line_outlier_ratio);
    let mut g = Generator {
        cfg,
        rng,
        world_from_cam: gt.inverse(),
    };
    let points = point_is_inlier.iter().map(|&i| g.point(i)).collect();
    let lines = line_is_inlier.iter().map(|&i| g.line(i)).collect();
    SyntheticProblem {
        camera: cfg.camera.clone(),
        gt,
        points,
        lines,
        point_is_inlier,
        line_is_inlier,
    }
}

/// Generates one problem from a seed (ChaCha8).
pub fn generate_seeded(cfg: &SyntheticConfig, seed: u64) -> SyntheticProblem {
    generate(cfg, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn inliers_reproject_and_outliers_do_not() {
        let cfg = SyntheticConfig {
            num_points: 100,
            point_outlier_ratio: 0.3,
            num_lines: 50,
            line_outlier_ratio: 0.2,
            noise_px: 0.0,
            ..SyntheticConfig::indoor(SyntheticConfig::default_camera())
        };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let pb = generate(&cfg, &mut rng);
        assert_eq!(pb.point_is_inlier.iter().filter(|&&b| !b).count(), 30);
        assert_eq!(pb.line_is_inlier.iter().filter(|&&b| !b).count(), 10);
        for (m, &inl) in pb.points.iter().zip(&pb.point_is_inlier) {
            let px = pb.camera.project(&pb.gt.transform_point(&m.world)).unwrap();
            let e = (px - m.pixel).norm();
            if inl {
                assert!(e < 1e-9, "{e}");
            }
        }
        for (l, &inl) in pb.lines.iter().zip(&pb.line_is_inlier) {
            let proj =
                geometry::lines::project_segment(&pb.camera, &pb.gt, &l.world, 1e-6).unwrap();
            let e = geometry::lines::line_reprojection_error(&l.segment, &proj).unwrap();
            if inl {
                assert!(e < 1e-8, "{e}");
            }
        }
        // Same seed, same problem.
        let again = generate(&cfg, &mut ChaCha8Rng::seed_from_u64(5));
        assert_eq!(again, pb);
    }
}
