//! The reference implementation's PL2Map weights, mapped onto this crate's network
//! (docs/formats.md, "Importing the reference's checkpoints").
//!
//! The reference's module holds, for the paper's network at D = 256:
//! - `line_encoder.desc_layers.0.slf_attn.{w_qs,w_ks,w_vs,fc}.{weight,bias}` (linear
//!   layers, weight `[out, in]`), `...slf_attn.layer_norm.{weight,bias}`,
//!   `...pos_ffn.{w_1,w_2}.{weight,bias}`, `...pos_ffn.layer_norm.{weight,bias}`;
//! - `gnn.layers.{i}.attn.proj.{0,1,2}` (query, key, value), `gnn.layers.{i}.attn.merge`,
//!   `gnn.layers.{i}.mlp.{0,2}` (kernel-1 convolutions, weight `[out, in, 1]`);
//! - `mapping_p.{0,2,4,6}` and `mapping_l.{0,2,4,6}` (the heads, kernel-1 convolutions
//!   with ReLU modules at the odd indices).
//!
//! Two conventions differ from this crate's:
//! - Weights: PyTorch stores `[out, in]`, burn's `Linear` `[in, out]`: transposed.
//! - Heads of the graph's attention: the reference reshapes each projection to
//!   `(D / heads, heads)`, so its channel `c` belongs to head `c % heads` (interleaved);
//!   here head `h` owns channels `h * D/heads .. (h + 1) * D/heads` (contiguous, see
//!   `attention.rs`). The output channels of the query, key and value projections and
//!   the input channels of the merge projection are permuted accordingly, which leaves
//!   the function unchanged. The line encoder's attention already splits contiguously
//!   (it reshapes to `(heads, D / heads)`): no permutation there.
//!
//! [`reference_keys`] lists every key with its shape in the order they are read, so a
//! refusal names the first missing or misshapen one.

use crate::config::{LayerKind, ModelConfig};
use crate::error::ModelError;
use crate::init::SequentialIds;
use crate::network::{LINE_OUTPUTS, POINT_OUTPUTS, Pl2Map};
use burn::module::{Module, Param};
use burn::nn::{LayerNorm, Linear};
use burn::tensor::TensorData;
use kernels::backend::Pl2MapBackend;

/// The reference's network: D = 256 (SuperPoint descriptors), 4 heads, feed-forward
/// width 1024, layers self, cross, self, cross, self, heads 512-1024-512, T = 12.
pub fn reference_config() -> ModelConfig {
    let c = ModelConfig::superpoint();
    debug_assert_eq!(c.ffn_dim, 1024);
    debug_assert_eq!(
        c.layers,
        [
            LayerKind::SelfAttention,
            LayerKind::Cross,
            LayerKind::SelfAttention,
            LayerKind::Cross,
            LayerKind::SelfAttention
        ]
    );
    c
}

const LINE: &str = "line_encoder.desc_layers.0";

/// Every key the import reads, with its expected shape, in reading order.
pub fn reference_keys(config: &ModelConfig) -> Vec<(String, Vec<usize>)> {
    let d = config.descriptor_dim;
    let f = config.ffn_dim;
    let mut keys = Vec::new();
    let layer = |keys: &mut Vec<(String, Vec<usize>)>, name: String, w: Vec<usize>| {
        let out = w[0];
        keys.push((format!("{name}.weight"), w));
        keys.push((format!("{name}.bias"), vec![out]));
    };
    for p in ["w_qs", "w_ks", "w_vs", "fc"] {
        layer(&mut keys, format!("{LINE}.slf_attn.{p}"), vec![d, d]);
    }
    layer(&mut keys, format!("{LINE}.slf_attn.layer_norm"), vec![d]);
    layer(&mut keys, format!("{LINE}.pos_ffn.w_1"), vec![f, d]);
    layer(&mut keys, format!("{LINE}.pos_ffn.w_2"), vec![d, f]);
    layer(&mut keys, format!("{LINE}.pos_ffn.layer_norm"), vec![d]);
    for i in 0..config.layers.len() {
        for p in ["proj.0", "proj.1", "proj.2", "merge"] {
            layer(&mut keys, format!("gnn.layers.{i}.attn.{p}"), vec![d, d, 1]);
        }
        layer(
            &mut keys,
            format!("gnn.layers.{i}.mlp.0"),
            vec![2 * d, 2 * d, 1],
        );
        layer(
            &mut keys,
            format!("gnn.layers.{i}.mlp.2"),
            vec![d, 2 * d, 1],
        );
    }
    for (head, hidden, outputs) in [
        ("mapping_p", &config.head_hidden[..], POINT_OUTPUTS),
        ("mapping_l", config.line_head_widths(), LINE_OUTPUTS),
    ] {
        let mut widths = vec![d];
        widths.extend_from_slice(hidden);
        widths.push(outputs);
        for (j, w) in widths.windows(2).enumerate() {
            layer(&mut keys, format!("{head}.{}", 2 * j), vec![w[1], w[0], 1]);
        }
    }
    keys
}

