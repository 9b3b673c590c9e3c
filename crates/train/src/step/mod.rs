//! One training step: forward, loss, backward, Adam.

pub mod groups;
mod optimizer;

use groups::GroupPools;
use model::buckets::BucketLimits;
use model::burn::module::{AutodiffModule, Module};
use model::burn::optim::{GradientsParams, Optimizer};
use model::burn::tensor::Tensor;
use model::burn::tensor::backend::AutodiffBackend;
use model::{
    Dropout, LossConfig, LossValues, ModelConfig, ModelError, Pl2Map, Pl2MapBackend, Sample,
    compute_loss,
};
pub use optimizer::{
    ADAM_BETA_1, ADAM_BETA_2, ADAM_EPSILON, Pl2MapOptimizer, adam_config, cpu_gradients,
    new_optimizer,
};
use std::ops::Range;
use std::sync::Barrier;

/// Per-step inputs that the trainer's schedule decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepOptions {
    /// Training progress t in [0, 1] (iteration / total iterations): drives tau(t) and the
    /// start of the reprojection term.
    pub progress: f64,
    pub learning_rate: f64,
    /// Seed of this step's dropout masks (the trainer derives it from its seed and the
    /// iteration, so a resumed run replays the same masks).
    pub dropout_seed: u64,
}

/// What a step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    pub losses: LossValues,
    /// False when the image held nothing to learn from (no points and no lines): the
    /// weights and the optimiser state were left alone.
    pub updated: bool,
}

/// A network, its optimiser and its loss configuration.
pub struct TrainState<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend> {
    // Option so that a step can move the network through the optimiser (burn's
    // optimisers take and return it by value); always Some between steps.
    model: Option<Pl2Map<B>>,
    pub optimizer: Pl2MapOptimizer<B>,
    pub loss: LossConfig,
    /// Gradient groups per step (`groups.rs`), and where they run.
    batch_groups: usize,
    group_pools: Option<GroupPools>,
    /// Called once a grouped step's gradients are made, before its update.
    on_gradients: Option<Box<dyn Fn() + Send + Sync>>,
    /// Shape buckets (crates/model/src/buckets.rs): None, the images' own sizes.
    shape_buckets: Option<BucketLimits>,
}

impl<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend> TrainState<B> {
    pub fn new(model: Pl2Map<B>, loss: LossConfig) -> Result<Self, ModelError> {
        loss.validate()?;
        Ok(TrainState {
            model: Some(model),
            optimizer: new_optimizer(),
            loss,
            batch_groups: 1,
            group_pools: None,
            on_gradients: None,
            shape_buckets: None,
        })
    }

    /// A fresh network from `config` and `seed`.
    pub fn init(
        config: &ModelConfig,
        loss: LossConfig,
        seed: u64,
        device: &B::Device,
    ) -> Result<Self, ModelError> {
        Self::new(config.init(seed, device)?, loss)
    }

    pub fn model(&self) -> &Pl2Map<B> {
        self.model
            .as_ref()
            .expect("TrainState holds a model between steps")
    }

    /// The network without autodiff, for evaluation.
    pub fn inference_model(&self) -> Pl2Map<B::InnerBackend> {
        self.model().valid()
    }

    /// Resumes from a network and an optimiser restored from a checkpoint.
    pub fn from_parts(
        model: Pl2Map<B>,
        optimizer: Pl2MapOptimizer<B>,
        loss: LossConfig,
    ) -> Result<Self, ModelError> {
        loss.validate()?;
        Ok(TrainState {
            model: Some(model),
            optimizer,
            loss,
            batch_groups: 1,
            group_pools: None,
            on_gradients: None,
            shape_buckets: None,
        })
    }

    pub fn into_parts(self) -> (Pl2Map<B>, Pl2MapOptimizer<B>) {
        let model = self.model.expect("TrainState holds a model between steps");
        (model, self.optimizer)
    }

    /// Forward + loss + backward + Adam step on one image.
    pub fn step(
        &mut self,
        sample: &Sample,
        options: &StepOptions,
    ) -> Result<StepReport, ModelError> {
        self.step_batch(std::slice::from_ref(sample), options)
    }

