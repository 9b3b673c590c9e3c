//! Multi-head attention on burn's Flex CPU backend as one operation (forward and backward).
//!
//! Composed from burn's operations, attention over N = 1152 tokens (the graph network at
//! 1024 keypoints and 128 lines) spent about a sixth of a CPU training step in
//! burn-flex's `FlexTensor::empty`: every matrix product's output is a zeroed byte buffer
//! that is then copied into a newly aligned one, page faults included, and the score
//! tensors are 4 x N x N floats (16 MiB). Here the products write into buffers made once
//! per operation (`Bytes::from_elems`, no copy), the per-head operands are read in place
//! through their strides instead of being made contiguous, and the softmax and its
//! backward pass run row by row in the scores' own buffer (`softmax_rows.rs`).
//!
//! The products are the composed path's: the same `gemm` calls on the same operands
//! (burn-flex's `matmul` is `gemm` with alpha 0 and beta 1), as is the queries' scaling.
//! The softmax has its own vectorised exponential and sums, so results agree with the
//! composed path's to a few f32 ulp, not bit for bit (test `matches_the_composed_path`).
//! Every task is a fixed block (one image and head, or 64 rows of scores), so results
//! never depend on the number of threads.

use crate::flex_matrix::{Operand, SendPtr, View, row_major, tensor, transposed};
use crate::softmax_rows::{softmax_backward_rows, softmax_rows};
use burn::backend::Flex;
use burn::tensor::Scalar;
use burn::tensor::ops::FloatTensorOps;
use burn_flex::FlexTensor;
use rayon::prelude::*;

/// One block's product on the calling thread (each block is its own rayon task).
///
/// SAFETY: as `flex_matrix::product`.
unsafe fn product(dst: *mut f32, m: usize, n: usize, k: usize, lhs: Operand, rhs: Operand) {
    unsafe { crate::flex_matrix::product(dst, (m, n, k), lhs, rhs, gemm::Parallelism::None) }
}

/// `blocks` products of `m x n` each into one new buffer, block b written by
/// `product_b(b, dst)` (one task per block: the split never depends on the threads).
/// The buffer is not zeroed first: each product writes every element of its block
/// (about a twentieth of a step went to zeroing buffers about to be overwritten).
///
/// SAFETY: `product_b(b, dst)` must write all m x n elements at dst (a `product` call
/// with that shape and m, n, k > 0 does).
unsafe fn block_products(
    blocks: usize,
    m: usize,
    n: usize,
    product_b: impl Fn(usize, *mut f32) + Sync,
) -> Vec<f32> {
    let len = blocks * m * n;
    let mut out: Vec<f32> = Vec::with_capacity(len);
    let base = SendPtr(out.as_mut_ptr());
    (0..blocks).into_par_iter().for_each(|b| {
        let base = &base;
        // Blocks are disjoint ranges of the allocation.
        product_b(b, unsafe { base.0.add(b * m * n) });
    });
    // SAFETY: every block, so every element, was written above.
    unsafe { out.set_len(len) };
    out
}

/// The sizes of one call: `groups` images of nq queries and nk keys, `heads` heads of dk.
#[derive(Clone, Copy, Debug)]
struct Dims {
    groups: usize,
    heads: usize,
    nq: usize,
    nk: usize,
    d: usize,
    dk: usize,
}

impl Dims {
    fn of(q: &View<'_>, k: &View<'_>, v: &View<'_>, heads: usize, groups: usize) -> Option<Self> {
        let d = q.cols;
        let ok = heads > 0
            && groups > 0
            && d.is_multiple_of(heads)
            && k.cols == d
            && v.cols == d
            && k.rows == v.rows
            && q.rows.is_multiple_of(groups)
            && k.rows.is_multiple_of(groups)
            && q.rows > 0
            && k.rows > 0;
        ok.then(|| Dims {
            groups,
            heads,
            nq: q.rows / groups,
            nk: k.rows / groups,
            d,
            dk: d / heads,
        })
    }

    fn blocks(&self) -> usize {
        self.groups * self.heads
    }

    /// The composed path's score scale, 1 / sqrt(dk), applied to the queries.
    fn scale(&self) -> Scalar {
        Scalar::Float(1.0 / (self.dk as f64).sqrt())
    }

    /// Every block's head of a [groups * rows, d] view (block = image * heads + head).
    fn heads_of(&self, t: &View<'_>, rows: usize) -> Vec<Operand> {
        (0..self.blocks()).map(|b| self.head(t, rows, b)).collect()
    }

    /// Head `h` of image `g` of a [groups * rows, d] view: a [rows, dk] operand.
    fn head(&self, t: &View<'_>, rows: usize, block: usize) -> Operand {
        let (g, h) = (block / self.heads, block % self.heads);
        Operand {
            ptr: t.data[t.offset + g * rows * t.row_stride + h * self.dk * t.col_stride..].as_ptr(),
            row_stride: t.row_stride,
            col_stride: t.col_stride,
        }
    }

    /// [blocks, rows, dk] (block = image * heads + head) back to [groups * rows, d].
    fn merge_heads(&self, per_head: &[f32], rows: usize) -> Vec<f32> {
        let mut out = vec![0.0f32; self.groups * rows * self.d];
        for block in 0..self.blocks() {
            let (g, h) = (block / self.heads, block % self.heads);
            for r in 0..rows {
                let src = &per_head[(block * rows + r) * self.dk..][..self.dk];
                out[(g * rows + r) * self.d + h * self.dk..][..self.dk].copy_from_slice(src);
            }
        }
        out
    }
}

