//! The backends the network runs on, and its two custom operations.
//!
//! Attention spends most of its non-matrix-product time in the softmax. Burn's autodiff
//! has no softmax operation of its own: it records max, sub, exp, sum and div, keeps every
//! intermediate, and its exp backward evaluates exp again. Here the softmax is one recorded
//! operation: the forward is the inner backend's own (fused on Flex) and the backward is
//! dx = y * (dy - sum(dy * y)) from the saved output y. This cut a CPU training step by
//! about a fifth (see the crate's benchmark).
//!
//! The second is multi-head attention as a whole (`multi_head_attention`), for backends
//! with a kernel for it: on Flex `attention_kernel.rs`, which computes exactly what the
//! composed operations compute with fewer buffers (docs/performance.md, "Attention as one
//! operation"); the others return None and `crates/model/src/attention.rs` composes burn's operations.

use crate::{attention_kernel, dense_kernel, permute};
use burn::backend::Autodiff;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::CheckpointStrategy;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::tensor::ops::FloatTensor;
use burn::tensor::{Shape, Tensor, TensorMetadata, TensorPrimitive, backend::Backend};

/// A burn backend with the softmax this network uses.
pub trait Pl2MapBackend: Backend {
    /// Whether tensors live in host memory, so that reading one into a `Vec` and back is
    /// a move, not a transfer (the fused Adam step, `adam.rs`).
    const HOST_MEMORY: bool = false;

    /// Softmax over the last dimension.
    fn softmax_last(x: FloatTensor<Self>) -> FloatTensor<Self> {
        let last = x.shape().num_dims() - 1;
        Self::softmax(x, last)
    }

    /// Multi-head attention as one operation (`crates/model/src/attention.rs`, `attend_grouped`), where
    /// the backend has a kernel for it; None means "compose burn's operations".
    fn multi_head_attention(
        q: FloatTensor<Self>,
        k: FloatTensor<Self>,
        v: FloatTensor<Self>,
        heads: usize,
        groups: usize,
    ) -> Option<FloatTensor<Self>> {
        Self::attention_forward(q, k, v, heads, groups).map(|(out, _)| out)
    }

    /// The kernel's forward pass: the output and what its backward pass needs
    /// (scaled queries, keys, values, probabilities). None: no kernel.
    fn attention_forward(
        _q: FloatTensor<Self>,
        _k: FloatTensor<Self>,
        _v: FloatTensor<Self>,
        _heads: usize,
        _groups: usize,
    ) -> Option<(FloatTensor<Self>, [FloatTensor<Self>; 4])> {
        None
    }

    /// The kernel's backward pass: the gradients of q, k and v from the output's
    /// gradient. Only called with what this backend's `attention_forward` saved; None
    /// where the saved tensors do not fit together.
    fn attention_backward(
        _saved: &[FloatTensor<Self>; 4],
        _grad: FloatTensor<Self>,
        _heads: usize,
        _groups: usize,
    ) -> Option<[FloatTensor<Self>; 3]> {
        None
    }

    /// A dense layer `x W + b` (x [m, k], W [k, n], b [n]), with a ReLU after it when
    /// `relu`, as one operation where the backend has a kernel for it (`crates/model/src/dense.rs`);
    /// None means "compose burn's operations".
    fn dense(
        x: FloatTensor<Self>,
        w: FloatTensor<Self>,
        b: FloatTensor<Self>,
        relu: bool,
    ) -> Option<FloatTensor<Self>> {
        Self::dense_forward(&x, &w, &b, relu)
    }

    /// The kernel's forward pass. None: no kernel, or operands it does not take.
    fn dense_forward(
        _x: &FloatTensor<Self>,
        _w: &FloatTensor<Self>,
        _b: &FloatTensor<Self>,
        _relu: bool,
    ) -> Option<FloatTensor<Self>> {
        None
    }

    /// The kernel's backward pass: (dx when `want_x`, dW, db) from the output's gradient,
    /// the layer's input and weight and, for a ReLU layer, its output. Only called for
    /// layers this backend's `dense_forward` computed.
    fn dense_backward(
        _x: &FloatTensor<Self>,
        _w: &FloatTensor<Self>,
        _y: Option<&FloatTensor<Self>>,
        _grad: FloatTensor<Self>,
        _want_x: bool,
    ) -> Option<DenseGradients<Self>> {
        None
    }

    /// `x` reshaped to `shape`, then its dimensions permuted by `axes`, as one recorded
    /// operation on autodiff backends (`permute.rs`).
    fn reshape_permute(x: FloatTensor<Self>, shape: Shape, axes: &[usize]) -> FloatTensor<Self> {
        Self::float_permute(Self::float_reshape(x, shape), axes)
    }

    /// A row-major copy of `x` where the backend has a faster one than its reshape
    /// makes (`permute.rs`); None: the backend's own.
    fn contiguous(_x: &FloatTensor<Self>) -> Option<FloatTensor<Self>> {
        None
    }
}