/// Builds the network of `config` from the reference's tensors. `get(key, shape)`
/// returns the tensor `key` (row-major values) after checking that it has `shape`, or
/// the caller's error, which is returned as is (the inner result); keys are asked for in
/// the order of [`reference_keys`]. `config` must have the reference's structure (the
/// [`reference_config`] for the released models); it is validated first (the outer
/// result).
pub fn from_reference<B, E, F>(
    config: &ModelConfig,
    device: &B::Device,
    mut get: F,
) -> Result<Result<Pl2Map<B>, E>, ModelError>
where
    B: Pl2MapBackend,
    F: FnMut(&str, &[usize]) -> Result<Vec<f32>, E>,
{
    let mut net = config.init::<B>(0, device)?;
    Ok(fill(&mut net, config, device, &mut get).map(|()| net.map(&mut SequentialIds::default())))
}

/// Where a reference layer's values go in a burn `Linear`.
#[derive(Clone, Copy)]
enum Permute<'a> {
    None,
    /// Output channel o of ours is the reference's output channel `p[o]`.
    Rows(&'a [usize]),
    /// Input channel i of ours is the reference's input channel `p[i]`.
    Cols(&'a [usize]),
}

fn fill<B, E, F>(
    net: &mut Pl2Map<B>,
    config: &ModelConfig,
    device: &B::Device,
    get: &mut F,
) -> Result<(), E>
where
    B: Pl2MapBackend,
    F: FnMut(&str, &[usize]) -> Result<Vec<f32>, E>,
{
    let d = config.descriptor_dim;
    let f = config.ffn_dim;
    let dk = d / config.heads;
    // Our channel h * dk + j is the reference's channel j * heads + h.
    let perm: Vec<usize> = (0..d).map(|c| (c % dk) * config.heads + c / dk).collect();
    let norm = |get: &mut F, ln: &mut LayerNorm<B>, name: &str| -> Result<(), E> {
        let g = get(&format!("{name}.weight"), &[d])?;
        let b = get(&format!("{name}.bias"), &[d])?;
        ln.gamma = Param::from_data(TensorData::new(g, [d]), device);
        ln.beta = Some(Param::from_data(TensorData::new(b, [d]), device));
        Ok(())
    };
    // The line encoder: dense layers, contiguous heads (no permutation).
    let dense = |get: &mut F, name: &str, out: usize, inp: usize| {
        reference_linear::<B, E, F>(get, device, name, [out, inp], false, Permute::None)
    };
    let e = &mut net.line_encoder;
    e.attention.query = dense(get, &format!("{LINE}.slf_attn.w_qs"), d, d)?;
    e.attention.key = dense(get, &format!("{LINE}.slf_attn.w_ks"), d, d)?;
    e.attention.value = dense(get, &format!("{LINE}.slf_attn.w_vs"), d, d)?;
    e.attention.merge = dense(get, &format!("{LINE}.slf_attn.fc"), d, d)?;
    norm(
        get,
        &mut e.attention_norm,
        &format!("{LINE}.slf_attn.layer_norm"),
    )?;
    e.ffn_in = dense(get, &format!("{LINE}.pos_ffn.w_1"), f, d)?;
    e.ffn_out = dense(get, &format!("{LINE}.pos_ffn.w_2"), d, f)?;
    norm(get, &mut e.ffn_norm, &format!("{LINE}.pos_ffn.layer_norm"))?;

    let mut linear = |name: &str, out: usize, inp: usize, permute: Permute<'_>| {
        reference_linear::<B, E, F>(get, device, name, [out, inp], true, permute)
    };
    for (i, layer) in net.graph.layers.iter_mut().enumerate() {
        let p = format!("gnn.layers.{i}");
        let a = &mut layer.attention;
        a.query = linear(&format!("{p}.attn.proj.0"), d, d, Permute::Rows(&perm))?;
        a.key = linear(&format!("{p}.attn.proj.1"), d, d, Permute::Rows(&perm))?;
        a.value = linear(&format!("{p}.attn.proj.2"), d, d, Permute::Rows(&perm))?;
        a.merge = linear(&format!("{p}.attn.merge"), d, d, Permute::Cols(&perm))?;
        layer.mlp_hidden = linear(&format!("{p}.mlp.0"), 2 * d, 2 * d, Permute::None)?;
        layer.mlp_out = linear(&format!("{p}.mlp.2"), d, 2 * d, Permute::None)?;
    }
    for (head, mlp) in [
        ("mapping_p", &mut net.point_head),
        ("mapping_l", &mut net.line_head),
    ] {
        for (j, l) in mlp.layers.iter_mut().enumerate() {
            let [inp, out] = l.weight.val().dims();
            *l = linear(&format!("{head}.{}", 2 * j), out, inp, Permute::None)?;
        }
    }
    Ok(())
}

