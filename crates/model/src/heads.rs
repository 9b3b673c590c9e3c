//! Regression heads: an MLP with ReLU between layers and no normalisation.

use crate::init::Initializer;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Tensor, activation, backend::Backend};

#[derive(Module, Debug)]
pub struct Mlp<B: Backend> {
    pub layers: Vec<Linear<B>>,
}

impl<B: Backend> Mlp<B> {
    /// `widths`: input, hidden..., output.
    pub(crate) fn new(init: &mut Initializer<'_, B>, widths: &[usize]) -> Self {
        Mlp {
            layers: widths.windows(2).map(|w| init.linear(w[0], w[1])).collect(),
        }
    }

    pub fn forward(&self, mut x: Tensor<B, 2>) -> Tensor<B, 2> {
        let last = self.layers.len().saturating_sub(1);
        for (i, layer) in self.layers.iter().enumerate() {
            x = layer.forward(x);
            if i < last {
                x = activation::relu(x);
            }
        }
        x
    }
}