    /// One Adam step on the mean loss of several images. Attention never crosses images;
    /// images of equal size go through the network together (`Pl2Map::forward_batch`).
    /// Dropout masks come from one stream seeded with `dropout_seed`, so a batch of one
    /// is exactly [`TrainState::step`]. Reported losses are the means over the images
    /// (counts summed). With gradient groups ([`TrainState::set_batch_groups`]) each
    /// group of images takes its own pass and its own dropout stream (group 0 the step's).
    pub fn step_batch(
        &mut self,
        samples: &[Sample],
        options: &StepOptions,
    ) -> Result<StepReport, ModelError> {
        if samples.is_empty() {
            return Err(ModelError::InvalidConfig(
                "a step needs at least one image".into(),
            ));
        }
        // Building and differentiating this step's graphs must not overlap another
        // thread's (autodiff_lock.rs).
        let _autodiff = kernels::autodiff_lock::exclusive();
        let ranges = groups::split(samples.len(), self.batch_groups);
        if ranges.len() > 1 {
            return self.step_grouped(samples, &ranges, options);
        }
        let model = self.model();
        let (values, total) = forward_loss(
            model,
            samples,
            &self.loss,
            (options.progress, options.dropout_seed),
            self.shape_buckets,
        )?;
        let losses = LossValues::mean(&values);
        let Some(total) = total else {
            return Ok(StepReport {
                losses,
                updated: false,
            });
        };
        // The mean over the batch keeps the learning rate's meaning for any size.
        let total = if samples.len() > 1 {
            total.div_scalar(samples.len() as f64)
        } else {
            total
        };
        let lr = options.learning_rate;
        self.adam_step(|optimizer, model| {
            let grads = total.backward();
            let grads = GradientsParams::from_grads(grads, &model);
            optimizer.step(lr, model, grads)
        });
        Ok(StepReport {
            losses,
            updated: true,
        })
    }

    /// Splits every step's images into `groups` gradient groups (`groups.rs`; 1: one
    /// stacked pass, the default). `threads`: the CPU threads the groups share, each
    /// group on its own pool, all at once; None runs them one after another on the
    /// caller's thread (a GPU backend, whose kernels the calling thread only queues).
    /// Either way the same weights come out: the grouping sets the rounding, the threads
    /// do not.
    pub fn set_batch_groups(
        &mut self,
        groups: usize,
        threads: Option<usize>,
    ) -> Result<(), ModelError> {
        if groups == 0 {
            return Err(ModelError::InvalidConfig(
                "batch_groups must be at least 1".into(),
            ));
        }
        self.batch_groups = groups;
        self.group_pools = match threads {
            Some(t) if groups > 1 => Some(GroupPools::new(groups, t)?),
            _ => None,
        };
        Ok(())
    }

    /// Pads every pass's images to shape buckets under `limits`
    /// (crates/model/src/buckets.rs; the trainer's `[train] shape_buckets`), or not
    /// (None, the default). The losses and gradients of the real rows are the same up
    /// to float rounding (dropout masks are drawn for the padded tensors, so with
    /// dropout on they differ); a JIT engine then meets a few fixed shapes.
    pub fn set_shape_buckets(&mut self, limits: Option<BucketLimits>) {
        self.shape_buckets = limits;
    }

    /// `f` is called in every grouped step once the groups' gradients are made, before
    /// the Adam update (the trainer lets its sample stream refill then: the update is
    /// bound by memory, the passes before it by both cores). Not called by a stacked
    /// step or one that made no gradients.
    pub fn set_on_gradients(&mut self, f: Option<Box<dyn Fn() + Send + Sync>>) {
        self.on_gradients = f;
    }

    /// One Adam step by `step`, which gets the optimiser and the network (the network
    /// moves through the optimiser: burn's optimisers take and return it by value).
    fn adam_step(&mut self, step: impl FnOnce(&mut Pl2MapOptimizer<B>, Pl2Map<B>) -> Pl2Map<B>) {
        let model = self
            .model
            .take()
            .expect("TrainState holds a model between steps");
        self.model = Some(step(&mut self.optimizer, model));
    }

