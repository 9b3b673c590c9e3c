//! The SuperPoint network on burn (docs/method.md section 2b): a VGG-style encoder to
//! 1/8 resolution, a detector head (65 channels, softmax, dustbin dropped, each cell's
//! 64 channels spread over its 8 x 8 pixels) and a descriptor head (256 channels,
//! L2-normalised). Inference only.

use crate::weights::{LAYERS, Weights};
use burn::backend::Flex;
use burn::tensor::activation::{relu, softmax};
use burn::tensor::module::{conv2d, max_pool2d};
use burn::tensor::ops::ConvOptions;
use burn::tensor::{Tensor, TensorData, backend::Backend};

/// The backend SuperPoint runs on (burn's Flex CPU backend, as the PL2Map network).
pub type SuperPointBackend = Flex;

/// The dense outputs of one image.
#[derive(Clone, Debug, PartialEq)]
pub struct DenseMaps {
    /// Keypoint probability per pixel, `score_height` x `score_width` row-major
    /// (8 x the cell grid: the input size floored to a multiple of 8).
    pub scores: Vec<f32>,
    pub score_width: usize,
    pub score_height: usize,
    /// 256 x `cell_height` x `cell_width`, unit norm over the 256 channels.
    pub descriptors: Vec<f32>,
    pub cell_width: usize,
    pub cell_height: usize,
}

/// The network's weights as tensors on a device.
#[derive(Clone, Debug)]
pub struct SuperPointNet<B: Backend> {
    layers: Vec<(Tensor<B, 4>, Tensor<B, 1>)>,
}

impl<B: Backend> SuperPointNet<B> {
    pub fn new(weights: &Weights, device: &B::Device) -> Self {
        let layers = LAYERS
            .iter()
            .zip(&weights.layers)
            .map(|(l, (w, b))| {
                let w = TensorData::new(
                    w.clone(),
                    [l.out_channels, l.in_channels, l.kernel, l.kernel],
                );
                let b = TensorData::new(b.clone(), [l.out_channels]);
                (Tensor::from_data(w, device), Tensor::from_data(b, device))
            })
            .collect();
        SuperPointNet { layers }
    }

    fn conv(&self, i: usize, x: Tensor<B, 4>) -> Tensor<B, 4> {
        let (w, b) = &self.layers[i];
        let pad = LAYERS[i].kernel / 2;
        conv2d(
            x,
            w.clone(),
            Some(b.clone()),
            ConvOptions::new([1, 1], [pad, pad], [1, 1], 1),
        )
    }

    /// Images [B, 1, H, W] (grey in [0, 1]) -> (scores [B, 8 Hc, 8 Wc], descriptors
    /// [B, 256, Hc, Wc]) with Hc = floor(H / 8), Wc = floor(W / 8).
    pub fn forward(&self, x: Tensor<B, 4>) -> (Tensor<B, 3>, Tensor<B, 4>) {
        let pool = |x| max_pool2d(x, [2, 2], [2, 2], [0, 0], [1, 1], false);
        let mut x = x;
        for block in 0..4 {
            x = relu(self.conv(2 * block, x));
            x = relu(self.conv(2 * block + 1, x));
            if block < 3 {
                x = pool(x);
            }
        }
        // Detector head.
        let p = self.conv(9, relu(self.conv(8, x.clone())));
        let [n, _, hc, wc] = p.dims();
        let p = softmax(p, 1).narrow(1, 0, 64);
        // Channel 8 dy + dx of cell (i, j) is pixel (8 i + dy, 8 j + dx).
        let scores = p
            .reshape([n, 8, 8, hc, wc])
            .permute([0, 3, 1, 4, 2])
            .reshape([n, hc * 8, wc * 8]);
        // Descriptor head.
        let d = self.conv(11, relu(self.conv(10, x)));
        let norm = d.clone().powi_scalar(2).sum_dim(1).sqrt().clamp_min(1e-12);
        (scores, d / norm)
    }

    /// The dense maps of equally sized images (`pixels[i]` row-major, `width` x `height`,
    /// grey in [0, 1]), run as one batch.
    pub fn dense(
        &self,
        pixels: &[&[f32]],
        width: usize,
        height: usize,
        device: &B::Device,
    ) -> Vec<DenseMaps> {
        let n = pixels.len();
        if n == 0 {
            return Vec::new();
        }
        let mut all = Vec::with_capacity(n * width * height);
        for p in pixels {
            all.extend_from_slice(p);
        }
        let x = Tensor::<B, 4>::from_data(TensorData::new(all, [n, 1, height, width]), device);
        let (scores, desc) = self.forward(x);
        let [_, sh, sw] = scores.dims();
        let [_, c, hc, wc] = desc.dims();
        let scores: Vec<f32> = scores
            .into_data()
            .convert::<f32>()
            .into_vec()
            .unwrap_or_default();
        let desc: Vec<f32> = desc
            .into_data()
            .convert::<f32>()
            .into_vec()
            .unwrap_or_default();
        (0..n)
            .map(|i| DenseMaps {
                scores: scores[i * sh * sw..(i + 1) * sh * sw].to_vec(),
                score_width: sw,
                score_height: sh,
                descriptors: desc[i * c * hc * wc..(i + 1) * c * hc * wc].to_vec(),
                cell_width: wc,
                cell_height: hc,
            })
            .collect()
    }
}
