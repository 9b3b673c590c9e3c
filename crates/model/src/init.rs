//! Seeded parameter initialisation on the host.
//!
//! Burn's own initialisers draw from a process-global backend RNG, so two models built in
//! parallel (tests, a trainer and a validator) would interleave draws. Drawing on the host
//! from a ChaCha stream owned by the builder makes a network a pure function of its seed,
//! identical on every backend and thread count. The distributions are PyTorch's defaults for
//! Linear / Conv1d(kernel 1) layers, U(-1/sqrt(fan_in), 1/sqrt(fan_in)) for weights and
//! biases, as in the reference implementation.

use burn::module::{ModuleMapper, Param, ParamId};
use burn::nn::{LayerNorm, LayerNormConfig, Linear};
use burn::tensor::{Tensor, TensorData, backend::Backend};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// LayerNorm epsilon of the line encoder (reference value).
pub const LAYER_NORM_EPS: f64 = 1e-6;

pub(crate) struct Initializer<'d, B: Backend> {
    rng: ChaCha8Rng,
    device: &'d B::Device,
}

impl<'d, B: Backend> Initializer<'d, B> {
    pub fn new(seed: u64, device: &'d B::Device) -> Self {
        Initializer {
            rng: ChaCha8Rng::seed_from_u64(seed),
            device,
        }
    }

    fn uniform(&mut self, len: usize, bound: f32) -> Vec<f32> {
        (0..len)
            .map(|_| (self.rng.random::<f32>() * 2.0 - 1.0) * bound)
            .collect()
    }

    /// A `d_in -> d_out` linear layer; burn stores the weight as `[d_in, d_out]`.
    pub fn linear(&mut self, d_in: usize, d_out: usize) -> Linear<B> {
        let bound = 1.0 / (d_in as f32).sqrt();
        let weight = self.uniform(d_in * d_out, bound);
        let bias = self.uniform(d_out, bound);
        self.linear_from(d_in, d_out, weight, bias)
    }

    /// He (Kaiming) uniform for a layer followed by a ReLU: weights U(+-sqrt(6/fan_in)),
    /// zero bias. The same draws as [`Self::linear`] scaled, so the layers after this one
    /// get the same values under either policy.
    pub fn linear_he(&mut self, d_in: usize, d_out: usize) -> Linear<B> {
        self.linear_scaled_zero_bias(d_in, d_out, 6.0f32.sqrt())
    }

    /// A linear layer whose bias starts at zero (last layer of a message MLP: a fresh
    /// propagation layer then adds a zero-mean update).
    pub fn linear_zero_bias(&mut self, d_in: usize, d_out: usize) -> Linear<B> {
        self.linear_scaled_zero_bias(d_in, d_out, 1.0)
    }

    /// Weights U(+-gain/sqrt(fan_in)) and a zero bias. The bias is drawn (and discarded)
    /// anyway so that later layers get the same values whichever policy this layer has.
    fn linear_scaled_zero_bias(&mut self, d_in: usize, d_out: usize, gain: f32) -> Linear<B> {
        let bound = 1.0 / (d_in as f32).sqrt();
        let weight = self.uniform(d_in * d_out, bound * gain);
        let _ = self.uniform(d_out, bound);
        self.linear_from(d_in, d_out, weight, vec![0.0; d_out])
    }

    fn linear_from(
        &self,
        d_in: usize,
        d_out: usize,
        weight: Vec<f32>,
        bias: Vec<f32>,
    ) -> Linear<B> {
        Linear {
            weight: Param::from_data(TensorData::new(weight, [d_in, d_out]), self.device),
            bias: Some(Param::from_data(
                TensorData::new(bias, [d_out]),
                self.device,
            )),
        }
    }

    pub fn layer_norm(&self, d: usize) -> LayerNorm<B> {
        LayerNormConfig::new(d)
            .with_epsilon(LAYER_NORM_EPS)
            .init(self.device)
    }
}

/// A float tensor from host values (shape must match `values.len()`).
pub(crate) fn tensor_from<B: Backend, const K: usize>(
    values: Vec<f32>,
    shape: [usize; K],
    device: &B::Device,
) -> Tensor<B, K> {
    Tensor::from_data(TensorData::new(values, shape), device)
}

/// Renumbers a module's parameters 1, 2, 3 ... in visiting order.
///
/// Why: burn gives every parameter a random id, which its records store (and Adam keys
/// its state by), so two runs of the same seed wrote different checkpoint bytes. With ids
/// that follow from the network's structure a seeded run's files are reproducible; a
/// checkpoint stores them, so a loaded network keeps its ids.
#[derive(Default)]
pub(crate) struct SequentialIds {
    next: u64,
}

impl<B: Backend> ModuleMapper<B> for SequentialIds {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<B, D>>) -> Param<Tensor<B, D>> {
        self.next += 1;
        let (_, tensor, mapper) = param.consume();
        Param::from_mapped_value(ParamId::from(self.next), tensor, mapper)
    }
}
