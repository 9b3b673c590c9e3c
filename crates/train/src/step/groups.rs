//! Gradient groups: a step's images split into a fixed number of groups whose forward and
//! backward passes run side by side, their gradients summed inside the one Adam step.
//!
//! Why: the main job's step (`pipeline/synthetic.toml`, 16 images, six-layer heads) is
//! matrix products of a few hundred rows, too small for the two threads of one product
//! to pay: on a 2-core Intel Xeon VM the stacked step took 0.049 s on two threads and
//! 0.058 s on one, while two processes each stepping on 8 images, one thread each, took
//! 0.035 s a step side by side (docs/performance.md, "Gradient groups"). Groups give each
//! core whole products instead of halves of each.
//!
//! The number of groups is configuration, not a thread setting: a group's gradient is a
//! sum over its own rows, and the groups' sums are added in group order, so the rounding
//! depends on the grouping (not on how many threads run it). One group is the stacked
//! step exactly.

use kernels::adam::FusedAdam;
use model::burn::module::{AutodiffModule, Module, ModuleMapper, ModuleVisitor, Param};
use model::burn::optim::adaptor::OptimizerAdaptor;
use model::burn::optim::record::AdaptorRecord;
use model::burn::optim::{GradientsParams, Optimizer, SimpleOptimizer};
use model::burn::tensor::Tensor;
use model::burn::tensor::backend::AutodiffBackend;
use model::{ModelError, Pl2MapBackend};
use std::ops::Range;

/// `groups` contiguous, non-empty ranges covering `0..n` (fewer when `n < groups`), their
/// sizes differing by at most one, the larger first.
pub fn split(n: usize, groups: usize) -> Vec<Range<usize>> {
    let groups = groups.clamp(1, n.max(1));
    let (base, extra) = (n / groups, n % groups);
    let mut start = 0;
    (0..groups)
        .map(|g| {
            let len = base + usize::from(g < extra);
            let r = start..start + len;
            start += len;
            r
        })
        .filter(|r| !r.is_empty())
        .collect()
}

/// Where each group's passes run: one rayon pool per group whose threads flush
/// denormals like the trainer's (see `crates/kernels/src/denormals.rs`), so a group's products and
/// element-wise kernels stay on its share of the cores.
pub struct GroupPools {
    pools: Vec<rayon::ThreadPool>,
}

