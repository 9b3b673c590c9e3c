//! The network's operations on burn's backends, apart from the network itself (the
//! `model` crate), as burn keeps custom operations: a backend-extension trait beside its
//! implementations.
//!
//! - [`Pl2MapBackend`] (`backend.rs`): a burn `Backend` with the operations this network
//!   makes its own: a fused softmax backward, multi-head attention and dense layers as
//!   one operation, and the line encoder's head split. Implemented for Flex (with the
//!   kernels below), NdArray, CUDA, LibTorch and their `Autodiff` wrappers; the defaults
//!   compose burn's operations. [`ops`] gives the tensor-level entries.
//! - The Flex CPU kernels: `attention_kernel.rs` (attention, its softmax row by row in
//!   place: `softmax_rows.rs`), `dense_kernel.rs` (dense layers; the input gradient of a
//!   layer with few rows as its transpose, `transpose.rs`), `permute.rs` (the head split's
//!   backward copy). All multiply through `flex_matrix.rs` (one band of rows per thread,
//!   bit-identical to gemm's own threading), and their element-wise passes are compiled
//!   for AVX-512, AVX2 and the baseline (`simd_dispatch.rs`, the same bits on each).
//! - [`adam::FusedAdam`]: burn's Adam in one pass per parameter on host-memory backends,
//!   bit for bit burn's arithmetic and record.
//! - The process settings a training step runs under: [`autodiff_lock`] (burn 0.21's
//!   autodiff is not safe for two threads differentiating at once), [`denormals`]
//!   (threads that flush denormals), [`alloc`] (freed memory kept for reuse).
//! - What the machine offers a GPU engine, asked before one starts: [`cuda_driver`] (the
//!   NVIDIA driver library: missing, the toolkit's stub, how many GPUs) and, with the
//!   `tch` feature, [`libtorch`] (whether PyTorch has CUDA and sees a GPU).
//!
//! Every `unsafe` block of the workspace's learning code is here, each with its SAFETY
//! comment; the network crate forbids unsafe code.

pub mod adam;
pub mod alloc;
mod attention_kernel;
pub mod autodiff_lock;
pub mod backend;
pub mod cuda_driver;
pub mod denormals;
mod dense_kernel;
mod flex_matrix;
#[cfg(feature = "tch")]
pub mod libtorch;
pub mod ops;
mod permute;
mod simd_dispatch;
mod softmax_rows;
#[doc(hidden)]
pub mod testing;
mod transpose;

pub use backend::Pl2MapBackend;
pub use burn;

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

/// burn's LibTorch backend (PyTorch's kernels through tch), f32.
#[cfg(feature = "tch")]
pub type LibTorchBackend = burn::backend::LibTorch<f32>;
#[cfg(feature = "tch")]
pub type LibTorchAutodiffBackend = burn::backend::Autodiff<LibTorchBackend>;
