//! After the sampling (step 5 of the module docs): one last local optimisation of the
//! best model, then the robust refinement on its inliers, points and lines jointly.

use super::score::{Score, Thresholds, line_sq_error, point_sq_error, score};
use crate::normalized::{NLine, NPoint};
use crate::refine::{Refinement, refine};
use crate::rigid::Rigid;

/// Rounds of inlier selection + refinement at the end.
const FINAL_ROUNDS: usize = 3;

/// The best model refined once more with the truncated loss `lo`, kept only if that
/// improves its MSAC score `best`.
pub(super) fn optimise_last(
    model: Rigid,
    best: &Score,
    pts: &[NPoint],
    lns: &[NLine],
    th: &Thresholds,
    lo: &Refinement,
) -> Rigid {
    let (refined, _) = refine(&model, pts, lns, lo);
    if score(&refined, pts, lns, th, best.cost).is_some() {
        refined
    } else {
        model
    }
}

/// Refines `model` on its inliers with the robust loss `fin`. The refined pose can move
/// a correspondence across the threshold: the inliers are selected again and the model
/// refined until they are stable, [`FINAL_ROUNDS`] times at most.
pub(super) fn refine_on_inliers(
    mut model: Rigid,
    pts: &[NPoint],
    lns: &[NLine],
    th: &Thresholds,
    fin: &Refinement,
) -> Rigid {
    let select = |m: &Rigid| -> (Vec<bool>, Vec<bool>) {
        (
            pts.iter()
                .map(|p| point_sq_error(m, p) < th.point_sq)
                .collect(),
            lns.iter()
                .map(|l| line_sq_error(m, l) < th.line_sq)
                .collect(),
        )
    };
    let mut masks = select(&model);
    for _ in 0..FINAL_ROUNDS {
        let inl_pts = kept(pts, &masks.0);
        let inl_lns = kept(lns, &masks.1);
        if inl_pts.len() + inl_lns.len() < 3 {
            break;
        }
        model = refine(&model, &inl_pts, &inl_lns, fin).0;
        let next = select(&model);
        if next == masks {
            break;
        }
        masks = next;
    }
    model
}

/// The items whose mask entry is set, in order.
fn kept<T: Copy>(items: &[T], mask: &[bool]) -> Vec<T> {
    items
        .iter()
        .zip(mask)
        .filter(|(_, k)| **k)
        .map(|(x, _)| *x)
        .collect()
}
