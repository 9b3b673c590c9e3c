//! Attentional graph network over the point and line descriptors of one image.
//!
//! Both streams run through the same layer weights, so each layer projects and updates the
//! rows of both streams in one matrix product ([N + M, D]); only the attention itself is
//! per stream. Both streams are updated from the previous layer's values.

use crate::attention::{KeyMask, Projections, attend_grouped};
use crate::config::LayerKind;
use crate::dense::dense;
use crate::init::Initializer;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Tensor, backend::Backend};
use kernels::backend::Pl2MapBackend;

/// One attentional propagation layer: d <- d + MLP([d || merge(attention(d, edges))]),
/// MLP 2D -> 2D -> D with ReLU, last bias initialised to zero.
#[derive(Module, Debug)]
pub struct PropagationLayer<B: Backend> {
    pub attention: Projections<B>,
    pub mlp_hidden: Linear<B>,
    pub mlp_out: Linear<B>,
}

impl<B: Pl2MapBackend> PropagationLayer<B> {
    pub(crate) fn new(init: &mut Initializer<'_, B>, d: usize) -> Self {
        PropagationLayer {
            attention: Projections::new(init, d),
            mlp_hidden: init.linear(2 * d, 2 * d),
            mlp_out: init.linear_zero_bias(2 * d, d),
        }
    }

    /// `x`: [n + m, D], the n point rows followed by the m line rows (n + m > 0), of
    /// `groups` images with n / groups points and m / groups lines each (in image order
    /// within each stream); attention stays within an image and skips padded keys.
    fn forward(
        &self,
        x: Tensor<B, 2>,
        (n, m): (usize, usize),
        kind: LayerKind,
        heads: usize,
        groups: usize,
        masks: &StreamMasks<B>,
    ) -> Tensor<B, 2> {
        let attend =
            |q: Tensor<B, 2>, k: Tensor<B, 2>, v: Tensor<B, 2>, mask: &Option<KeyMask<B>>| {
                attend_grouped(q, k, v, heads, groups, mask.as_ref())
            };
        let (mp, ml) = (&masks.points, &masks.lines);
        let [rows, d] = x.dims();
        let context = if n > 0 && m > 0 {
            let q = dense(&self.attention.query, x.clone(), false);
            let k = dense(&self.attention.key, x.clone(), false);
            let v = dense(&self.attention.value, x.clone(), false);
            let split = |t: Tensor<B, 2>| (t.clone().narrow(0, 0, n), t.narrow(0, n, m));
            let (qp, ql) = split(q);
            let (kp, kl) = split(k);
            let (vp, vl) = split(v);
            let (cp, cl) = match kind {
                LayerKind::SelfAttention => (attend(qp, kp, vp, mp), attend(ql, kl, vl, ml)),
                LayerKind::Cross => (attend(qp, kl, vl, ml), attend(ql, kp, vp, mp)),
            };
            Tensor::cat(vec![cp, cl], 0)
        } else {
            match kind {
                LayerKind::SelfAttention => {
                    let q = dense(&self.attention.query, x.clone(), false);
                    let k = dense(&self.attention.key, x.clone(), false);
                    let v = dense(&self.attention.value, x.clone(), false);
                    attend(q, k, v, if n > 0 { mp } else { ml })
                }
                // The other stream is empty: attention over an empty edge set is an empty
                // sum, so the context is zero and the message is the merge bias.
                LayerKind::Cross => Tensor::zeros([rows, d], &x.device()),
            }
        };
        let message = dense(&self.attention.merge, context, false);
        let hidden = dense(
            &self.mlp_hidden,
            Tensor::cat(vec![x.clone(), message], 1),
            true,
        );
        x + dense(&self.mlp_out, hidden, false)
    }
}

/// The key masks of the two streams of a pass over padded images (`buckets.rs`); None
/// where no row of the stream is padded.
#[derive(Clone, Debug)]
pub struct StreamMasks<B: Backend> {
    pub points: Option<KeyMask<B>>,
    pub lines: Option<KeyMask<B>>,
}

impl<B: Backend> StreamMasks<B> {
    /// Nothing padded.
    pub fn none() -> Self {
        StreamMasks {
            points: None,
            lines: None,
        }
    }
}

#[derive(Module, Debug)]
pub struct GraphNetwork<B: Backend> {
    pub layers: Vec<PropagationLayer<B>>,
    #[module(skip)]
    pub kinds: Vec<LayerKind>,
    pub heads: usize,
}

