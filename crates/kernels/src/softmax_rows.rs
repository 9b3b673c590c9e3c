//! Softmax over the rows of the attention kernel's score matrices, in place, with a
//! vectorised exponential (`attention_kernel.rs`).
//!
//! burn-flex's fused softmax calls libm's scalar `expf` for every score: at 1024 keypoints
//! and 128 lines the graph network's attention computes about 5 M exponentials a layer,
//! and a one-thread profile of its training step (docs/performance.md, "The attention's
//! softmax") put 20 % of the step in that softmax (scalar `expf` 10 %, its other passes
//! and a zeroed output buffer the rest). Here each row is three passes over data that
//! stays in the L1 cache (max, exponential and sum, scale), the exponential is a
//! polynomial the compiler vectorises, and the scores' own buffer holds the result.
//!
//! Results do not depend on the machine or the thread count: rows are split into fixed
//! tasks, every sum runs over 16 fixed lanes reduced in a fixed order, and the only
//! fused operation (`mul_add`) is exact on every target. The same code is compiled once
//! for AVX-512, once for AVX2 + FMA and once for the baseline, chosen at run time.

use crate::simd_dispatch::dispatch;
use rayon::prelude::*;

/// Lanes of every sum: one AVX-512 register, two AVX2 registers, four of SSE or NEON,
/// the same arithmetic on each.
const LANES: usize = 16;
/// Rows per rayon task (a fixed split: results never depend on the threads).
const ROWS_PER_TASK: usize = 64;

/// e^x for x <= 88: at most 2 ulp from the exact value for x in [-87, 88], 0 below -87
/// (where e^x is under 1.7e-38, nothing next to a softmax row's largest term, e^0 = 1),
/// NaN for NaN.
///
/// x = n ln 2 + r with n an integer and |r| <= ln(2) / 2, so e^x = 2^n e^r; e^r is its
/// Taylor polynomial to degree 7 (the first term left out, r^8 / 8!, is under 6e-9, a
/// tenth of an f32 ulp), and 2^n is built from its exponent bits.
#[inline(always)]
pub(crate) fn exp_lane(x: f32) -> f32 {
    const LOG2_E: f32 = std::f32::consts::LOG2_E;
    // ln 2 in two parts: the first has few enough bits that n * LN2_HI is exact.
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    // 1.5 * 2^23: adding it rounds to the nearest integer, in the low mantissa bits.
    const ROUND: f32 = 12_582_912.0;
    let clamped = if x < -87.0 { -87.0 } else { x };
    let shifted = clamped * LOG2_E + ROUND;
    let n = shifted - ROUND;
    let n_bits = shifted.to_bits().wrapping_sub(ROUND.to_bits()) as i32;
    let r = n.mul_add(-LN2_LO, n.mul_add(-LN2_HI, clamped));
    let mut p: f32 = 1.0 / 5040.0;
    for c in [
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        1.0 / 2.0,
        1.0,
        1.0,
    ] {
        p = p.mul_add(r, c);
    }
    let scale = f32::from_bits((n_bits.wrapping_add(127) as u32) << 23);
    if x < -87.0 { 0.0 } else { p * scale }
}

/// The largest element of a row (NaN elements are passed over: they make the row NaN
/// through x - max).
#[inline(always)]
fn row_max(row: &[f32]) -> f32 {
    let mut lanes = [f32::NEG_INFINITY; LANES];
    let chunks = row.chunks_exact(LANES);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (m, &v) in lanes.iter_mut().zip(chunk) {
            *m = m.max(v);
        }
    }
    for (m, &v) in lanes.iter_mut().zip(rest) {
        *m = m.max(v);
    }
    lanes.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b))
}

/// The sum of 16 lanes in a fixed order (pairs 8 apart, then 4, 2, 1).
#[inline(always)]
fn reduce(mut lanes: [f32; LANES]) -> f32 {
    let mut width = LANES / 2;
    while width > 0 {
        for i in 0..width {
            lanes[i] += lanes[i + width];
        }
        width /= 2;
    }
    lanes[0]
}

