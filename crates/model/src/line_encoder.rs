//! Line encoder: one post-LayerNorm transformer block over the T descriptors sampled along
//! each segment; the line descriptor is the block's output at token 0 (the start point).
//!
//! Only token 0's output is used, and in a single block token 0's output depends on the
//! keys and values of all tokens but on the query, residuals, LayerNorms and feed-forward
//! of token 0 alone. So queries and everything after the attention are computed for token 0
//! only: the same function and the same gradients as running the block on all T tokens
//! (a test checks this), at about a third of the cost.

use crate::attention::Projections;
use crate::dense::dense;
use crate::dropout::Dropout;
use crate::init::Initializer;
use burn::module::Module;
use burn::nn::{LayerNorm, Linear};
use burn::tensor::{Tensor, activation, backend::Backend};
use kernels::backend::{Pl2MapBackend, softmax_last};
use kernels::ops::reshape_permute;

#[derive(Module, Debug)]
pub struct LineEncoder<B: Backend> {
    pub attention: Projections<B>,
    pub attention_norm: LayerNorm<B>,
    pub ffn_in: Linear<B>,
    pub ffn_out: Linear<B>,
    pub ffn_norm: LayerNorm<B>,
    pub heads: usize,
}

impl<B: Pl2MapBackend> LineEncoder<B> {
    pub(crate) fn new(init: &mut Initializer<'_, B>, d: usize, heads: usize, ffn: usize) -> Self {
        LineEncoder {
            attention: Projections::new(init, d),
            attention_norm: init.layer_norm(d),
            ffn_in: init.linear(d, ffn),
            ffn_out: init.linear(ffn, d),
            ffn_norm: init.layer_norm(d),
            heads,
        }
    }

    /// `lines`: [M, T, D] with M > 0; returns [M, D].
    ///
    /// Dropout (training only) sits where the reference has it: on the attention weights,
    /// on the attention output before the residual, and on the feed-forward output before
    /// the residual.
    pub fn forward(&self, lines: Tensor<B, 3>, dropout: &mut Dropout) -> Tensor<B, 2> {
        let [m, t, d] = lines.dims();
        let h = self.heads;
        let dk = d / h;
        let scale = 1.0 / (dk as f64).sqrt();

        let token0 = lines.clone().narrow(1, 0, 1).reshape([m, d]);
        let flat = lines.reshape([m * t, d]);
        // [M, h, T, dk] and [M, h, dk, T]
        let k = reshape_permute(
            dense(&self.attention.key, flat.clone(), false),
            [m, t, h, dk],
            [0, 2, 3, 1],
        );
        let v = reshape_permute(
            dense(&self.attention.value, flat, false),
            [m, t, h, dk],
            [0, 2, 1, 3],
        );
        let q = dense(&self.attention.query, token0.clone(), false)
            .mul_scalar(scale)
            .reshape([m, h, 1, dk]);

        let weights = softmax_last(q.matmul(k)); // [M, h, 1, T]
        let weights = dropout.apply(weights);
        let context = weights.matmul(v).reshape([m, d]);
        let attended = dropout.apply(dense(&self.attention.merge, context, false));
        let x = self.attention_norm.forward(attended + token0);

        let hidden = activation::gelu(dense(&self.ffn_in, x.clone(), false));
        let out = dropout.apply(dense(&self.ffn_out, hidden, false));
        self.ffn_norm.forward(out + x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{B, assert_close, pseudo, tensor, tiny_config, values};

    /// The block run on all T tokens, as the reference does; token 0 of its output.
    fn full_block(e: &LineEncoder<B>, x: Tensor<B, 3>) -> Tensor<B, 2> {
        let [m, t, d] = x.dims();
        let h = e.heads;
        let dk = d / h;
        let split = |y: Tensor<B, 3>| y.reshape([m, t, h, dk]).swap_dims(1, 2);
        let q = split(e.attention.query.forward(x.clone())).div_scalar((dk as f64).sqrt());
        let k = split(e.attention.key.forward(x.clone()));
        let v = split(e.attention.value.forward(x.clone()));
        let w = activation::softmax(q.matmul(k.swap_dims(2, 3)), 3);
        let c = w.matmul(v).swap_dims(1, 2).reshape([m, t, d]);
        let a = e.attention_norm.forward(e.attention.merge.forward(c) + x);
        let f = e
            .ffn_out
            .forward(activation::gelu(e.ffn_in.forward(a.clone())));
        let y = e.ffn_norm.forward(f + a);
        y.narrow(1, 0, 1).reshape([m, d])
    }

    #[test]
    fn token0_shortcut_equals_the_full_block() {
        let cfg = tiny_config();
        let net = cfg.init::<B>(3, &Default::default()).unwrap();
        let (m, t, d) = (3, cfg.line_tokens, cfg.descriptor_dim);
        let x = tensor::<B, 3>(pseudo(m * t * d, 5), [m, t, d]);
        let fast = net.line_encoder.forward(x.clone(), &mut Dropout::off());
        let full = full_block(&net.line_encoder, x);
        assert_close(&values(&fast), &values(&full), 1e-5);
    }

    #[test]
    fn dropout_is_seeded() {
        let cfg = tiny_config();
        let net = cfg.init::<B>(3, &Default::default()).unwrap();
        let (m, t, d) = (4, cfg.line_tokens, cfg.descriptor_dim);
        let x = tensor::<B, 3>(pseudo(m * t * d, 6), [m, t, d]);
        let run = |dropout: &mut Dropout| values(&net.line_encoder.forward(x.clone(), dropout));
        let a = run(&mut Dropout::seeded(0.5, 11));
        let b = run(&mut Dropout::seeded(0.5, 11));
        let c = run(&mut Dropout::seeded(0.5, 12));
        let off = run(&mut Dropout::off());
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, off);
    }
}
