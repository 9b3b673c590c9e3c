//! Real roots of univariate polynomials up to degree 8, without allocation.
//!
//! Method (Sturm's theorem): the Sturm chain `p0 = p, p1 = p', p_{k+1} = -(p_{k-1} mod
//! p_k)` counts the distinct real roots in any interval by the change in the number of
//! sign changes along the chain. Bisection from Fujiwara's root bound isolates each root
//! in an interval of its own, where Newton's method safeguarded by bisection converges.
//! Roots closer than the chain can resolve (double roots to rounding) come out once.
/// Highest supported degree.
pub(crate) const MAX_DEGREE: usize = 8;

/// A small fixed-capacity list of roots, sorted ascending.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Roots {
    vals: [f64; MAX_DEGREE],
    len: usize,
}

impl Roots {
    pub(crate) fn new() -> Self {
        Roots {
            vals: [0.0; MAX_DEGREE],
            len: 0,
        }
    }

    pub(crate) fn as_slice(&self) -> &[f64] {
        &self.vals[..self.len]
    }

    fn clear(&mut self) {
        self.len = 0;
    }

    fn push(&mut self, x: f64) {
        if self.len < MAX_DEGREE {
            self.vals[self.len] = x;
            self.len += 1;
        }
    }
}

/// `p(x)` for coefficients in ascending order.
#[inline]
pub(crate) fn horner(p: &[f64], x: f64) -> f64 {
    let mut acc = 0.0;
    for &c in p.iter().rev() {
        acc = acc * x + c;
    }
    acc
}

/// Real roots of `a x^2 + b x + c` (numerically stable form), ascending.
pub(crate) fn quadratic_roots(a: f64, b: f64, c: f64, out: &mut Roots) {
    out.clear();
    if a == 0.0 {
        if b != 0.0 {
            out.push(-c / b);
        }
        return;
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        // A slightly negative discriminant from rounding is a double root.
        if disc > -4.0 * f64::EPSILON * (b * b + (4.0 * a * c).abs()) {
            out.push(-b / (2.0 * a));
        }
        return;
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        // b == 0 and c == 0.
        out.push(0.0);
        return;
    }
    let (r1, r2) = (q / a, c / q);
    if r1 <= r2 {
        out.push(r1);
        out.push(r2);
    } else {
        out.push(r2);
        out.push(r1);
    }
}

/// Real roots of the monic cubic `x^3 + a x^2 + b x + c`, ascending: Cardano's formula
/// for one real root, the trigonometric form for three, each polished by Newton.
fn cubic_roots(a: f64, b: f64, c: f64, out: &mut Roots) {
    out.clear();
    let shift = a / 3.0;
    // x = t - a/3: t^3 + p t + q = 0.
    let p = b - a * shift;
    let q = c - b * shift + 2.0 * shift * shift * shift;
    let half_q = 0.5 * q;
    let third_p = p / 3.0;
    let disc = half_q * half_q + third_p * third_p * third_p;
    let mut t = [0.0f64; 3];
    let n = if disc > 0.0 {
        // One real root; the sum of cube roots in a cancellation-free form.
        let u = (-half_q - half_q.signum() * disc.sqrt()).cbrt();
        t[0] = if u != 0.0 { u - third_p / u } else { 0.0 };
        1
    } else if third_p == 0.0 {
        t[0] = 0.0;
        1
    } else {
        let r = (-third_p).sqrt();
        let cos3 = (-half_q / (r * r * r)).clamp(-1.0, 1.0);
        let phi = cos3.acos() / 3.0;
        for (k, tk) in t.iter_mut().enumerate() {
            *tk = 2.0 * r * (phi - std::f64::consts::TAU * k as f64 / 3.0).cos();
        }
        3
    };
    let poly = [c, b, a, 1.0];
    let dpoly = [b, 2.0 * a, 3.0];
    for &tk in &t[..n] {
        let mut x = tk - shift;
        for _ in 0..3 {
            let f = horner(&poly, x);
            let d = horner(&dpoly, x);
            if f == 0.0 || d == 0.0 {
                break;
            }
            let next = x - f / d;
            if !next.is_finite() || (next - x).abs() <= 4.0 * f64::EPSILON * x.abs() {
                x = if next.is_finite() { next } else { x };
                break;
            }
            x = next;
        }
        out.push(x);
    }
    let len = out.len;
    out.vals[..len].sort_by(|x, y| x.total_cmp(y));
}

