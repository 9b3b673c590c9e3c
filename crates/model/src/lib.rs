//! The PL2Map network and its losses on burn (docs/method.md sections 2 and 4).
//!
//! - [`ModelConfig`] describes a network; [`ModelConfig::init`] builds a [`Pl2Map`] whose
//!   weights are a pure function of a seed.
//! - [`Pl2Map::forward`] maps one image's point descriptors [N, D] and line descriptors
//!   [M, T, D] to 3D points + reliability [N, 4] and 3D line endpoints + reliability [M, 7].
//! - [`compute_loss`] evaluates L_m, L_r and L_pi; [`TrainState::step`] runs forward, loss,
//!   backward and an Adam step.
//!
//! Backends: the network is generic over [`Pl2MapBackend`], a burn `Backend` with a fused
//! softmax and, on Flex, an attention kernel (see `backend.rs`), implemented for Flex, NdArray, CUDA and their `Autodiff`
//! wrappers. [`CpuBackend`] (burn's Flex backend) is the default; the `cuda` feature adds
//! [`CudaBackend`] and the `ndarray` feature burn's NdArray backend (kept for comparison).
//! [`Device`] is how runs choose between CPU and CUDA (`--device cpu|cuda[:N]`).
//!
//! Benchmark: [`bench::run_step_benchmark`], printed by
//! `cargo run --release -p model --example step_bench` (PyTorch side with
//! `PL2MAP_TORCH_PYTHON=/path/to/python` pointing at an interpreter with torch).
//!
//! The crate re-exports `burn` so that dependants use exactly the pinned version.

pub mod adam;
pub mod alloc;
mod amx;
pub mod attention;
mod attention_kernel;
pub mod autodiff_lock;
pub mod backend;
pub mod bench;
pub mod bf16_products;
pub mod config;
#[cfg(feature = "cuda")]
mod cuda_check;
pub mod denormals;
pub mod dense;
mod dense_kernel;
pub mod device;
pub mod dropout;
pub mod error;
mod flex_matrix;
pub mod graph;
pub mod groups;
pub mod heads;
pub mod import_reference;
mod init;
pub mod line_encoder;
pub mod loss;
pub mod network;
pub mod permute;
pub mod sample;
mod simd_dispatch;
mod softmax_rows;
pub mod step;
#[cfg(test)]
mod testutil;
mod transpose;

pub use backend::Pl2MapBackend;
pub use burn;
pub use config::{HeadInit, LayerKind, ModelConfig};
pub use device::Device;
pub use dropout::Dropout;
pub use error::ModelError;
pub use init::LAYER_NORM_EPS;
pub use loss::{LossConfig, LossTerms, LossValues, ReprojectionTargets, compute_loss};
pub use network::{
    HostPrediction, LinePrediction, NetworkInput, ParameterCounts, Pl2Map, PointPrediction,
    Prediction,
};
pub use sample::{Pinhole, Sample, SampleTensors, Targets};
pub use step::{StepOptions, StepReport, TrainState, adam_config};

/// The default CPU backend (burn's Flex: its matrix products use the `gemm` crate with
/// SIMD kernels and rayon, measured faster than NdArray on this network).
pub type CpuBackend = burn::backend::Flex;
/// [`CpuBackend`] with automatic differentiation, for training.
pub type CpuAutodiffBackend = burn::backend::Autodiff<CpuBackend>;

#[cfg(feature = "ndarray")]
pub type NdArrayBackend = burn::backend::NdArray;
#[cfg(feature = "ndarray")]
pub type NdArrayAutodiffBackend = burn::backend::Autodiff<NdArrayBackend>;

#[cfg(feature = "cuda")]
pub type CudaBackend = burn::backend::Cuda;
#[cfg(feature = "cuda")]
pub type CudaAutodiffBackend = burn::backend::Autodiff<CudaBackend>;
