//! Multi-head scaled dot-product attention with a contiguous head split
//! (channels `h * D/heads .. (h + 1) * D/heads` belong to head `h`).

use crate::init::Initializer;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Tensor, TensorPrimitive, backend::Backend};
use kernels::backend::{Pl2MapBackend, softmax_last};

/// Query, key and value projections and the output (merge) projection, all `D -> D` with bias.
#[derive(Module, Debug)]
pub struct Projections<B: Backend> {
    pub query: Linear<B>,
    pub key: Linear<B>,
    pub value: Linear<B>,
    pub merge: Linear<B>,
}

impl<B: Backend> Projections<B> {
    pub(crate) fn new(init: &mut Initializer<'_, B>, d: usize) -> Self {
        Projections {
            query: init.linear(d, d),
            key: init.linear(d, d),
            value: init.linear(d, d),
            merge: init.linear(d, d),
        }
    }
}

/// Which keys of each image are real, for images padded to a shape bucket
/// (`buckets.rs`): `keep` is 1 for a real key and 0 for a padded one, `bias` 0 and
/// [`MASKED_LOGIT`]; both [groups, 1, 1, Nk / groups], broadcast over heads and queries.
#[derive(Clone, Debug)]
pub struct KeyMask<B: Backend> {
    keep: Tensor<B, 4>,
    bias: Tensor<B, 4>,
}

/// The logit bias of a padded key: its softmax weight is exactly 0 in f32 beside any real
/// key (exp(-1e30 - max) underflows), and unlike -inf a row of padded keys only gives
/// equal weights (no NaN), which `keep` then zeroes.
pub const MASKED_LOGIT: f64 = -1e30;

impl<B: Backend> KeyMask<B> {
    /// The mask of images with `real[g]` real keys each among `per_image` rows; None when
    /// no key is padded (attention then takes the unmasked path, the Flex kernel on the
    /// CPU).
    pub fn from_counts(real: &[usize], per_image: usize, device: &B::Device) -> Option<Self> {
        if real.iter().all(|&r| r >= per_image) {
            return None;
        }
        let groups = real.len();
        let keep: Vec<f32> = real
            .iter()
            .flat_map(|&r| (0..per_image).map(move |j| if j < r { 1.0 } else { 0.0 }))
            .collect();
        let keep = crate::init::tensor_from::<B, 4>(keep, [groups, 1, 1, per_image], device);
        let bias = keep.clone().sub_scalar(1.0).mul_scalar(-MASKED_LOGIT);
        Some(KeyMask { keep, bias })
    }
}

/// Attention of `q` ([Nq, D]) over `k`, `v` ([Nk, D]), already projected; returns the
/// per-head contexts concatenated back to [Nq, D] (before the merge projection).
/// Scores are scaled by 1 / sqrt(D / heads). `Nq` and `Nk` must be positive.
/// (The network calls the grouped form; this one image form is the tests' reference.)
#[cfg(test)]
pub(crate) fn attend<B: Pl2MapBackend>(
    q: Tensor<B, 2>,
    k: Tensor<B, 2>,
    v: Tensor<B, 2>,
    heads: usize,
) -> Tensor<B, 2> {
    attend_grouped(q, k, v, heads, 1, None)
}

/// [`attend`] for `groups` images at once: the rows of `q` are `groups` consecutive blocks
/// of Nq / groups (one per image), those of `k` and `v` blocks of Nk / groups, and block g
/// of the queries attends to block g of the keys only. One batched matrix product
/// instead of one small product per image. With `mask`, padded keys get no weight (a
/// query whose keys are all padded gets a zero context: an empty edge set's).
pub(crate) fn attend_grouped<B: Pl2MapBackend>(
    q: Tensor<B, 2>,
    k: Tensor<B, 2>,
    v: Tensor<B, 2>,
    heads: usize,
    groups: usize,
    mask: Option<&KeyMask<B>>,
) -> Tensor<B, 2> {
    if mask.is_some() {
        return attend_composed(q, k, v, heads, groups, mask);
    }
    // One operation where the backend has a kernel (Flex: attention_kernel.rs).
    if let Some(out) = B::multi_head_attention(
        q.clone().into_primitive().tensor(),
        k.clone().into_primitive().tensor(),
        v.clone().into_primitive().tensor(),
        heads,
        groups,
    ) {
        return Tensor::from_primitive(TensorPrimitive::Float(out));
    }
    attend_composed(q, k, v, heads, groups, None)
}