    fn step_grouped(
        &mut self,
        samples: &[Sample],
        ranges: &[Range<usize>],
        options: &StepOptions,
    ) -> Result<StepReport, ModelError> {
        let model = self.model();
        let copies: Vec<Pl2Map<B>> = ranges
            .iter()
            .map(|_| groups::with_own_leaves(model))
            .collect();
        let n = samples.len() as f64;
        let loss = &self.loss;
        let buckets = self.shape_buckets;
        // No group's backward pass may start while another group still builds its graph:
        // each backward pass ends in burn's sweep over every graph of the process, which
        // can free the steps of a graph under construction (autodiff_lock.rs). Groups run
        // one after another (no pools) need no barrier.
        let side_by_side = self.group_pools.is_some();
        let built = Barrier::new(if side_by_side { ranges.len() } else { 1 });
        let work = |g: usize| -> Result<(Vec<LossValues>, Option<GradientsParams>), ModelError> {
            let copy = &copies[g];
            // Each group's share of the batch mean, so that the sum is the mean's gradient.
            let forward = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                forward_loss(
                    copy,
                    &samples[ranges[g].clone()],
                    loss,
                    (
                        options.progress,
                        group_dropout_seed(options.dropout_seed, g),
                    ),
                    buckets,
                )
                .map(|(values, total)| (values, total.map(|t| t.div_scalar(n))))
            }));
            // Every group reaches the barrier, errors and panics included, or the others
            // would wait for it forever; a panic is raised again after it.
            built.wait();
            let (values, total) = forward.unwrap_or_else(|p| std::panic::resume_unwind(p))?;
            let grads = total.map(|t| GradientsParams::from_grads(t.backward(), copy));
            Ok((values, grads))
        };
        let results = match &self.group_pools {
            Some(pools) => pools.run(ranges.len(), work),
            None => (0..ranges.len()).map(work).collect(),
        };
        // The copies share the weights' buffers: dropped now, Adam updates them in place
        // (adam.rs) instead of copying each one first.
        drop(copies);
        let mut values = Vec::with_capacity(samples.len());
        let mut parts = Vec::with_capacity(ranges.len());
        for result in results {
            let (v, grads) = result?;
            values.extend(v);
            parts.extend(grads);
        }
        let losses = LossValues::mean(&values);
        if parts.is_empty() {
            return Ok(StepReport {
                losses,
                updated: false,
            });
        }
        let lr = options.learning_rate;
        if let Some(f) = &self.on_gradients {
            f();
        }
        self.adam_step(|optimizer, model| groups::adam_step_groups(optimizer, lr, model, parts));
        Ok(StepReport {
            losses,
            updated: true,
        })
    }
}

