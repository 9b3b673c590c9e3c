//! The PL2Map network: line encoder -> attentional graph -> point and line heads.

use crate::attention::KeyMask;
use crate::buckets::BucketLimits;
use crate::config::ModelConfig;
use crate::dropout::Dropout;
use crate::error::ModelError;
use crate::graph::{GraphNetwork, StreamMasks};
use crate::heads::Mlp;
use crate::init::{Initializer, tensor_from};
use crate::line_encoder::LineEncoder;
use burn::module::Module;
use burn::tensor::{Tensor, backend::Backend};
use kernels::backend::Pl2MapBackend;

/// Output channels of the point head: x, y, z, u.
pub const POINT_OUTPUTS: usize = 4;
/// Output channels of the line head: start xyz, end xyz, u.
pub const LINE_OUTPUTS: usize = 7;

#[derive(Module, Debug)]
pub struct Pl2Map<B: Backend> {
    pub line_encoder: LineEncoder<B>,
    pub graph: GraphNetwork<B>,
    pub point_head: Mlp<B>,
    pub line_head: Mlp<B>,
    #[module(skip)]
    pub config: ModelConfig,
}

/// Parameter counts of the four parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParameterCounts {
    pub line_encoder: usize,
    pub graph: usize,
    pub point_head: usize,
    pub line_head: usize,
}

impl ParameterCounts {
    pub fn total(&self) -> usize {
        self.line_encoder + self.graph + self.point_head + self.line_head
    }
}

impl ModelConfig {
    /// Builds a network with weights drawn from `seed` (see `init.rs`): the same seed gives
    /// the same weights on every backend.
    pub fn init<B: Pl2MapBackend>(
        &self,
        seed: u64,
        device: &B::Device,
    ) -> Result<Pl2Map<B>, ModelError> {
        self.validate()?;
        let d = self.descriptor_dim;
        let mut init = Initializer::<B>::new(seed, device);
        let line_encoder = LineEncoder::new(&mut init, d, self.heads, self.ffn_dim);
        let graph = GraphNetwork::new(&mut init, d, self.heads, &self.layers);
        let widths = |hidden: &[usize], out: usize| {
            let mut w = vec![d];
            w.extend_from_slice(hidden);
            w.push(out);
            w
        };
        let point_head = Mlp::new(
            &mut init,
            &widths(&self.head_hidden, POINT_OUTPUTS),
            self.head_init,
        );
        let line_head = Mlp::new(
            &mut init,
            &widths(self.line_head_widths(), LINE_OUTPUTS),
            self.head_init,
        );
        let model = Pl2Map {
            line_encoder,
            graph,
            point_head,
            line_head,
            config: self.clone(),
        };
        Ok(model.map(&mut crate::init::SequentialIds::default()))
    }
}

/// The descriptors of one image as tensors; `None` for an image without points or lines.
#[derive(Clone, Debug)]
pub struct NetworkInput<B: Backend> {
    /// [N, D]
    pub points: Option<Tensor<B, 2>>,
    /// [M, T, D]
    pub lines: Option<Tensor<B, 3>>,
    /// For an image padded to a shape bucket (`buckets.rs`): its real (N, M), the first
    /// rows of each stream; the rest are zero rows that attention ignores. None: all real.
    pub real: Option<(usize, usize)>,
}

impl<B: Backend> NetworkInput<B> {
    /// From row-major host arrays: `points` holds N x D values, `lines` M x T x D.
    pub fn from_host(
        config: &ModelConfig,
        points: &[f32],
        lines: &[f32],
        device: &B::Device,
    ) -> Result<Self, ModelError> {
        Self::from_host_padded(config, points, lines, None, device)
    }

