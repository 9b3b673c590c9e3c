//! Helpers for the tests of this crate and of the crates above it (train, bench): a tiny
//! network configuration and a consistent sample for it, and the generic helpers of
//! `kernels::testing`. Not for production code.

use crate::config::{LayerKind, ModelConfig};
use crate::sample::{Pinhole, Sample};
use burn::tensor::{Tensor, backend::Backend};
pub use kernels::testing::*;

pub fn tiny_config() -> ModelConfig {
    ModelConfig {
        descriptor_dim: 8,
        heads: 2,
        line_tokens: 4,
        ffn_dim: 16,
        layers: vec![LayerKind::SelfAttention, LayerKind::Cross],
        head_hidden: vec![16],
        line_head_hidden: None,
        dropout: 0.1,
        reliability_beta: 100.0,
        point_input_scale: 1.0,
        head_init: crate::HeadInit::Reference,
    }
}

/// A prediction's numbers in one vector (points: xyz and reliability; lines: both
/// endpoints), for comparisons within a tolerance.
pub fn flat(p: &crate::HostPrediction) -> Vec<f32> {
    p.points
        .iter()
        .flat_map(|x| [x.xyz[0], x.xyz[1], x.xyz[2], x.reliability])
        .chain(p.lines.iter().flat_map(|x| {
            [
                x.start[0], x.start[1], x.start[2], x.end[0], x.end[1], x.end[2],
            ]
        }))
        .collect()
}

/// Every parameter of `net` as bit patterns, in visiting order (weights compared bit
/// for bit).
pub fn parameter_bits<Bk: Backend>(net: &crate::Pl2Map<Bk>) -> Vec<u32> {
    use burn::module::{Module, ModuleVisitor, Param};
    struct Collect(Vec<u32>);
    impl<Bk: Backend> ModuleVisitor<Bk> for Collect {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<Bk, D>>) {
            let data = param.val().into_data().convert::<f32>();
            self.0.extend(data.iter::<f32>().map(f32::to_bits));
        }
    }
    let mut c = Collect(Vec::new());
    net.visit(&mut c);
    c.0
}

/// A small consistent sample: identity pose, labels are back-projections of the keypoints
/// and segment endpoints (so a perfect network has zero reprojection error).
pub fn tiny_sample(config: &ModelConfig, n: usize, m: usize) -> Sample {
    let d = config.descriptor_dim;
    let t = config.line_tokens;
    let camera = Pinhole {
        fx: 100.0,
        fy: 100.0,
        cx: 50.0,
        cy: 40.0,
    };
    let r = pseudo(4 * n + 6 * m, 99);
    let back = |u: f32, v: f32, z: f32| [(u - 50.0) / 100.0 * z, (v - 40.0) / 100.0 * z, z];
    let keypoints: Vec<[f32; 2]> = (0..n)
        .map(|i| [50.0 + 40.0 * r[4 * i], 40.0 + 30.0 * r[4 * i + 1]])
        .collect();
    let point_labels = keypoints
        .iter()
        .enumerate()
        .map(|(i, k)| back(k[0], k[1], 2.0 + r[4 * i + 2]))
        .collect();
    let segments: Vec<[f32; 4]> = (0..m)
        .map(|j| {
            let o = 4 * n + 6 * j;
            [
                50.0 + 40.0 * r[o],
                40.0 + 30.0 * r[o + 1],
                50.0 + 40.0 * r[o + 2],
                40.0 + 30.0 * r[o + 3],
            ]
        })
        .collect();
    let line_labels = segments
        .iter()
        .enumerate()
        .map(|(j, s)| {
            let o = 4 * n + 6 * j;
            let a = back(s[0], s[1], 2.0 + r[o + 4]);
            let b = back(s[2], s[3], 2.0 + r[o + 5]);
            [a[0], a[1], a[2], b[0], b[1], b[2]]
        })
        .collect();
    Sample {
        point_descriptors: pseudo(n * d, 1),
        line_descriptors: pseudo(m * t * d, 2),
        keypoints,
        segments,
        point_labels,
        point_valid: (0..n).map(|i| i % 3 != 2).collect(),
        line_labels,
        line_valid: (0..m).map(|j| j % 2 == 0).collect(),
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0; 3],
        camera,
    }
}
