//! The PL2Map network and its losses on burn (docs/method.md sections 2 and 4).
//!
//! - [`ModelConfig`] describes a network; [`ModelConfig::init`] builds a [`Pl2Map`] whose
//!   weights are a pure function of a seed.
//! - [`Pl2Map::forward`] maps one image's point descriptors [N, D] and line descriptors
//!   [M, T, D] to 3D points + reliability [N, 4] and 3D line endpoints + reliability [M, 7].
//! - [`compute_loss`] evaluates L_m, L_r and L_pi; [`TrainState::step`] runs forward, loss,
//!   backward and an Adam step.
//!
//! Backends: the network is generic over [`Pl2MapBackend`] (crate `kernels`: a burn
//! `Backend` with the operations this network makes its own, and their CPU kernels),
//! implemented for Flex, NdArray, CUDA, LibTorch and their `Autodiff` wrappers.
//! [`CpuBackend`] (burn's Flex backend) is the default; the `cuda` feature adds
//! `CudaBackend` (CubeCL), the `tch` feature `LibTorchBackend` (PyTorch's kernels) and the
//! `ndarray` feature burn's NdArray backend (kept for comparison). [`Device`] is how runs
//! choose the engine and device (`--device cpu|cuda[:N]|libtorch:cpu|libtorch:cuda[:N]`),
//! and `device_probe` asks the machine before a GPU run starts. The training step (optimiser,
//! gradient groups) is the `train` crate's (`crates/train/src/step/`).
//!
//! The crate re-exports `burn` so that dependants use exactly the pinned version.

#![forbid(unsafe_code)]

pub mod attention;
pub mod buckets;
pub mod config;
pub mod dense;
pub mod device;
mod device_probe;
pub mod dropout;
pub mod error;
pub mod graph;
pub mod heads;
pub mod import_reference;
mod init;
pub mod kernel_cache;
pub mod line_encoder;
pub mod loss;
pub mod network;
pub mod sample;
#[doc(hidden)]
pub mod testing;

pub use burn;
pub use config::{HeadInit, LayerKind, ModelConfig};
pub use device::Device;
pub use dropout::Dropout;
pub use error::ModelError;
pub use init::LAYER_NORM_EPS;
pub use kernels::Pl2MapBackend;
pub use loss::{LossConfig, LossTerms, LossValues, ReprojectionTargets, compute_loss};
pub use network::{
    HostPrediction, LinePrediction, NetworkInput, ParameterCounts, Pl2Map, PointPrediction,
    Prediction,
};
pub use sample::{Pinhole, Sample, SampleTensors, Targets};

pub use kernels::{CpuAutodiffBackend, CpuBackend};
#[cfg(feature = "cuda")]
pub use kernels::{CudaAutodiffBackend, CudaBackend};
#[cfg(feature = "tch")]
pub use kernels::{LibTorchAutodiffBackend, LibTorchBackend};
#[cfg(feature = "ndarray")]
pub use kernels::{NdArrayAutodiffBackend, NdArrayBackend};
