//! Adam in one pass over each parameter, on backends whose tensors live in host memory.
//!
//! Why: burn's Adam updates a parameter with about a dozen tensor operations (two for
//! each moment, the square, the bias corrections, the square root, the division, the
//! learning rate, the subtraction), each a pass over the parameter and a fresh buffer.
//! On the CPU that is memory traffic, not arithmetic. Here each element is read once
//! and its parameter and both moments are written once, in parallel chunks.
//!
//! The arithmetic is burn's, operation for operation in f32 (train crate test
//! `fused_adam_equals_burns_adam_bit_for_bit`), so a run gives the same weights and the
//! same optimiser state as with burn's Adam; the state is burn's own record type, so
//! checkpoints are unchanged. On other backends (CUDA) the step is burn's Adam itself.

use crate::backend::Pl2MapBackend;
use crate::simd_dispatch::dispatch;
use burn::optim::{
    Adam, AdamConfig, AdamState, AdaptiveMomentumState, LearningRate, SimpleOptimizer,
};
use burn::tensor::{DType, Tensor, TensorData};
use rayon::prelude::*;

/// Elements per parallel task: small parameters (biases, norms) stay on one thread.
const CHUNK: usize = 1 << 14;

/// Adam with burn's arithmetic and record, fused on host-memory backends.
#[derive(Clone)]
pub struct FusedAdam {
    beta_1: f32,
    beta_2: f32,
    epsilon: f32,
    /// burn's Adam with the same settings: the step on other backends.
    fallback: Adam,
}

impl FusedAdam {
    pub fn new(beta_1: f32, beta_2: f32, epsilon: f32) -> Self {
        FusedAdam {
            beta_1,
            beta_2,
            epsilon,
            fallback: AdamConfig::new()
                .with_beta_1(beta_1)
                .with_beta_2(beta_2)
                .with_epsilon(epsilon)
                .build(),
        }
    }
}

impl std::fmt::Debug for FusedAdam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FusedAdam")
            .field("beta_1", &self.beta_1)
            .field("beta_2", &self.beta_2)
            .field("epsilon", &self.epsilon)
            .finish()
    }
}

/// The values of an f32 tensor (callers check the dtype: the conversion is then a move
/// on host-memory backends and cannot fail).
fn host_f32<B: Pl2MapBackend, const D: usize>(t: Tensor<B, D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .into_vec::<f32>()
        .unwrap_or_default()
}

impl FusedAdam {
    /// One Adam step of a parameter whose gradient is the sum of `grads`, added in their
    /// order (one element: that gradient). On host memory the sum is made element by
    /// element inside the update pass, so the gradient groups' sum
    /// (the training step's gradient groups, `crates/train/src/step/groups.rs`) costs no pass of its own; each element is
    /// still `g0 + g1 + ...` in order, as a sum of the tensors would make it, so the
    /// result does not depend on the fusion.
    pub fn step_sum<B: Pl2MapBackend, const D: usize>(
        &self,
        lr: LearningRate,
        tensor: Tensor<B, D>,
        grads: Vec<Tensor<B, D>>,
        state: Option<AdamState<B, D>>,
    ) -> (Tensor<B, D>, Option<AdamState<B, D>>) {
        let f32_state = state.as_ref().is_none_or(|s| {
            let s = &s.momentum;
            s.moment_1.dtype() == DType::F32
                && s.moment_2.dtype() == DType::F32
                && s.max_moment_2.is_none()
        });
        if !B::HOST_MEMORY
            || tensor.dtype() != DType::F32
            || grads.is_empty()
            || grads
                .iter()
                .any(|g| g.dtype() != DType::F32 || g.shape() != tensor.shape())
            || !f32_state
        {
            // burn's Adam on the tensors' sum: its own behaviour for what the pass below
            // does not take (other dtypes and devices, no gradient, mismatched shapes).
            let grad = grads.into_iter().reduce(|total, g| total + g);
            return match grad {
                Some(grad) => self.fallback.step(lr, tensor, grad, state),
                None => (tensor, state),
            };
        }
        let shape = tensor.shape();
        let device = tensor.device();
        let mut p = host_f32(tensor);
        let grads: Vec<Vec<f32>> = grads.into_iter().map(host_f32).collect();
        let (time, mut m, mut v, first) = match state {
            Some(s) => {
                let s = s.momentum;
                (
                    s.time + 1,
                    host_f32(s.moment_1),
                    host_f32(s.moment_2),
                    false,
                )
            }
            None => (1, vec![0.0; p.len()], vec![0.0; p.len()], true),
        };
        let update = Update::new(self, time, lr as f32, first);
        p.par_chunks_mut(CHUNK)
            .zip(m.par_chunks_mut(CHUNK))
            .zip(v.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, ((p, m), v))| {
                let range = c * CHUNK..c * CHUNK + p.len();
                match grads.as_slice() {
                    [g] => run_one(&update, p, &g[range], m, v),
                    [g0, g1] => run_two(&update, p, &g0[range.clone()], &g1[range], m, v),
                    more => {
                        let mut sum = more[0][range.clone()].to_vec();
                        for g in &more[1..] {
                            for (s, x) in sum.iter_mut().zip(&g[range.clone()]) {
                                *s += x;
                            }
                        }
                        run_one(&update, p, &sum, m, v)
                    }
                }
            });
        let tensor =
            |x: Vec<f32>| Tensor::<B, D>::from_data(TensorData::new(x, shape.clone()), &device);
        let state = AdamState::new(AdaptiveMomentumState {
            time,
            moment_1: tensor(m),
            moment_2: tensor(v),
            max_moment_2: None,
        });
        (tensor(p), Some(state))
    }
}

