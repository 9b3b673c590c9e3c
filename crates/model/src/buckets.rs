//! Shape buckets: the few fixed sizes that a JIT engine's images are padded to.
//!
//! A JIT engine (burn's CUDA backend, CubeCL) compiles its kernels for each tensor shape
//! it meets (crates/model/src/device.rs). Each training image has its own number of
//! keypoints N and lines M, so without padding nearly every step presents new shapes.
//! With buckets, N and M go up to the next size of a short ladder and the padded rows are
//! masked (`network.rs`: attention ignores padded keys; `loss.rs`: every term ignores
//! padded rows), so a run meets a handful of shapes.
//!
//! The ladder of a limit L: the powers of two below L / 4, then L / 4, L / 2, 3 L / 4
//! and L (L / 4 rounded up). Why this one: training images mostly sit at the limit or
//! just under it (the limits subsample every larger image), where the quarters waste at
//! most a third of the rows; the rarer small images get powers of two, at most twice
//! their rows but only log2(L / 4) sizes. A limit of 1024 has 12 sizes (1, 2, 4, ...,
//! 128, 256, 512, 768, 1024), 128 has 9, 32 has 7 and 12 has 6; with 0 (an image
//! without lines keeps no line stream) a pair of limits gives at most (12 + 1) x (9 + 1)
//! pairs, and real data meets far fewer (tests/shape_buckets.rs counts them).

/// The padded size of `n` rows under the limit `limit`: the smallest size of the
/// ladder that holds `n`. 0 stays 0; above the limit (or without one: `limit` 0) the
/// size is the next power of two of `n`, so a size is never below `n`.
pub fn bucket(n: usize, limit: usize) -> usize {
    if n == 0 {
        return 0;
    }
    if n > limit {
        return n.next_power_of_two();
    }
    ladder(limit)
        .into_iter()
        .find(|&size| size >= n)
        .unwrap_or(limit)
}

/// Every size of the ladder of `limit`, increasing (module comment); empty for 0.
pub fn ladder(limit: usize) -> Vec<usize> {
    if limit == 0 {
        return Vec::new();
    }
    let quarter = limit.div_ceil(4);
    let mut sizes: Vec<usize> = std::iter::successors(Some(1usize), |s| Some(s * 2))
        .take_while(|&s| s < quarter)
        .collect();
    sizes.extend(
        [quarter, 2 * quarter, 3 * quarter]
            .into_iter()
            .filter(|&s| s < limit),
    );
    sizes.push(limit);
    sizes.dedup();
    sizes
}

/// The limits whose ladders a run pads to: the trainer's `[train.limits]`, or at query
/// time the predictor's top-K keypoints and no line limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BucketLimits {
    pub points: usize,
    pub lines: usize,
}

impl BucketLimits {
    /// The padded (N, M) of images with `sizes` real (N, M) that go through the network
    /// together: each stream padded to the bucket of its largest image, so that the
    /// images stack into one pass of one shape.
    pub fn padded(&self, sizes: &[(usize, usize)]) -> (usize, usize) {
        let n = sizes.iter().map(|s| s.0).max().unwrap_or(0);
        let m = sizes.iter().map(|s| s.1).max().unwrap_or(0);
        (bucket(n, self.points), bucket(m, self.lines))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ladders_of_the_recipes_limits() {
        assert_eq!(
            ladder(1024),
            [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 768, 1024]
        );
        assert_eq!(ladder(128), [1, 2, 4, 8, 16, 32, 64, 96, 128]);
        assert_eq!(ladder(32), [1, 2, 4, 8, 16, 24, 32]);
        assert_eq!(ladder(12), [1, 2, 3, 6, 9, 12]);
        assert_eq!(ladder(1), [1]);
        assert_eq!(ladder(2), [1, 2]);
        assert_eq!(ladder(5), [1, 2, 4, 5]);
        assert!(ladder(0).is_empty());
    }

    #[test]
    fn buckets_hold_their_rows_and_stay_under_the_limit() {
        for limit in [1, 2, 3, 5, 12, 32, 100, 128, 1024] {
            let sizes = ladder(limit);
            assert!(sizes.windows(2).all(|w| w[0] < w[1]), "{sizes:?}");
            for n in 0..=limit {
                let b = bucket(n, limit);
                assert!(b >= n && b <= limit, "n {n} limit {limit}: {b}");
                assert!(n == 0 || sizes.contains(&b));
            }
            assert_eq!(bucket(limit, limit), limit);
        }
        assert_eq!(bucket(0, 128), 0);
        assert_eq!(bucket(33, 32), 64);
        assert_eq!(bucket(7, 0), 8);
        assert_eq!(bucket(600, 1024), 768);
        assert_eq!(bucket(12, 12), 12);
        assert_eq!(bucket(10, 12), 12);
        assert_eq!(bucket(7, 12), 9);
    }

    #[test]
    fn a_group_pads_to_its_largest_image() {
        let l = BucketLimits {
            points: 32,
            lines: 12,
        };
        assert_eq!(l.padded(&[(30, 0), (17, 5), (3, 12)]), (32, 12));
        assert_eq!(l.padded(&[(20, 0), (17, 0)]), (24, 0));
        assert_eq!(l.padded(&[]), (0, 0));
    }
}
