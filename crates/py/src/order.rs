//! The order in which a split's frames are served (docs/formats.md section 6, "Order").
//!
//! Everything here is a pure function of (frame count, seed, epoch, world size) and of
//! the caller's place in the job (rank, worker), so every process of a distributed job
//! computes the same global order without talking to the others:
//!
//! 1. **Permutation**: a Fisher-Yates shuffle of `0..n` driven by SplitMix64 (below),
//!    seeded from `(seed, epoch)`; without `shuffle`, the reading order `0..n`.
//! 2. **Global order**: the permutation, padded to a multiple of the world size by
//!    repeating its first positions (as torch's `DistributedSampler` pads), or, with
//!    `drop_last`, cut to the largest multiple.
//! 3. **Ranks**: of the positions from `start` on (`start` = samples the whole job has
//!    consumed, for a resume), rank `r` of `R` takes every `R`-th: `start + r`,
//!    `start + r + R`, ... Lock-stepped ranks thus consume the global order together.
//! 4. **Workers**: a rank's stream is cut into blocks of `block` samples (the
//!    DataLoader's batch size) and worker `w` of `W` takes blocks `w`, `w + W`, ... A
//!    DataLoader collects each worker's samples into batches and returns the batches of
//!    its workers in turn, so it hands the rank's stream back in order, whatever `W`.
//!
//! SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
//! 2014), written out so that another implementation can reproduce the order:
//! `state = seed ^ mix(epoch + G)`; each draw does `state += G` and returns
//! `mix(state)`, with `G = 0x9E3779B97F4A7C15` and `mix` the finaliser below (all
//! arithmetic wrapping modulo 2^64). Fisher-Yates: for `i` from `n - 1` down to 1,
//! `j = (draw * (i + 1)) >> 64` (a 128-bit product) and positions `i` and `j` swap.

/// The golden-ratio increment of SplitMix64.
const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output function (a bijection of u64).
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    fn new(seed: u64, epoch: u64) -> Self {
        SplitMix64 {
            state: seed ^ mix(epoch.wrapping_add(GOLDEN)),
        }
    }

    fn next(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN);
        mix(self.state)
    }

    /// A draw in `0..bound` (Lemire's multiply-shift, without rejection: the bias is
    /// below `bound / 2^64`, under 1e-12 for any split that fits in memory).
    fn below(&mut self, bound: usize) -> usize {
        ((u128::from(self.next()) * bound as u128) >> 64) as usize
    }
}

/// The epoch's permutation of `0..n` (step 1 of the module docs).
pub fn permutation(n: usize, seed: u64, epoch: u64) -> Vec<usize> {
    let mut rng = SplitMix64::new(seed, epoch);
    let mut p: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = rng.below(i + 1);
        p.swap(i, j);
    }
    p
}

/// What fixes the global order of an epoch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// Frames in the split.
    pub frames: usize,
    pub seed: u64,
    pub epoch: u64,
    /// Ranks of the job (1 without distributed training).
    pub world: usize,
    /// Cut the order to a multiple of `world` instead of padding it.
    pub drop_last: bool,
    /// Permute (step 1); without it the order is the reading order.
    pub shuffle: bool,
}

/// The caller's place: which rank and worker, from which global position on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Place {
    pub rank: usize,
    pub worker: usize,
    pub workers: usize,
    /// Samples per worker block (the DataLoader's batch size; 1 without batching).
    pub block: usize,
    /// Global positions already consumed (0 at the start of an epoch).
    pub start: usize,
}

impl Plan {
    pub fn check(&self) -> Result<(), String> {
        if self.world == 0 {
            return Err("world size must be at least 1".into());
        }
        if self.frames == 0 {
            return Err("the split has no frames".into());
        }
        Ok(())
    }

    /// Length of the global order (step 2).
    pub fn total(&self) -> usize {
        if self.drop_last {
            self.frames / self.world * self.world
        } else {
            self.frames.div_ceil(self.world) * self.world
        }
    }

    /// The global order: frame indices (positions in the split's reading order).
    pub fn global_order(&self) -> Vec<usize> {
        let p = if self.shuffle {
            permutation(self.frames, self.seed, self.epoch)
        } else {
            (0..self.frames).collect()
        };
        // Padding may need more than one pass over p when world > frames.
        (0..self.total()).map(|i| p[i % p.len().max(1)]).collect()
    }