/// A dense layer's gradients: of its input (when asked for), weight and bias.
pub type DenseGradients<B> = (Option<FloatTensor<B>>, FloatTensor<B>, FloatTensor<B>);

impl Pl2MapBackend for burn::backend::Flex {
    const HOST_MEMORY: bool = true;

    fn attention_forward(
        q: FloatTensor<Self>,
        k: FloatTensor<Self>,
        v: FloatTensor<Self>,
        heads: usize,
        groups: usize,
    ) -> Option<(FloatTensor<Self>, [FloatTensor<Self>; 4])> {
        attention_kernel::forward(&q, &k, &v, heads, groups)
    }

    fn attention_backward(
        saved: &[FloatTensor<Self>; 4],
        grad: FloatTensor<Self>,
        heads: usize,
        groups: usize,
    ) -> Option<[FloatTensor<Self>; 3]> {
        attention_kernel::backward(saved, &grad, heads, groups)
    }

    fn dense_forward(
        x: &FloatTensor<Self>,
        w: &FloatTensor<Self>,
        b: &FloatTensor<Self>,
        relu: bool,
    ) -> Option<FloatTensor<Self>> {
        dense_kernel::forward(x, w, b, relu)
    }

    fn dense_backward(
        x: &FloatTensor<Self>,
        w: &FloatTensor<Self>,
        y: Option<&FloatTensor<Self>>,
        grad: FloatTensor<Self>,
        want_x: bool,
    ) -> Option<DenseGradients<Self>> {
        dense_kernel::backward(x, w, y, &grad, want_x)
    }

    fn contiguous(x: &FloatTensor<Self>) -> Option<FloatTensor<Self>> {
        permute::contiguous(x)
    }
}

#[cfg(feature = "ndarray")]
impl Pl2MapBackend for burn::backend::NdArray {
    const HOST_MEMORY: bool = true;
}

#[cfg(feature = "cuda")]
impl Pl2MapBackend for burn::backend::Cuda {}

/// PyTorch's own kernels: the composed operations (softmax, attention, dense layers)
/// each map to one ATen call, so no kernel of this crate is needed.
#[cfg(feature = "tch")]
impl Pl2MapBackend for burn::backend::LibTorch<f32> {}

#[derive(Debug)]
struct SoftmaxLast;

impl<B: Backend> Backward<B, 1> for SoftmaxLast {
    /// The forward output y.
    type State = B::FloatTensorPrimitive;

    fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _: &mut Checkpointer) {
        let y = ops.state;
        unary::<B, _>(ops.parents, ops.node, grads, |grad| {
            let last = grad.shape().num_dims() - 1;
            let dot = B::float_sum_dim(B::float_mul(grad.clone(), y.clone()), last);
            B::float_mul(B::float_sub(grad, dot), y)
        });
    }
}

/// The attention kernel's recorded operation (parents q, k, v).
#[derive(Debug)]
struct Attention;

impl<B: Pl2MapBackend> Backward<B, 3> for Attention {
    /// What the inner backend's forward saved, heads, groups.
    type State = ([B::FloatTensorPrimitive; 4], usize, usize);

    fn backward(self, ops: Ops<Self::State, 3>, grads: &mut Gradients, _: &mut Checkpointer) {
        let grad = grads.consume::<B>(&ops.node);
        let (saved, heads, groups) = ops.state;
        let computed = B::attention_backward(&saved, grad, heads, groups);
        // `attention_forward` of the same backend made `saved`, so the kernel's own
        // checks pass; if they ever did not, the parents get no gradient from here
        // rather than a wrong one.
        if let Some(g) = computed {
            for (parent, g) in ops.parents.iter().zip(g) {
                if let Some(node) = parent {
                    grads.register::<B>(node.id, g);
                }
            }
        }
    }
}

/// The dense-layer kernel's recorded operation (parents x, W, b).
#[derive(Debug)]
struct Dense;

impl<B: Pl2MapBackend> Backward<B, 3> for Dense {
    /// The layer's input and weight, and its output when it ends in a ReLU.
    type State = (
        B::FloatTensorPrimitive,
        B::FloatTensorPrimitive,
        Option<B::FloatTensorPrimitive>,
    );

    fn backward(self, ops: Ops<Self::State, 3>, grads: &mut Gradients, _: &mut Checkpointer) {
        let [node_x, node_w, node_b] = ops.parents;
        let grad = grads.consume::<B>(&ops.node);
        let (x, w, y) = ops.state;
        // `dense_forward` of the same backend accepted these operands, so the backward
        // accepts them too; if it ever did not, the parents get no gradient from here
        // rather than a wrong one.
        let Some((dx, dw, db)) = B::dense_backward(&x, &w, y.as_ref(), grad, node_x.is_some())
        else {
            return;
        };
        if let (Some(node), Some(dx)) = (node_x, dx) {
            grads.register::<B>(node.id, dx);
        }
        if let Some(node) = node_w {
            grads.register::<B>(node.id, dw);
        }
        if let Some(node) = node_b {
            grads.register::<B>(node.id, db);
        }
    }
}