impl GroupPools {
    /// `groups` pools sharing `threads` threads (at least one each).
    pub fn new(groups: usize, threads: usize) -> Result<Self, ModelError> {
        let each = (threads / groups.max(1)).max(1);
        let pools = (0..groups)
            .map(|g| {
                kernels::denormals::flushing_pool_of(each, &format!("group{g}")).map_err(|e| {
                    ModelError::InvalidConfig(format!("starting the threads of group {g}: {e}"))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(GroupPools { pools })
    }

    pub fn len(&self) -> usize {
        self.pools.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pools.is_empty()
    }

    /// Runs `work(g)` for the first `count` groups, group g on pool g, all at once;
    /// results in group order. A panic in a group is raised again here.
    pub fn run<T: Send>(&self, count: usize, work: impl Fn(usize) -> T + Sync) -> Vec<T> {
        std::thread::scope(|s| {
            let work = &work;
            let handles: Vec<_> = self
                .pools
                .iter()
                .take(count)
                .enumerate()
                .map(|(g, pool)| s.spawn(move || pool.install(|| work(g))))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
                .collect()
        })
    }
}

/// A copy of `model` whose parameters are new autodiff leaves with the same ids and
/// values. burn keeps every autodiff graph that shares a node under one lock, so two
/// groups' passes through the same parameter tensors would run their backward passes
/// one after the other; through their own leaves they do not share a node, and
/// [`GradientsParams`] still files each gradient under the parameter's id.
pub fn with_own_leaves<B: AutodiffBackend, M: Module<B>>(model: &M) -> M {
    model.clone().map(&mut OwnLeaves)
}

struct OwnLeaves;

impl<B: AutodiffBackend> ModuleMapper<B> for OwnLeaves {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<B, D>>) -> Param<Tensor<B, D>> {
        let (id, tensor, mapper) = param.consume();
        let leaf = if tensor.is_require_grad() {
            tensor.detach().require_grad()
        } else {
            tensor
        };
        Param::from_mapped_value(id, leaf, mapper)
    }
}

/// One Adam step of `model` with the sum of the groups' gradients, parameter by
/// parameter, added in group order (a parameter that no group's loss reached keeps its
/// value and its moments, as after one backward pass).
///
/// The sum is made inside Adam's pass over each parameter ([`FusedAdam::step_sum`]):
/// summing first took a pass of its own, reading both groups' gradients and writing the
/// sum that Adam then read again, about a millisecond of the main job's 31 ms step on
/// memory traffic alone. Each element is still `g0 + g1 + ...` in group order, so the
/// weights are those of summing first. The optimiser's record (burn's
/// [`OptimizerAdaptor`] record: checkpoints) is the same as burn's step would keep.
pub fn adam_step_groups<B, M>(
    optimizer: &mut OptimizerAdaptor<FusedAdam, M, B>,
    learning_rate: f64,
    model: M,
    parts: Vec<GradientsParams>,
) -> M
where
    B: AutodiffBackend<InnerBackend: Pl2MapBackend>,
    M: AutodiffModule<B>,
{
    let adam = optimizer.optim().clone();
    // The moments move out of the optimiser so that each is the only owner of its
    // buffer: the pass then updates it in place instead of copying it first.
    let taken = std::mem::replace(optimizer, OptimizerAdaptor::from(adam.clone()));
    let mut records = taken.to_record();
    drop(taken);
    let model = model.map(&mut GroupAdam::<B, M> {
        adam: &adam,
        records: &mut records,
        parts,
        learning_rate,
    });
    *optimizer = OptimizerAdaptor::from(adam).load_record(records);
    model
}

/// The groups' gradients added as tensors, parameter by parameter in group order, and
/// filed under their parameter: what [`adam_step_groups`] computes inside its pass, as a
/// separate step (the reference its test and `examples/adam_bench.rs` compare it with).
pub fn sum_gradients<B: AutodiffBackend, M: Module<B>>(
    model: &M,
    mut parts: Vec<GradientsParams>,
) -> GradientsParams {
    struct Sum<'a> {
        parts: &'a mut [GradientsParams],
        out: GradientsParams,
    }
    impl<B: AutodiffBackend> ModuleVisitor<B> for Sum<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<B, D>>) {
            let sum = self
                .parts
                .iter_mut()
                .filter_map(|part| part.remove::<B::InnerBackend, D>(param.id))
                .reduce(|total, g| total + g);
            if let Some(sum) = sum {
                self.out.register(param.id, sum);
            }
        }
    }
    let mut sum = Sum {
        parts: &mut parts,
        out: GradientsParams::new(),
    };
    model.visit(&mut sum);
    sum.out
}

/// The record burn's adaptor keeps for [`FusedAdam`]: one entry per parameter.
type Records<B, M> = <OptimizerAdaptor<FusedAdam, M, B> as Optimizer<M, B>>::Record;

/// burn's adaptor step (`SimpleOptimizerMapper`) with the groups' gradients instead of
/// one: each parameter with a gradient in any group is stepped, its record replaced.
struct GroupAdam<'a, B, M>
where
    B: AutodiffBackend<InnerBackend: Pl2MapBackend>,
    M: AutodiffModule<B>,
{
    adam: &'a FusedAdam,
    records: &'a mut Records<B, M>,
    parts: Vec<GradientsParams>,
    learning_rate: f64,
}

