//! The sampling loop (steps 2 to 4 of the module docs): draw a solver and a minimal
//! sample, solve it, score every solution with MSAC, run a local optimisation from a
//! minimal model with more inliers than any before, until the adaptive stopping rule or
//! the iteration cap ends it.

use super::options::RansacOptions;
use super::sampler::{SOLVERS, Sampler};
use super::score::{Score, Thresholds, score};
use crate::normalized::{NLine, NPoint};
use crate::refine::{Refinement, refine};
use crate::rigid::{Rigid, Solutions};
use crate::solvers::{p1p2ll_into, p2p1ll_into, p3ll_into, p3p_into};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// What the sampling found, and what it took.
pub(super) struct Search {
    /// The model of lowest MSAC cost, minimal or locally optimised, and its score.
    pub best: Option<(Rigid, Score)>,
    /// Lowest cost of a minimal model so far: the bound that stops scoring a model
    /// early once it cannot win.
    best_minimal_cost: f64,
    /// Most inliers of a minimal model so far: a model with more is optimised locally.
    best_minimal_inliers: usize,
    /// Minimal samples drawn.
    pub iterations: usize,
    /// Local optimisations run.
    pub refinements: usize,
    /// Samples drawn per solver: P3P, P2P1LL, P1P2LL, P3LL.
    pub samples_per_solver: [usize; 4],
}

/// Runs the sampling loop on the usable correspondences, with the MSAC thresholds `th`
/// and the local optimisation `lo`.
pub(super) fn search(
    sampler: &Sampler,
    pts: &[NPoint],
    lns: &[NLine],
    th: &Thresholds,
    lo: &Refinement,
    opt: &RansacOptions,
) -> Search {
    let stop_log = opt.dynamic_trials_factor * (1.0 - opt.success_probability).ln();
    let mut rng = ChaCha8Rng::seed_from_u64(opt.seed);
    let mut s = Search {
        best: None,
        best_minimal_cost: f64::INFINITY,
        best_minimal_inliers: 0,
        iterations: 0,
        refinements: 0,
        samples_per_solver: [0; 4],
    };
    let mut sols = Solutions::new();
    let (mut pidx, mut lidx) = ([0usize; 3], [0usize; 3]);
    while s.iterations < opt.max_iterations {
        let inliers = s.best.map(|(_, b)| (b.point_inliers, b.line_inliers));
        if let Some(inl) = inliers
            && s.iterations >= opt.min_iterations
            && sampler.log_miss(&s.samples_per_solver, inl) <= stop_log
        {
            break;
        }
        let solver = sampler.select(&mut rng, inliers);
        s.iterations += 1;
        s.samples_per_solver[solver] += 1;
        let (k, m) = SOLVERS[solver];
        Sampler::draw(&mut rng, pts.len(), k, &mut pidx);
        Sampler::draw(&mut rng, lns.len(), m, &mut lidx);
        solve_sample(solver, &pidx, &lidx, pts, lns, &mut sols);
        if let Some(start) = s.score_minimal(sols.as_slice(), pts, lns, th) {
            s.optimise_locally(&start, pts, lns, th, lo);
        }
    }
    s
}

impl Search {
    fn keep_if_best(&mut self, model: Rigid, sc: Score) {
        if self.best.is_none_or(|(_, b)| sc.cost < b.cost) {
            self.best = Some((model, sc));
        }
    }

    /// Scores the minimal models of one sample, keeps the best, and returns the last
    /// one with more inliers than any minimal model before: the start of a local
    /// optimisation.
    fn score_minimal(
        &mut self,
        models: &[Rigid],
        pts: &[NPoint],
        lns: &[NLine],
        th: &Thresholds,
    ) -> Option<Rigid> {
        let mut lo_start = None;
        for model in models {
            let Some(sc) = score(model, pts, lns, th, self.best_minimal_cost) else {
                continue;
            };
            self.best_minimal_cost = sc.cost;
            self.keep_if_best(*model, sc);
            if sc.inliers() > self.best_minimal_inliers {
                self.best_minimal_inliers = sc.inliers();
                lo_start = Some(*model);
            }
        }
        lo_start
    }

    /// Refines `start` on all correspondences with the truncated loss and keeps the
    /// result if it is the best model so far.
    fn optimise_locally(
        &mut self,
        start: &Rigid,
        pts: &[NPoint],
        lns: &[NLine],
        th: &Thresholds,
        lo: &Refinement,
    ) {
        let (refined, _) = refine(start, pts, lns, lo);
        self.refinements += 1;
        if let Some(sc) = score(&refined, pts, lns, th, f64::INFINITY) {
            self.keep_if_best(refined, sc);
        }
    }
}

/// Solves the minimal sample of solver `s` into `out`.
fn solve_sample(
    s: usize,
    pidx: &[usize; 3],
    lidx: &[usize; 3],
    points: &[NPoint],
    lines: &[NLine],
    out: &mut Solutions,
) {
    let ray = |i: usize| {
        let p = &points[pidx[i]];
        Vector3::new(p.x.x, p.x.y, 1.0)
    };
    let wp = |i: usize| points[pidx[i]].world;
    let ln = |i: usize| &lines[lidx[i]];
    match s {
        0 => p3p_into(&[ray(0), ray(1), ray(2)], &[wp(0), wp(1), wp(2)], out),
        1 => p2p1ll_into(
            &[ray(0), ray(1)],
            &[wp(0), wp(1)],
            &ln(0).normal,
            &ln(0).a,
            &ln(0).dir,
            out,
        ),
        2 => p1p2ll_into(
            &ray(0),
            &wp(0),
            &[ln(0).normal, ln(1).normal],
            &[ln(0).a, ln(1).a],
            &[ln(0).dir, ln(1).dir],
            out,
        ),
        _ => p3ll_into(
            &[ln(0).normal, ln(1).normal, ln(2).normal],
            &[ln(0).a, ln(1).a, ln(2).a],
            &[ln(0).dir, ln(1).dir, ln(2).dir],
            out,
        ),
    }
}
