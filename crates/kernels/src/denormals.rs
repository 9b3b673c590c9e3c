//! Training steps on threads that flush denormal floats to zero.
//!
//! Why: after a few hundred steps some of the network's and the optimiser's values
//! (Adam's moment estimates of weights whose gradients have died away, tiny activations)
//! fall below f32's smallest normal number. Intel cores take a microcode assist on every
//! such operand, and a CPU training step of `pipeline/synthetic.toml` went from 0.068 s
//! to 0.116 s at about step 800 on a Sapphire Rapids VM (flat at 0.07 s with flushing;
//! the AMD EPYC measured before barely slows down). Flush-to-zero (FTZ) and
//! denormals-are-zero (DAZ) are what GPU training and most CPU deep-learning runtimes use.
//!
//! Values below 1.2e-38 become 0: a different rounding, not a different model. A run is
//! still a pure function of its inputs (every thread that computes a step flushes), so
//! seeded runs stay reproducible for any thread count; they do not equal runs made
//! before this change.

/// A rayon pool with as many threads as the current one whose threads flush denormals,
/// for running training steps in (`pool.install(|| state.step(...))`); burn's matrix
/// products (gemm) and element-wise operations then run on those threads.
pub fn flushing_pool() -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    flushing_pool_of(rayon::current_num_threads(), "train")
}

/// A pool of `threads` flushing threads named `<name>-<i>` (the gradient groups' pools,
/// `crates/train/src/step/groups.rs`).
pub fn flushing_pool_of(
    threads: usize,
    name: &str,
) -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    let name = name.to_string();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("{name}-{i}"))
        .start_handler(|_| flush_denormals_on_this_thread())
        .build()
}

/// Sets FTZ and DAZ in this thread's SSE/AVX control register (x86-64). Other
/// architectures keep their default (IEEE gradual underflow): aarch64 cores handle
/// denormals at full speed.
fn flush_denormals_on_this_thread() {
    #[cfg(target_arch = "x86_64")]
    {
        // MXCSR bit 15 = flush to zero, bit 6 = denormals are zero.
        const FTZ_DAZ: u32 = 0x8040;
        #[allow(deprecated)]
        // SAFETY: only the two rounding-mode bits are set; the rest of MXCSR (exception
        // masks, rounding direction) is written back as read.
        unsafe {
            use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
            _mm_setcsr(_mm_getcsr() | FTZ_DAZ);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::hint::black_box;

    /// Half the smallest normal f32 is a denormal; on a flushing thread it is read as 0
    /// and a product that would underflow to a denormal gives 0.
    #[test]
    fn the_pool_flushes_denormals_and_the_caller_does_not() {
        let tiny = f32::MIN_POSITIVE;
        let plain = black_box(tiny) * black_box(0.5);
        assert!(
            plain > 0.0 && !plain.is_normal(),
            "the caller keeps IEEE denormals"
        );
        let pool = flushing_pool().unwrap();
        let flushed = pool.install(|| black_box(tiny) * black_box(0.5));
        let read = pool.install(|| black_box(plain) * black_box(1.0));
        if cfg!(target_arch = "x86_64") {
            assert_eq!(flushed, 0.0);
            assert_eq!(read, 0.0);
        } else {
            assert_eq!(flushed, plain);
        }
        assert_eq!(pool.current_num_threads(), rayon::current_num_threads());
    }
}
