//! Rectangle NFA and improvement (IPOL paper, section "Rectangle improvement"): a
//! rectangle that is not meaningful as found is retried with finer angle precisions,
//! smaller widths and shifted sides, keeping any variant with a better NFA.

use crate::angle::is_aligned;
use crate::grid::Grid;
use crate::nfa::nfa;
use crate::rect::{Rect, RectPixels};
use std::f64::consts::PI;

/// `-log10(NFA)` of `rec`: its in-image pixels against those aligned with its axis.
pub(crate) fn rect_nfa(rec: &Rect, angles: &Grid<f64>, log_nt: f64) -> f64 {
    let (mut pts, mut alg) = (0u64, 0u64);
    for (x, y) in RectPixels::new(rec) {
        if angles.contains(x, y) {
            pts += 1;
            if is_aligned(x as usize, y as usize, angles, rec.theta, rec.prec) {
                alg += 1;
            }
        }
    }
    nfa(pts, alg, rec.p, log_nt)
}

/// Step by which the width shrinks (pixels).
const DELTA: f64 = 0.5;

/// Tries variants of `rec` while its `-log10(NFA)` is `<= log_eps`, in the reference's
/// order (finer precision, narrower, one side in, the other side in, finer precision
/// again; five steps each). Updates `rec` to the best and returns its `-log10(NFA)`.
pub(crate) fn rect_improve(rec: &mut Rect, angles: &Grid<f64>, log_nt: f64, log_eps: f64) -> f64 {
    let mut log_nfa = rect_nfa(rec, angles, log_nt);
    if log_nfa > log_eps {
        return log_nfa;
    }
    let try_steps = |rec: &mut Rect, log_nfa: &mut f64, step: &dyn Fn(&mut Rect) -> bool| {
        let mut r = *rec;
        for _ in 0..5 {
            if step(&mut r) {
                let new = rect_nfa(&r, angles, log_nt);
                if new > *log_nfa {
                    *log_nfa = new;
                    *rec = r;
                }
            }
        }
    };
    let finer = |r: &mut Rect| {
        r.p /= 2.0;
        r.prec = r.p * PI;
        true
    };
    let narrower = |r: &mut Rect| {
        if r.width - DELTA >= 0.5 {
            r.width -= DELTA;
            true
        } else {
            false
        }
    };
    // Moving both endpoints by a quarter pixel across the axis and narrowing by half a
    // pixel keeps the other side in place.
    let side = |sign: f64| {
        move |r: &mut Rect| {
            if r.width - DELTA >= 0.5 {
                let (ox, oy) = (-r.dy * (DELTA / 2.0), r.dx * (DELTA / 2.0));
                if sign > 0.0 {
                    r.x1 += ox;
                    r.y1 += oy;
                    r.x2 += ox;
                    r.y2 += oy;
                } else {
                    r.x1 -= ox;
                    r.y1 -= oy;
                    r.x2 -= ox;
                    r.y2 -= oy;
                }
                r.width -= DELTA;
                true
            } else {
                false
            }
        }
    };
    let plus = side(1.0);
    let minus = side(-1.0);
    let steps: [&dyn Fn(&mut Rect) -> bool; 5] = [&finer, &narrower, &plus, &minus, &finer];
    for step in steps {
        try_steps(rec, &mut log_nfa, step);
        if log_nfa > log_eps {
            break;
        }
    }
    log_nfa
}
