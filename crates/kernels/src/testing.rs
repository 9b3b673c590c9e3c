//! Helpers for the tests of this crate and of the crates above it (model, train, bench):
//! pseudo-random values, bit-exact comparisons, thread pools of a given size. Not for
//! production code.

use burn::tensor::{Tensor, TensorData, backend::Backend};

pub type B = crate::CpuBackend;
pub type AD = crate::CpuAutodiffBackend;

/// `f` run on a rayon pool of its own with `threads` threads (results that must not
/// depend on the thread count are compared across calls).
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool")
        .install(f)
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
