//! A dense layer (`Linear`, optionally followed by a ReLU) as one operation where the
//! backend has a kernel for it (Flex: `dense_kernel.rs`), burn's operations otherwise.

use burn::nn::Linear;
use burn::tensor::{Tensor, TensorPrimitive, activation};
use kernels::backend::Pl2MapBackend;

/// `relu(layer(x))` when `relu`, `layer(x)` otherwise; x: [rows, d_in].
pub fn dense<B: Pl2MapBackend>(layer: &Linear<B>, x: Tensor<B, 2>, relu: bool) -> Tensor<B, 2> {
    if let Some(bias) = &layer.bias
        && let Some(out) = B::dense(
            x.clone().into_primitive().tensor(),
            layer.weight.val().into_primitive().tensor(),
            bias.val().into_primitive().tensor(),
            relu,
        )
    {
        return Tensor::from_primitive(TensorPrimitive::Float(out));
    }
    dense_composed(layer, x, relu)
}

/// [`dense`] as burn's operations (backends without a kernel, and the kernel's reference
/// in tests).
pub(crate) fn dense_composed<B: Pl2MapBackend>(
    layer: &Linear<B>,
    x: Tensor<B, 2>,
    relu: bool,
) -> Tensor<B, 2> {
    let y = layer.forward(x);
    if relu { activation::relu(y) } else { y }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::init::Initializer;
    use crate::testing::{AD, B, bits, pseudo, tensor, values};

    /// A three-layer MLP (ReLU, ReLU, plain) on rows sliced out of a larger tensor,
    /// through the kernel and through burn's operations: the outputs and the gradients
    /// of the input, every weight and every bias are equal bit for bit. Sizes on both
    /// sides of burn-flex's threshold for threaded products (192^3); one input element
    /// NaN (its row must come out of the first ReLU as burn-flex's does, as zeros).
    #[test]
    fn matches_the_composed_path() {
        // Differentiates: not beside another thread's graphs (autodiff_lock.rs).
        let _autodiff = kernels::autodiff_lock::exclusive();
        for (rows, widths) in [(37, vec![16, 24, 24, 3]), (256, vec![128, 256, 256, 4])] {
            let device = Default::default();
            let layers: Vec<Linear<AD>> = {
                let mut init = Initializer::<AD>::new(3, &device);
                widths.windows(2).map(|w| init.linear(w[0], w[1])).collect()
            };
            let d = widths[0];
            let mut x = pseudo((rows + 5) * d, 9);
            x[7 * d + 2] = f32::NAN;
            let w_out = pseudo(rows * widths[widths.len() - 1], 4);
            let run = |kernel: bool| {
                let all = tensor::<AD, 2>(x.clone(), [rows + 5, d]).require_grad();
                let mut h = all.clone().narrow(0, 5, rows);
                for (i, layer) in layers.iter().enumerate() {
                    let relu = i + 1 < layers.len();
                    h = if kernel {
                        dense(layer, h, relu)
                    } else {
                        dense_composed(layer, h, relu)
                    };
                }
                let out_w = tensor::<AD, 2>(w_out.clone(), [rows, widths[widths.len() - 1]]);
                let loss = (h.clone() * out_w).sum();
                let g = loss.backward();
                let mut got = vec![bits(&values(&h)), bits(&values(&all.grad(&g).unwrap()))];
                for layer in &layers {
                    got.push(bits(&values(&layer.weight.grad(&g).unwrap())));
                    got.push(bits(&values(
                        &layer.bias.as_ref().unwrap().grad(&g).unwrap(),
                    )));
                }
                got
            };
            let (kernel, composed) = (run(true), run(false));
            for (i, (a, b)) in kernel.iter().zip(&composed).enumerate() {
                assert!(a == b, "rows {rows}: output / gradient {i} differs");
            }
            // The kernel path ran (a silent fallback would pass the comparison trivially).
            let x0 = tensor::<B, 2>(x[..rows * d].to_vec(), [rows, d]);
            let w0 = tensor::<B, 2>(values(&layers[0].weight.val()), [d, widths[1]]);
            let b0 = tensor::<B, 1>(pseudo(widths[1], 5), [widths[1]]);
            let flex = B::dense(
                x0.into_primitive().tensor(),
                w0.into_primitive().tensor(),
                b0.into_primitive().tensor(),
                true,
            );
            assert!(flex.is_some(), "Flex has a dense kernel");
        }
    }

    /// Operands the kernel does not take (a bias of the wrong length) fall back to
    /// burn's operations instead of failing.
    #[test]
    fn unfit_operands_are_refused() {
        let x = tensor::<B, 2>(pseudo(12, 1), [3, 4]);
        let w = tensor::<B, 2>(pseudo(8, 2), [4, 2]);
        let b = tensor::<B, 1>(pseudo(3, 3), [3]);
        assert!(
            B::dense(
                x.into_primitive().tensor(),
                w.into_primitive().tensor(),
                b.into_primitive().tensor(),
                false
            )
            .is_none()
        );
    }
}
