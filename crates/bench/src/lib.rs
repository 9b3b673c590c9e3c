//! The benchmarks of pl2map-rs, apart from the libraries they measure. Each prints a
//! table; docs/performance.md quotes them with their commands.
//!
//! - [`step`]: one training step (forward, loss, backward, Adam) on burn, against the same
//!   step in PyTorch (`python/torch_step.py`) when an interpreter is given; printed by
//!   `cargo run --release -p bench --example step_bench`.
//! - [`localize`]: where a query's time goes and queries per second (`pl2map bench localize`).
//! - [`features`]: the SIFT + LSD front-end per step and images/s (`pl2map bench features`).
//! - [`engines`]: one engine (CubeCL CUDA, LibTorch) against the CPU's: predictions,
//!   losses, gradients, training steps (`examples/engine_check.rs`, the GPU check).
//! - [`cli`]: the `pl2map bench` subcommands (colmap, pose, features, localize, stages);
//!   the `pl2map` binary only forwards to them.
//! - `examples/`: `step_bench`, `adam_bench` (the fused Adam against burn's), `gemm_rate`
//!   (gemm's rate on the step's product shapes).

pub mod cli;
pub mod engines;
pub mod features;
pub mod localize;
pub mod step;

/// A benchmark that could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Model(#[from] model::ModelError),
    #[error("benchmark: {0}")]
    Bench(String),
    #[error(transparent)]
    Io(#[from] fileio::IoError),
}
