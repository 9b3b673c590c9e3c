//! Density refinement (IPOL paper, section "Refinement"): a rectangle in which the region
//! fills less than `density_th` of the area (a curve, or two segments meeting at an angle)
//! is regrown with a tolerance estimated near the seed and, if still too sparse, cut down
//! to a shrinking radius around the seed.
//!
//! pytlsd comments the call out (its `density_th` argument does nothing): run with
//! `density_th = 0` ([`crate::Params::pytlsd`]), where the first density test always passes
//! and this module changes nothing.

use crate::angle::angle_diff_signed;
use crate::grid::Grid;
use crate::rect::Rect;
use crate::region::{Region, region_grow, region_to_rect};

/// Euclidean distance as the reference computes it (`sqrt` of the sum of squares, not
/// `hypot`, whose rounding differs).
fn dist(x1: f64, y1: f64, x2: f64, y2: f64) -> f64 {
    ((x2 - x1) * (x2 - x1) + (y2 - y1) * (y2 - y1)).sqrt()
}

/// Region pixels (`n`) per unit of rectangle area.
fn density_of(n: usize, rec: &Rect) -> f64 {
    n as f64 / (dist(rec.x1, rec.y1, rec.x2, rec.y2) * rec.width)
}

/// Refines `region` and `rec` until the density reaches `density_th`; false when the
/// region is rejected.
pub(crate) fn refine(
    region: &mut Region,
    rec: &mut Rect,
    modgrad: &Grid<f64>,
    angles: &Grid<f64>,
    used: &mut Grid<bool>,
    density_th: f64,
) -> bool {
    if density_of(region.points.len(), rec) >= density_th {
        return true;
    }
    // First try: the tolerance becomes twice the standard deviation of the angles within
    // one rectangle width of the seed.
    let (xc, yc) = (region.points[0].0 as f64, region.points[0].1 as f64);
    let ang_c = angles.get(region.points[0].0, region.points[0].1);
    let (mut sum, mut s_sum, mut n) = (0.0, 0.0, 0usize);
    for &(x, y) in &region.points {
        used.set(x, y, false);
        if dist(xc, yc, x as f64, y as f64) < rec.width {
            let d = angle_diff_signed(angles.get(x, y), ang_c);
            sum += d;
            s_sum += d * d;
            n += 1;
        }
    }
    let mean = sum / n as f64;
    let tau = 2.0 * ((s_sum - 2.0 * mean * sum) / n as f64 + mean * mean).sqrt();
    let seed = region.points[0];
    region_grow(seed.0, seed.1, angles, used, tau, region);
    if region.points.len() < 2 {
        return false;
    }
    *rec = region_to_rect(region, modgrad, rec.prec, rec.p);
    if density_of(region.points.len(), rec) >= density_th {
        return true;
    }
    // Second try: drop the pixels farthest from the seed, the radius shrinking to 3/4
    // each round.
    let mut rad = dist(xc, yc, rec.x1, rec.y1).max(dist(xc, yc, rec.x2, rec.y2));
    while density_of(region.points.len(), rec) < density_th {
        rad *= 0.75;
        // Remove by swapping in the last pixel, as the reference does (the order of the
        // survivors matters to the next rectangle's sums).
        let mut i = 0;
        while i < region.points.len() {
            let (x, y) = region.points[i];
            if dist(xc, yc, x as f64, y as f64) > rad {
                used.set(x, y, false);
                region.points.swap_remove(i);
            } else {
                i += 1;
            }
        }
        if region.points.len() < 2 {
            return false;
        }
        *rec = region_to_rect(region, modgrad, rec.prec, rec.p);
    }
    true
}
