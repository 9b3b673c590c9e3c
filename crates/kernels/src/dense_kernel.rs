//! A dense layer, `relu(x W + b)` or `x W + b`, on burn's Flex CPU backend as one
//! operation (forward and backward).
//!
//! Composed from burn's operations a layer is a product, a bias addition and a ReLU
//! forward, and a ReLU mask, two products and a column sum backward: six buffers, each
//! product's made zeroed and then copied once more (`flex_matrix.rs`). Here each direction
//! makes one buffer per result and adds the bias and applies the ReLU in the product's
//! pass: the main job's training step got 7-8 % faster, the graph network's 15 %
//! (docs/performance.md, "Dense layers as one operation").
//!
//! The arithmetic is the composed path's: the same `gemm` calls on the same operands
//! (burn's `linear` is `x.matmul(W)`, its backward `grad.matmul(W^T)` and
//! `x^T.matmul(grad)`; the first, for a layer with few rows, as the product's
//! transpose, whose elements are the same sums: [`input_gradient`]), the bias added to
//! the finished product, burn-flex's ReLU (`max(z, 0)`, and backward the gradient where
//! the output is positive, 0 elsewhere) and burn-flex's own first-dimension sum for the
//! bias. The results equal the composed
//! path's bit for bit (test `matches_the_composed_path`) and never depend on the number of
//! threads (element-wise passes; gemm's sums do not depend on its threads).

use crate::flex_matrix::{Operand, View, new_product, parallelism_of, tensor, transposed};
use crate::simd_dispatch::dispatch;
use burn::backend::Flex;
use burn::tensor::Shape;
use burn::tensor::ops::FloatTensorOps;
use burn_flex::FlexTensor;
use rayon::prelude::*;

/// Rows per task of the element-wise passes: a fixed split, whatever the threads.
const ROWS_PER_TASK: usize = 64;

/// The layer's operands, checked: x [m, k], W [k, n], b [n], all sizes positive.
struct Shapes<'a> {
    x: View<'a>,
    w: View<'a>,
    m: usize,
    k: usize,
    n: usize,
}

impl<'a> Shapes<'a> {
    fn of(x: &'a FlexTensor, w: &'a FlexTensor) -> Option<Self> {
        let (x, w) = (View::of(x)?, View::of(w)?);
        let (m, k, n) = (x.rows, x.cols, w.cols);
        (w.rows == k && m > 0 && k > 0 && n > 0).then_some(Shapes { x, w, m, k, n })
    }
}

/// The bias as n contiguous values: None unless a 1-D f32 tensor of n elements.
fn bias_values(b: &FlexTensor, n: usize) -> Option<Vec<f32>> {
    let layout = b.layout();
    if b.dtype() != burn::tensor::DType::F32 || layout.shape().num_dims() != 1 {
        return None;
    }
    let (len, stride) = (layout.shape()[0], layout.strides()[0]);
    let stride = usize::try_from(stride).ok()?;
    let data = b.storage::<f32>();
    let start = layout.start_offset();
    if len != n || (n > 0 && start + (n - 1) * stride >= data.len()) {
        return None;
    }
    Some((0..n).map(|j| data[start + j * stride]).collect())
}

/// `x W + b`, then ReLU when `relu`: [m, n]. None when the operands are not plain f32
/// matrices of matching, positive sizes (the caller then composes burn's operations).
pub(crate) fn forward(
    x: &FlexTensor,
    w: &FlexTensor,
    b: &FlexTensor,
    relu: bool,
) -> Option<FlexTensor> {
    let Shapes { x, w, m, k, n } = Shapes::of(x, w)?;
    let bias = bias_values(b, n)?;
    // SAFETY: both views were checked by View::of, their shapes fit and are positive.
    let mut out =
        unsafe { new_product((m, n, k), x.operand(), w.operand(), parallelism_of(m, n, k)) };
    out.par_chunks_mut(ROWS_PER_TASK * n)
        .for_each(|rows| add_bias(rows, &bias, relu));
    Some(tensor(out, vec![m, n]))
}