/// [`attend_grouped`] as burn's operations (backends without a kernel, masked keys, and
/// the kernel's reference in tests).
pub(crate) fn attend_composed<B: Pl2MapBackend>(
    q: Tensor<B, 2>,
    k: Tensor<B, 2>,
    v: Tensor<B, 2>,
    heads: usize,
    groups: usize,
    mask: Option<&KeyMask<B>>,
) -> Tensor<B, 2> {
    let [rows_q, d] = q.dims();
    let [rows_k, _] = k.dims();
    let (nq, nk) = (rows_q / groups, rows_k / groups);
    let dk = d / heads;
    let scale = 1.0 / (dk as f64).sqrt();
    // Scaling the queries costs Nq*D multiplications instead of Nq*Nk on the scores.
    let q = q
        .mul_scalar(scale)
        .reshape([groups, nq, heads, dk])
        .swap_dims(1, 2); // [g, h, Nq, dk]
    let k = k.reshape([groups, nk, heads, dk]).permute([0, 2, 3, 1]); // [g, h, dk, Nk]
    let v = v.reshape([groups, nk, heads, dk]).swap_dims(1, 2); // [g, h, Nk, dk]
    let scores = q.matmul(k); // [g, h, Nq, Nk]
    let weights = match mask {
        None => softmax_last(scores),
        Some(m) => softmax_last(scores + m.bias.clone()) * m.keep.clone(),
    };
    weights.matmul(v).swap_dims(1, 2).reshape([rows_q, d])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{B, assert_close, pseudo, tensor, values};

    /// Naive per-head attention on the host, head h owning channels h*dk..(h+1)*dk.
    fn naive(
        q: &[f32],
        k: &[f32],
        v: &[f32],
        nq: usize,
        nk: usize,
        d: usize,
        heads: usize,
    ) -> Vec<f32> {
        let dk = d / heads;
        let mut out = vec![0.0f32; nq * d];
        for h in 0..heads {
            for i in 0..nq {
                let scores: Vec<f64> = (0..nk)
                    .map(|j| {
                        (0..dk)
                            .map(|c| (q[i * d + h * dk + c] * k[j * d + h * dk + c]) as f64)
                            .sum::<f64>()
                            / (dk as f64).sqrt()
                    })
                    .collect();
                let max = scores.iter().cloned().fold(f64::MIN, f64::max);
                let e: Vec<f64> = scores.iter().map(|s| (s - max).exp()).collect();
                let z: f64 = e.iter().sum();
                for c in 0..dk {
                    out[i * d + h * dk + c] = (0..nk)
                        .map(|j| e[j] / z * v[j * d + h * dk + c] as f64)
                        .sum::<f64>() as f32;
                }
            }
        }
        out
    }

    #[test]
    fn matches_naive_contiguous_head_split() {
        let (nq, nk, d, heads) = (3, 5, 8, 4);
        let q = pseudo(nq * d, 1)
            .iter()
            .map(|x| 3.0 * x)
            .collect::<Vec<_>>();
        let k = pseudo(nk * d, 2);
        let v = pseudo(nk * d, 3);
        let got = attend(
            tensor::<B, 2>(q.clone(), [nq, d]),
            tensor::<B, 2>(k.clone(), [nk, d]),
            tensor::<B, 2>(v.clone(), [nk, d]),
            heads,
        );
        assert_close(&values(&got), &naive(&q, &k, &v, nq, nk, d, heads), 1e-5);
    }

    /// Grouped attention is each group's own attention, stacked.
    #[test]
    fn groups_attend_only_within_themselves() {
        let (g, nq, nk, d, heads) = (3, 4, 2, 8, 2);
        let q = pseudo(g * nq * d, 5);
        let k = pseudo(g * nk * d, 6);
        let v = pseudo(g * nk * d, 7);
        let got = attend_grouped(
            tensor::<B, 2>(q.clone(), [g * nq, d]),
            tensor::<B, 2>(k.clone(), [g * nk, d]),
            tensor::<B, 2>(v.clone(), [g * nk, d]),
            heads,
            g,
            None,
        );
        let mut want = Vec::new();
        for i in 0..g {
            let (qs, ks) = (i * nq * d..(i + 1) * nq * d, i * nk * d..(i + 1) * nk * d);
            want.extend(naive(&q[qs], &k[ks.clone()], &v[ks], nq, nk, d, heads));
        }
        assert_close(&values(&got), &want, 1e-5);
    }

    /// Whether `K` runs its attention kernel on row slices of `x` as the test below
    /// passes them: queries the first g * nq rows, keys and values the next g * nk.
    fn kernel_runs<K: Pl2MapBackend>(
        x: Tensor<K, 2>,
        (g, nq, nk, heads): (usize, usize, usize, usize),
    ) -> bool {
        let part =
            |start: usize, len: usize| x.clone().narrow(0, start, len).into_primitive().tensor();
        let (q, kv) = (part(0, g * nq), part(g * nq, g * nk));
        K::multi_head_attention(q, kv.clone(), kv, heads, g).is_some()
    }

    /// The Flex kernel (attention_kernel.rs) against burn's composed operations: the
    /// output and the gradients of q, k and v, on operands that are row slices of larger
    /// tensors (as the graph network passes them), several images and heads. The products
    /// are the same; the kernel's softmax (softmax_rows.rs) has its own exponential and
    /// sums, so the results agree to a few f32 ulp, not bit for bit.
    #[test]
    fn the_kernel_matches_the_composed_path() {
        // Differentiates: not beside another thread's graphs (autodiff_lock.rs).
        let _autodiff = kernels::autodiff_lock::exclusive();
        use crate::testing::AD;
        let (g, nq, nk, d, heads) = (2, 37, 70, 16, 4);
        let rows = g * (nq + nk);
        let x = pseudo(rows * d, 11)
            .iter()
            .map(|v| 2.0 * v)
            .collect::<Vec<_>>();
        let w = pseudo(g * nq * d, 12);
        let run = |kernel: bool| {
            let xt = tensor::<AD, 2>(x.clone(), [rows, d]).require_grad();
            // q: the first g * nq rows; k and v: the rest (k negated so they differ).
            let q = xt.clone().narrow(0, 0, g * nq);
            let k = xt.clone().narrow(0, g * nq, g * nk).neg();
            let v = xt.clone().narrow(0, g * nq, g * nk).mul_scalar(0.5);
            let out = if kernel {
                attend_grouped(q, k, v, heads, g, None)
            } else {
                attend_composed(q, k, v, heads, g, None)
            };
            let loss = (out.clone() * tensor::<AD, 2>(w.clone(), [g * nq, d])).sum();
            let grads = loss.backward();
            (values(&out), values(&xt.grad(&grads).unwrap()))
        };
        // The kernel must have run (not fallen back to the composed path) on these
        // operands, with and without autodiff.
        let shape = (g, nq, nk, heads);
        assert!(kernel_runs(
            tensor::<AD, 2>(x.clone(), [rows, d]).require_grad(),
            shape
        ));
        assert!(kernel_runs(tensor::<B, 2>(x.clone(), [rows, d]), shape));
        let (out_kernel, grad_kernel) = run(true);
        let (out_composed, grad_composed) = run(false);
        assert_close(&out_kernel, &out_composed, 2e-6);
        assert_close(&grad_kernel, &grad_composed, 2e-6);
        // And without autodiff.
        let plain = |kernel: bool| {
            let q = tensor::<B, 2>(x[..g * nq * d].to_vec(), [g * nq, d]);
            let k = tensor::<B, 2>(x[g * nq * d..].to_vec(), [g * nk, d]);
            let out = if kernel {
                attend_grouped(q, k.clone(), k, heads, g, None)
            } else {
                attend_composed(q, k.clone(), k, heads, g, None)
            };
            values(&out)
        };
        assert_close(&plain(true), &plain(false), 2e-6);
    }
}