/// The root of a polynomial that is monotonic on `[lo, hi]` and changes sign there:
/// Newton's method, with a bisection step whenever Newton would leave the bracket or
/// does not at least halve the step (slow convergence far from the root).
fn bracketed_root(p: &[f64], dp: &[f64], mut lo: f64, mut hi: f64, f_lo: f64) -> f64 {
    let lo_negative = f_lo < 0.0;
    let mut x = 0.5 * (lo + hi);
    let mut step_before = hi - lo;
    let mut step = step_before;
    for _ in 0..200 {
        let f = horner(p, x);
        if f == 0.0 {
            return x;
        }
        if (f < 0.0) == lo_negative {
            lo = x;
        } else {
            hi = x;
        }
        let d = horner(dp, x);
        let newton = x - f / d;
        let slow = (2.0 * f).abs() > (step_before * d).abs();
        step_before = step;
        let next = if newton > lo && newton < hi && !slow {
            newton
        } else {
            0.5 * (lo + hi)
        };
        step = (next - x).abs();
        // Newton converges quadratically: after a step of 1e-11 (relative) the error is
        // far below rounding.
        if (step <= 1e-11 * next.abs() && next == newton)
            || step <= 2.0 * f64::EPSILON * next.abs()
            || hi - lo <= 2.0 * f64::EPSILON * hi.abs().max(lo.abs())
        {
            return next;
        }
        x = next;
    }
    x
}

/// A Sturm chain, each member scaled to unit max coefficient (signs are what matter).
struct Sturm {
    polys: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
    degs: [usize; MAX_DEGREE + 1],
    len: usize,
}

fn normalized(p: &mut [f64]) -> bool {
    let m = p.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if !(m > 0.0 && m.is_finite()) {
        return false;
    }
    p.iter_mut().for_each(|c| *c /= m);
    true
}

impl Sturm {
    fn new(p: &[f64], degree: usize) -> Sturm {
        let mut s = Sturm {
            polys: [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1],
            degs: [0; MAX_DEGREE + 1],
            len: 2,
        };
        s.polys[0][..=degree].copy_from_slice(&p[..=degree]);
        s.degs[0] = degree;
        for i in 0..degree {
            s.polys[1][i] = p[i + 1] * (i + 1) as f64;
        }
        s.degs[1] = degree - 1;
        normalized(&mut s.polys[1][..degree]);
        while s.degs[s.len - 1] > 0 {
            let (a, da) = (s.polys[s.len - 2], s.degs[s.len - 2]);
            let (b, db) = (s.polys[s.len - 1], s.degs[s.len - 1]);
            // r = a mod b (long division, highest terms first).
            let mut r = a;
            for i in (db..=da).rev() {
                let c = r[i] / b[db];
                for j in 0..=db {
                    r[i - db + j] -= c * b[j];
                }
            }
            // The remainder has degree < db; drop leading terms that are rounding noise.
            let mut dr = db - 1;
            let scale = r[..db].iter().fold(0.0f64, |m, c| m.max(c.abs()));
            if !(scale > 1e-13) {
                // p has a repeated factor: the chain ends at gcd(p, p').
                break;
            }
            while dr > 0 && r[dr].abs() <= 1e-13 * scale {
                dr -= 1;
            }
            let mut next = [0.0; MAX_DEGREE + 1];
            for i in 0..=dr {
                next[i] = -r[i];
            }
            normalized(&mut next[..=dr]);
            s.polys[s.len] = next;
            s.degs[s.len] = dr;
            s.len += 1;
        }
        s
    }

    /// Sign changes along the chain at `x` (zeros skipped).
    fn changes(&self, x: f64) -> usize {
        let mut count = 0;
        let mut last = 0.0f64;
        for k in 0..self.len {
            let v = horner(&self.polys[k][..=self.degs[k]], x);
            if v != 0.0 {
                if last != 0.0 && (v < 0.0) != (last < 0.0) {
                    count += 1;
                }
                last = v;
            }
        }
        count
    }
}

