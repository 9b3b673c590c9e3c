//! The transpose of a row-major f32 matrix into a new buffer, 8 x 8 blocks at a time with
//! AVX shuffles where the CPU has them.
//!
//! Why: the dense layers' input gradient is computed as its transpose (`dense_kernel.rs`,
//! `input_gradient`), and a plain element loop over a 256 x 512 matrix took as long as
//! that saved (115 µs, reading one of the two sides with a stride of a row). Values are
//! moved, never computed, so every path gives the same bits. It checks for AVX itself
//! rather than through `simd_dispatch.rs`, whose copies are one Rust loop compiled for
//! each instruction set: the shuffles here are AVX intrinsics with no baseline form.

/// `src` holds `rows` x `cols` values row-major; returns its transpose, `cols` x `rows`
/// row-major.
pub(crate) fn transposed_copy(src: &[f32], rows: usize, cols: usize) -> Vec<f32> {
    assert_eq!(
        src.len(),
        rows * cols,
        "transpose: {rows} x {cols} values expected"
    );
    let mut dst = vec![0.0f32; rows * cols];
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked above); both buffers hold rows x cols values.
        unsafe { transpose_avx(src, rows, cols, &mut dst) };
        return dst;
    }
    transpose_rest(src, rows, cols, &mut dst, 0, 0);
    dst
}

/// The elements of rows `r0..` and columns `c0..` not covered by whole 8 x 8 blocks below
/// (r0, c0: where those blocks end), or everything with r0 = c0 = 0: one at a time.
fn transpose_rest(src: &[f32], rows: usize, cols: usize, dst: &mut [f32], r0: usize, c0: usize) {
    for r in 0..rows {
        let from = if r < r0 { c0 } else { 0 };
        for c in from..cols {
            dst[c * rows + r] = src[r * cols + c];
        }
    }
}

/// SAFETY: the CPU has AVX; `src` and `dst` hold rows x cols values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn transpose_avx(src: &[f32], rows: usize, cols: usize, dst: &mut [f32]) {
    use std::arch::x86_64::*;
    let (r8, c8) = (rows / 8 * 8, cols / 8 * 8);
    let (s, d) = (src.as_ptr(), dst.as_mut_ptr());
    for r in (0..r8).step_by(8) {
        for c in (0..c8).step_by(8) {
            // SAFETY: rows r..r + 8 and columns c..c + 8 lie inside both matrices.
            unsafe {
                let row = |i: usize| _mm256_loadu_ps(s.add((r + i) * cols + c));
                let (a0, a1, a2, a3) = (row(0), row(1), row(2), row(3));
                let (a4, a5, a6, a7) = (row(4), row(5), row(6), row(7));
                // Pairs of rows interleaved, then pairs of pairs, then the 128-bit halves
                // exchanged: output row j is input column j.
                let (t0, t1) = (_mm256_unpacklo_ps(a0, a1), _mm256_unpackhi_ps(a0, a1));
                let (t2, t3) = (_mm256_unpacklo_ps(a2, a3), _mm256_unpackhi_ps(a2, a3));
                let (t4, t5) = (_mm256_unpacklo_ps(a4, a5), _mm256_unpackhi_ps(a4, a5));
                let (t6, t7) = (_mm256_unpacklo_ps(a6, a7), _mm256_unpackhi_ps(a6, a7));
                let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
                let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
                let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
                let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
                let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
                let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
                let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
                let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
                let out = |j: usize| d.add((c + j) * rows + r);
                _mm256_storeu_ps(out(0), _mm256_permute2f128_ps::<0x20>(u0, u4));
                _mm256_storeu_ps(out(1), _mm256_permute2f128_ps::<0x20>(u1, u5));
                _mm256_storeu_ps(out(2), _mm256_permute2f128_ps::<0x20>(u2, u6));
                _mm256_storeu_ps(out(3), _mm256_permute2f128_ps::<0x20>(u3, u7));
                _mm256_storeu_ps(out(4), _mm256_permute2f128_ps::<0x31>(u0, u4));
                _mm256_storeu_ps(out(5), _mm256_permute2f128_ps::<0x31>(u1, u5));
                _mm256_storeu_ps(out(6), _mm256_permute2f128_ps::<0x31>(u2, u6));
                _mm256_storeu_ps(out(7), _mm256_permute2f128_ps::<0x31>(u3, u7));
            }
        }
    }
    transpose_rest(src, rows, cols, dst, r8, c8);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shape around the 8 x 8 blocks, against the definition, bit for bit (NaN
    /// payloads and -0 included).
    #[test]
    fn equals_the_definition_for_every_shape() {
        for rows in [1, 3, 7, 8, 9, 16, 17, 31, 64] {
            for cols in [1, 5, 8, 12, 15, 16, 24, 33] {
                let src: Vec<f32> = (0..rows * cols)
                    .map(|i| match i % 11 {
                        3 => f32::from_bits(0x7fc0_1234),
                        7 => -0.0,
                        _ => i as f32 * 0.37 - 5.0,
                    })
                    .collect();
                let t = transposed_copy(&src, rows, cols);
                for r in 0..rows {
                    for c in 0..cols {
                        assert_eq!(
                            t[c * rows + r].to_bits(),
                            src[r * cols + c].to_bits(),
                            "{rows} x {cols} at ({r}, {c})"
                        );
                    }
                }
            }
        }
    }
}
