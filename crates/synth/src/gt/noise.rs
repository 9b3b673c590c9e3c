//! Label noise: what an SfM error would do to the written 3D points and line endpoints.
//!
//! `label_noise_cm = X` adds independent Gaussian noise of standard deviation
//! `sigma = X / sqrt(3)` cm to each coordinate, so the 3D displacement has an RMS norm of
//! X cm (E|n|^2 = 3 sigma^2 = X^2). The generator is ChaCha8 seeded from the scene seed;
//! points are perturbed in id order, then the line tracks' start and end points in track
//! order, so the noise is a pure function of the seed and the labels.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Mixed into the scene seed so the label noise stream differs from the scene's.
const NOISE_SALT: u64 = 0x6c61_6265_6c5f_6e6f;

/// Per-coordinate standard deviation (metres) for an RMS 3D error of `rms_cm`.
pub fn sigma_per_coordinate_m(rms_cm: f64) -> f64 {
    rms_cm / 100.0 / 3f64.sqrt()
}

/// The seed of the noise stream of a scene seed.
pub fn noise_seed(scene_seed: u64) -> u64 {
    scene_seed ^ NOISE_SALT
}

/// Isotropic Gaussian perturbation of 3D points.
pub struct LabelNoise {
    rng: ChaCha8Rng,
    sigma_m: f64,
}

impl LabelNoise {
    pub fn new(rms_cm: f64, scene_seed: u64) -> Self {
        LabelNoise {
            rng: ChaCha8Rng::seed_from_u64(noise_seed(scene_seed)),
            sigma_m: sigma_per_coordinate_m(rms_cm),
        }
    }

    /// Standard normal sample (Box-Muller; one of the pair is used, which keeps the
    /// stream position a simple function of the number of samples).
    fn normal(&mut self) -> f64 {
        let u1: f64 = 1.0 - self.rng.random::<f64>(); // (0, 1]
        let u2: f64 = self.rng.random::<f64>();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// `p` plus noise; `p` itself when the noise is off (no samples drawn).
    pub fn perturb(&mut self, p: [f64; 3]) -> [f64; 3] {
        if self.sigma_m == 0.0 {
            return p;
        }
        p.map(|v| v + self.sigma_m * self.normal())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rms_of_the_3d_displacement_is_the_requested_one() {
        let mut n = LabelNoise::new(2.0, 7);
        let k = 20000;
        let ms: f64 = (0..k)
            .map(|_| {
                let p = n.perturb([0.0; 3]);
                p.iter().map(|v| v * v).sum::<f64>()
            })
            .sum::<f64>()
            / k as f64;
        let rms_cm = ms.sqrt() * 100.0;
        assert!((rms_cm - 2.0).abs() < 0.05, "{rms_cm}");
    }

    #[test]
    fn zero_noise_is_the_identity() {
        let mut n = LabelNoise::new(0.0, 7);
        assert_eq!(n.perturb([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0]);
    }
}
