//! Which minimal solver to run, which correspondences to feed it, and when to stop.
//!
//! Solver choice (the hybrid scheme of Camposeco et al., CVPR 2018, as PoseLib's hybrid
//! estimator uses it): a solver taking `k` points and `3 - k` lines is drawn with
//! probability proportional to its number of minimal samples `C(np, k) C(nl, 3 - k)`
//! (so before any model, minimal samples are uniform over points and lines together)
//! times the probability that such a sample is all inliers, `rp^k rl^(3-k)`, with the
//! inlier ratios of the best model so far (Laplace-smoothed, so that no solver is
//! starved by one unlucky early model).
//!
//! Stopping: after `n_s` samples of each solver, the chance that none was all inliers
//! is `prod_s (1 - eps_s)^n_s`; RANSAC stops once that falls below
//! `(1 - success_probability)^factor`. With one solver this is PoseLib's
//! `n >= factor * log(1 - p) / log(1 - eps)`.

use rand::Rng;

/// (points, lines) taken by each solver: P3P, P2P1LL, P1P2LL, P3LL.
pub(crate) const SOLVERS: [(usize, usize); 4] = [(3, 0), (2, 1), (1, 2), (0, 3)];

/// `C(n, k)` for `k <= 3`, as a float (no overflow concerns at these sizes).
fn choose(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    let n = n as f64;
    match k {
        0 => 1.0,
        1 => n,
        2 => n * (n - 1.0) / 2.0,
        _ => n * (n - 1.0) * (n - 2.0) / 6.0,
    }
}

pub(crate) struct Sampler {
    num_points: usize,
    num_lines: usize,
    prior: [f64; 4],
}

impl Sampler {
    pub(crate) fn new(num_points: usize, num_lines: usize) -> Self {
        let prior = SOLVERS.map(|(k, m)| choose(num_points, k) * choose(num_lines, m));
        Sampler {
            num_points,
            num_lines,
            prior,
        }
    }

    /// Whether any solver can run.
    pub(crate) fn feasible(&self) -> bool {
        self.prior.iter().any(|&p| p > 0.0)
    }

    /// Draws a solver index given the inlier counts of the best model so far.
    pub(crate) fn select(&self, rng: &mut impl Rng, inliers: Option<(usize, usize)>) -> usize {
        let (rp, rl) = match inliers {
            Some((pi, li)) => (
                (pi as f64 + 1.0) / (self.num_points as f64 + 2.0),
                (li as f64 + 1.0) / (self.num_lines as f64 + 2.0),
            ),
            None => (1.0, 1.0),
        };
        let mut w = [0.0; 4];
        let mut total = 0.0;
        for (s, &(k, m)) in SOLVERS.iter().enumerate() {
            w[s] = self.prior[s] * rp.powi(k as i32) * rl.powi(m as i32);
            total += w[s];
        }
        let mut u = rng.random::<f64>() * total;
        for (s, &ws) in w.iter().enumerate() {
            if ws > 0.0 {
                if u < ws {
                    return s;
                }
                u -= ws;
            }
        }
        // Rounding left `u` past the end: the last feasible solver.
        (0..4).rev().find(|&s| w[s] > 0.0).unwrap_or(0)
    }

    /// `k` distinct indices below `n` into `out[..k]` (k <= 3 <= n assumed by the caller
    /// through `select`, which never picks an infeasible solver).
    pub(crate) fn draw(rng: &mut impl Rng, n: usize, k: usize, out: &mut [usize; 3]) {
        let mut i = 0;
        while i < k {
            let c = rng.random_range(0..n);
            if !out[..i].contains(&c) {
                out[i] = c;
                i += 1;
            }
        }
    }

    /// `log` of the probability that none of the samples drawn so far (`counts` per
    /// solver) was all inliers, at the inlier ratios of the best model.
    pub(crate) fn log_miss(&self, counts: &[usize; 4], inliers: (usize, usize)) -> f64 {
        let rp = if self.num_points > 0 {
            inliers.0 as f64 / self.num_points as f64
        } else {
            0.0
        };
        let rl = if self.num_lines > 0 {
            inliers.1 as f64 / self.num_lines as f64
        } else {
            0.0
        };
        let mut total = 0.0;
        for (s, &(k, m)) in SOLVERS.iter().enumerate() {
            if counts[s] == 0 {
                continue;
            }
            let eps = rp.powi(k as i32) * rl.powi(m as i32);
            total += counts[s] as f64 * (-eps).ln_1p();
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn priors_follow_sample_counts() {
        // 8 points, 60 lines: C(8,3)=56, C(8,2)*60=1680, 8*C(60,2)=14160, C(60,3)=34220.
        let s = Sampler::new(8, 60);
        assert_eq!(s.prior, [56.0, 1680.0, 14160.0, 34220.0]);
        let only_points = Sampler::new(5, 0);
        assert_eq!(only_points.prior, [10.0, 0.0, 0.0, 0.0]);
        assert!(!Sampler::new(1, 1).feasible());
        assert!(Sampler::new(1, 2).feasible());
        // Empirical frequencies match the priors before any model.
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut hist = [0usize; 4];
        for _ in 0..100_000 {
            hist[s.select(&mut rng, None)] += 1;
        }
        let total: f64 = s.prior.iter().sum();
        for (i, &h) in hist.iter().enumerate() {
            let expect = s.prior[i] / total;
            let got = h as f64 / 100_000.0;
            assert!((got - expect).abs() < 0.01, "{i}: {got} vs {expect}");
        }
        // Points-only never picks a line solver.
        for _ in 0..1000 {
            assert_eq!(only_points.select(&mut rng, Some((3, 0))), 0);
        }
    }

    #[test]
    fn stopping_matches_the_single_solver_formula() {
        // 200 points, 60 % inliers: eps = 0.216; PoseLib's count with factor 3 is
        // ceil(3 * log(1e-4) / log(0.784)) = 114.
        let s = Sampler::new(200, 0);
        let target = 3.0 * (1.0f64 - 0.9999).ln();
        let n = (1..1000)
            .find(|&n| s.log_miss(&[n, 0, 0, 0], (120, 0)) <= target)
            .unwrap();
        assert_eq!(n, 114);
    }

    #[test]
    fn draws_are_distinct() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut out = [0; 3];
        for _ in 0..1000 {
            Sampler::draw(&mut rng, 3, 3, &mut out);
            let mut v = out.to_vec();
            v.sort();
            assert_eq!(v, vec![0, 1, 2]);
        }
    }
}