impl<B: Pl2MapBackend> GraphNetwork<B> {
    pub(crate) fn new(
        init: &mut Initializer<'_, B>,
        d: usize,
        heads: usize,
        kinds: &[LayerKind],
    ) -> Self {
        GraphNetwork {
            layers: kinds
                .iter()
                .map(|_| PropagationLayer::new(init, d))
                .collect(),
            kinds: kinds.to_vec(),
            heads,
        }
    }

    /// `x`: [n + m, D], points first; returns the updated rows in the same order.
    pub fn forward(&self, x: Tensor<B, 2>, n: usize, m: usize) -> Tensor<B, 2> {
        self.forward_grouped(x, n, m, 1, &StreamMasks::none())
    }

    /// [`GraphNetwork::forward`] on `groups` images of equal size at once: `x` holds the
    /// n points of all images (image by image), then their m lines; n and m are
    /// multiples of `groups`. `masks` marks the padded rows of padded images (their
    /// outputs are meaningless; the real rows' are those of the unpadded images).
    pub fn forward_grouped(
        &self,
        mut x: Tensor<B, 2>,
        n: usize,
        m: usize,
        groups: usize,
        masks: &StreamMasks<B>,
    ) -> Tensor<B, 2> {
        for (layer, kind) in self.layers.iter().zip(&self.kinds) {
            x = layer.forward(x, (n, m), *kind, self.heads, groups, masks);
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attention::attend;
    use crate::testing::{B, assert_close, pseudo, tensor, values};
    use burn::tensor::activation;

    /// One layer applied to each stream on its own, from the previous values.
    fn separate(
        layer: &PropagationLayer<B>,
        x: Tensor<B, 2>,
        src: Option<Tensor<B, 2>>,
    ) -> Tensor<B, 2> {
        let [rows, d] = x.dims();
        let a = &layer.attention;
        let context = match src {
            Some(s) => attend(
                a.query.forward(x.clone()),
                a.key.forward(s.clone()),
                a.value.forward(s),
                2,
            ),
            None => Tensor::zeros([rows, d], &x.device()),
        };
        let msg = a.merge.forward(context);
        let h = activation::relu(
            layer
                .mlp_hidden
                .forward(Tensor::cat(vec![x.clone(), msg], 1)),
        );
        x + layer.mlp_out.forward(h)
    }

    fn graph(kinds: &[LayerKind]) -> GraphNetwork<B> {
        let device = Default::default();
        let mut init = Initializer::<B>::new(4, &device);
        GraphNetwork::new(&mut init, 8, 2, kinds)
    }

    #[test]
    fn streams_update_simultaneously_with_shared_weights() {
        let g = graph(&[LayerKind::Cross, LayerKind::SelfAttention]);
        let (n, m) = (5, 3);
        let p = tensor::<B, 2>(pseudo(n * 8, 1), [n, 8]);
        let l = tensor::<B, 2>(pseudo(m * 8, 2), [m, 8]);
        let out = g.forward(Tensor::cat(vec![p.clone(), l.clone()], 0), n, m);
        // Cross layer: points attend to the old lines, lines to the old points.
        let p1 = separate(&g.layers[0], p.clone(), Some(l.clone()));
        let l1 = separate(&g.layers[0], l, Some(p));
        // Self layer.
        let p2 = separate(&g.layers[1], p1.clone(), Some(p1));
        let l2 = separate(&g.layers[1], l1.clone(), Some(l1));
        let want = Tensor::cat(vec![p2, l2], 0);
        assert_close(&values(&out), &values(&want), 1e-5);
    }

    #[test]
    fn a_missing_stream_sends_the_empty_message() {
        let g = graph(&[LayerKind::SelfAttention, LayerKind::Cross]);
        let p = tensor::<B, 2>(pseudo(4 * 8, 3), [4, 8]);
        let out = g.forward(p.clone(), 4, 0);
        let p1 = separate(&g.layers[0], p.clone(), Some(p));
        let p2 = separate(&g.layers[1], p1, None);
        assert_close(&values(&out), &values(&p2), 1e-5);
        // The last bias of each message MLP starts at zero.
        let bias = g.layers[1].mlp_out.bias.as_ref().unwrap().val();
        assert!(values(&bias).iter().all(|&b| b == 0.0));
    }
}