/// [`Update::run`] of one gradient, with the widest vectors this CPU has
/// (`simd_dispatch.rs`: the same bits on every path).
fn run_one(u: &Update, p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32]) {
    dispatch!(
        baseline,
        (u: &Update, p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32]),
        u.run(p, g.iter().copied(), m, v)
    )
}

/// [`Update::run`] of two gradient groups' sum, `g0 + g1` element by element, as
/// [`run_one`].
fn run_two(u: &Update, p: &mut [f32], g0: &[f32], g1: &[f32], m: &mut [f32], v: &mut [f32]) {
    dispatch!(
        baseline,
        (
            u: &Update,
            p: &mut [f32],
            g0: &[f32],
            g1: &[f32],
            m: &mut [f32],
            v: &mut [f32]
        ),
        u.run(p, g0.iter().zip(g1).map(|(a, b)| a + b), m, v)
    )
}

/// One step's constants, exactly as burn computes them (f32).
struct Update {
    b1: f32,
    b2: f32,
    f1: f32,
    f2: f32,
    combined_factor: f32,
    eps: f32,
    lr: f32,
    first: bool,
}

impl Update {
    fn new(adam: &FusedAdam, time: usize, lr: f32, first: bool) -> Self {
        let (b1, b2) = (adam.beta_1, adam.beta_2);
        let t = time as i32;
        let bias_correction2_sqrt = (1.0 - b2.powi(t)).sqrt();
        Update {
            b1,
            b2,
            f1: 1.0 - b1,
            f2: 1.0 - b2,
            combined_factor: bias_correction2_sqrt / (1.0 - b1.powi(t)),
            eps: adam.epsilon * bias_correction2_sqrt,
            lr,
            first,
        }
    }

    /// The update of one chunk of a parameter, its gradient's values in order. Zipped
    /// slices (no bounds checks) and the first-step branch outside the loop: the compiler
    /// then vectorises it. Lane-wise sqrt and division are IEEE-exact, so the results are
    /// the scalar loop's bit for bit. Inlined into each instruction set's copy.
    #[inline(always)]
    fn run(&self, p: &mut [f32], g: impl Iterator<Item = f32>, m: &mut [f32], v: &mut [f32]) {
        let Update {
            b1,
            b2,
            f1,
            f2,
            combined_factor,
            eps,
            lr,
            first,
        } = *self;
        let update = |p: &mut f32, mi: f32, vi: f32| {
            let delta = (mi * combined_factor) / (vi.sqrt() + eps);
            *p -= delta * lr;
        };
        let it = p.iter_mut().zip(g).zip(m.iter_mut().zip(v.iter_mut()));
        if first {
            // The first step starts the moments from the gradient (not 0 * beta + ...:
            // that would turn -0 into +0).
            for ((p, gi), (m, v)) in it {
                let (mi, vi) = (gi * f1, (gi * gi) * f2);
                *m = mi;
                *v = vi;
                update(p, mi, vi);
            }
        } else {
            for ((p, gi), (m, v)) in it {
                let (mi, vi) = (*m * b1 + gi * f1, *v * b2 + (gi * gi) * f2);
                *m = mi;
                *v = vi;
                update(p, mi, vi);
            }
        }
    }
}

impl<B: Pl2MapBackend> SimpleOptimizer<B> for FusedAdam {
    type State<const D: usize> = AdamState<B, D>;

    fn step<const D: usize>(
        &self,
        lr: LearningRate,
        tensor: Tensor<B, D>,
        grad: Tensor<B, D>,
        state: Option<Self::State<D>>,
    ) -> (Tensor<B, D>, Option<Self::State<D>>) {
        self.step_sum(lr, tensor, vec![grad], state)
    }

    fn to_device<const D: usize>(state: Self::State<D>, device: &B::Device) -> Self::State<D> {
        <Adam as SimpleOptimizer<B>>::to_device(state, device)
    }
}

#[cfg(test)]
mod tests {
    /// The update pass gives the same bits on this CPU's widest vectors as on the
    /// baseline target (`Update::run` called directly), first step and later ones, one
    /// gradient and two groups' sum, over a length that leaves a remainder.
    #[test]
    fn every_code_path_gives_the_same_bits() {
        use super::{FusedAdam, Update, run_one, run_two};
        /// One update pass over (parameter, moment 1, moment 2).
        type Pass<'a> = dyn Fn(&mut [f32], &mut [f32], &mut [f32]) + 'a;
        use crate::testing::{bits, pseudo};
        let n = 1000 + 13;
        let adam = FusedAdam::new(0.9, 0.999, 1e-8);
        let (g0, g1) = (pseudo(n, 1), pseudo(n, 2));
        for first in [true, false] {
            let update = Update::new(&adam, if first { 1 } else { 7 }, 1e-3, first);
            // The bits of (parameter, moment 1, moment 2) after `pass` from a fixed start.
            let after = |pass: &Pass| {
                let (mut p, mut m) = (pseudo(n, 3), pseudo(n, 4));
                let mut v: Vec<f32> = pseudo(n, 5).iter().map(|v| v.abs()).collect();
                pass(&mut p, &mut m, &mut v);
                (bits(&p), bits(&m), bits(&v))
            };
            assert_eq!(
                after(&|p, m, v| run_one(&update, p, &g0, m, v)),
                after(&|p, m, v| update.run(p, g0.iter().copied(), m, v)),
                "one gradient, first step {first}"
            );
            let sum = || g0.iter().zip(&g1).map(|(a, b)| a + b);
            assert_eq!(
                after(&|p, m, v| run_two(&update, p, &g0, &g1, m, v)),
                after(&|p, m, v| update.run(p, sum(), m, v)),
                "two groups, first step {first}"
            );
        }
    }
}