/// One row: x -> e^(x - max) / sum.
#[inline(always)]
fn softmax_row(row: &mut [f32]) {
    let max = row_max(row);
    let mut lanes = [0.0f32; LANES];
    let mut chunks = row.chunks_exact_mut(LANES);
    for chunk in &mut chunks {
        for (s, v) in lanes.iter_mut().zip(chunk) {
            *v = exp_lane(*v - max);
            *s += *v;
        }
    }
    for (s, v) in lanes.iter_mut().zip(chunks.into_remainder()) {
        *v = exp_lane(*v - max);
        *s += *v;
    }
    let inverse = 1.0 / reduce(lanes);
    for v in row.iter_mut() {
        *v *= inverse;
    }
}

/// One row of the softmax's backward pass: dy -> (dy - sum(dy * y)) * y.
#[inline(always)]
fn backward_row(grad: &mut [f32], probs: &[f32]) {
    let mut lanes = [0.0f32; LANES];
    let (g_chunks, p_chunks) = (grad.chunks_exact(LANES), probs.chunks_exact(LANES));
    let (g_rest, p_rest) = (g_chunks.remainder(), p_chunks.remainder());
    for (g, p) in g_chunks.zip(p_chunks) {
        for ((s, &g), &p) in lanes.iter_mut().zip(g).zip(p) {
            *s = g.mul_add(p, *s);
        }
    }
    for ((s, &g), &p) in lanes.iter_mut().zip(g_rest).zip(p_rest) {
        *s = g.mul_add(p, *s);
    }
    let dot = reduce(lanes);
    for (g, &p) in grad.iter_mut().zip(probs) {
        *g = (*g - dot) * p;
    }
}

/// Softmax of every row of `data` (rows of `row_len`), in place.
pub(crate) fn softmax_rows(data: &mut [f32], row_len: usize) {
    if row_len == 0 {
        return;
    }
    data.par_chunks_mut(ROWS_PER_TASK * row_len)
        .for_each(|rows| softmax_task(rows, row_len));
}

fn softmax_task(rows: &mut [f32], row_len: usize) {
    dispatch!(baseline, (rows: &mut [f32], row_len: usize), {
        for row in rows.chunks_mut(row_len) {
            softmax_row(row);
        }
    })
}

/// The softmax's backward pass over every row: `grad` (the output's gradient) becomes
/// the input's, given the softmax's output `probs` (same rows of `row_len`).
pub(crate) fn softmax_backward_rows(grad: &mut [f32], probs: &[f32], row_len: usize) {
    assert_eq!(grad.len(), probs.len(), "softmax backward: sizes differ");
    if row_len == 0 {
        return;
    }
    let chunk = ROWS_PER_TASK * row_len;
    grad.par_chunks_mut(chunk)
        .zip(probs.par_chunks(chunk))
        .for_each(|(g, p)| backward_task(g, p, row_len));
}

