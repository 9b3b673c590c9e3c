//! Matrices of burn's Flex backend read in place and multiplied with `gemm`, as
//! burn-flex's own `matmul` multiplies them, for the network's kernels
//! (`attention_kernel.rs`, `dense_kernel.rs`).
//!
//! burn-flex makes every product's output with `FlexTensor::empty`: a zeroed byte buffer
//! that is then copied into a newly aligned one (cubecl's `Bytes::from_bytes_vec`). The
//! kernels write their products into `Vec<f32>` buffers instead (`Bytes::from_elems`: no
//! zeroing, no copy), with the same `gemm` call, so the values are the same bit for bit.

use burn::tensor::{Bytes, DType, Shape};
use burn_flex::{FlexTensor, Layout};
use rayon::prelude::*;

/// A 2-D f32 operand read in place: storage, first element, (row, column) strides.
#[derive(Clone, Copy)]
pub(crate) struct View<'a> {
    pub data: &'a [f32],
    pub offset: usize,
    pub rows: usize,
    pub cols: usize,
    pub row_stride: usize,
    pub col_stride: usize,
}

impl<'a> View<'a> {
    /// None unless `t` is a 2-D f32 tensor with non-negative strides inside its storage.
    pub fn of(t: &'a FlexTensor) -> Option<Self> {
        let layout = t.layout();
        let shape = layout.shape();
        if t.dtype() != DType::F32 || shape.num_dims() != 2 {
            return None;
        }
        let strides = layout.strides();
        let (row_stride, col_stride) = (
            usize::try_from(strides[0]).ok()?,
            usize::try_from(strides[1]).ok()?,
        );
        let view = View {
            data: t.storage::<f32>(),
            offset: layout.start_offset(),
            rows: shape[0],
            cols: shape[1],
            row_stride,
            col_stride,
        };
        let fits = within(
            view.data.len(),
            view.offset,
            &[view.rows, view.cols],
            &[row_stride, col_stride],
        );
        fits.then_some(view)
    }

    /// The whole view as a product operand.
    pub fn operand(&self) -> Operand {
        Operand {
            ptr: self.data[self.offset..].as_ptr(),
            row_stride: self.row_stride,
            col_stride: self.col_stride,
        }
    }

    /// Element (r, c).
    #[inline]
    pub fn at(&self, r: usize, c: usize) -> f32 {
        self.data[self.offset + r * self.row_stride + c * self.col_stride]
    }
}

/// Whether every element of the view (`shape` and `strides` from `offset`) lies inside
/// a storage of `len` elements (an empty view always does).
pub(crate) fn within(len: usize, offset: usize, shape: &[usize], strides: &[usize]) -> bool {
    if shape.contains(&0) {
        return true;
    }
    let last = offset
        + shape
            .iter()
            .zip(strides)
            .map(|(&d, &s)| (d - 1) * s)
            .sum::<usize>();
    last < len
}

/// A strided matrix operand of one product: first element and (row, column) strides.
#[derive(Clone, Copy)]
pub(crate) struct Operand {
    pub ptr: *const f32,
    pub row_stride: usize,
    pub col_stride: usize,
}

// SAFETY: an operand is only ever read, and the callers of the unsafe products promise
// that its storage outlives them; the kernels hand operands to their rayon tasks.
unsafe impl Send for Operand {}
unsafe impl Sync for Operand {}

/// The operand's transpose (the same storage read the other way).
pub(crate) fn transposed(o: Operand) -> Operand {
    Operand {
        row_stride: o.col_stride,
        col_stride: o.row_stride,
        ..o
    }
}

/// A contiguous row-major matrix of `cols` columns starting at `data[0]`.
pub(crate) fn row_major(data: &[f32], cols: usize) -> Operand {
    Operand {
        ptr: data.as_ptr(),
        row_stride: cols,
        col_stride: 1,
    }
}

/// burn-flex's rule for a 2-D product's threads (`matmul.rs`, `get_parallelism`): gemm
/// spreads a product over the current rayon pool from 192^3 multiply-adds on, and runs
/// smaller ones on the calling thread. gemm's result does not depend on it.
pub(crate) fn parallelism_of(m: usize, n: usize, k: usize) -> gemm::Parallelism {
    if m.saturating_mul(n).saturating_mul(k) >= 192 * 192 * 192 {
        gemm::Parallelism::Rayon(0)
    } else {
        gemm::Parallelism::None
    }
}

