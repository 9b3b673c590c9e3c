//! Regression heads: an MLP with ReLU between layers and no normalisation.

use crate::config::HeadInit;
use crate::dense::dense;
use crate::init::Initializer;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Tensor, backend::Backend};
use kernels::backend::Pl2MapBackend;

#[derive(Module, Debug)]
pub struct Mlp<B: Backend> {
    pub layers: Vec<Linear<B>>,
}

impl<B: Pl2MapBackend> Mlp<B> {
    /// `widths`: input, hidden..., output.
    pub(crate) fn new(init: &mut Initializer<'_, B>, widths: &[usize], how: HeadInit) -> Self {
        let last = widths.len().saturating_sub(2);
        Mlp {
            layers: widths
                .windows(2)
                .enumerate()
                .map(|(i, w)| match how {
                    HeadInit::He if i < last => init.linear_he(w[0], w[1]),
                    _ => init.linear(w[0], w[1]),
                })
                .collect(),
        }
    }

    pub fn forward(&self, mut x: Tensor<B, 2>) -> Tensor<B, 2> {
        let last = self.layers.len().saturating_sub(1);
        for (i, layer) in self.layers.iter().enumerate() {
            x = dense(layer, x, i < last);
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{B, pseudo, tensor, values};

    /// Spread of the head's outputs over a batch of different inputs: the mean over
    /// output channels of each channel's standard deviation across rows.
    fn output_spread(how: HeadInit) -> f32 {
        let device = Default::default();
        let mut init = Initializer::<B>::new(7, &device);
        let (d, rows) = (128, 64);
        let head = Mlp::new(&mut init, &[d, 512, 512, 512, 512, 512, 512, 4], how);
        // Unit-variance inputs, as the scaled point descriptors are.
        let x: Vec<f32> = pseudo(rows * d, 3)
            .iter()
            .map(|v| v * 3f32.sqrt())
            .collect();
        let y = values(&head.forward(tensor(x, [rows, d])));
        let spread = |c: usize| {
            let col: Vec<f32> = (0..rows).map(|r| y[r * 4 + c]).collect();
            let mean = col.iter().sum::<f32>() / rows as f32;
            (col.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / rows as f32).sqrt()
        };
        (0..4).map(spread).sum::<f32>() / 4.0
    }

    /// The reason for `HeadInit::He`: PyTorch's default bound shrinks the signal at every
    /// ReLU layer, so the six-layer point head of pipeline/synthetic.toml starts out
    /// giving nearly the same output for every descriptor; He's keeps its scale.
    #[test]
    fn he_init_keeps_a_deep_head_from_starting_constant() {
        let reference = output_spread(HeadInit::Reference);
        let he = output_spread(HeadInit::He);
        // Each of the six ReLU layers keeps about 1/6 of the second moment under the
        // reference bound (1/3 from the uniform's variance, 1/2 from the ReLU): the
        // spread falls by roughly sqrt(6)^6 = 216 against He's.
        assert!(reference < 0.02, "reference spread {reference}");
        assert!(he > 0.1, "He spread {he}");
        assert!(he / reference > 50.0, "{he} / {reference}");
    }

    #[test]
    fn he_init_scales_the_reference_draws_and_keeps_the_last_layer() {
        let device = Default::default();
        let widths = [16, 32, 32, 4];
        let reference = Mlp::new(
            &mut Initializer::<B>::new(5, &device),
            &widths,
            HeadInit::Reference,
        );
        let he = Mlp::new(
            &mut Initializer::<B>::new(5, &device),
            &widths,
            HeadInit::He,
        );
        for (i, (r, h)) in reference.layers.iter().zip(&he.layers).enumerate() {
            let (rw, hw) = (values(&r.weight.val()), values(&h.weight.val()));
            let hb = values(&h.bias.as_ref().unwrap().val());
            let rb = values(&r.bias.as_ref().unwrap().val());
            if i + 1 < widths.len() - 1 {
                for (a, b) in rw.iter().zip(&hw) {
                    assert!((a * 6f32.sqrt() - b).abs() < 1e-6);
                }
                assert!(hb.iter().all(|&b| b == 0.0));
            } else {
                // The last (linear) layer, and so every draw after the head, is unchanged.
                assert_eq!(rw, hw);
                assert_eq!(rb, hb);
            }
        }
    }
}