/// The gradients of x (when `want_x`), W and b from the output's gradient `grad`, given
/// the layer's input `x`, weight `w` and, with `relu`, its output `y` (whose positive
/// elements let the gradient through): (dx, dW, db). None when the tensors do not fit
/// together.
pub(crate) fn backward(
    x: &FlexTensor,
    w: &FlexTensor,
    y: Option<&FlexTensor>,
    grad: &FlexTensor,
    want_x: bool,
) -> Option<(Option<FlexTensor>, FlexTensor, FlexTensor)> {
    let Shapes { x, w, m, k, n } = Shapes::of(x, w)?;
    let g = View::of(grad)?;
    if g.rows != m || g.cols != n {
        return None;
    }
    // Through the ReLU: a new contiguous gradient, as burn-flex's `relu_backward` makes.
    let dz_tensor = match y {
        Some(y) => {
            let y = View::of(y)?;
            if y.rows != m || y.cols != n {
                return None;
            }
            let mut dz: Vec<f32> = Vec::with_capacity(m * n);
            for r in 0..m {
                if y.col_stride == 1 && g.col_stride == 1 {
                    let yr = &y.data[y.offset + r * y.row_stride..][..n];
                    let gr = &g.data[g.offset + r * g.row_stride..][..n];
                    relu_mask(&mut dz, yr, gr);
                } else {
                    dz.extend((0..n).map(|c| if y.at(r, c) > 0.0 { g.at(r, c) } else { 0.0 }));
                }
            }
            tensor(dz, vec![m, n])
        }
        None => grad.clone(),
    };
    let dz = View::of(&dz_tensor)?.operand();

    // SAFETY (the products): operands checked above, sizes positive.
    // dx = dz W^T: [m, k].
    let dx = want_x.then(|| {
        tensor(
            unsafe { input_gradient(dz, w.operand(), (m, k, n)) },
            vec![m, k],
        )
    });
    // dW = x^T dz: [k, n].
    let dw = unsafe {
        new_product(
            (k, n, m),
            transposed(x.operand()),
            dz,
            parallelism_of(k, n, m),
        )
    };
    // db: burn's own first-dimension sum (its summation order depends on the layout).
    let db = Flex::float_reshape(Flex::float_sum_dim(dz_tensor, 0), Shape::new([n]));
    Some((dx, tensor(dw, vec![k, n]), db))
}

/// Whether [`input_gradient`] computes dx as its transpose: with at most half as many
/// rows as inputs (the main job's heads: 256 or 96 rows a group against 512 inputs), and
/// away from gemm's special paths for tiny products (a destination of up to 16 x 16, a
/// sum of at most two terms, a single row or column), where the two ways are not known
/// to sum alike.
fn via_transpose(m: usize, k: usize, n: usize) -> bool {
    m >= 17 && 2 * m <= k && n >= 3
}

/// dx = dz W^T, [m, k] row-major, for dz [m, n] and W [k, n].
///
/// gemm packs its left operand into column panels, and for a row-major destination it
/// multiplies the transposed problem: here W, read across its rows, one element at a
/// time (gather). Computed instead as dx^T = W dz^T ([k, m]; what gemm then gathers is
/// dz, m x n values instead of k x n) and transposed back (`transpose.rs`), a product of
/// the main job's point head (256 x 512 x 512 a group) took 851 + ~25 µs instead of
/// 942 µs and one of its line head (96 rows) 333 + ~10 µs instead of 474 µs, 2-core
/// Intel Xeon VM. Each element is the same sum in the same order either way (gemm
/// blocks the summed dimension by its length alone, whatever the other two): the
/// values are the same bits (test `input_gradient_is_the_same_either_way`).
///
/// SAFETY: dz reaches m x n and w k x n valid elements through their strides; m, n,
/// k > 0.
unsafe fn input_gradient(dz: Operand, w: Operand, (m, k, n): (usize, usize, usize)) -> Vec<f32> {
    if via_transpose(m, k, n) {
        let dxt = unsafe { new_product((k, m, n), w, transposed(dz), parallelism_of(k, m, n)) };
        return crate::transpose::transposed_copy(&dxt, k, m);
    }
    unsafe { new_product((m, k, n), dz, transposed(w), parallelism_of(m, k, n)) }
}