/// Real roots of the polynomial with ascending coefficients `coeffs` (degree at most
/// `MAX_DEGREE`), sorted ascending. Leading coefficients below `1e-14` of the largest
/// are dropped (their roots would lie beyond any useful range).
pub(crate) fn real_roots(coeffs: &[f64], out: &mut Roots) {
    out.clear();
    if !coeffs.iter().all(|c| c.is_finite()) {
        return;
    }
    let scale = coeffs.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if scale == 0.0 {
        return;
    }
    let mut n = coeffs.len().min(MAX_DEGREE + 1);
    while n > 1 && coeffs[n - 1].abs() <= 1e-14 * scale {
        n -= 1;
    }
    let degree = n - 1;
    if degree == 0 {
        return;
    }
    // Monic copy.
    let mut p = [0.0f64; MAX_DEGREE + 1];
    let lead = coeffs[degree];
    for i in 0..=degree {
        p[i] = coeffs[i] / lead;
    }
    match degree {
        1 => {
            out.push(-p[0]);
            return;
        }
        2 => {
            quadratic_roots(1.0, p[1], p[0], out);
            return;
        }
        3 => {
            cubic_roots(p[2], p[1], p[0], out);
            return;
        }
        _ => {}
    }
    // Fujiwara's bound on the root moduli, `2 max_k |a_(n-k)|^(1/k)` (monic; the last
    // term halved), rounded up to a power of two from the exponents alone (no powf).
    let mut bound_exp = i64::MIN;
    for k in 1..=degree {
        let c = p[degree - k].abs() * if k == degree { 0.5 } else { 1.0 };
        if c > 0.0 {
            // floor(log2 c) + 1 > log2 c for normal and subnormal values alike.
            let e = ((c.to_bits() >> 52) & 0x7ff) as i64 - 1022;
            bound_exp = bound_exp.max(e.div_euclid(k as i64) + 1);
        }
    }
    let bound = if bound_exp == i64::MIN {
        1.0
    } else {
        2.0 * 2f64.powi(bound_exp.clamp(-1000, 1000) as i32)
    };
    let mut dp = [0.0f64; MAX_DEGREE];
    for i in 0..degree {
        dp[i] = p[i + 1] * (i + 1) as f64;
    }
    let mut d2p = [0.0f64; MAX_DEGREE];
    for i in 0..degree - 1 {
        d2p[i] = dp[i + 1] * (i + 1) as f64;
    }
    let (p, dp) = (&p[..=degree], &dp[..degree]);
    let sturm = Sturm::new(p, degree);
    // Isolate by bisection: (a, b] holds `changes(a) - changes(b)` distinct roots.
    let mut stack = [(0.0f64, 0.0f64, 0usize, 0usize, 0u32); 64];
    stack[0] = (
        -bound,
        bound,
        sturm.changes(-bound),
        sturm.changes(bound),
        0,
    );
    let mut top = 1;
    while top > 0 {
        top -= 1;
        let (a, b, ca, cb, depth) = stack[top];
        let k = ca.saturating_sub(cb);
        if k == 0 {
            continue;
        }
        if k == 1 {
            let (fa, fb) = (horner(p, a), horner(p, b));
            let root = if fb == 0.0 {
                b
            } else if (fa < 0.0) != (fb < 0.0) && fa != 0.0 {
                bracketed_root(p, dp, a, b, fa)
            } else {
                // No sign change: a root of even multiplicity (to rounding), where p'
                // changes sign instead.
                let (ga, gb) = (horner(dp, a), horner(dp, b));
                if (ga < 0.0) != (gb < 0.0) && ga != 0.0 && gb != 0.0 {
                    bracketed_root(dp, &d2p[..degree - 1], a, b, ga)
                } else {
                    0.5 * (a + b)
                }
            };
            out.push(root);
            continue;
        }
        let m = 0.5 * (a + b);
        if depth >= 60 || !(m > a && m < b) || top + 2 > stack.len() {
            // Roots closer than the chain can separate: report one.
            out.push(m);
            continue;
        }
        let cm = sturm.changes(m);
        stack[top] = (m, b, cm, cb, depth + 1);
        stack[top + 1] = (a, m, ca, cm, depth + 1);
        top += 2;
    }
    let n = out.len;
    out.vals[..n].sort_by(|x, y| x.total_cmp(y));
}