/// One reference layer (`[out, in]`, or `[out, in, 1]` for a kernel-1 convolution) as a
/// burn `Linear` (`[in, out]`).
fn reference_linear<B, E, F>(
    get: &mut F,
    device: &B::Device,
    name: &str,
    [out, inp]: [usize; 2],
    conv: bool,
    permute: Permute<'_>,
) -> Result<Linear<B>, E>
where
    B: Pl2MapBackend,
    F: FnMut(&str, &[usize]) -> Result<Vec<f32>, E>,
{
    let shape: Vec<usize> = if conv {
        vec![out, inp, 1]
    } else {
        vec![out, inp]
    };
    let w = get(&format!("{name}.weight"), &shape)?;
    let b = get(&format!("{name}.bias"), &[out])?;
    let row = |o: usize| match permute {
        Permute::Rows(p) => p[o],
        _ => o,
    };
    let col = |i: usize| match permute {
        Permute::Cols(p) => p[i],
        _ => i,
    };
    let mut weight = vec![0.0f32; inp * out];
    for i in 0..inp {
        let ci = col(i);
        for o in 0..out {
            weight[i * out + o] = w[row(o) * inp + ci];
        }
    }
    let bias: Vec<f32> = (0..out).map(|o| b[row(o)]).collect();
    Ok(Linear {
        weight: Param::from_data(TensorData::new(weight, [inp, out]), device),
        bias: Some(Param::from_data(TensorData::new(bias, [out]), device)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::B;
    use std::collections::BTreeMap;

    /// Every key is read once, in the listed order, with the listed shape.
    #[test]
    fn reads_exactly_the_listed_keys_in_order() {
        let cfg = reference_config();
        let keys = reference_keys(&cfg);
        let mut asked = Vec::new();
        let net = from_reference::<B, String, _>(&cfg, &Default::default(), |k, s| {
            asked.push((k.to_string(), s.to_vec()));
            Ok(vec![0.5; s.iter().product()])
        })
        .unwrap()
        .unwrap();
        assert_eq!(asked, keys);
        let total: usize = keys.iter().map(|(_, s)| s.iter().product::<usize>()).sum();
        assert_eq!(total, net.num_params());
        let unique: BTreeMap<_, _> = keys.iter().cloned().collect();
        assert_eq!(unique.len(), keys.len());
    }

    /// The first failing key stops the import with the caller's error.
    #[test]
    fn the_first_error_is_returned() {
        let cfg = reference_config();
        let r = from_reference::<B, String, _>(&cfg, &Default::default(), |k, s| {
            if k.starts_with("gnn.layers.1") {
                Err(k.to_string())
            } else {
                Ok(vec![0.0; s.iter().product()])
            }
        })
        .unwrap();
        assert_eq!(r.err().unwrap(), "gnn.layers.1.attn.proj.0.weight");
    }
}