/// Adds the bias to every row of `rows` (rows of `bias.len()`), then the ReLU when
/// `relu`, with the widest vectors this CPU has (`simd_dispatch.rs`).
fn add_bias(rows: &mut [f32], bias: &[f32], relu: bool) {
    dispatch!(
        baseline,
        (rows: &mut [f32], bias: &[f32], relu: bool),
        add_bias_rows(rows, bias, relu)
    )
}

#[inline(always)]
fn add_bias_rows(rows: &mut [f32], bias: &[f32], relu: bool) {
    for row in rows.chunks_exact_mut(bias.len()) {
        for (v, b) in row.iter_mut().zip(bias) {
            let z = *v + b;
            // burn-flex's ReLU: f32::max, which also takes NaN to 0.
            *v = if relu { z.max(0.0) } else { z };
        }
    }
}

/// Appends one row of the gradient through the ReLU: `g` where the output `y` is
/// positive, 0 elsewhere (burn-flex's `relu_backward`), as [`add_bias`] dispatches.
fn relu_mask(dz: &mut Vec<f32>, y: &[f32], g: &[f32]) {
    dispatch!(
        baseline,
        (dz: &mut Vec<f32>, y: &[f32], g: &[f32]),
        relu_mask_row(dz, y, g)
    )
}

#[inline(always)]
fn relu_mask_row(dz: &mut Vec<f32>, y: &[f32], g: &[f32]) {
    dz.extend(
        y.iter()
            .zip(g)
            .map(|(y, g)| if *y > 0.0 { *g } else { 0.0 }),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flex_matrix::row_major;
    use crate::testing::{bits, pseudo};

    /// The element-wise passes give the same bits on this CPU's widest vectors as on
    /// the baseline target (the functions called directly, not dispatched), NaN,
    /// infinities, signed zeros and a row length that leaves a remainder included.
    #[test]
    fn every_code_path_gives_the_same_bits() {
        let n = 37;
        let mut x: Vec<f32> = pseudo(9 * n, 3).iter().map(|v| 4.0 * v).collect();
        x[5] = f32::NAN;
        x[6] = f32::INFINITY;
        x[7] = -0.0;
        x[8] = f32::NEG_INFINITY;
        let bias = pseudo(n, 4);
        for relu in [true, false] {
            let (mut dispatched, mut baseline) = (x.clone(), x.clone());
            add_bias(&mut dispatched, &bias, relu);
            add_bias_rows(&mut baseline, &bias, relu);
            assert_eq!(bits(&dispatched), bits(&baseline), "bias, relu {relu}");
        }
        let g = pseudo(x.len(), 5);
        let (mut dispatched, mut baseline) = (Vec::new(), Vec::new());
        relu_mask(&mut dispatched, &x, &g);
        relu_mask_row(&mut baseline, &x, &g);
        assert_eq!(bits(&dispatched), bits(&baseline), "relu mask");
    }

    /// dx through its transpose equals the direct product bit for bit, for the shapes
    /// [`via_transpose`] takes (the main job's among them) and a few it leaves alone,
    /// on one thread and in bands over two.
    #[test]
    fn input_gradient_is_the_same_either_way() {
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let mut taken = 0;
        for (m, k) in [
            (17, 34),
            (40, 128),
            (96, 512),
            (96, 128),
            (256, 512),
            (100, 513),
            (64, 1024),
        ] {
            for n in [3, 4, 65, 129, 512] {
                let dz = pseudo(m * n, (m * n) as u32);
                let w = pseudo(k * n, (k + n) as u32);
                let (dz_op, w_op) = (row_major(&dz, n), row_major(&w, n));
                for pool in [&one, &two] {
                    pool.install(|| {
                        // SAFETY: dz holds m x n and w k x n values, row-major.
                        let direct = unsafe {
                            new_product((m, k, n), dz_op, transposed(w_op), parallelism_of(m, k, n))
                        };
                        let got = unsafe { input_gradient(dz_op, w_op, (m, k, n)) };
                        assert_eq!(bits(&got), bits(&direct), "{m} x {k} x {n}");
                    });
                }
                taken += usize::from(via_transpose(m, k, n));
            }
        }
        assert!(
            taken >= 20,
            "the shapes exercise the transposed product ({taken})"
        );
    }
}
