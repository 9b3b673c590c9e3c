//! The backends the network runs on, and its one custom operation.
//!
//! Attention spends most of its non-matrix-product time in the softmax. Burn's autodiff
//! has no softmax operation of its own: it records max, sub, exp, sum and div, keeps every
//! intermediate, and its exp backward evaluates exp again. Here the softmax is one recorded
//! operation: the forward is the inner backend's own (fused on Flex) and the backward is
//! dx = y * (dy - sum(dy * y)) from the saved output y. This cut a CPU training step by
//! about a fifth (see the crate's benchmark).

use burn::backend::Autodiff;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::CheckpointStrategy;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::tensor::ops::FloatTensor;
use burn::tensor::{Tensor, TensorMetadata, TensorPrimitive, backend::Backend};

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
}

impl Pl2MapBackend for burn::backend::Flex {
    const HOST_MEMORY: bool = true;
}

#[cfg(feature = "ndarray")]
impl Pl2MapBackend for burn::backend::NdArray {
    const HOST_MEMORY: bool = true;
}

#[cfg(feature = "cuda")]
impl Pl2MapBackend for burn::backend::Cuda {}

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

impl<B: Pl2MapBackend, C: CheckpointStrategy> Pl2MapBackend for Autodiff<B, C> {
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
    use crate::testutil::{AD, B, assert_close, pseudo, tensor, values};
    use burn::tensor::activation::softmax;

    #[test]
    fn matches_burns_softmax_and_its_gradient() {
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