/// Group g's dropout stream: group 0 keeps the step's seed; the others a fixed mix of
/// it with g, so the masks depend on the grouping only.
fn group_dropout_seed(seed: u64, g: usize) -> u64 {
    seed ^ (g as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Each image's loss values, and the sum of the losses that have a gradient (None when
/// none has).
type ImageLosses<B> = (Vec<LossValues>, Option<Tensor<B, 1>>);

/// The (images, N, M) of each pass through the network of a step on images of real
/// sizes `sizes` (N, M) (after the trainer's limits), split into `batch_groups`
/// gradient groups, with shape buckets or without: what a JIT engine compiles kernels
/// for (tests/shape_buckets.rs counts them over a run's data).
pub fn pass_shapes(
    sizes: &[(usize, usize)],
    batch_groups: usize,
    buckets: Option<BucketLimits>,
) -> Vec<(usize, usize, usize)> {
    groups::split(sizes.len(), batch_groups)
        .into_iter()
        .flat_map(|r| {
            let group = &sizes[r];
            match buckets {
                Some(b) => model::network::pass_shapes(&vec![b.padded(group); group.len()]),
                None => model::network::pass_shapes(group),
            }
        })
        .collect()
}

/// The forward pass and the loss of `samples` through `model` at (training progress,
/// dropout seed), padded to shape buckets under `buckets`.
fn forward_loss<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
    model: &Pl2Map<B>,
    samples: &[Sample],
    loss: &LossConfig,
    (progress, dropout_seed): (f64, u64),
    buckets: Option<BucketLimits>,
) -> Result<ImageLosses<B>, ModelError> {
    let device = model
        .devices()
        .into_iter()
        .next()
        .ok_or_else(|| ModelError::InvalidConfig("network has no parameters".into()))?;
    // One padded size for all the pass's images, so that they stack into one pass.
    let padded = buckets.map(|b| {
        let sizes: Vec<(usize, usize)> = samples
            .iter()
            .map(|s| (s.num_points(), s.num_lines()))
            .collect();
        b.padded(&sizes)
    });
    let mut inputs = Vec::with_capacity(samples.len());
    let mut targets = Vec::with_capacity(samples.len());
    for sample in samples {
        let t = sample.to_tensors_padded::<B>(&model.config, padded, &device)?;
        inputs.push(t.input);
        targets.push(t.targets);
    }
    let mut dropout = Dropout::seeded(model.config.dropout, dropout_seed);
    let predictions = model.forward_batch(inputs, &mut dropout);
    let mut total = None;
    let mut values = Vec::with_capacity(samples.len());
    for (prediction, targets) in predictions.iter().zip(&targets) {
        let terms = compute_loss(prediction, targets, loss, progress);
        values.push(terms.values());
        if terms.has_gradient {
            total = Some(match total {
                None => terms.total,
                Some(t) => t + terms.total,
            });
        }
    }
    Ok((values, total))
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::testing::{AD, flat, on_threads, parameter_bits, tiny_config, tiny_sample};
    use std::sync::Arc;

    fn options(i: usize, progress: f64) -> StepOptions {
        StepOptions {
            progress,
            learning_rate: 3e-3,
            dropout_seed: i as u64,
        }
    }

    #[test]
    fn adam_lowers_the_loss_on_a_tiny_problem() {
        let cfg = ModelConfig {
            dropout: 0.0,
            ..tiny_config()
        };
        let sample = tiny_sample(&cfg, 12, 4);
        let mut state =
            TrainState::<AD>::init(&cfg, LossConfig::indoor(), 5, &Default::default()).unwrap();
        // progress 0.9: every term, the reprojection one included, is on. At first the
        // predictions sit near the camera centre (depth < 0.1 m), so L_pi only joins in
        // once the points have moved in front of the camera.
        let first = state.step(&sample, &options(0, 0.9)).unwrap();
        assert!(first.updated);
        assert!(first.losses.reprojection_active);
        let mut history = vec![first.losses];
        for i in 1..60 {
            let r = state.step(&sample, &options(i, 0.9)).unwrap();
            assert!(r.losses.total.is_finite());
            history.push(r.losses);
        }
        let last = history[history.len() - 1];
        let l = &first.losses;
        assert!(last.map_points < 0.5 * l.map_points, "{l:?} -> {last:?}");
        assert!(last.map_lines < 0.5 * l.map_lines, "{l:?} -> {last:?}");
        assert!(
            last.reliability_points + last.reliability_lines
                < l.reliability_points + l.reliability_lines
        );
        let joined = history
            .iter()
            .position(|v| v.reprojection_valid_points == v.reprojection_candidates_points)
            .expect("every labelled point ends up in front of the camera");
        assert!(
            last.reprojection_points < history[joined].reprojection_points,
            "{:?} -> {last:?}",
            history[joined]
        );
        assert!(last.total < history[joined].total);
    }

    #[test]
    fn steps_are_deterministic() {
        let cfg = tiny_config();
        let sample = tiny_sample(&cfg, 6, 3);
        let run = || {
            let mut s =
                TrainState::<AD>::init(&cfg, LossConfig::indoor(), 9, &Default::default()).unwrap();
            let mut out = Vec::new();
            for i in 0..3 {
                out.push(s.step(&sample, &options(i, 0.85)).unwrap().losses.total);
            }
            let p = s
                .inference_model()
                .predict(&sample.point_descriptors, &sample.line_descriptors);
            (out, p.unwrap())
        };
        assert_eq!(run(), run());
    }

    #[test]
    fn steps_do_not_depend_on_the_thread_count() {
        // Large enough that burn-flex runs its matrix products on several threads.
        let cfg = ModelConfig {
            descriptor_dim: 64,
            head_hidden: vec![512],
            ..tiny_config()
        };
        let sample = tiny_sample(&cfg, 256, 16);
        let run = |threads: usize| {
            on_threads(threads, || {
                let mut s =
                    TrainState::<AD>::init(&cfg, LossConfig::indoor(), 3, &Default::default())
                        .unwrap();
                for i in 0..2 {
                    s.step(&sample, &options(i, 0.9)).unwrap();
                }
                s.inference_model()
                    .predict(&sample.point_descriptors, &sample.line_descriptors)
                    .unwrap()
            })
        };
        let one = run(1);
        assert_eq!(one, run(2));
        assert_eq!(one, run(3));
    }

    /// A batch averages: [a, a] moves the weights as a alone (no dropout; up to the
    /// rounding of the stacked products), and [a, b] differs from both, for images of
    /// equal size (stacked) and of different sizes (one by one).
    #[test]
    fn a_batch_steps_on_the_mean_loss() {
        let cfg = ModelConfig {
            dropout: 0.0,
            ..tiny_config()
        };
        let a = tiny_sample(&cfg, 6, 3);
        let mut b = tiny_sample(&cfg, 5, 2);
        for l in &mut b.point_labels {
            l[0] += 1.0;
        }
        let after = |batch: &[Sample]| {
            let mut s =
                TrainState::<AD>::init(&cfg, LossConfig::indoor(), 9, &Default::default()).unwrap();
            let r = s.step_batch(batch, &options(0, 0.9)).unwrap();
            let p = s
                .inference_model()
                .predict(&a.point_descriptors, &a.line_descriptors)
                .unwrap();
            (r.losses, p)
        };
        let (la, pa) = after(std::slice::from_ref(&a));
        let (laa, paa) = after(&[a.clone(), a.clone()]);
        model::testing::assert_close(&flat(&paa), &flat(&pa), 1e-5);
        assert!((la.total - laa.total).abs() < 1e-6 * la.total.abs());
        assert_eq!(
            laa.reprojection_candidates_points,
            2 * la.reprojection_candidates_points
        );
        let mut same_size = tiny_sample(&cfg, 6, 3);
        for l in &mut same_size.point_labels {
            l[1] -= 1.0;
        }
        for b in [b, same_size] {
            let (lab, pab) = after(&[a.clone(), b.clone()]);
            let (lb, _) = after(std::slice::from_ref(&b));
            assert_ne!(pab, pa);
            assert!(
                (lab.total - 0.5 * (la.total + lb.total)).abs() < 1e-6 * la.total.abs().max(1.0)
            );
        }
        let mut s =
            TrainState::<AD>::init(&cfg, LossConfig::indoor(), 9, &Default::default()).unwrap();
        assert!(s.step_batch(&[], &options(0, 0.9)).is_err());
    }

    /// Every parameter's gradient of `total` through `model`, in visiting order.
    fn parameter_gradients(model: &Pl2Map<AD>, total: Tensor<AD, 1>) -> Vec<f32> {
        use model::burn::module::{ModuleVisitor, Param};
        type Grads = <AD as AutodiffBackend>::Gradients;
        struct Collect<'a>(&'a Grads, Vec<f32>);
        impl ModuleVisitor<AD> for Collect<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<AD, D>>) {
                if let Some(g) = param.val().grad(self.0) {
                    self.1.extend(g.into_data().convert::<f32>().iter::<f32>());
                }
            }
        }
        let grads = total.backward();
        let mut c = Collect(&grads, Vec::new());
        model.visit(&mut c);
        c.1
    }

    /// The per-image loss values and the parameter gradients of one pass.
    fn pass(
        model: &Pl2Map<AD>,
        batch: &[Sample],
        loss: &LossConfig,
        buckets: Option<BucketLimits>,
    ) -> (Vec<LossValues>, Vec<f32>) {
        let (values, total) = forward_loss(model, batch, loss, (0.9, 3), buckets).unwrap();
        (values, parameter_gradients(model, total.unwrap()))
    }

    /// Shape buckets (crates/model/src/buckets.rs) change no loss term and no gradient
    /// beyond float rounding: networks with and without attention layers, both
    /// reprojection target sets, images with and without lines (and one without
    /// points) of different real sizes padded into one stacked pass.
    #[test]
    fn shape_buckets_keep_losses_and_gradients() {
        let _autodiff = kernels::autodiff_lock::exclusive();
        let limits = BucketLimits {
            points: 8,
            lines: 4,
        };
        for layers in [tiny_config().layers, Vec::new()] {
            let cfg = ModelConfig {
                layers,
                dropout: 0.0,
                ..tiny_config()
            };
            let mut batch: Vec<Sample> = [(6, 3), (4, 0), (5, 2), (0, 3)]
                .iter()
                .map(|&(n, m)| tiny_sample(&cfg, n, m))
                .collect();
            for (i, s) in batch.iter_mut().enumerate() {
                for l in &mut s.point_labels {
                    l[0] += 0.2 * i as f32;
                }
                // A degenerate segment: left out of the reprojection term either way.
                if let Some(seg) = s.segments.get_mut(1) {
                    seg[2] = seg[0];
                    seg[3] = seg[1];
                }
            }
            let net = cfg.init::<AD>(2, &Default::default()).unwrap();
            for targets in [
                model::ReprojectionTargets::LabelledWeighted,
                model::ReprojectionTargets::Unlabelled,
            ] {
                let loss = LossConfig {
                    reprojection_targets: targets,
                    reprojection_start: 0.0,
                    ..LossConfig::indoor()
                };
                let (off, grad_off) = pass(&net, &batch, &loss, None);
                let (on, grad_on) = pass(&net, &batch, &loss, Some(limits));
                assert_eq!(off.len(), on.len());
                for (a, b) in off.iter().zip(&on) {
                    let close = |x: f64, y: f64| (x - y).abs() <= 1e-5 * (1.0 + x.abs());
                    for (x, y) in [
                        (a.total, b.total),
                        (a.map_points, b.map_points),
                        (a.map_lines, b.map_lines),
                        (a.reliability_points, b.reliability_points),
                        (a.reliability_lines, b.reliability_lines),
                        (a.reprojection_points, b.reprojection_points),
                        (a.reprojection_lines, b.reprojection_lines),
                    ] {
                        assert!(close(x, y), "{a:?}\n{b:?}");
                    }
                    assert_eq!(
                        (
                            a.reprojection_valid_points,
                            a.reprojection_valid_lines,
                            a.reprojection_candidates_points,
                            a.reprojection_candidates_lines
                        ),
                        (
                            b.reprojection_valid_points,
                            b.reprojection_valid_lines,
                            b.reprojection_candidates_points,
                            b.reprojection_candidates_lines
                        )
                    );
                }
                assert!(off.iter().any(|v| v.reprojection_valid_points > 0));
                assert_eq!(grad_off.len(), grad_on.len());
                let scale = grad_off.iter().fold(0f32, |m, g| m.max(g.abs()));
                assert!(scale > 0.0);
                for (x, y) in grad_off.iter().zip(&grad_on) {
                    assert!((x - y).abs() <= 1e-5 * scale, "{x} vs {y}");
                }
            }
        }
    }

    /// Images already at a bucket's size: attention takes the unpadded path (the Flex
    /// kernel), only the loss is in its masked form, and the gradients are the same
    /// bits as the index-list form's.
    #[test]
    fn masked_losses_at_a_buckets_size_keep_the_gradients_bit_for_bit() {
        let _autodiff = kernels::autodiff_lock::exclusive();
        let cfg = ModelConfig {
            dropout: 0.0,
            ..tiny_config()
        };
        let batch = vec![tiny_sample(&cfg, 8, 4), tiny_sample(&cfg, 8, 4)];
        let limits = BucketLimits {
            points: 8,
            lines: 4,
        };
        let net = cfg.init::<AD>(2, &Default::default()).unwrap();
        let loss = LossConfig {
            reprojection_start: 0.0,
            ..LossConfig::indoor()
        };
        let (_, off) = pass(&net, &batch, &loss, None);
        let (_, on) = pass(&net, &batch, &loss, Some(limits));
        let bits = |g: &[f32]| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&off), bits(&on));
    }

    /// What the shape-count test (tests/shape_buckets.rs) counts: one stacked pass per
    /// gradient group with buckets; without, one pass per image when sizes differ.
    #[test]
    fn pass_shapes_follow_the_batch() {
        let limits = BucketLimits {
            points: 32,
            lines: 12,
        };
        let sizes = [(32, 12), (30, 12), (32, 7), (32, 12)];
        assert_eq!(
            pass_shapes(&sizes, 1, None),
            [(1, 32, 12), (1, 30, 12), (1, 32, 7), (1, 32, 12)]
        );
        assert_eq!(pass_shapes(&sizes, 1, Some(limits)), [(4, 32, 12)]);
        assert_eq!(
            pass_shapes(&sizes, 2, Some(limits)),
            [(2, 32, 12), (2, 32, 12)]
        );
        assert_eq!(pass_shapes(&[(32, 12), (32, 12)], 1, None), [(2, 32, 12)]);
    }

    /// The gradient-group tests' network and images: no dropout (the groups draw their
    /// own masks, the stacked step one stream), five images of two sizes whose point
    /// labels differ, and a probe image to predict on.
    fn group_fixture() -> (ModelConfig, Vec<Sample>, Sample) {
        let cfg = ModelConfig {
            descriptor_dim: 64,
            head_hidden: vec![256, 256],
            dropout: 0.0,
            ..tiny_config()
        };
        let mut batch: Vec<Sample> = (0..5)
            .map(|i| tiny_sample(&cfg, 40 + 8 * (i % 2), 6))
            .collect();
        for (i, s) in batch.iter_mut().enumerate() {
            for l in &mut s.point_labels {
                l[0] += i as f32 * 0.3;
            }
        }
        let probe = tiny_sample(&cfg, 16, 4);
        (cfg, batch, probe)
    }

    /// Three steps on `batch` from seed 4 in `groups` groups (`threads` as
    /// `set_batch_groups` takes it): each step's loss and the probe's prediction.
    fn three_grouped_steps(
        fixture: &(ModelConfig, Vec<Sample>, Sample),
        groups: usize,
        threads: Option<usize>,
    ) -> (Vec<f64>, model::HostPrediction) {
        let (cfg, batch, probe) = fixture;
        let mut s =
            TrainState::<AD>::init(cfg, LossConfig::indoor(), 4, &Default::default()).unwrap();
        s.set_batch_groups(groups, threads).unwrap();
        // The hook before the update runs once a grouped step, never for a stacked one.
        let calls = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let counter = Arc::clone(&calls);
        s.set_on_gradients(Some(Box::new(move || {
            counter.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        })));
        let mut losses = Vec::new();
        for i in 0..3 {
            let r = s.step_batch(batch, &options(i, 0.9)).unwrap();
            assert!(r.updated);
            losses.push(r.losses.total);
            let expected = if groups > 1 { i + 1 } else { 0 };
            assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), expected);
        }
        let p = s
            .inference_model()
            .predict(&probe.point_descriptors, &probe.line_descriptors)
            .unwrap();
        (losses, p)
    }

    /// Two gradient groups give the stacked step's weights up to rounding, and the same
    /// weights however many threads run them (or none: one after another).
    #[test]
    fn gradient_groups_sum_to_the_batch_gradient_for_any_thread_count() {
        let fixture = group_fixture();
        let (cfg, batch, _) = &fixture;
        let run =
            |groups: usize, threads: Option<usize>| three_grouped_steps(&fixture, groups, threads);
        let (stacked_losses, stacked) = run(1, Some(2));
        let (losses, grouped) = run(2, Some(2));
        for (a, b) in losses.iter().zip(&stacked_losses) {
            assert!((a - b).abs() < 1e-4 * b.abs().max(1.0), "{a} vs {b}");
        }
        // The points (the lines' endpoints drift further apart within three steps).
        let points = |p: &model::HostPrediction| flat(p)[..4 * p.points.len()].to_vec();
        model::testing::assert_close(&points(&grouped), &points(&stacked), 1e-4);
        assert_ne!(
            grouped, stacked,
            "two groups round differently from one pass"
        );
        for threads in [Some(1), Some(3), None] {
            assert_eq!(run(2, threads).1, grouped, "threads {threads:?}");
        }
        // More groups than images: one image each.
        let mut s =
            TrainState::<AD>::init(cfg, LossConfig::indoor(), 4, &Default::default()).unwrap();
        s.set_batch_groups(8, Some(2)).unwrap();
        assert!(s.step_batch(batch, &options(0, 0.9)).unwrap().updated);
        assert!(s.set_batch_groups(0, None).is_err());
    }

    /// Two trainers in one process (the tests run side by side; a library user may run
    /// two) leave each other's steps alone: a grouped run repeated beside another thread
    /// that keeps stepping its own network gives the weights it gives alone. Without
    /// the process's autodiff lock a quarter of such runs differed in a probe, and this
    /// test did not finish within minutes (autodiff_lock.rs).
    #[test]
    fn concurrent_trainers_do_not_change_each_others_steps() {
        let fixture = group_fixture();
        let cfg = &fixture.0;
        let run = || three_grouped_steps(&fixture, 2, Some(2)).1;
        let alone = run();
        let stop = std::sync::atomic::AtomicBool::new(false);
        let other_steps = std::thread::scope(|scope| {
            let other = scope.spawn(|| {
                let sample = tiny_sample(cfg, 6, 3);
                let mut s =
                    TrainState::<AD>::init(cfg, LossConfig::indoor(), 9, &Default::default())
                        .unwrap();
                let mut steps = 0;
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    s.step(&sample, &options(steps, 0.5)).unwrap();
                    steps += 1;
                }
                steps
            });
            // Stops the other trainer however this thread leaves (a failed comparison
            // included), so that the scope can end.
            struct StopOnDrop<'a>(&'a std::sync::atomic::AtomicBool);
            impl Drop for StopOnDrop<'_> {
                fn drop(&mut self) {
                    self.0.store(true, std::sync::atomic::Ordering::Relaxed);
                }
            }
            let stopping = StopOnDrop(&stop);
            for attempt in 0..12 {
                assert_eq!(run(), alone, "run {attempt} beside another trainer");
            }
            drop(stopping);
            other.join().unwrap()
        });
        assert!(other_steps > 0, "the other trainer stepped");
    }

    /// The point input scale multiplies the point descriptors only: the network on
    /// scaled descriptors with scale 1 gives the same outputs.
    #[test]
    fn point_input_scale_scales_point_descriptors() {
        let base = tiny_config();
        let scaled = ModelConfig {
            point_input_scale: 4.0,
            ..base.clone()
        };
        let s = tiny_sample(&base, 6, 3);
        let net = scaled
            .init::<model::CpuBackend>(2, &Default::default())
            .unwrap();
        let mut plain = net.clone();
        plain.config = base.clone();
        let times4: Vec<f32> = s.point_descriptors.iter().map(|v| v * 4.0).collect();
        let a = net
            .predict(&s.point_descriptors, &s.line_descriptors)
            .unwrap();
        let b = plain.predict(&times4, &s.line_descriptors).unwrap();
        assert_eq!(a, b);
        let bad = ModelConfig {
            point_input_scale: 0.0,
            ..base
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("point_input_scale")
        );
    }

    #[test]
    fn images_without_lines_or_points() {
        let cfg = tiny_config();
        let mut state =
            TrainState::<AD>::init(&cfg, LossConfig::indoor(), 1, &Default::default()).unwrap();
        for (n, m, updated) in [(5, 0, true), (0, 3, true), (0, 0, false)] {
            let r = state
                .step(&tiny_sample(&cfg, n, m), &options(0, 0.9))
                .unwrap();
            assert_eq!(r.updated, updated, "n = {n}, m = {m}");
            assert!(r.losses.total.is_finite());
        }
    }

    #[test]
    fn bad_samples_are_errors() {
        let cfg = tiny_config();
        let mut state =
            TrainState::<AD>::init(&cfg, LossConfig::indoor(), 1, &Default::default()).unwrap();
        let mut s = tiny_sample(&cfg, 4, 2);
        s.point_valid.pop();
        let e = state.step(&s, &options(0, 0.0)).unwrap_err().to_string();
        assert!(e.contains("point_valid"), "{e}");
        let mut s = tiny_sample(&cfg, 4, 2);
        s.line_descriptors[cfg.line_tokens * cfg.descriptor_dim + 3] = f32::NAN;
        let e = state.step(&s, &options(0, 0.0)).unwrap_err().to_string();
        assert!(
            e.contains("line_descriptors") && e.contains("element 1"),
            "{e}"
        );
        let mut s = tiny_sample(&cfg, 4, 2);
        s.point_labels[0][1] = f32::INFINITY;
        let e = state.step(&s, &options(0, 0.0)).unwrap_err().to_string();
        assert!(e.contains("point_labels") && e.contains("element 0"), "{e}");
        let mut s = tiny_sample(&cfg, 4, 2);
        s.rotation[0][0] = 2.0;
        assert!(state.step(&s, &options(0, 0.0)).is_err());
        let mut s = tiny_sample(&cfg, 4, 2);
        s.camera.fx = 0.0;
        assert!(state.step(&s, &options(0, 0.0)).is_err());
        // In gradient groups side by side, one group's bad image is the step's error
        // (the other group does not wait for it at the barrier forever).
        state.set_batch_groups(2, Some(2)).unwrap();
        let mut bad = tiny_sample(&cfg, 4, 2);
        bad.point_valid.pop();
        let batch = vec![tiny_sample(&cfg, 4, 2), bad];
        let e = state
            .step_batch(&batch, &options(0, 0.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("point_valid"), "{e}");
    }

    /// Five steps of the fused Adam and of burn's Adam, on the gradients of different
    /// samples, give the same parameters bit for bit after every step (and so the same
    /// moments: a moment that differed would move the next step's parameters).
    #[test]
    fn fused_adam_equals_burns_adam_bit_for_bit() {
        let cfg = tiny_config();
        let net = cfg.init::<AD>(3, &Default::default()).unwrap();
        let mut burns = adam_config().init::<AD, Pl2Map<AD>>();
        let mut fused = new_optimizer::<AD>();
        let (mut a, mut b) = (net.clone(), net);
        for i in 0..5 {
            let sample = tiny_sample(&cfg, 8 + i, 3);
            let lr = 3e-3 / (i + 1) as f64;
            let ga = cpu_gradients(&a, &sample).unwrap();
            let gb = cpu_gradients(&b, &sample).unwrap();
            a = burns.step(lr, a, ga);
            b = fused.step(lr, b, gb);
            let (pa, pb) = (parameter_bits(&a), parameter_bits(&b));
            assert_eq!(pa.len(), pb.len());
            let differing = pa.iter().zip(&pb).filter(|(x, y)| x != y).count();
            assert_eq!(differing, 0, "step {i}: {differing} of {} differ", pa.len());
        }
        assert_ne!(
            parameter_bits(&a),
            parameter_bits(&cfg.init::<AD>(3, &Default::default()).unwrap())
        );
    }
}
