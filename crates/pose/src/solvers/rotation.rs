//! Rotations satisfying three linear constraints `sum_jk G_jk R_jk = 0`, the first of
//! rank one (`a^T R b = 0`, the direction constraint of a line correspondence).
//!
//! Every mixed point/line minimal problem reduces to this (see `lines.rs`): each line
//! gives `l^T R V = 0` (the 3D direction lies in the plane back-projected from the 2D
//! line), and eliminating the translation and depths from the remaining equations
//! leaves constraints that are linear in the entries of `R`.
//!
//! Method. Rotate both frames so that `a = e_x` (camera side) and `b = e_z` (world
//! side). The rotations with `e_x^T R' e_z = 0` are exactly `R' = Rx(th) Rz(psi)`.
//! Each remaining constraint is then `A_i(th) cos psi + B_i(th) sin psi + C_i(th) = 0`
//! with `A_i, B_i, C_i` affine in `(cos th, sin th)`. Solving the two for
//! `(cos psi, sin psi)` by Cramer's rule and imposing `cos^2 + sin^2 = 1` gives
//!
//! `(B1 C2 - B2 C1)^2 + (C1 A2 - C2 A1)^2 = (A1 B2 - A2 B1)^2`,
//!
//! a trigonometric polynomial of degree 4 in `th`, i.e. an octic in `u = tan(phi/2)`
//! with `th = th0 + phi`. The offset `th0` puts `u = infinity` where the polynomial is
//! largest, so no solution sits at infinity. Up to 8 real solutions.
//!
//! Special case: a constraint that does not involve `psi` (a second line parallel in
//! 3D to the first: it only constrains where `R` sends `b`) makes the octic a perfect
//! square with double roots; it is solved directly instead (`th` from that constraint,
//! two values, then `psi` from the other, two each).

use crate::poly::{Roots, mul_into, real_roots};
use crate::rigid::orthogonal_unit;
use nalgebra::{Matrix3, Vector3};

/// (cos, sin) of 12 angles evenly spaced on the circle.
const ANGLES: [(f64, f64); 12] = {
    const H: f64 = 0.866_025_403_784_438_6; // sqrt(3) / 2
    [
        (1.0, 0.0),
        (H, 0.5),
        (0.5, H),
        (0.0, 1.0),
        (-0.5, H),
        (-H, 0.5),
        (-1.0, 0.0),
        (-H, -0.5),
        (-0.5, -H),
        (0.0, -1.0),
        (0.5, -H),
        (H, -0.5),
    ]
};

/// `alpha cos th + beta sin th + gamma`.
#[derive(Clone, Copy, Debug)]
struct Affine {
    alpha: f64,
    beta: f64,
    gamma: f64,
}

impl Affine {
    #[inline]
    fn at(&self, c: f64, s: f64) -> f64 {
        self.alpha * c + self.beta * s + self.gamma
    }

    /// The same function of `phi = th - th0`.
    fn shifted(&self, c0: f64, s0: f64) -> Affine {
        Affine {
            alpha: self.alpha * c0 + self.beta * s0,
            beta: -self.alpha * s0 + self.beta * c0,
            gamma: self.gamma,
        }
    }

    /// `(1 + u^2)` times the function of `phi` with `u = tan(phi / 2)`: a quadratic.
    fn quadratic(&self) -> [f64; 3] {
        [
            self.alpha + self.gamma,
            2.0 * self.beta,
            self.gamma - self.alpha,
        ]
    }
}

/// The coefficients `(A, B, C)` of one constraint after the change of frames.
fn forms(g: &Matrix3<f64>) -> [Affine; 3] {
    // sum G'_jk R'_jk with R' = [[cp, -sp, 0], [c sp, c cp, -s], [s sp, s cp, c]].
    [
        Affine {
            alpha: g[(1, 1)],
            beta: g[(2, 1)],
            gamma: g[(0, 0)],
        },
        Affine {
            alpha: g[(1, 0)],
            beta: g[(2, 0)],
            gamma: -g[(0, 1)],
        },
        Affine {
            alpha: g[(2, 2)],
            beta: -g[(1, 2)],
            gamma: 0.0,
        },
    ]
}

/// A rotation whose rows are `[first, p, first x p]`: it maps `first` to `e_x`.
fn frame_to_x(first: &Vector3<f64>) -> Matrix3<f64> {
    let p = orthogonal_unit(first);
    let q = first.cross(&p);
    Matrix3::from_rows(&[first.transpose(), p.transpose(), q.transpose()])
}

/// A rotation whose rows are `[p, last x p, last]`: it maps `last` to `e_z`.
fn frame_to_z(last: &Vector3<f64>) -> Matrix3<f64> {
    let p = orthogonal_unit(last);
    let q = last.cross(&p);
    Matrix3::from_rows(&[p.transpose(), q.transpose(), last.transpose()])
}

