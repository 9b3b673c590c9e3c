//! One engine against the CPU's (Flex): the same networks (weights drawn on the host from
//! one seed, so the same on both), the same images and the same training steps must
//! agree up to float rounding. Compared, for a transformer-only network (one
//! self-attention layer) and the graph network (self and cross attention,
//! `crates/model/src/graph.rs`):
//!
//! - the fresh network's predictions and its line encoder's output;
//! - the loss terms of one image, and every parameter's gradient of that loss;
//! - the predictions after five Adam steps on four images, in one gradient group and in
//!   two (`crates/train/src/step/groups.rs`).
//!
//! The GPU check (`scripts/gpu-check.sh`) runs it through `examples/engine_check.rs`
//! for every engine a build has; `tests/engines_libtorch.rs` runs it on LibTorch's CPU
//! device in CI. The differences are `max |a - b| / (1 + |b|)` over the values.

use crate::BenchError as E;
use crate::step::synthetic_sample;
use model::burn::module::{AutodiffModule, Module, ModuleVisitor, Param};
use model::burn::optim::GradientsParams;
use model::burn::tensor::backend::{AutodiffBackend, Backend};
use model::burn::tensor::{Tensor, TensorData};
use model::{
    Device, Dropout, HostPrediction, LayerKind, LossConfig, ModelConfig, Pl2Map, Pl2MapBackend,
    Sample, compute_loss,
};
use serde::Serialize;
use std::fmt;
use train::step::{StepOptions, TrainState};

/// One comparison.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub what: String,
    pub values: usize,
    /// max |engine - cpu| / (1 + |cpu|).
    pub difference: f64,
    pub bound: f64,
}

impl Comparison {
    pub fn passed(&self) -> bool {
        self.difference <= self.bound
    }
}

/// All comparisons of one engine.
#[derive(Clone, Debug, Serialize)]
pub struct Agreement {
    pub device: String,
    pub comparisons: Vec<Comparison>,
    /// How far five steps moved the CPU's predictions (max, same measure): the
    /// comparisons after training say something only when this is far above them.
    pub training_moved: f64,
}

impl Agreement {
    pub fn passed(&self) -> bool {
        let trained = self
            .comparisons
            .iter()
            .filter(|c| c.what.contains("after 5 steps"))
            .map(|c| c.difference)
            .fold(0.0, f64::max);
        self.comparisons.iter().all(Comparison::passed) && self.training_moved > 10.0 * trained
    }

    /// The largest difference of each kind of comparison (for a one-line summary).
    pub fn worst(&self) -> f64 {
        self.comparisons
            .iter()
            .map(|c| c.difference)
            .fold(0.0, f64::max)
    }
}

impl fmt::Display for Agreement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} against the CPU (Flex):", self.device)?;
        writeln!(
            f,
            "  {:<52} {:>7} {:>10} {:>8}  ok",
            "compared", "values", "max diff", "bound"
        )?;
        for c in &self.comparisons {
            writeln!(
                f,
                "  {:<52} {:>7} {:>10.2e} {:>8.0e}  {}",
                c.what,
                c.values,
                c.difference,
                c.bound,
                if c.passed() { "yes" } else { "NO" }
            )?;
        }
        writeln!(
            f,
            "  training moved the predictions by {:.2e}; verdict: {}",
            self.training_moved,
            if self.passed() { "AGREE" } else { "DISAGREE" }
        )
    }
}

/// Bounds: f32 products summed in another order (or on TF32 tensor cores) stay far
/// inside them; a wrong kernel differs by the order of the values themselves.
const FORWARD_BOUND: f64 = 2e-3;
const GRADIENT_BOUND: f64 = 5e-3;
/// After training: Adam divides each gradient entry by its own size, so entries near zero
/// turn float noise into steps of the learning rate's size; measured up to 7.7e-3 on
/// LibTorch's CPU (docs/performance.md, "The LibTorch engine and the GPU check").
const TRAINED_BOUND: f64 = 3e-2;

/// The two network kinds.
fn configs() -> [(&'static str, ModelConfig); 2] {
    let base = ModelConfig {
        descriptor_dim: 64,
        heads: 4,
        line_tokens: 4,
        ffn_dim: 128,
        layers: vec![LayerKind::SelfAttention, LayerKind::Cross],
        head_hidden: vec![128, 128],
        line_head_hidden: None,
        dropout: 0.0,
        reliability_beta: 100.0,
        point_input_scale: 1.0,
        head_init: model::HeadInit::He,
    };
    [
        (
            "transformer",
            ModelConfig {
                layers: vec![LayerKind::SelfAttention],
                ..base.clone()
            },
        ),
        ("graph", base),
    ]
}

/// What one engine computed, by name, in the order of [`measure`].
type Measured = Vec<(String, Vec<f32>)>;

fn flat(p: &HostPrediction) -> Vec<f32> {
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

fn host<Bk: Backend, const D: usize>(t: Tensor<Bk, D>) -> Vec<f32> {
    t.into_data().convert::<f32>().to_vec().unwrap_or_default()
}

/// Every parameter's gradient, in visiting order.
fn gradients<B: AutodiffBackend>(net: &Pl2Map<B>, grads: &GradientsParams) -> Vec<f32> {
    struct Collect<'a>(&'a GradientsParams, Vec<f32>);
    impl<B: AutodiffBackend> ModuleVisitor<B> for Collect<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<B, D>>) {
            if let Some(g) = self.0.get::<B::InnerBackend, D>(param.id) {
                self.1.extend(host(g));
            }
        }
    }
    let mut c = Collect(grads, Vec::new());
    net.visit(&mut c);
    c.1
}

