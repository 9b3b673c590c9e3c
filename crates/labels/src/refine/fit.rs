//! Robust 3D line fitting: RANSAC over point pairs with an adaptive number of
//! iterations, then a least-squares (principal axis) refit on the inliers.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::Rng;

/// An infinite 3D line: a point on it and a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line3 {
    pub point: Vector3<f64>,
    pub dir: Vector3<f64>,
}

impl Line3 {
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        let v = p - self.point;
        (v - self.dir * v.dot(&self.dir)).norm()
    }

    /// Parameter of the orthogonal projection of `p` on the line.
    pub fn param(&self, p: &Vector3<f64>) -> f64 {
        (p - self.point).dot(&self.dir)
    }

    pub fn at(&self, t: f64) -> Vector3<f64> {
        self.point + self.dir * t
    }
}

/// Least-squares line through points: centroid and principal axis. None for fewer than
/// two distinct points.
pub fn principal_line(points: &[Vector3<f64>]) -> Option<Line3> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let c = points.iter().fold(Vector3::zeros(), |a, p| a + p) / n;
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - c;
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov);
    let (k, &largest) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    if !(largest > 0.0) {
        return None;
    }
    let dir = eig.eigenvectors.column(k).into_owned();
    let norm = dir.norm();
    if !(norm > 0.0) {
        return None;
    }
    Some(Line3 {
        point: c,
        dir: dir / norm,
    })
}

/// Result of a robust fit: the refit line and which points are inliers.
#[derive(Clone, Debug)]
pub struct Fit {
    pub line: Line3,
    pub inliers: Vec<bool>,
}

impl Fit {
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

fn inliers_of(line: &Line3, points: &[Vector3<f64>], threshold: f64) -> Vec<bool> {
    points
        .iter()
        .map(|p| line.distance(p) <= threshold)
        .collect()
}

/// RANSAC: lines through two random points, the one with most points within
/// `threshold` wins; stops when `max_iterations` are done or when, with the best inlier
/// ratio so far, an all-inlier pair would have been drawn with probability 0.999.
/// The winner is refit to its inliers (and those recounted) while that does not lose
/// inliers. None for fewer than two points or no non-degenerate pair.
pub fn ransac_line(
    points: &[Vector3<f64>],
    threshold: f64,
    max_iterations: usize,
    rng: &mut impl Rng,
) -> Option<Fit> {
    let m = points.len();
    if m < 2 {
        return None;
    }
    let mut best: Option<(usize, Line3)> = None;
    let mut needed = max_iterations;
    let mut it = 0;
    while it < needed.min(max_iterations) {
        it += 1;
        let i = rng.random_range(0..m);
        let mut j = rng.random_range(0..m - 1);
        if j >= i {
            j += 1;
        }
        let d = points[j] - points[i];
        let len = d.norm();
        if !(len > 1e-12) {
            continue;
        }
        let line = Line3 {
            point: points[i],
            dir: d / len,
        };
        let count = points
            .iter()
            .filter(|p| line.distance(p) <= threshold)
            .count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            best = Some((count, line));
            let w = count as f64 / m as f64;
            let p_all = w * w;
            needed = if p_all >= 1.0 {
                it
            } else if p_all <= 0.0 {
                max_iterations
            } else {
                ((1.0f64 - 0.999).ln() / (1.0 - p_all).ln()).ceil() as usize
            };
        }
    }
    let (mut count, mut line) = best?;
    let mut inliers = inliers_of(&line, points, threshold);
    // Local optimisation: least squares on the inliers, kept while it does not lose any.
    for _ in 0..3 {
        let pts: Vec<Vector3<f64>> = points
            .iter()
            .zip(&inliers)
            .filter(|(_, b)| **b)
            .map(|(p, _)| *p)
            .collect();
        let Some(refit) = principal_line(&pts) else {
            break;
        };
        let refit_inliers = inliers_of(&refit, points, threshold);
        let refit_count = refit_inliers.iter().filter(|&&b| b).count();
        if refit_count < count {
            break;
        }
        let changed = refit_inliers != inliers;
        line = refit;
        inliers = refit_inliers;
        count = refit_count;
        if !changed {
            break;
        }
    }
    Some(Fit { line, inliers })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn principal_axis_of_a_sampled_line() {
        let pts: Vec<Vector3<f64>> = (0..10)
            .map(|k| Vector3::new(1.0, 2.0, 3.0) + Vector3::new(1.0, -2.0, 0.5) * k as f64)
            .collect();
        let l = principal_line(&pts).unwrap();
        let expected = Vector3::new(1.0, -2.0, 0.5).normalize();
        assert!(l.dir.dot(&expected).abs() > 1.0 - 1e-12);
        assert!(pts.iter().all(|p| l.distance(p) < 1e-9));
        assert!(principal_line(&pts[..1]).is_none());
        assert!(principal_line(&[pts[0], pts[0]]).is_none());
    }

    #[test]
    fn ransac_ignores_outliers_and_is_seeded() {
        let mut pts: Vec<Vector3<f64>> = (0..40)
            .map(|k| Vector3::new(0.05 * k as f64, 1.0, 2.0))
            .collect();
        // 10 % outliers, 0.5 m off the line.
        for k in [3, 11, 25, 38] {
            pts[k].y += 0.5;
        }
        let fit =
            |seed| ransac_line(&pts, 0.01, 100, &mut ChaCha8Rng::seed_from_u64(seed)).unwrap();
        let a = fit(7);
        assert_eq!(a.inlier_count(), 36);
        for k in [3, 11, 25, 38] {
            assert!(!a.inliers[k]);
        }
        assert!(a.line.distance(&Vector3::new(10.0, 1.0, 2.0)) < 1e-9);
        let b = fit(7);
        assert_eq!(a.line, b.line);
        assert!(ransac_line(&pts[..1], 0.01, 10, &mut ChaCha8Rng::seed_from_u64(0)).is_none());
    }
}
