//! Dropout with masks drawn on the host from a seeded stream.
//!
//! Burn's `Dropout` samples from a process-global backend RNG, which makes a training run
//! depend on whatever else drew from it. Here every step gets its own ChaCha stream (the
//! trainer derives its seed from the run seed and the iteration), so a step is a pure
//! function of (weights, sample, seed) and a resumed run replays the same masks. The masks
//! are small: only the line encoder uses dropout, and only on the token-0 path.

use crate::init::tensor_from;
use burn::tensor::{Tensor, backend::Backend};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Whether the forward pass is a training pass (dropout on) or an evaluation pass.
pub enum Dropout {
    Off,
    // Boxed: the stream is 300-odd bytes and `Off` is the common case.
    On { prob: f64, rng: Box<ChaCha8Rng> },
}

impl Dropout {
    pub fn off() -> Self {
        Dropout::Off
    }

    /// Training-mode dropout with its own stream.
    pub fn seeded(prob: f64, seed: u64) -> Self {
        if prob <= 0.0 {
            return Dropout::Off;
        }
        Dropout::On {
            prob,
            rng: Box::new(ChaCha8Rng::seed_from_u64(seed)),
        }
    }

    pub fn is_on(&self) -> bool {
        matches!(self, Dropout::On { .. })
    }

    /// Zeroes each element with probability `prob` and scales the rest by 1 / (1 - prob).
    pub fn apply<B: Backend, const K: usize>(&mut self, x: Tensor<B, K>) -> Tensor<B, K> {
        match self {
            Dropout::Off => x,
            Dropout::On { prob, rng } => {
                let keep = 1.0 - *prob as f32;
                let scale = 1.0 / keep;
                let shape: [usize; K] = x.dims();
                let n: usize = shape.iter().product();
                let mask: Vec<f32> = (0..n)
                    .map(|_| {
                        if rng.random::<f32>() < keep {
                            scale
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let mask = tensor_from::<B, K>(mask, shape, &x.device());
                x * mask
            }
        }
    }
}