    /// [`NetworkInput::from_host`] with each stream padded by zero rows (lines: zero
    /// tokens) up to `padded` = (N, M) rows where given (sizes below the real ones are
    /// refused). An image without lines keeps no line stream when M is 0.
    pub fn from_host_padded(
        config: &ModelConfig,
        points: &[f32],
        lines: &[f32],
        padded: Option<(usize, usize)>,
        device: &B::Device,
    ) -> Result<Self, ModelError> {
        let d = config.descriptor_dim;
        let t = config.line_tokens;
        if !points.len().is_multiple_of(d) {
            return Err(ModelError::Length {
                field: "point_descriptors",
                expected: points.len().div_ceil(d) * d,
                found: points.len(),
            });
        }
        if !lines.len().is_multiple_of(t * d) {
            return Err(ModelError::Length {
                field: "line_descriptors",
                expected: lines.len().div_ceil(t * d) * t * d,
                found: lines.len(),
            });
        }
        let n = points.len() / d;
        let m = lines.len() / (t * d);
        let (rows_n, rows_m) = padded.unwrap_or((n, m));
        if rows_n < n || rows_m < m {
            return Err(ModelError::InvalidConfig(format!(
                "cannot pad {n} points and {m} lines to {rows_n} and {rows_m}"
            )));
        }
        let scale = config.point_input_scale as f32;
        let mut points: Vec<f32> = if scale == 1.0 {
            points.to_vec()
        } else {
            points.iter().map(|v| v * scale).collect()
        };
        points.resize(rows_n * d, 0.0);
        let mut lines = lines.to_vec();
        lines.resize(rows_m * t * d, 0.0);
        Ok(NetworkInput {
            points: (rows_n > 0).then(|| tensor_from(points, [rows_n, d], device)),
            lines: (rows_m > 0).then(|| tensor_from(lines, [rows_m, t, d], device)),
            real: ((rows_n, rows_m) != (n, m)).then_some((n, m)),
        })
    }

    /// The real (N, M) of the image: all rows unless padded.
    pub fn real_sizes(&self) -> (usize, usize) {
        self.real.unwrap_or((self.num_points(), self.num_lines()))
    }

    pub fn num_points(&self) -> usize {
        self.points.as_ref().map_or(0, |p| p.dims()[0])
    }

    pub fn num_lines(&self) -> usize {
        self.lines.as_ref().map_or(0, |l| l.dims()[0])
    }
}

/// Raw network outputs of one image (of a padded image: its padded rows too, after the
/// real ones; the loss masks them and [`Pl2Map::predict_bucketed`] drops them).
#[derive(Clone, Debug)]
pub struct Prediction<B: Backend> {
    /// [N, 4]: x, y, z, u.
    pub points: Option<Tensor<B, 2>>,
    /// [M, 7]: start xyz, end xyz, u.
    pub lines: Option<Tensor<B, 2>>,
    pub reliability_beta: f64,
}

/// r = 1 / (1 + |beta u|).
pub fn reliability<B: Backend>(u: Tensor<B, 2>, beta: f64) -> Tensor<B, 2> {
    u.abs().mul_scalar(beta).add_scalar(1.0).recip()
}

impl<B: Backend> Prediction<B> {
    /// [N, 3] predicted world coordinates.
    pub fn point_coordinates(&self) -> Option<Tensor<B, 2>> {
        self.points.clone().map(|p| p.narrow(1, 0, 3))
    }

    /// [N, 1] reliabilities.
    pub fn point_reliability(&self) -> Option<Tensor<B, 2>> {
        let beta = self.reliability_beta;
        self.points
            .clone()
            .map(|p| reliability(p.narrow(1, 3, 1), beta))
    }

    /// [M, 6] predicted endpoints (start xyz, end xyz).
    pub fn line_endpoints(&self) -> Option<Tensor<B, 2>> {
        self.lines.clone().map(|l| l.narrow(1, 0, 6))
    }

    /// [M, 1] reliabilities.
    pub fn line_reliability(&self) -> Option<Tensor<B, 2>> {
        let beta = self.reliability_beta;
        self.lines
            .clone()
            .map(|l| reliability(l.narrow(1, 6, 1), beta))
    }