/// Attention of `q` ([groups * nq, d]) over `k`, `v` ([groups * nk, d]) with `heads`
/// heads, image g's queries attending to image g's keys only: the output
/// [groups * nq, d] and what the backward pass needs: `[q / sqrt(dk) (contiguous), k, v,
/// softmax(q k^T / sqrt(dk)) ([groups, heads, nq, nk])]`. None when the operands are not
/// plain f32 matrices of matching sizes (the caller then composes burn's operations).
pub(crate) fn forward(
    q: &FlexTensor,
    k: &FlexTensor,
    v: &FlexTensor,
    heads: usize,
    groups: usize,
) -> Option<(FlexTensor, [FlexTensor; 4])> {
    let (qv, kv, vv) = (View::of(q)?, View::of(k)?, View::of(v)?);
    let dims = Dims::of(&qv, &kv, &vv, heads, groups)?;
    let Dims { nq, nk, dk, .. } = dims;
    // The composed path scales the queries (N x D multiplications, not N x N).
    let q_scaled = Flex::float_mul_scalar(q.clone(), dims.scale()).to_contiguous();
    let qs = View::of(&q_scaled)?;

    let (qs_ops, k_ops) = (dims.heads_of(&qs, nq), dims.heads_of(&kv, nk));
    // SAFETY (here and below): the operands are heads of views checked by View::of and
    // Dims::of; every product has positive sizes and writes its whole block.
    // The scores, then their softmax in the same buffer.
    let mut probs = unsafe {
        block_products(dims.blocks(), nq, nk, |b, dst| {
            product(dst, nq, nk, dk, qs_ops[b], transposed(k_ops[b]))
        })
    };
    softmax_rows(&mut probs, nk);

    let v_ops = dims.heads_of(&vv, nk);
    let per_head = unsafe {
        block_products(dims.blocks(), nq, dk, |b, dst| {
            product(
                dst,
                nq,
                dk,
                nk,
                row_major(&probs[b * nq * nk..], nk),
                v_ops[b],
            )
        })
    };
    let output = tensor(
        dims.merge_heads(&per_head, nq),
        vec![dims.groups * nq, dims.d],
    );
    Some((
        output,
        [
            q_scaled,
            k.clone(),
            v.clone(),
            tensor(probs, vec![dims.groups, heads, nq, nk]),
        ],
    ))
}

/// The gradients of the queries, keys and values from the output's gradient `grad`.
/// `saved` is what [`forward`] returned; None when its tensors do not fit together.
pub(crate) fn backward(
    saved: &[FlexTensor; 4],
    grad: &FlexTensor,
    heads: usize,
    groups: usize,
) -> Option<[FlexTensor; 3]> {
    let (qs, kv, vv, gv) = (
        View::of(&saved[0])?,
        View::of(&saved[1])?,
        View::of(&saved[2])?,
        View::of(grad)?,
    );
    let dims = Dims::of(&qs, &kv, &vv, heads, groups)?;
    let Dims { nq, nk, dk, .. } = dims;
    if gv.rows != qs.rows || gv.cols != dims.d {
        return None;
    }
    let probs = saved[3].as_slice::<f32>()?;
    if probs.len() != dims.blocks() * nq * nk {
        return None;
    }
    let (q_ops, k_ops, v_ops, g_ops) = (
        dims.heads_of(&qs, nq),
        dims.heads_of(&kv, nk),
        dims.heads_of(&vv, nk),
        dims.heads_of(&gv, nq),
    );

    // Through the second product (P V): dP = dO V^T.
    let mut dp = unsafe {
        block_products(dims.blocks(), nq, nk, |b, dst| {
            product(dst, nq, nk, dk, g_ops[b], transposed(v_ops[b]))
        })
    };
    // Through the softmax: dS = (dP - sum(dP * P)) * P, row by row.
    softmax_backward_rows(&mut dp, probs, nk);
    let ds = &dp;

    // Through the first product (Q' K^T): dQ' = dS K, d(K^T) = Q'^T dS.
    let dq_heads = unsafe {
        block_products(dims.blocks(), nq, dk, |b, dst| {
            product(dst, nq, dk, nk, row_major(&ds[b * nq * nk..], nk), k_ops[b])
        })
    };
    let dkt = unsafe {
        block_products(dims.blocks(), dk, nk, |b, dst| {
            product(
                dst,
                dk,
                nk,
                nq,
                transposed(q_ops[b]),
                row_major(&ds[b * nq * nk..], nk),
            )
        })
    };
    // Through P V: dV = P^T dO.
    let dv_heads = unsafe {
        block_products(dims.blocks(), nk, dk, |b, dst| {
            product(
                dst,
                nk,
                dk,
                nq,
                transposed(row_major(&probs[b * nq * nk..], nk)),
                g_ops[b],
            )
        })
    };

    // d(K^T) [blocks, dk, nk] back to [groups * nk, d].
    let mut dk_rows = vec![0.0f32; dims.groups * nk * dims.d];
    for b in 0..dims.blocks() {
        let (g, h) = (b / heads, b % heads);
        for c in 0..dk {
            for j in 0..nk {
                dk_rows[(g * nk + j) * dims.d + h * dk + c] = dkt[(b * dk + c) * nk + j];
            }
        }
    }
    let dq = Flex::float_mul_scalar(
        tensor(
            dims.merge_heads(&dq_heads, nq),
            vec![dims.groups * nq, dims.d],
        ),
        dims.scale(),
    );
    let dk_t = tensor(dk_rows, vec![dims.groups * nk, dims.d]);
    let dv = tensor(
        dims.merge_heads(&dv_heads, nk),
        vec![dims.groups * nk, dims.d],
    );
    Some([dq, dk_t, dv])
}