/// dst [m, n] (row-major) = lhs [m, k] x rhs [k, n], as burn-flex's `matmul` computes it
/// (alpha 0, beta 1: every element of dst is written, none is read, for k > 0).
///
/// With `Parallelism::Rayon`, the rows of dst are split into one band per thread of the
/// current rayon pool and each band is one single-threaded `gemm` call ([`row_bands`]).
/// gemm's own threading synchronises its threads twice per block of k (packing, then the
/// products) and reached 159 GFLOP/s on two threads where one thread alone reached 199
/// (the weight gradient of a 128-wide layer over 1024 rows, `examples/gemm_rate.rs`,
/// 2-core Intel Xeon VM); independent bands reached 228. Every element of dst is the
/// same sum in the same order either way (test `row_bands_equal_gemms_threaded_product`):
/// gemm works on the transpose of a row-major dst, and once dst has more than 64
/// columns and a band more than one row (bands average 16 rows or more), it blocks k by
/// k's length alone and takes neither its small-matrix nor its single-row paths, for
/// the whole or for a band.
///
/// SAFETY: dst points to m x n writable elements; lhs reaches m x k and rhs k x n valid
/// elements through their strides; m, n, k > 0.
pub(crate) unsafe fn product(
    dst: *mut f32,
    (m, n, k): (usize, usize, usize),
    lhs: Operand,
    rhs: Operand,
    parallelism: gemm::Parallelism,
) {
    let bands = match parallelism {
        gemm::Parallelism::Rayon(threads) => row_bands(m, n, threads),
        gemm::Parallelism::None => 1,
    };
    if bands <= 1 {
        unsafe { gemm_call(dst, (m, n, k), lhs, rhs, parallelism) };
        return;
    }
    let rows = m.div_ceil(bands);
    let dst = SendPtr(dst);
    (0..bands).into_par_iter().for_each(|band| {
        // Whole values, not their raw-pointer fields, cross to the tasks.
        let (dst, lhs) = (&dst, &lhs);
        let first = band * rows;
        let count = rows.min(m - first);
        let band_lhs = Operand {
            ptr: lhs.ptr.wrapping_add(first * lhs.row_stride),
            ..*lhs
        };
        // SAFETY: band `band` is rows first..first + count of dst and lhs: inside
        // both, and disjoint from every other band's rows of dst.
        unsafe {
            gemm_call(
                dst.0.add(first * n),
                (count, n, k),
                band_lhs,
                rhs,
                gemm::Parallelism::None,
            )
        };
    });
}

/// How many bands of rows a threaded product of m x n is split into (1: not split):
/// one per thread (`threads` 0 = the current rayon pool's), at least 16 rows a band on
/// average, and only with more than 64 columns, where gemm sums every element the same way
/// in a band as in the whole ([`product`]).
pub(crate) fn row_bands(m: usize, n: usize, threads: usize) -> usize {
    let threads = if threads == 0 {
        rayon::current_num_threads()
    } else {
        threads
    };
    if n <= 64 {
        return 1;
    }
    threads.min(m / 16).max(1)
}

/// An output buffer handed to rayon tasks, each of which writes its own disjoint part.
#[derive(Clone, Copy)]
pub(crate) struct SendPtr(pub *mut f32);
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}

/// One `gemm` call with burn-flex's arguments.
///
/// SAFETY: as [`product`].
unsafe fn gemm_call(
    dst: *mut f32,
    (m, n, k): (usize, usize, usize),
    lhs: Operand,
    rhs: Operand,
    parallelism: gemm::Parallelism,
) {
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst,
            1,
            n as isize,
            false,
            lhs.ptr,
            lhs.col_stride as isize,
            lhs.row_stride as isize,
            rhs.ptr,
            rhs.col_stride as isize,
            rhs.row_stride as isize,
            0.0,
            1.0,
            false,
            false,
            false,
            parallelism,
        );
    }
}

/// A new [m, n] buffer holding lhs x rhs (not zeroed first: the product writes it all).
///
/// SAFETY: as [`product`], without dst.
pub(crate) unsafe fn new_product(
    (m, n, k): (usize, usize, usize),
    lhs: Operand,
    rhs: Operand,
    parallelism: gemm::Parallelism,
) -> Vec<f32> {
    let len = m * n;
    let mut out: Vec<f32> = Vec::with_capacity(len);
    unsafe {
        product(out.as_mut_ptr(), (m, n, k), lhs, rhs, parallelism);
        // Every element was written by the product.
        out.set_len(len);
    }
    out
}

/// A contiguous f32 tensor of `shape` over `values` (moved, not copied).
pub(crate) fn tensor(values: Vec<f32>, shape: Vec<usize>) -> FlexTensor {
    FlexTensor::new(
        Bytes::from_elems(values),
        Layout::contiguous(Shape::from(shape)),
        DType::F32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{bits, on_threads, pseudo};

    /// Products split into bands of rows equal gemm's own threaded product bit for bit,
    /// for every band count, both operand layouts, and shapes on both sides of gemm's
    /// special paths (64 columns, k over 512, a band's minimum of 16 rows).
    #[test]
    fn row_bands_equal_gemms_threaded_product() {
        for (m, n, k) in [
            (1024, 128, 128),
            (128, 128, 1024),
            (100, 65, 700),
            (37, 200, 513),
            (64, 64, 600),
            (300, 7, 900),
        ] {
            for (lt, rt) in [(false, false), (true, false), (false, true)] {
                let a = pseudo(m * k, 1);
                let b = pseudo(k * n, 2);
                let lhs = if lt {
                    transposed(row_major(&a, m))
                } else {
                    row_major(&a, k)
                };
                let rhs = if rt {
                    transposed(row_major(&b, k))
                } else {
                    row_major(&b, n)
                };
                let mut whole = vec![0.0f32; m * n];
                unsafe {
                    gemm_call(
                        whole.as_mut_ptr(),
                        (m, n, k),
                        lhs,
                        rhs,
                        gemm::Parallelism::Rayon(0),
                    )
                };
                for threads in [1, 2, 3, 5] {
                    let banded = on_threads(threads, || unsafe {
                        new_product((m, n, k), lhs, rhs, gemm::Parallelism::Rayon(0))
                    });
                    assert_eq!(
                        bits(&banded),
                        bits(&whole),
                        "{m} x {n} x {k}, transposed {lt} {rt}, {threads} threads"
                    );
                }
            }
        }
    }

    #[test]
    fn row_bands_only_where_gemm_sums_alike() {
        assert_eq!(row_bands(1024, 128, 2), 2);
        assert_eq!(row_bands(1024, 64, 2), 1);
        assert_eq!(row_bands(20, 128, 2), 1);
        assert_eq!(row_bands(40, 128, 4), 2);
        assert_eq!(row_bands(1024, 128, 1), 1);
    }
}