impl<B, M> ModuleMapper<B> for GroupAdam<'_, B, M>
where
    B: AutodiffBackend<InnerBackend: Pl2MapBackend>,
    M: AutodiffModule<B>,
{
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<B, D>>) -> Param<Tensor<B, D>> {
        let (id, tensor, mapper) = param.consume();
        let grads: Vec<Tensor<B::InnerBackend, D>> = self
            .parts
            .iter_mut()
            .filter_map(|part| part.remove::<B::InnerBackend, D>(id))
            .collect();
        if grads.is_empty() {
            return Param::from_mapped_value(id, tensor, mapper);
        }
        let require_grad = tensor.is_require_grad();
        // As burn's adaptor: the state follows the gradient's device (a run resumed on
        // another device than its checkpoint's).
        let device = grads[0].device();
        let state = self.records.remove(&id).map(|r| {
            <FusedAdam as SimpleOptimizer<B::InnerBackend>>::to_device(r.into_state::<D>(), &device)
        });
        let (inner, state) = self
            .adam
            .step_sum(self.learning_rate, tensor.inner(), grads, state);
        if let Some(state) = state {
            self.records.insert(id, AdaptorRecord::from_state(state));
        }
        let mut tensor = Tensor::from_inner(inner);
        if require_grad {
            tensor = tensor.require_grad();
        }
        Param::from_mapped_value(id, tensor, mapper)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::step::optimizer::{adam_config, cpu_gradients, new_optimizer};
    use model::Pl2Map;
    use model::testing::{AD, parameter_bits, tiny_config, tiny_sample};

    /// Takes the first parameter's gradient out of `part` (a gradient one group lacks).
    fn drop_first_gradient(net: &Pl2Map<AD>, part: &mut GradientsParams) {
        struct DropFirst<'a>(&'a mut GradientsParams, bool);
        impl ModuleVisitor<AD> for DropFirst<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<AD, D>>) {
                type Inner = <AD as AutodiffBackend>::InnerBackend;
                if !self.1 {
                    self.1 = self.0.remove::<Inner, D>(param.id).is_some();
                }
            }
        }
        let mut d = DropFirst(part, false);
        net.visit(&mut d);
        assert!(d.1, "a gradient was dropped");
    }

    /// Four steps of Adam over the sum of three groups' gradients: made inside the fused
    /// pass, and made first as tensors then stepped by burn's own Adam, give the same
    /// parameters bit for bit after every step (so the same moments too). In the third
    /// step one group has no gradient for a parameter (its loss did not reach it).
    #[test]
    fn fused_group_step_equals_summing_then_burns_adam() {
        let cfg = tiny_config();
        let net = cfg.init::<AD>(5, &Default::default()).unwrap();
        let mut burns = adam_config().init::<AD, Pl2Map<AD>>();
        let mut fused = new_optimizer::<AD>();
        let (mut a, mut b) = (net.clone(), net);
        for step in 0..4 {
            let lr = 2e-3 / (step + 1) as f64;
            for groups in [2, 3] {
                let parts = |net: &Pl2Map<AD>| -> Vec<GradientsParams> {
                    let mut parts: Vec<_> = (0..groups)
                        .map(|g| cpu_gradients(net, &tiny_sample(&cfg, 6 + g + step, 3)).unwrap())
                        .collect();
                    if step == 2 {
                        drop_first_gradient(net, &mut parts[1]);
                    }
                    parts
                };
                let (pa, pb) = (parts(&a), parts(&b));
                a = burns.step(lr, a.clone(), sum_gradients(&a, pa));
                b = adam_step_groups(&mut fused, lr, b, pb);
                let (wa, wb) = (parameter_bits(&a), parameter_bits(&b));
                let differing = wa.iter().zip(&wb).filter(|(x, y)| x != y).count();
                assert_eq!(
                    differing, 0,
                    "step {step}, {groups} groups: {differing} differ"
                );
            }
        }
    }

    #[test]
    fn split_covers_every_image_once_in_order() {
        assert_eq!(split(16, 2), vec![0..8, 8..16]);
        assert_eq!(split(5, 2), vec![0..3, 3..5]);
        assert_eq!(split(7, 3), vec![0..3, 3..5, 5..7]);
        assert_eq!(split(1, 2), vec![0..1]);
        assert_eq!(split(3, 1), vec![0..3]);
        assert!(split(0, 2).is_empty());
    }

    #[test]
    fn groups_run_on_their_own_flushing_pools() {
        let pools = GroupPools::new(2, 2).unwrap();
        let names = pools.run(2, |g| {
            let tiny = std::hint::black_box(f32::MIN_POSITIVE) * std::hint::black_box(0.5);
            (
                g,
                std::thread::current().name().map(str::to_string),
                rayon::current_num_threads(),
                tiny,
            )
        });
        assert_eq!(names.len(), 2);
        for (g, (i, name, threads, tiny)) in names.into_iter().enumerate() {
            assert_eq!(i, g);
            assert_eq!(name.as_deref(), Some(format!("group{g}-0").as_str()));
            assert_eq!(threads, 1);
            if cfg!(target_arch = "x86_64") {
                assert_eq!(tiny, 0.0);
            }
        }
    }
}
