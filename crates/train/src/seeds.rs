//! Seeds derived from the run's seed and a position, so that every random choice of the
//! trainer (epoch order, augmentation, subsampling, dropout) is a pure function of
//! (seed, where it happens) and a resumed run replays it without any saved RNG state.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Purposes of derived streams: a different constant per use keeps them independent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    EpochOrder = 1,
    Sample = 2,
    Dropout = 3,
}

/// SplitMix64's finaliser: a bijection of u64 that spreads nearby inputs apart.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of `purpose` at `index` (epoch, stream position or iteration).
pub fn derive(seed: u64, purpose: Purpose, index: u64) -> u64 {
    mix(mix(mix(seed) ^ purpose as u64) ^ index)
}

pub fn rng(seed: u64, purpose: Purpose, index: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(derive(seed, purpose, index))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn purposes_and_indices_give_different_seeds() {
        let a = derive(7, Purpose::Sample, 3);
        assert_eq!(a, derive(7, Purpose::Sample, 3));
        assert_ne!(a, derive(7, Purpose::Dropout, 3));
        assert_ne!(a, derive(7, Purpose::Sample, 4));
        assert_ne!(a, derive(8, Purpose::Sample, 3));
    }
}
