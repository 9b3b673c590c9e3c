//! Helpers shared by the unit tests.

use crate::config::{LayerKind, ModelConfig};
use crate::sample::{Pinhole, Sample};
use burn::tensor::{Tensor, TensorData, backend::Backend};

pub type B = crate::CpuBackend;
pub type AD = crate::CpuAutodiffBackend;

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

/// `f` run on a rayon pool of its own with `threads` threads (results that must not
/// depend on the thread count are compared across calls).
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool")
        .install(f)
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

/// Bit patterns, so that equality also tells -0.0 from 0.0 and compares NaNs.
pub fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

pub fn values<Bk: Backend, const K: usize>(t: &Tensor<Bk, K>) -> Vec<f32> {
    t.to_data().convert::<f32>().to_vec::<f32>().unwrap()
}

pub fn tensor<Bk: Backend, const K: usize>(v: Vec<f32>, shape: [usize; K]) -> Tensor<Bk, K> {
    Tensor::from_data(TensorData::new(v, shape), &Default::default())
}

pub fn assert_close(a: &[f32], b: &[f32], tol: f32) {
    assert_eq!(a.len(), b.len(), "lengths differ");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol * (1.0 + y.abs()),
            "element {i}: {x} vs {y} (tol {tol})"
        );
    }
}

/// Deterministic pseudo-random values in [-1, 1).
pub fn pseudo(n: usize, seed: u32) -> Vec<f32> {
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(12345);
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s as f32 / u32::MAX as f32) * 2.0 - 1.0
        })
        .collect()
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