fn losses(v: &model::LossValues) -> Vec<f32> {
    [
        v.total,
        v.map_points,
        v.map_lines,
        v.reliability_points,
        v.reliability_lines,
        v.reprojection_points,
        v.reprojection_lines,
    ]
    .iter()
    .map(|&x| x as f32)
    .collect()
}

/// Everything compared, on backend `B` at `device`.
fn measure<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    device: &B::Device,
) -> Result<Measured, E> {
    let mut out = Measured::new();
    for (kind, cfg) in configs() {
        let batch: Vec<Sample> = (0..4)
            .map(|i| synthetic_sample(&cfg, 48 + 16 * (i % 2), 8, 11 + i as u64))
            .collect();
        let probe = synthetic_sample(&cfg, 40, 6, 3);
        let net = cfg.init::<B>(7, device)?;
        // Fresh predictions and the line encoder.
        let inference = net.valid();
        out.push((
            format!("{kind}: predictions, fresh"),
            flat(&inference.predict(&probe.point_descriptors, &probe.line_descriptors)?),
        ));
        let (m, t, d) = (probe.num_lines(), cfg.line_tokens, cfg.descriptor_dim);
        let lines = Tensor::<B::InnerBackend, 3>::from_data(
            TensorData::new(probe.line_descriptors.clone(), [m, t, d]),
            device,
        );
        out.push((
            format!("{kind}: line encoder output"),
            host(
                inference
                    .line_encoder
                    .forward(lines, &mut Dropout::seeded(0.0, 0)),
            ),
        ));
        // One image's loss terms and gradients (every term on, no dropout).
        {
            let _autodiff = kernels::autodiff_lock::exclusive();
            let s = &batch[0];
            let t = s.to_tensors::<B>(&cfg, device)?;
            let p = net.forward_batch(vec![t.input], &mut Dropout::seeded(0.0, 0));
            let terms = compute_loss(&p[0], &t.targets, &LossConfig::indoor(), 0.9);
            out.push((format!("{kind}: loss terms"), losses(&terms.values())));
            let grads = GradientsParams::from_grads(terms.total.backward(), &net);
            out.push((
                format!("{kind}: parameter gradients"),
                gradients(&net, &grads),
            ));
        }
        // Five Adam steps in one and in two gradient groups.
        for groups in [1, 2] {
            let mut state = TrainState::<B>::new(net.clone(), LossConfig::indoor())?;
            state.set_batch_groups(groups, None)?;
            for i in 0..5 {
                let options = StepOptions {
                    progress: 0.9,
                    learning_rate: 1e-3,
                    dropout_seed: i,
                };
                state.step_batch(&batch, &options)?;
            }
            let trained = state
                .inference_model()
                .predict(&probe.point_descriptors, &probe.line_descriptors)?;
            out.push((
                format!("{kind}: predictions after 5 steps, {groups} group(s)"),
                flat(&trained),
            ));
        }
    }
    Ok(out)
}

fn difference(a: &[f32], b: &[f32]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    a.iter()
        .zip(b)
        .map(|(x, y)| f64::from((x - y).abs()) / (1.0 + f64::from(y.abs())))
        .fold(
            0.0,
            |m, d| if d.is_nan() { f64::INFINITY } else { m.max(d) },
        )
}

fn compare(device: &Device, engine: Measured, cpu: Measured) -> Agreement {
    let mut comparisons = Vec::new();
    let mut moved = f64::INFINITY;
    for ((what, e), (_, c)) in engine.iter().zip(&cpu) {
        let bound = if what.contains("after 5 steps") {
            TRAINED_BOUND
        } else if what.contains("gradients") || what.contains("loss") {
            GRADIENT_BOUND
        } else {
            FORWARD_BOUND
        };
        comparisons.push(Comparison {
            what: what.clone(),
            values: c.len(),
            difference: difference(e, c),
            bound,
        });
    }
    // How far training moved each network (fresh against trained, on the CPU).
    for (kind, _) in configs() {
        let find = |name: String| cpu.iter().find(|(w, _)| *w == name).map(|(_, v)| v);
        if let (Some(fresh), Some(trained)) = (
            find(format!("{kind}: predictions, fresh")),
            find(format!("{kind}: predictions after 5 steps, 1 group(s)")),
        ) {
            moved = moved.min(difference(trained, fresh));
        }
    }
    Agreement {
        device: device.to_string(),
        comparisons,
        training_moved: if moved.is_finite() { moved } else { 0.0 },
    }
}

/// Runs every comparison of `device`'s engine against the CPU. The device is checked
/// first (`Device::check_usable`: built, driver, GPU index).
pub fn check_agreement(device: Device) -> Result<Agreement, E> {
    device.check_usable()?;
    let cpu = measure::<model::CpuAutodiffBackend>(&Default::default())?;
    let engine = match device {
        Device::Cpu => measure::<model::CpuAutodiffBackend>(&Default::default())?,
        #[cfg(feature = "cuda")]
        Device::Cuda(i) => measure::<model::CudaAutodiffBackend>(&Device::cuda(i))?,
        #[cfg(feature = "tch")]
        Device::LibTorchCpu | Device::LibTorchCuda(_) => {
            measure::<model::LibTorchAutodiffBackend>(&device.libtorch())?
        }
        #[allow(unreachable_patterns)]
        _ => return Err(device.not_built().into()),
    };
    Ok(compare(&device, engine, cpu))
}