    /// Copies the outputs to the host.
    pub fn to_host(&self) -> HostPrediction {
        let rows = |t: &Option<Tensor<B, 2>>, width: usize| -> Vec<f32> {
            match t {
                Some(t) => {
                    let data = t.to_data().convert::<f32>();
                    let values = data.to_vec::<f32>().unwrap_or_default();
                    debug_assert_eq!(values.len() % width, 0);
                    values
                }
                None => Vec::new(),
            }
        };
        let beta = self.reliability_beta as f32;
        let r = |u: f32| 1.0 / (1.0 + (beta * u).abs());
        let points = rows(&self.points, POINT_OUTPUTS)
            .chunks_exact(POINT_OUTPUTS)
            .map(|c| PointPrediction {
                xyz: [c[0], c[1], c[2]],
                reliability: r(c[3]),
            })
            .collect();
        let lines = rows(&self.lines, LINE_OUTPUTS)
            .chunks_exact(LINE_OUTPUTS)
            .map(|c| LinePrediction {
                start: [c[0], c[1], c[2]],
                end: [c[3], c[4], c[5]],
                reliability: r(c[6]),
            })
            .collect();
        HostPrediction { points, lines }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointPrediction {
    pub xyz: [f32; 3],
    pub reliability: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinePrediction {
    pub start: [f32; 3],
    pub end: [f32; 3],
    pub reliability: f32,
}

/// Predictions of one image on the host, in input order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HostPrediction {
    pub points: Vec<PointPrediction>,
    pub lines: Vec<LinePrediction>,
}

/// The passes [`Pl2Map::forward_batch`] makes for images of (N, M) rows `sizes`, as
/// (images, N, M) each: one stacked pass when all are equal, else one per image. On a
/// JIT engine each distinct triple is a new set of kernels (`buckets.rs`).
pub fn pass_shapes(sizes: &[(usize, usize)]) -> Vec<(usize, usize, usize)> {
    let uniform = sizes.windows(2).all(|w| w[0] == w[1]);
    match sizes.first() {
        Some(&(n, m)) if uniform => vec![(sizes.len(), n, m)],
        _ => sizes.iter().map(|&(n, m)| (1, n, m)).collect(),
    }
}

impl<B: Pl2MapBackend> Pl2Map<B> {
    pub fn parameter_counts(&self) -> ParameterCounts {
        ParameterCounts {
            line_encoder: self.line_encoder.num_params(),
            graph: self.graph.num_params(),
            point_head: self.point_head.num_params(),
            line_head: self.line_head.num_params(),
        }
    }

    /// Runs the network on one image. `dropout` is `Dropout::off()` for evaluation.
    /// An image without lines (or without points) runs the other stream alone; cross
    /// layers then pass it the message of an empty edge set.
    pub fn forward(&self, input: NetworkInput<B>, dropout: &mut Dropout) -> Prediction<B> {
        let real = [input.real_sizes()];
        self.forward_grouped(input, &real, dropout)
    }

    /// The forward pass over `real.len()` equal-sized images stacked row-wise (see
    /// [`Pl2Map::forward_batch`]), of which `real` holds the real (N, M) of each; the
    /// outputs stay stacked.
    fn forward_grouped(
        &self,
        input: NetworkInput<B>,
        real: &[(usize, usize)],
        dropout: &mut Dropout,
    ) -> Prediction<B> {
        let groups = real.len();
        let n = input.num_points();
        let m = input.num_lines();
        let device = input
            .points
            .as_ref()
            .map(|p| p.device())
            .or_else(|| input.lines.as_ref().map(|l| l.device()));
        let masks = match device {
            Some(device) => {
                let counts = |f: fn(&(usize, usize)) -> usize| -> Vec<usize> {
                    real.iter().map(f).collect()
                };
                StreamMasks {
                    points: KeyMask::from_counts(&counts(|r| r.0), n / groups, &device),
                    lines: KeyMask::from_counts(&counts(|r| r.1), m / groups, &device),
                }
            }
            None => StreamMasks::none(),
        };
        let lines = input.lines.map(|l| self.line_encoder.forward(l, dropout));
        let x = match (input.points, lines) {
            (Some(p), Some(l)) => Some(Tensor::cat(vec![p, l], 0)),
            (Some(p), None) => Some(p),
            (None, Some(l)) => Some(l),
            (None, None) => None,
        };
        let beta = self.config.reliability_beta;
        let Some(x) = x else {
            return Prediction {
                points: None,
                lines: None,
                reliability_beta: beta,
            };
        };
        let x = self.graph.forward_grouped(x, n, m, groups, &masks);
        let points = (n > 0).then(|| self.point_head.forward(x.clone().narrow(0, 0, n)));
        let lines = (m > 0).then(|| self.line_head.forward(x.narrow(0, n, m)));
        Prediction {
            points,
            lines,
            reliability_beta: beta,
        }
    }

    /// The network on several images at once: the same outputs as [`Pl2Map::forward`] on
    /// each (up to float rounding), in input order. Images of equal size (the trainer's
    /// limits make nearly every training image so) share every matrix product: the
    /// streams of all images are stacked row-wise, and attention runs per image as one
    /// batched product. Otherwise each image runs on its own. Dropout masks come from
    /// `dropout`'s one stream, drawn for the stacked tensors.
    pub fn forward_batch(
        &self,
        inputs: Vec<NetworkInput<B>>,
        dropout: &mut Dropout,
    ) -> Vec<Prediction<B>> {
        let g = inputs.len();
        let sizes: Vec<(usize, usize)> = inputs
            .iter()
            .map(|i| (i.num_points(), i.num_lines()))
            .collect();
        if g <= 1 || pass_shapes(&sizes).len() > 1 {
            return inputs
                .into_iter()
                .map(|i| self.forward(i, dropout))
                .collect();
        }
        let (n, m) = sizes[0];
        let real: Vec<(usize, usize)> = inputs.iter().map(|i| i.real_sizes()).collect();
        let mut points = Vec::with_capacity(g);
        let mut lines = Vec::with_capacity(g);
        for i in inputs {
            points.extend(i.points);
            lines.extend(i.lines);
        }
        let stacked = NetworkInput {
            points: (n > 0).then(|| Tensor::cat(points, 0)),
            lines: (m > 0).then(|| Tensor::cat(lines, 0)),
            real: None,
        };
        let out = self.forward_grouped(stacked, &real, dropout);
        (0..g)
            .map(|k| Prediction {
                points: out.points.clone().map(|p| p.narrow(0, k * n, n)),
                lines: out.lines.clone().map(|l| l.narrow(0, k * m, m)),
                reliability_beta: out.reliability_beta,
            })
            .collect()
    }

    /// Evaluation-mode forward pass on host descriptors, results on the host.
    pub fn predict(
        &self,
        point_descriptors: &[f32],
        line_descriptors: &[f32],
    ) -> Result<HostPrediction, ModelError> {
        self.predict_bucketed(point_descriptors, line_descriptors, None)
    }

    /// [`Pl2Map::predict`] with the image padded to the shape buckets of `buckets`
    /// where given (a JIT engine's query path, `buckets.rs`); the padded rows' outputs
    /// are dropped, so the result is the unpadded one up to float rounding.
    pub fn predict_bucketed(
        &self,
        point_descriptors: &[f32],
        line_descriptors: &[f32],
        buckets: Option<BucketLimits>,
    ) -> Result<HostPrediction, ModelError> {
        let device = self.devices().into_iter().next();
        let Some(device) = device else {
            return Err(ModelError::InvalidConfig(
                "network has no parameters".into(),
            ));
        };
        let d = self.config.descriptor_dim;
        let rows = (
            point_descriptors.len() / d,
            line_descriptors.len() / (d * self.config.line_tokens),
        );
        let padded = buckets.map(|b| b.padded(&[rows]));
        let input = NetworkInput::from_host_padded(
            &self.config,
            point_descriptors,
            line_descriptors,
            padded,
            &device,
        )?;
        let mut out = self.forward(input, &mut Dropout::off()).to_host();
        out.points.truncate(rows.0);
        out.lines.truncate(rows.1);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{B, assert_close, flat, pseudo, tiny_config, tiny_sample, values};

    #[test]
    fn reference_parameter_count_at_d256() {
        let net = ModelConfig::superpoint()
            .init::<B>(0, &Default::default())
            .unwrap();
        let c = net.parameter_counts();
        assert_eq!(c.line_encoder, 789_760);
        assert_eq!(c.graph, 3_285_760);
        assert_eq!(c.point_head, 1_183_748);
        assert_eq!(c.line_head, 1_185_287);
        assert_eq!(c.total(), 6_444_555);
        assert_eq!(net.num_params(), 6_444_555);
    }

    #[test]
    fn the_line_head_can_be_smaller_than_the_point_head() {
        let mut cfg = ModelConfig::sift();
        cfg.head_hidden = vec![512, 512, 512];
        let same = cfg
            .init::<B>(0, &Default::default())
            .unwrap()
            .parameter_counts();
        // 128 -> 512 -> 512 -> 512 -> 7, weights and biases.
        assert_eq!(
            same.line_head,
            128 * 512 + 512 + 2 * (512 * 512 + 512) + 512 * 7 + 7
        );
        cfg.line_head_hidden = Some(vec![64]);
        let small = cfg
            .init::<B>(0, &Default::default())
            .unwrap()
            .parameter_counts();
        assert_eq!(small.line_head, 128 * 64 + 64 + 64 * 7 + 7);
        assert_eq!(small.point_head, same.point_head);
        // Configs without the key read as before and write without it.
        let text = serde_json::to_string(&ModelConfig::sift()).unwrap();
        assert!(!text.contains("line_head_hidden"), "{text}");
        let back: ModelConfig = serde_json::from_str(&text).unwrap();
        assert_eq!(back, ModelConfig::sift());
        cfg.line_head_hidden = Some(vec![0]);
        assert!(cfg.validate().is_err());
    }

    #[test]
    fn weights_are_a_function_of_the_seed() {
        let cfg = tiny_config();
        let d = Default::default();
        let w = |seed| {
            values(
                &cfg.init::<B>(seed, &d).unwrap().point_head.layers[0]
                    .weight
                    .val(),
            )
        };
        assert_eq!(w(1), w(1));
        assert_ne!(w(1), w(2));
        // PyTorch's default bound 1 / sqrt(fan_in).
        let bound = 1.0 / (cfg.descriptor_dim as f32).sqrt();
        assert!(w(1).iter().all(|x| x.abs() <= bound));
    }

    #[test]
    fn output_shapes_and_empty_streams() {
        let cfg = tiny_config();
        let net = cfg.init::<B>(1, &Default::default()).unwrap();
        for (n, m) in [(5, 3), (5, 0), (0, 3), (0, 0)] {
            let s = tiny_sample(&cfg, n, m);
            let p = net
                .predict(&s.point_descriptors, &s.line_descriptors)
                .unwrap();
            assert_eq!((p.points.len(), p.lines.len()), (n, m));
            for x in &p.points {
                assert!(x.xyz.iter().all(|v| v.is_finite()));
                assert!(x.reliability > 0.0 && x.reliability <= 1.0);
            }
            for x in &p.lines {
                assert!(x.start.iter().chain(&x.end).all(|v| v.is_finite()));
            }
        }
    }

    #[test]
    fn points_do_not_depend_on_line_order() {
        // Attention is permutation-invariant over its sources: shuffling the lines leaves
        // the point predictions unchanged and permutes the line predictions.
        let cfg = tiny_config();
        let net = cfg.init::<B>(1, &Default::default()).unwrap();
        let s = tiny_sample(&cfg, 4, 3);
        let block = cfg.line_tokens * cfg.descriptor_dim;
        let mut swapped = s.line_descriptors.clone();
        swapped[..block].copy_from_slice(&s.line_descriptors[2 * block..]);
        swapped[2 * block..].copy_from_slice(&s.line_descriptors[..block]);
        let a = net
            .predict(&s.point_descriptors, &s.line_descriptors)
            .unwrap();
        let b = net.predict(&s.point_descriptors, &swapped).unwrap();
        for (x, y) in a.points.iter().zip(&b.points) {
            for k in 0..3 {
                assert!((x.xyz[k] - y.xyz[k]).abs() < 1e-5);
            }
        }
        assert!((a.lines[0].start[0] - b.lines[2].start[0]).abs() < 1e-5);
    }

    /// A batch gives each image what it gets on its own: stacked (equal sizes, also
    /// with one stream empty) and one by one (unequal sizes).
    #[test]
    fn a_batch_is_each_image_on_its_own() {
        let cfg = tiny_config();
        let net = cfg.init::<B>(3, &Default::default()).unwrap();
        let d = cfg.descriptor_dim;
        let t = cfg.line_tokens;
        let device = Default::default();
        for sizes in [
            vec![(5, 3), (5, 3), (5, 3)],
            vec![(4, 0), (4, 0)],
            vec![(0, 2), (0, 2)],
            vec![(5, 3), (2, 1), (5, 3)],
        ] {
            let inputs: Vec<(Vec<f32>, Vec<f32>)> = sizes
                .iter()
                .enumerate()
                .map(|(k, &(n, m))| {
                    (
                        pseudo(n * d, 10 + k as u32),
                        pseudo(m * t * d, 20 + k as u32),
                    )
                })
                .collect();
            let tensors = |(p, l): &(Vec<f32>, Vec<f32>)| {
                NetworkInput::<B>::from_host(&cfg, p, l, &device).unwrap()
            };
            let batch =
                net.forward_batch(inputs.iter().map(tensors).collect(), &mut Dropout::off());
            assert_eq!(batch.len(), sizes.len());
            for (input, got) in inputs.iter().zip(&batch) {
                let want = net.forward(tensors(input), &mut Dropout::off());
                let (g, w) = (got.to_host(), want.to_host());
                assert_eq!(
                    (g.points.len(), g.lines.len()),
                    (w.points.len(), w.lines.len())
                );
                for (a, b) in g.points.iter().zip(&w.points) {
                    assert_close(
                        &[a.xyz[0], a.xyz[1], a.xyz[2], a.reliability],
                        &[b.xyz[0], b.xyz[1], b.xyz[2], b.reliability],
                        1e-5,
                    );
                }
                for (a, b) in g.lines.iter().zip(&w.lines) {
                    assert_close(
                        &[a.start[0], a.start[2], a.end[1], a.reliability],
                        &[b.start[0], b.start[2], b.end[1], b.reliability],
                        1e-5,
                    );
                }
            }
        }
    }

    /// Images padded to a shape bucket (`buckets.rs`) give their real rows the outputs
    /// of the unpadded images: with and without attention layers, with and without
    /// lines, several images of different real sizes stacked in one padded pass (also
    /// an image with no real points or no real lines among images that have them).
    #[test]
    fn padded_images_give_their_unpadded_outputs() {
        let device = Default::default();
        let limits = BucketLimits {
            points: 12,
            lines: 6,
        };
        for layers in [tiny_config().layers, Vec::new()] {
            let cfg = ModelConfig {
                layers,
                ..tiny_config()
            };
            let net = cfg.init::<B>(3, &device).unwrap();
            let (d, t) = (cfg.descriptor_dim, cfg.line_tokens);
            for sizes in [
                vec![(5, 3), (2, 1), (7, 0)],
                vec![(4, 0), (3, 0)],
                vec![(0, 2), (0, 1)],
                vec![(9, 4)],
                vec![(12, 6), (11, 6)],
                vec![(0, 3), (5, 0)],
            ] {
                let host: Vec<(Vec<f32>, Vec<f32>)> = sizes
                    .iter()
                    .enumerate()
                    .map(|(k, &(n, m))| {
                        (
                            pseudo(n * d, 30 + k as u32),
                            pseudo(m * t * d, 40 + k as u32),
                        )
                    })
                    .collect();
                let padded = limits.padded(&sizes);
                let inputs = host
                    .iter()
                    .map(|(p, l)| {
                        NetworkInput::<B>::from_host_padded(&cfg, p, l, Some(padded), &device)
                            .unwrap()
                    })
                    .collect();
                let batch = net.forward_batch(inputs, &mut Dropout::off());
                for ((p, l), got) in host.iter().zip(&batch) {
                    let input = NetworkInput::<B>::from_host(&cfg, p, l, &device).unwrap();
                    let want = net.forward(input, &mut Dropout::off()).to_host();
                    let mut got = got.to_host();
                    assert_eq!((got.points.len(), got.lines.len()), padded, "{sizes:?}");
                    got.points.truncate(want.points.len());
                    got.lines.truncate(want.lines.len());
                    assert_close(&flat(&got), &flat(&want), 1e-5);
                    let bucketed = net.predict_bucketed(p, l, Some(limits)).unwrap();
                    assert_close(&flat(&bucketed), &flat(&want), 1e-5);
                    assert_eq!(bucketed.points.len(), want.points.len());
                    assert_eq!(bucketed.lines.len(), want.lines.len());
                }
            }
        }
        // Padding below the real size is refused.
        let cfg = tiny_config();
        let p = pseudo(3 * cfg.descriptor_dim, 1);
        assert!(NetworkInput::<B>::from_host_padded(&cfg, &p, &[], Some((2, 0)), &device).is_err());
    }

    #[test]
    fn rejects_descriptors_of_the_wrong_size() {
        let cfg = tiny_config();
        let net = cfg.init::<B>(1, &Default::default()).unwrap();
        let err = net.predict(&[0.0; 7], &[]).unwrap_err();
        assert!(err.to_string().contains("point_descriptors"), "{err}");
    }
}
