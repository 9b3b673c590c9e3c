//! Minimal solvers mixing points and lines: P2P1LL, P1P2LL, P3LL.
//!
//! Notation: a point correspondence is a ray `x` (camera frame, any scale) and a world
//! point `X`: `R X + t = lambda x`, `lambda > 0`. A line correspondence is the normal `l`
//! of the plane through the camera centre and the 2D line, and a world line
//! `C + s V`: every point of the line lies on that plane, so
//!
//! `l^T R V = 0` and `l^T (R C + t) = 0`.
//!
//! Each solver eliminates `t` (and the depths) to get three constraints linear in the
//! entries of `R`, solves them with `rotation::rotations_from_constraints`, then
//! recovers `t` linearly and drops solutions with points behind the camera.

use super::rotation::rotations_from_constraints;
use crate::rigid::{Rigid, Solutions, orthogonal_unit};
use nalgebra::{Matrix3, Vector3};

/// P3LL: three line correspondences. The rotation comes from `l_i^T R V_i = 0`; then
/// `l_i^T t = -l_i^T R C_i` is a 3x3 linear system (singular when the three image lines
/// meet in one point).
pub(crate) fn p3ll_into(
    l: &[Vector3<f64>; 3],
    c: &[Vector3<f64>; 3],
    v: &[Vector3<f64>; 3],
    out: &mut Solutions,
) {
    out.clear();
    let lmat = Matrix3::from_rows(&[l[0].transpose(), l[1].transpose(), l[2].transpose()]);
    let Some(linv) = lmat.try_inverse() else {
        return;
    };
    // The frames are fixed by the line least parallel to the other two, so that two
    // parallel lines (common in man-made scenes) keep a generic parametrisation.
    let spread = |k: usize| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        v[k].cross(&v[i]).norm().min(v[k].cross(&v[j]).norm())
    };
    let k = (0..3)
        .max_by(|&a, &b| spread(a).total_cmp(&spread(b)))
        .unwrap_or(0);
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    let mut rots = [Matrix3::zeros(); 8];
    let n = rotations_from_constraints(
        &l[k],
        &v[k],
        &(l[i] * v[i].transpose()),
        &(l[j] * v[j].transpose()),
        &mut rots,
    );
    for r in &rots[..n] {
        let rhs = -Vector3::new(
            l[0].dot(&(r * c[0])),
            l[1].dot(&(r * c[1])),
            l[2].dot(&(r * c[2])),
        );
        out.push(Rigid {
            r: *r,
            t: linv * rhs,
        });
    }
}

/// P2P1LL: two point and one line correspondences. With the anchor point `a`:
/// `t = lambda x_a - R X_a`; the line's point constraint gives
/// `lambda = -l^T R (C - X_a) / (l^T x_a)`; the second point must then lie on its ray:
/// `w^T (R (X_b - X_a) + lambda x_a) = 0` for the two directions `w` orthogonal to
/// `x_b`. Multiplied by `l^T x_a`, both are linear in `R`. The anchor is the point
/// farther from the image line (`l^T x_a` away from 0).
pub(crate) fn p2p1ll_into(
    x: &[Vector3<f64>; 2],
    world: &[Vector3<f64>; 2],
    l: &Vector3<f64>,
    c: &Vector3<f64>,
    v: &Vector3<f64>,
    out: &mut Solutions,
) {
    out.clear();
    let xn = [x[0].normalize(), x[1].normalize()];
    let (ia, ib) = if l.dot(&xn[0]).abs() >= l.dot(&xn[1]).abs() {
        (0, 1)
    } else {
        (1, 0)
    };
    let (xa, xb) = (xn[ia], xn[ib]);
    let la = l.dot(&xa);
    if la == 0.0 {
        return;
    }
    let d_b = world[ib] - world[ia];
    let d_c = c - world[ia];
    let p = orthogonal_unit(&xb);
    let q = xb.cross(&p);
    let g = |w: &Vector3<f64>| w * d_b.transpose() * la - l * d_c.transpose() * w.dot(&xa);
    let mut rots = [Matrix3::zeros(); 8];
    let n = rotations_from_constraints(l, v, &g(&p), &g(&q), &mut rots);
    for r in &rots[..n] {
        let lambda = -l.dot(&(r * d_c)) / la;
        if !(lambda > 0.0) {
            continue;
        }
        let t = xa * lambda - r * world[ia];
        if (r * world[ib] + t).dot(&xb) <= 0.0 {
            continue;
        }
        out.push(Rigid { r: *r, t });
    }
}

/// P1P2LL: one point and two line correspondences. `t = lambda x - R X`; each line's
/// point constraint gives `lambda (l_i^T x) = -l_i^T R (C_i - X)`; eliminating lambda
/// between the two gives the third constraint linear in `R`:
/// `(l_2^T x) l_1^T R (C_1 - X) - (l_1^T x) l_2^T R (C_2 - X) = 0`.
pub(crate) fn p1p2ll_into(
    x: &Vector3<f64>,
    world: &Vector3<f64>,
    l: &[Vector3<f64>; 2],
    c: &[Vector3<f64>; 2],
    v: &[Vector3<f64>; 2],
    out: &mut Solutions,
) {
    out.clear();
    let xn = x.normalize();
    let (l0x, l1x) = (l[0].dot(&xn), l[1].dot(&xn));
    let d0 = c[0] - world;
    let d1 = c[1] - world;
    let g3 = l[0] * d0.transpose() * l1x - l[1] * d1.transpose() * l0x;
    let mut rots = [Matrix3::zeros(); 8];
    let n = rotations_from_constraints(&l[0], &v[0], &(l[1] * v[1].transpose()), &g3, &mut rots);
    // Depth from the line the point is farther from.
    let (lk, dk, lkx) = if l0x.abs() >= l1x.abs() {
        (l[0], d0, l0x)
    } else {
        (l[1], d1, l1x)
    };
    if lkx == 0.0 {
        return;
    }
    for r in &rots[..n] {
        let lambda = -lk.dot(&(r * dk)) / lkx;
        if !(lambda > 0.0) {
            continue;
        }
        out.push(Rigid {
            r: *r,
            t: xn * lambda - r * world,
        });
    }
}