fn residual_poly(f1: &[Affine; 3], f2: &[Affine; 3], c: f64, s: f64) -> f64 {
    let (a1, b1, c1) = (f1[0].at(c, s), f1[1].at(c, s), f1[2].at(c, s));
    let (a2, b2, c2) = (f2[0].at(c, s), f2[1].at(c, s), f2[2].at(c, s));
    let p = b1 * c2 - b2 * c1;
    let q = c1 * a2 - c2 * a1;
    let d = a1 * b2 - a2 * b1;
    p * p + q * q - d * d
}

/// Unit vectors `(cos psi, sin psi)` with `a cos psi + b sin psi + c = 0` (0, 1 or 2).
fn circle_solutions(a: f64, b: f64, c: f64, out: &mut [(f64, f64); 2]) -> usize {
    let rho2 = a * a + b * b;
    if !(rho2 > 0.0) {
        return 0;
    }
    let h2 = rho2 - c * c;
    if h2 < -1e-12 * rho2 {
        return 0;
    }
    let h = h2.max(0.0).sqrt();
    out[0] = ((-c * a - b * h) / rho2, (-c * b + a * h) / rho2);
    out[1] = ((-c * a + b * h) / rho2, (-c * b - a * h) / rho2);
    if h == 0.0 { 1 } else { 2 }
}

/// Whether a constraint does not involve `psi` (its `A` and `B` vanish): it then
/// constrains only where `R` sends `b`, e.g. a second line parallel in 3D to the one
/// that fixed the frames.
fn is_psi_free(f: &[Affine; 3]) -> bool {
    let ab = [
        f[0].alpha, f[0].beta, f[0].gamma, f[1].alpha, f[1].beta, f[1].gamma,
    ];
    let size_ab = ab.iter().map(|v| v * v).sum::<f64>();
    let size_c = f[2].alpha * f[2].alpha + f[2].beta * f[2].beta;
    size_ab <= 1e-20 * size_c
}

/// `R = Rc^T Rx(th) Rz(psi) Rw`.
fn compose(
    rct: &Matrix3<f64>,
    rw: &Matrix3<f64>,
    c: f64,
    s: f64,
    cpsi: f64,
    spsi: f64,
) -> Matrix3<f64> {
    let rp = Matrix3::new(
        cpsi,
        -spsi,
        0.0,
        c * spsi,
        c * cpsi,
        -s,
        s * spsi,
        s * cpsi,
        c,
    );
    rct * rp * rw
}

/// The special case where one constraint (`free`) does not involve psi: it fixes th
/// (`C(th) = alpha cos th + beta sin th = 0`, two solutions), and the other gives psi.
fn solve_psi_free(
    free: &[Affine; 3],
    other: &[Affine; 3],
    rct: &Matrix3<f64>,
    rw: &Matrix3<f64>,
    out: &mut [Matrix3<f64>; 8],
) -> usize {
    let (al, be) = (free[2].alpha, free[2].beta);
    let h = al.hypot(be);
    if !(h > 0.0) {
        return 0;
    }
    let mut n = 0;
    for sign in [1.0, -1.0] {
        let (c, s) = (sign * be / h, -sign * al / h);
        let mut psis = [(0.0, 0.0); 2];
        let k = circle_solutions(
            other[0].at(c, s),
            other[1].at(c, s),
            other[2].at(c, s),
            &mut psis,
        );
        for &(cp, sp) in &psis[..k] {
            out[n] = compose(rct, rw, c, s, cp, sp);
            n += 1;
        }
    }
    n
}

