//! One function body compiled for several x86-64 instruction sets, chosen at run time.
//!
//! Why: the release build targets baseline x86-64 (SSE2), so the element-wise passes of
//! the network's kernels (`softmax_rows.rs`) and of the fused Adam (`adam.rs`) were
//! vectorised four lanes wide; the machines of this project have AVX-512 or AVX2. The
//! body is the same Rust code on every path, and Rust never fuses a multiply and an add
//! on its own (only an explicit `mul_add` does, and that is exact everywhere), so every
//! path computes the same bits: only the width of the vectors differs.

/// Compiles `$body` (an expression over the arguments) for AVX-512, for AVX2 + FMA and for the baseline
/// target, and runs the best one this CPU has.
macro_rules! dispatch_impl {
    ($name:ident, ($($arg:ident: $ty:ty),*), $body:expr) => {{
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f,avx2,fma")]
            unsafe fn avx512($($arg: $ty),*) { $body }
            #[target_feature(enable = "avx2,fma")]
            unsafe fn avx2($($arg: $ty),*) { $body }
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has the features the function was compiled for.
                return unsafe { avx512($($arg),*) };
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: as above.
                return unsafe { avx2($($arg),*) };
            }
        }
        fn $name($($arg: $ty),*) { $body }
        $name($($arg),*)
    }};
}

pub(crate) use dispatch_impl as dispatch;