/// `reshape_permute`'s recorded operation (parent x).
#[derive(Debug)]
struct ReshapePermute;

impl<B: Pl2MapBackend> Backward<B, 1> for ReshapePermute {
    /// The input's shape and the permutation.
    type State = (Shape, Vec<usize>);

    fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _: &mut Checkpointer) {
        let (shape, axes) = ops.state;
        unary::<B, _>(ops.parents, ops.node, grads, |grad| {
            let back = B::float_permute(grad, &permute::inverse(&axes));
            let back = B::contiguous(&back).unwrap_or(back);
            B::float_reshape(back, shape)
        });
    }
}

impl<B: Pl2MapBackend, C: CheckpointStrategy> Pl2MapBackend for Autodiff<B, C> {
    fn reshape_permute(x: FloatTensor<Self>, shape: Shape, axes: &[usize]) -> FloatTensor<Self> {
        let input_shape = x.primitive.shape();
        let out = B::reshape_permute(x.primitive, shape, axes);
        match ReshapePermute
            .prepare::<C>([x.node.clone()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => prep.finish((input_shape, axes.to_vec()), out),
            OpsKind::UnTracked(prep) => prep.finish(out),
        }
    }

    fn dense(
        x: FloatTensor<Self>,
        w: FloatTensor<Self>,
        b: FloatTensor<Self>,
        relu: bool,
    ) -> Option<FloatTensor<Self>> {
        let out = B::dense_forward(&x.primitive, &w.primitive, &b.primitive, relu)?;
        Some(
            match Dense
                .prepare::<C>([x.node.clone(), w.node.clone(), b.node.clone()])
                .compute_bound()
                .stateful()
            {
                OpsKind::Tracked(prep) => {
                    let y = relu.then(|| out.clone());
                    prep.finish((x.primitive, w.primitive, y), out)
                }
                OpsKind::UnTracked(prep) => prep.finish(out),
            },
        )
    }

    fn multi_head_attention(
        q: FloatTensor<Self>,
        k: FloatTensor<Self>,
        v: FloatTensor<Self>,
        heads: usize,
        groups: usize,
    ) -> Option<FloatTensor<Self>> {
        let (out, saved) = B::attention_forward(
            q.primitive.clone(),
            k.primitive.clone(),
            v.primitive.clone(),
            heads,
            groups,
        )?;
        Some(
            match Attention
                .prepare::<C>([q.node.clone(), k.node.clone(), v.node.clone()])
                .compute_bound()
                .stateful()
            {
                OpsKind::Tracked(prep) => prep.finish((saved, heads, groups), out),
                OpsKind::UnTracked(prep) => prep.finish(out),
            },
        )
    }

    fn softmax_last(x: FloatTensor<Self>) -> FloatTensor<Self> {
        match SoftmaxLast
            .prepare::<C>([x.node.clone()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => {
                let y = B::softmax_last(x.primitive);
                prep.finish(y.clone(), y)
            }
            OpsKind::UnTracked(prep) => prep.finish(B::softmax_last(x.primitive)),
        }
    }
}

/// Softmax over the last dimension of a tensor.
pub fn softmax_last<B: Pl2MapBackend, const D: usize>(x: Tensor<B, D>) -> Tensor<B, D> {
    Tensor::from_primitive(TensorPrimitive::Float(B::softmax_last(
        x.into_primitive().tensor(),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{AD, B, assert_close, pseudo, tensor, values};
    use burn::tensor::activation::softmax;

    #[test]
    fn matches_burns_softmax_and_its_gradient() {
        // Differentiates: not beside another thread's graphs (autodiff_lock.rs).
        let _autodiff = crate::autodiff_lock::exclusive();
        let x = pseudo(2 * 3 * 5, 4)
            .iter()
            .map(|v| 4.0 * v)
            .collect::<Vec<_>>();
        let w = pseudo(2 * 3 * 5, 8);
        let run = |fused: bool| {
            let xt = tensor::<AD, 3>(x.clone(), [2, 3, 5]).require_grad();
            let y = if fused {
                softmax_last(xt.clone())
            } else {
                softmax(xt.clone(), 2)
            };
            let loss = (y.clone() * tensor::<AD, 3>(w.clone(), [2, 3, 5])).sum();
            let g = loss.backward();
            (values(&y), values(&xt.grad(&g).unwrap()))
        };
        let (y_fused, g_fused) = run(true);
        let (y_ref, g_ref) = run(false);
        assert_close(&y_fused, &y_ref, 1e-6);
        assert_close(&g_fused, &g_ref, 1e-5);
        // And without autodiff.
        let plain = softmax_last(tensor::<B, 3>(x.clone(), [2, 3, 5]));
        assert_close(&values(&plain), &y_ref, 1e-6);
    }
}
