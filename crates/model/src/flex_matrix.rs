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
/// SAFETY: dst points to m x n writable elements; lhs reaches m x k and rhs k x n valid
/// elements through their strides; m, n, k > 0.
pub(crate) unsafe fn product(
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