/// Product of two polynomials (ascending coefficients) into `out` (cleared first).
pub(crate) fn mul_into(a: &[f64], b: &[f64], out: &mut [f64]) {
    for o in out.iter_mut() {
        *o = 0.0;
    }
    for (i, &ai) in a.iter().enumerate() {
        for (j, &bj) in b.iter().enumerate() {
            out[i + j] += ai * bj;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn from_roots(roots: &[f64], lead: f64) -> Vec<f64> {
        let mut p = vec![lead];
        for &r in roots {
            let mut q = vec![0.0; p.len() + 1];
            for (i, &c) in p.iter().enumerate() {
                q[i + 1] += c;
                q[i] -= r * c;
            }
            p = q;
        }
        p
    }

    #[test]
    fn quadratic_cases() {
        let mut r = Roots::new();
        quadratic_roots(1.0, -3.0, 2.0, &mut r);
        assert_eq!(r.as_slice(), &[1.0, 2.0]);
        quadratic_roots(1.0, 0.0, 1.0, &mut r);
        assert!(r.as_slice().is_empty());
        quadratic_roots(0.0, 2.0, -4.0, &mut r);
        assert_eq!(r.as_slice(), &[2.0]);
        // Cancellation-prone: roots 1e-8 and 1e8.
        quadratic_roots(1.0, -(1e8 + 1e-8), 1.0, &mut r);
        assert!((r.as_slice()[0] - 1e-8).abs() < 1e-22);
        assert!((r.as_slice()[1] - 1e8).abs() < 1e-6);
    }

    #[test]
    fn random_real_rooted_polynomials() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..2000 {
            let degree = 3 + trial % 6;
            let mut roots: Vec<f64> = (0..degree).map(|_| rng.random_range(-10.0..10.0)).collect();
            roots.sort_by(|a, b| a.total_cmp(b));
            // Skip clusters closer than the achievable accuracy.
            if roots.windows(2).any(|w| w[1] - w[0] < 1e-3) {
                continue;
            }
            let p = from_roots(&roots, rng.random_range(0.5..3.0));
            let mut found = Roots::new();
            real_roots(&p, &mut found);
            assert_eq!(
                found.as_slice().len(),
                degree,
                "degree {degree} roots {roots:?}"
            );
            for (a, b) in found.as_slice().iter().zip(&roots) {
                assert!((a - b).abs() < 1e-8 * (1.0 + b.abs()), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn complex_pairs_are_skipped_and_double_roots_kept() {
        // (x^2 + 1)(x - 2)(x + 3)(x^2 + 4x + 5)
        let mut p = vec![1.0];
        for f in [
            vec![1.0, 0.0, 1.0],
            vec![-2.0, 1.0],
            vec![3.0, 1.0],
            vec![5.0, 4.0, 1.0],
        ] {
            let mut q = vec![0.0; p.len() + f.len() - 1];
            mul_into(&p, &f, &mut q);
            p = q;
        }
        let mut r = Roots::new();
        real_roots(&p, &mut r);
        assert_eq!(r.as_slice().len(), 2);
        assert!((r.as_slice()[0] + 3.0).abs() < 1e-12);
        assert!((r.as_slice()[1] - 2.0).abs() < 1e-12);
        // (x - 1)^2 (x + 2): the double root is found.
        let p = from_roots(&[1.0, 1.0, -2.0], 1.0);
        real_roots(&p, &mut r);
        assert!(
            r.as_slice().iter().any(|x| (x - 1.0).abs() < 1e-6),
            "{:?}",
            r.as_slice()
        );
        assert!(r.as_slice().iter().any(|x| (x + 2.0).abs() < 1e-12));
    }

    #[test]
    fn degenerate_inputs() {
        let mut r = Roots::new();
        real_roots(&[], &mut r);
        assert!(r.as_slice().is_empty());
        real_roots(&[0.0, 0.0], &mut r);
        assert!(r.as_slice().is_empty());
        real_roots(&[f64::NAN, 1.0], &mut r);
        assert!(r.as_slice().is_empty());
        // Tiny leading coefficient is dropped: 1e-20 x^3 + x - 1.
        real_roots(&[-1.0, 1.0, 0.0, 1e-20], &mut r);
        assert_eq!(r.as_slice(), &[1.0]);
    }
}
