//! Tensor-level entries of the backend's own operations (`backend.rs`), for the network's
//! layers: they take and return burn tensors and call the [`Pl2MapBackend`] method.

use crate::backend::Pl2MapBackend;
use burn::tensor::{Tensor, TensorPrimitive};

/// `x.reshape(shape).permute(axes)` (`axes` a permutation of `0..D2`), recorded as one
/// operation on autodiff backends.
pub fn reshape_permute<B: Pl2MapBackend, const D1: usize, const D2: usize>(
    x: Tensor<B, D1>,
    shape: [usize; D2],
    axes: [usize; D2],
) -> Tensor<B, D2> {
    Tensor::from_primitive(TensorPrimitive::Float(B::reshape_permute(
        x.into_primitive().tensor(),
        shape.into(),
        &axes,
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{AD, bits, pseudo, tensor, values};

    /// Forward values and the input's gradient equal those of burn's reshape and
    /// permute, bit for bit, for both of the line encoder's head splits.
    #[test]
    fn matches_burns_reshape_and_permute() {
        // Differentiates: not beside another thread's graphs (autodiff_lock.rs).
        let _autodiff = crate::autodiff_lock::exclusive();
        let (m, t, h, dk) = (6, 4, 2, 3);
        let x = pseudo(m * t * h * dk, 2);
        let w = pseudo(m * t * h * dk, 3);
        for axes in [[0, 2, 3, 1], [0, 2, 1, 3]] {
            let run = |fused: bool| {
                let xt = tensor::<AD, 2>(x.clone(), [m * t, h * dk]).require_grad();
                let y = if fused {
                    reshape_permute(xt.clone(), [m, t, h, dk], axes)
                } else {
                    xt.clone().reshape([m, t, h, dk]).permute(axes)
                };
                let dims = y.dims();
                // A weighting that differs per element, so a misplaced gradient shows.
                let weights = tensor::<AD, 4>(w.clone(), dims);
                let grads = (y.clone() * weights).sum().backward();
                let gx = xt.grad(&grads).expect("x has a gradient");
                (values(&y.inner()), values(&gx))
            };
            let (y_ours, g_ours) = run(true);
            let (y_burn, g_burn) = run(false);
            assert_eq!(bits(&y_ours), bits(&y_burn), "forward, axes {axes:?}");
            assert_eq!(bits(&g_ours), bits(&g_burn), "gradient, axes {axes:?}");
        }
    }
}
