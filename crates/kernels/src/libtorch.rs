//! What LibTorch (the PyTorch the `tch` build links) offers, asked before a run uses
//! `libtorch:cuda[:N]`: tch panics on its first CUDA tensor when PyTorch has no CUDA or
//! sees no GPU, so the run checks first and says what to do in one line.

/// How many GPUs PyTorch sees, or why its GPU `index` cannot be used.
pub fn check_cuda(index: usize) -> Result<usize, String> {
    if !tch::utils::has_cuda() {
        return Err(
            "the PyTorch this pl2map is linked against has no CUDA (a CPU-only \
             wheel): install a CUDA build of PyTorch 2.9 and point LD_LIBRARY_PATH at its \
             torch/lib (scripts/libtorch-env.sh), or use --device libtorch:cpu"
                .into(),
        );
    }
    let n = tch::Cuda::device_count().max(0) as usize;
    if n == 0 {
        return Err(
            "PyTorch sees no CUDA GPU (torch.cuda.device_count() = 0): check \
             `nvidia-smi` and CUDA_VISIBLE_DEVICES, or use --device libtorch:cpu"
                .into(),
        );
    }
    if index >= n {
        return Err(format!(
            "there is no GPU {index}: PyTorch sees {n} (libtorch:cuda:0 to libtorch:cuda:{})",
            n - 1
        ));
    }
    Ok(n)
}
