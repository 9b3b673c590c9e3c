//! The optimiser of a training step: Adam with the reference's settings, fused on the
//! CPU (`crates/kernels/src/adam.rs`), and the gradients an update is tested and
//! measured on.

use kernels::adam::FusedAdam;
use model::burn::optim::adaptor::OptimizerAdaptor;
use model::burn::optim::{AdamConfig, GradientsParams};
use model::burn::tensor::backend::AutodiffBackend;
use model::{Dropout, LossConfig, ModelError, Pl2Map, Pl2MapBackend, Sample, compute_loss};

/// Adam as the reference runs it (PyTorch defaults: betas 0.9 / 0.999, eps 1e-8, no weight
/// decay). Burn's own default epsilon is 1e-5.
pub const ADAM_BETA_1: f32 = 0.9;
pub const ADAM_BETA_2: f32 = 0.999;
pub const ADAM_EPSILON: f32 = 1e-8;

/// burn's Adam with the reference's settings (what [`FusedAdam`] computes).
pub fn adam_config() -> AdamConfig {
    AdamConfig::new()
        .with_beta_1(ADAM_BETA_1)
        .with_beta_2(ADAM_BETA_2)
        .with_epsilon(ADAM_EPSILON)
}

pub type Pl2MapOptimizer<B> = OptimizerAdaptor<FusedAdam, Pl2Map<B>, B>;

/// A fresh optimiser: Adam with the reference's settings, fused on the CPU (`adam.rs`:
/// the same arithmetic and state as burn's Adam, in one pass per parameter).
pub fn new_optimizer<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>()
-> Pl2MapOptimizer<B> {
    OptimizerAdaptor::from(FusedAdam::new(ADAM_BETA_1, ADAM_BETA_2, ADAM_EPSILON))
}

/// The parameter gradients of one image's loss on the CPU (no dropout, every loss term
/// on): what an optimiser update is measured and tested on apart from the passes (the
/// fused Adam's test in `mod.rs`, `groups.rs`'s tests, the bench crate's `adam_bench`).
pub fn cpu_gradients(
    net: &Pl2Map<model::CpuAutodiffBackend>,
    sample: &Sample,
) -> Result<GradientsParams, ModelError> {
    // Not beside another thread's graphs (crates/kernels/src/autodiff_lock.rs).
    let _autodiff = kernels::autodiff_lock::exclusive();
    let t = sample.to_tensors::<model::CpuAutodiffBackend>(&net.config, &Default::default())?;
    let p = net.forward_batch(vec![t.input], &mut Dropout::seeded(0.0, 0));
    let terms = compute_loss(&p[0], &t.targets, &LossConfig::indoor(), 0.9);
    Ok(GradientsParams::from_grads(terms.total.backward(), net))
}