    /// The frame indices the worker at `place` yields, in order (steps 3 and 4).
    pub fn indices(&self, place: &Place) -> Result<Vec<usize>, String> {
        self.check()?;
        if place.rank >= self.world {
            return Err(format!(
                "rank {} is outside a world of {}",
                place.rank, self.world
            ));
        }
        if place.workers == 0 || place.worker >= place.workers {
            return Err(format!(
                "worker {} is outside {} workers",
                place.worker, place.workers
            ));
        }
        if place.block == 0 {
            return Err("the block (batch size) must be at least 1".into());
        }
        let order = self.global_order();
        if place.start > order.len() {
            return Err(format!(
                "resume position {} is past the epoch's {} samples",
                place.start,
                order.len()
            ));
        }
        Ok(order[place.start..]
            .iter()
            .skip(place.rank)
            .step_by(self.world)
            .enumerate()
            .filter(|(i, _)| (i / place.block) % place.workers == place.worker)
            .map(|(_, &f)| f)
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn place(rank: usize, worker: usize, workers: usize, block: usize, start: usize) -> Place {
        Place {
            rank,
            worker,
            workers,
            block,
            start,
        }
    }

    #[test]
    fn permutation_is_a_seeded_bijection() {
        let a = permutation(1000, 7, 0);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..1000).collect::<Vec<_>>());
        assert_eq!(a, permutation(1000, 7, 0));
        assert_ne!(a, permutation(1000, 7, 1));
        assert_ne!(a, permutation(1000, 8, 0));
        assert_eq!(permutation(1, 3, 3), vec![0]);
        assert!(permutation(0, 3, 3).is_empty());
    }

    #[test]
    fn splitmix_matches_its_published_values() {
        // SplitMix64 from state 0 (the reference implementation's first outputs): our
        // generator starts at `seed ^ mix(epoch + G)`, so pick the seed that makes it 0.
        let mut g = SplitMix64::new(mix(GOLDEN), 0);
        assert_eq!(g.state, 0);
        assert_eq!(g.next(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next(), 0x6E78_9E6A_A1B9_65F4);
    }

    /// Interleaves the workers' streams as a DataLoader does: block by block, in turn,
    /// skipping a worker once it is exhausted.
    fn dataloader(streams: &[Vec<usize>], block: usize) -> Vec<usize> {
        let mut chunks: Vec<std::collections::VecDeque<Vec<usize>>> = streams
            .iter()
            .map(|s| s.chunks(block).map(<[usize]>::to_vec).collect())
            .collect();
        let mut out = Vec::new();
        while chunks.iter().any(|c| !c.is_empty()) {
            for c in &mut chunks {
                if let Some(b) = c.pop_front() {
                    out.extend(b);
                }
            }
        }
        out
    }

    #[test]
    fn every_frame_once_and_the_order_does_not_depend_on_workers() {
        for frames in [1, 2, 13, 64] {
            for world in [1, 2, 3] {
                for drop_last in [false, true] {
                    let plan = Plan {
                        frames,
                        seed: 5,
                        epoch: 2,
                        world,
                        drop_last,
                        shuffle: true,
                    };
                    if plan.total() == 0 {
                        continue;
                    }
                    let global = plan.global_order();
                    for block in [1, 4] {
                        for workers in [1, 2, 3] {
                            let ranks: Vec<Vec<usize>> = (0..world)
                                .map(|r| {
                                    let streams: Vec<Vec<usize>> = (0..workers)
                                        .map(|w| {
                                            plan.indices(&place(r, w, workers, block, 0)).unwrap()
                                        })
                                        .collect();
                                    dataloader(&streams, block)
                                })
                                .collect();
                            // Lock-stepped ranks, one sample each per step.
                            let mut joined = Vec::new();
                            for i in 0..ranks[0].len() {
                                for r in &ranks {
                                    joined.push(r[i]);
                                }
                            }
                            assert_eq!(joined, global, "{plan:?} workers {workers} block {block}");
                        }
                    }
                    let mut seen = global.clone();
                    seen.sort_unstable();
                    seen.dedup();
                    if drop_last {
                        assert_eq!(seen.len(), global.len(), "{plan:?}");
                    } else {
                        assert_eq!(seen, (0..frames).collect::<Vec<_>>(), "{plan:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn resume_serves_the_rest_of_the_global_order() {
        let plan = Plan {
            frames: 13,
            seed: 1,
            epoch: 4,
            world: 2,
            drop_last: false,
            shuffle: true,
        };
        let global = plan.global_order();
        for start in [0, 2, 6, 14] {
            let r0 = plan.indices(&place(0, 0, 1, 1, start)).unwrap();
            let r1 = plan.indices(&place(1, 0, 1, 1, start)).unwrap();
            let mut joined = Vec::new();
            for (i, &x) in r0.iter().enumerate() {
                joined.push(x);
                joined.extend(r1.get(i));
            }
            assert_eq!(joined, global[start..], "start {start}");
        }
        assert!(plan.indices(&place(0, 0, 1, 1, 15)).is_err());
        assert!(plan.indices(&place(2, 0, 1, 1, 0)).is_err());
        assert!(plan.indices(&place(0, 1, 1, 1, 0)).is_err());
        assert!(plan.indices(&place(0, 0, 1, 0, 0)).is_err());
    }
}