fn backward_task(grad: &mut [f32], probs: &[f32], row_len: usize) {
    dispatch!(
        baseline,
        (grad: &mut [f32], probs: &[f32], row_len: usize),
        {
            for (g, p) in grad.chunks_mut(row_len).zip(probs.chunks(row_len)) {
                backward_row(g, p);
            }
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{bits, on_threads, pseudo};

    /// Ulps between two finite f32 of the same sign.
    fn ulps(a: f32, b: f32) -> u32 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn exp_is_within_two_ulp_of_the_exact_value() {
        let mut worst = (0, 0.0f32);
        let mut x = -87.0f32;
        while x <= 88.0 {
            let exact = (x as f64).exp() as f32;
            let u = ulps(exp_lane(x), exact);
            if u > worst.0 {
                worst = (u, x);
            }
            x += 0.000_37;
        }
        assert!(worst.0 <= 2, "{} ulp at x = {}", worst.0, worst.1);
        assert_eq!(exp_lane(0.0), 1.0);
        assert_eq!(exp_lane(-87.5), 0.0);
        assert_eq!(exp_lane(f32::NEG_INFINITY), 0.0);
        assert!(exp_lane(f32::NAN).is_nan());
    }

    /// Against the softmax computed in f64: within a few ulp of every probability (beyond
    /// the rounding of x - max),
    /// rows of every length around the lane count, large and small scores.
    #[test]
    fn softmax_matches_f64() {
        for row_len in [1, 3, 15, 16, 17, 70, 1024] {
            let rows = 5;
            let x: Vec<f32> = pseudo(rows * row_len, row_len as u32)
                .iter()
                .map(|v| 30.0 * v)
                .collect();
            let mut y = x.clone();
            softmax_rows(&mut y, row_len);
            for (xr, yr) in x.chunks(row_len).zip(y.chunks(row_len)) {
                let max = xr.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b as f64));
                let sum: f64 = xr.iter().map(|&v| (v as f64 - max).exp()).sum();
                for (&xv, &yv) in xr.iter().zip(yr) {
                    let exact = (xv as f64 - max).exp() / sum;
                    // Rounding x - max to f32 is an absolute error of up to half an ulp
                    // of it, a relative one of the exponential: every f32 softmax has it.
                    let argument = 0.6e-7 * (xv as f64 - max).abs();
                    assert!(
                        (yv as f64 - exact).abs() <= (4e-7 + argument) * exact + 1e-30,
                        "{yv} vs {exact} (row length {row_len})"
                    );
                }
            }
        }
    }

    #[test]
    fn softmax_backward_matches_f64() {
        let row_len = 45;
        let x = pseudo(3 * row_len, 5);
        let mut y = x.clone();
        softmax_rows(&mut y, row_len);
        let dy = pseudo(3 * row_len, 6);
        let mut dx = dy.clone();
        softmax_backward_rows(&mut dx, &y, row_len);
        for ((g, p), d) in dy
            .chunks(row_len)
            .zip(y.chunks(row_len))
            .zip(dx.chunks(row_len))
        {
            let dot: f64 = g.iter().zip(p).map(|(&a, &b)| a as f64 * b as f64).sum();
            for ((&g, &p), &d) in g.iter().zip(p).zip(d) {
                let exact = (g as f64 - dot) * p as f64;
                assert!((d as f64 - exact).abs() <= 1e-6 * (1.0 + exact.abs()));
            }
        }
    }

    /// The same bits for any number of threads and on every code path of this CPU.
    #[test]
    fn results_do_not_depend_on_threads_or_code_path() {
        let row_len = 150;
        let x: Vec<f32> = pseudo(200 * row_len, 9).iter().map(|v| 10.0 * v).collect();
        let run = |threads: usize| {
            on_threads(threads, || {
                let mut y = x.clone();
                softmax_rows(&mut y, row_len);
                let mut g = x.clone();
                softmax_backward_rows(&mut g, &y, row_len);
                (bits(&y), bits(&g))
            })
        };
        let one = run(1);
        assert_eq!(run(2), one);
        assert_eq!(run(3), one);
        // The baseline code path (no AVX): the same rows one by one.
        let mut y = x.clone();
        for row in y.chunks_mut(row_len) {
            softmax_row(row);
        }
        assert_eq!(bits(&y), one.0);
        let mut g = x.clone();
        for (g, p) in g.chunks_mut(row_len).zip(y.chunks(row_len)) {
            backward_row(g, p);
        }
        assert_eq!(bits(&g), one.1);
    }

    #[test]
    fn nan_scores_make_their_row_nan_only() {
        let mut x = vec![0.5f32, f32::NAN, 1.0, 2.0, 3.0, 4.0];
        softmax_rows(&mut x, 3);
        assert!(x[..3].iter().all(|v| v.is_nan()));
        assert!(x[3..].iter().all(|v| v.is_finite()));
    }
}
