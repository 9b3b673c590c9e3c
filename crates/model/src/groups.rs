//! Gradient groups: a step's images split into a fixed number of groups whose forward and
//! backward passes run side by side, their gradients summed before the one Adam step.
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

use crate::backend::Pl2MapBackend;
use crate::error::ModelError;
use burn::module::{Module, ModuleMapper, ModuleVisitor, Param, ParamId};
use burn::optim::GradientsParams;
use burn::tensor::Tensor;
use burn::tensor::backend::AutodiffBackend;
use rayon::prelude::*;
use std::collections::HashMap;
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
/// denormals like the trainer's (see `denormals.rs`), so a group's products and
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
                crate::denormals::flushing_pool_of(each, &format!("group{g}")).map_err(|e| {
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

/// The sum of the groups' gradients, parameter by parameter, added in group order (a
/// parameter that no group's loss reached has none, as after one backward pass).
///
/// On host-memory backends the parameters are summed side by side (one task each):
/// each addition is one pass over its parameter on one thread, and with the sum on one
/// thread the step's second core sat idle for about a millisecond a step. Each element
/// is still `g0 + g1 + ...` in group order, so the task split never changes a bit. A
/// GPU backend's additions are queued from the calling thread, one after another.
pub fn sum_gradients<B, M>(model: &M, mut parts: Vec<GradientsParams>) -> GradientsParams
where
    B: AutodiffBackend<InnerBackend: Pl2MapBackend>,
    M: Module<B>,
{
    let mut collect = Collect::<B> {
        parts: &mut parts,
        found: Vec::new(),
    };
    model.visit(&mut collect);
    let add = |(id, grads): (ParamId, Vec<Tensor<B::InnerBackend, 1>>)| {
        let total = grads.into_iter().reduce(|total, g| total + g)?;
        Some((id, total))
    };
    let sums: HashMap<ParamId, Tensor<B::InnerBackend, 1>> =
        if <B::InnerBackend as Pl2MapBackend>::HOST_MEMORY {
            collect.found.into_par_iter().filter_map(add).collect()
        } else {
            collect.found.into_iter().filter_map(add).collect()
        };
    let mut register = Register::<B> {
        sums,
        out: GradientsParams::new(),
    };
    model.visit(&mut register);
    register.out
}

/// Each parameter's group gradients, in group order, flattened (a reshape of the
/// contiguous gradient: no copy) so that parameters of every rank share one list.
struct Collect<'a, B: AutodiffBackend> {
    parts: &'a mut [GradientsParams],
    found: Vec<(ParamId, Vec<Tensor<B::InnerBackend, 1>>)>,
}

impl<B: AutodiffBackend> ModuleVisitor<B> for Collect<'_, B> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<B, D>>) {
        let grads: Vec<_> = self
            .parts
            .iter_mut()
            .filter_map(|part| part.remove::<B::InnerBackend, D>(param.id))
            .map(|g| g.flatten::<1>(0, D - 1))
            .collect();
        if !grads.is_empty() {
            self.found.push((param.id, grads));
        }
    }
}

/// Files each sum under its parameter, in the parameter's shape again.
struct Register<B: AutodiffBackend> {
    sums: HashMap<ParamId, Tensor<B::InnerBackend, 1>>,
    out: GradientsParams,
}

impl<B: AutodiffBackend> ModuleVisitor<B> for Register<B> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<B, D>>) {
        if let Some(sum) = self.sums.remove(&param.id) {
            let dims = param.val().dims();
            self.out.register(param.id, sum.reshape(dims));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