/// Up to 8 rotations with `a^T R b = 0`, `<G2, R> = 0`, `<G3, R> = 0`, appended to
/// `out` (returns how many). `a`, `b` non-zero.
pub(crate) fn rotations_from_constraints(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    g2: &Matrix3<f64>,
    g3: &Matrix3<f64>,
    out: &mut [Matrix3<f64>; 8],
) -> usize {
    let (na, nb) = (a.norm(), b.norm());
    if !(na > 0.0 && nb > 0.0 && na.is_finite() && nb.is_finite()) {
        return 0;
    }
    let rc = frame_to_x(&(a / na));
    let rw = frame_to_z(&(b / nb));
    // <G, Rc^T R' Rw> = <Rc G Rw^T, R'>.
    let f1 = forms(&(rc * g2 * rw.transpose()));
    let f2 = forms(&(rc * g3 * rw.transpose()));
    let rct = rc.transpose();
    if is_psi_free(&f1) {
        return solve_psi_free(&f1, &f2, &rct, &rw, out);
    }
    if is_psi_free(&f2) {
        return solve_psi_free(&f2, &f1, &rct, &rw, out);
    }

    // Pick th0 + pi (u = infinity) where the trigonometric polynomial is largest.
    let mut best = 0;
    let mut best_val = -1.0;
    for (k, &(c, s)) in ANGLES.iter().enumerate() {
        let v = residual_poly(&f1, &f2, c, s).abs();
        if v > best_val {
            best_val = v;
            best = k;
        }
    }
    if !(best_val > 0.0 && best_val.is_finite()) {
        return 0;
    }
    // th0 = angle - pi.
    let (c0, s0) = (-ANGLES[best].0, -ANGLES[best].1);
    let q = |f: &Affine| f.shifted(c0, s0).quadratic();
    let (qa1, qb1, qc1) = (q(&f1[0]), q(&f1[1]), q(&f1[2]));
    let (qa2, qb2, qc2) = (q(&f2[0]), q(&f2[1]), q(&f2[2]));
    let quartic_det = |x1: &[f64; 3], y2: &[f64; 3], x2: &[f64; 3], y1: &[f64; 3]| {
        // x1 y2 - x2 y1
        let mut m1 = [0.0; 5];
        let mut m2 = [0.0; 5];
        mul_into(x1, y2, &mut m1);
        mul_into(x2, y1, &mut m2);
        let mut r = [0.0; 5];
        for i in 0..5 {
            r[i] = m1[i] - m2[i];
        }
        r
    };
    let pp = quartic_det(&qb1, &qc2, &qb2, &qc1);
    let qq = quartic_det(&qc1, &qa2, &qc2, &qa1);
    let dd = quartic_det(&qa1, &qb2, &qa2, &qb1);
    let mut octic = [0.0; 9];
    let mut tmp = [0.0; 9];
    mul_into(&pp, &pp, &mut tmp);
    octic.iter_mut().zip(&tmp).for_each(|(o, t)| *o += t);
    mul_into(&qq, &qq, &mut tmp);
    octic.iter_mut().zip(&tmp).for_each(|(o, t)| *o += t);
    mul_into(&dd, &dd, &mut tmp);
    octic.iter_mut().zip(&tmp).for_each(|(o, t)| *o -= t);

    let mut roots = Roots::new();
    real_roots(&octic, &mut roots);
    let mut n = 0;
    for &u in roots.as_slice() {
        let w = 1.0 / (1.0 + u * u);
        let (cp, sp) = ((1.0 - u * u) * w, 2.0 * u * w);
        let c = c0 * cp - s0 * sp;
        let s = s0 * cp + c0 * sp;
        let (a1, b1, c1) = (f1[0].at(c, s), f1[1].at(c, s), f1[2].at(c, s));
        let (a2, b2, c2) = (f2[0].at(c, s), f2[1].at(c, s), f2[2].at(c, s));
        let det = a1 * b2 - a2 * b1;
        let scale = (a1.abs() + b1.abs()) * (a2.abs() + b2.abs());
        let mut cands = [(0.0, 0.0); 2];
        let mut nc = 0;
        if det.abs() > 1e-10 * scale {
            let (x, y) = ((b1 * c2 - b2 * c1) / det, (c1 * a2 - c2 * a1) / det);
            let h = (x * x + y * y).sqrt();
            if h > 0.0 {
                cands[0] = (x / h, y / h);
                nc = 1;
            }
        } else if a1.hypot(b1) >= a2.hypot(b2) {
            // Parallel constraints in (cos psi, sin psi): intersect the better one with
            // the unit circle; the other holds up to rounding.
            nc = circle_solutions(a1, b1, c1, &mut cands);
        } else {
            nc = circle_solutions(a2, b2, c2, &mut cands);
        }
        for &(cpsi, spsi) in &cands[..nc] {
            if n >= out.len() {
                return n;
            }
            out[n] = compose(&rct, &rw, c, s, cpsi, spsi);
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
        Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize()
    }

    #[test]
    fn recovers_a_rotation_from_three_rank_one_constraints() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut found = 0;
        let trials = 500;
        for _ in 0..trials {
            let axis = Unit::new_normalize(unit(&mut rng));
            let r = Rotation3::from_axis_angle(&axis, rng.random_range(-3.1..3.1)).into_inner();
            // Constraints a_i^T R b_i = 0: pick b_i, then a_i orthogonal to R b_i.
            let mut ab = Vec::new();
            for _ in 0..3 {
                let b = unit(&mut rng);
                let rb = r * b;
                let a = rb.cross(&unit(&mut rng)).normalize();
                ab.push((a, b));
            }
            let g2 = ab[1].0 * ab[1].1.transpose();
            let g3 = ab[2].0 * ab[2].1.transpose();
            let mut out = [Matrix3::zeros(); 8];
            let n = rotations_from_constraints(&ab[0].0, &ab[0].1, &g2, &g3, &mut out);
            for sol in &out[..n] {
                // Every solution satisfies the constraints and is a rotation.
                assert!((sol.transpose() * sol - Matrix3::identity()).amax() < 1e-9);
                assert!((sol.determinant() - 1.0).abs() < 1e-9);
                for (a, b) in &ab {
                    assert!(a.dot(&(sol * b)).abs() < 1e-7, "{}", a.dot(&(sol * b)));
                }
            }
            if out[..n].iter().any(|s| (s - r).amax() < 1e-8) {
                found += 1;
            }
        }
        assert!(found >= trials * 998 / 1000, "found {found}/{trials}");
    }
}
