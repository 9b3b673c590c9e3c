//! P3P in the manner of Lambda Twist (Persson & Nordberg, ECCV 2018): the depths
//! `L = (l1, l2, l3)` of the three points along their unit bearings `y_i` satisfy
//!
//! `|l_i y_i - l_j y_j|^2 = a_ij`  (`a_ij` the squared world distances),
//!
//! three quadrics `L^T M_ij L = a_ij`. Two homogeneous combinations
//! `D1 = a23 M12 - a12 M23`, `D2 = a23 M13 - a13 M23` vanish on every solution, so the
//! solution rays are the intersection of two conics. A degenerate member
//! `D0 = D1 + g D2` of their pencil (a root of the cubic `det(D1 + g D2) = 0`) factors
//! into a pair of planes through the origin; on each plane one conic gives two rays,
//! their length comes from the inhomogeneous equations, and Gauss-Newton on the three
//! original equations polishes the depths. The pose follows from the three
//! camera-frame points by one 3x3 solve.

use crate::poly::{Roots, real_roots};
use crate::rigid::{Rigid, Solutions, orthogonal_unit};
use nalgebra::{Matrix3, Vector3};

/// Cofactor matrix of a symmetric 3x3 matrix (equal to its adjugate).
fn adjugate_sym(m: &Matrix3<f64>) -> Matrix3<f64> {
    let c00 = m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)];
    let c01 = m[(1, 2)] * m[(2, 0)] - m[(1, 0)] * m[(2, 2)];
    let c02 = m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)];
    let c11 = m[(0, 0)] * m[(2, 2)] - m[(0, 2)] * m[(2, 0)];
    let c12 = m[(0, 1)] * m[(2, 0)] - m[(0, 0)] * m[(2, 1)];
    let c22 = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    Matrix3::new(c00, c01, c02, c01, c11, c12, c02, c12, c22)
}

/// `tr(A B)` for symmetric matrices.
fn trace_product(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    a.component_mul(b).sum()
}

/// Sum of the principal 2x2 minors (the product of the two non-zero eigenvalues of a
/// rank-2 symmetric matrix).
fn principal_minors(d: &Matrix3<f64>) -> f64 {
    d[(0, 0)] * d[(1, 1)] - d[(0, 1)] * d[(0, 1)] + d[(0, 0)] * d[(2, 2)] - d[(0, 2)] * d[(0, 2)]
        + d[(1, 1)] * d[(2, 2)]
        - d[(1, 2)] * d[(1, 2)]
}

/// Unit eigenvector of the symmetric `d` for the simple eigenvalue `sigma`.
fn eigenvector(d: &Matrix3<f64>, sigma: f64) -> Option<Vector3<f64>> {
    let m = d - Matrix3::identity() * sigma;
    let (r0, r1, r2) = (
        m.row(0).transpose(),
        m.row(1).transpose(),
        m.row(2).transpose(),
    );
    let cands = [r0.cross(&r1), r0.cross(&r2), r1.cross(&r2)];
    let best = cands
        .iter()
        .max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))?;
    let n = best.norm();
    (n > 0.0 && n.is_finite()).then(|| best / n)
}

struct Problem {
    y: [Vector3<f64>; 3],
    c12: f64,
    c13: f64,
    c23: f64,
    a12: f64,
    a13: f64,
    a23: f64,
}

impl Problem {
    fn residuals(&self, l: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            l.x * l.x + l.y * l.y - 2.0 * self.c12 * l.x * l.y - self.a12,
            l.x * l.x + l.z * l.z - 2.0 * self.c13 * l.x * l.z - self.a13,
            l.y * l.y + l.z * l.z - 2.0 * self.c23 * l.y * l.z - self.a23,
        )
    }

    /// Newton's method on the three distance equations. Near a double solution (nearly
    /// collinear points) it converges only linearly, hence the generous cap; it stops
    /// as soon as the residual no longer decreases.
    fn polish(&self, l: &mut Vector3<f64>) {
        let tol = 1e-15 * self.a12.max(self.a13).max(self.a23);
        let mut r = self.residuals(l);
        for _ in 0..50 {
            if r.amax() <= tol {
                break;
            }
            let j = Matrix3::new(
                2.0 * (l.x - self.c12 * l.y),
                2.0 * (l.y - self.c12 * l.x),
                0.0,
                2.0 * (l.x - self.c13 * l.z),
                0.0,
                2.0 * (l.z - self.c13 * l.x),
                0.0,
                2.0 * (l.y - self.c23 * l.z),
                2.0 * (l.z - self.c23 * l.y),
            );
            let Some(ji) = j.try_inverse() else { break };
            let step = ji * r;
            // Halve the step while it does not reduce the residual.
            let mut improved = false;
            let mut k = 1.0;
            for _ in 0..8 {
                let next = *l - step * k;
                let rn = self.residuals(&next);
                if rn.amax() < r.amax() {
                    *l = next;
                    r = rn;
                    improved = true;
                    break;
                }
                k *= 0.5;
            }
            if !improved {
                break;
            }
        }
    }

    /// Sum of the three left-hand sides for a depth direction (for the scale).
    fn lhs_sum(&self, l: &Vector3<f64>) -> f64 {
        (self.y[0] * l.x - self.y[1] * l.y).norm_squared()
            + (self.y[0] * l.x - self.y[2] * l.z).norm_squared()
            + (self.y[1] * l.y - self.y[2] * l.z).norm_squared()
    }
}

/// Every real pose (up to 4) that maps the three world points onto the three rays
/// `x` (any scale, in front of the camera). Writes into `out` (cleared first).
pub(crate) fn p3p_into(x: &[Vector3<f64>; 3], world: &[Vector3<f64>; 3], out: &mut Solutions) {
    out.clear();
    let y = [x[0].normalize(), x[1].normalize(), x[2].normalize()];
    let d12 = world[0] - world[1];
    let d13 = world[0] - world[2];
    let d23 = world[1] - world[2];
    let n = d12.cross(&d13);
    let xmat = Matrix3::from_columns(&[d12, d13, n]);
    let Some(xinv) = xmat.try_inverse() else {
        return;
    };
    let pb = Problem {
        y,
        c12: y[0].dot(&y[1]),
        c13: y[0].dot(&y[2]),
        c23: y[1].dot(&y[2]),
        a12: d12.norm_squared(),
        a13: d13.norm_squared(),
        a23: d23.norm_squared(),
    };
    if !(pb.a12 > 0.0 && pb.a13 > 0.0 && pb.a23 > 0.0) {
        return;
    }
    let m12 = Matrix3::new(1.0, -pb.c12, 0.0, -pb.c12, 1.0, 0.0, 0.0, 0.0, 0.0);
    let m13 = Matrix3::new(1.0, 0.0, -pb.c13, 0.0, 0.0, 0.0, -pb.c13, 0.0, 1.0);
    let m23 = Matrix3::new(0.0, 0.0, 0.0, 0.0, 1.0, -pb.c23, 0.0, -pb.c23, 1.0);
    // Scaled by 1/a23 (the pencil is unchanged).
    let d1 = m12 - m23 * (pb.a12 / pb.a23);
    let d2 = m13 - m23 * (pb.a13 / pb.a23);
    // det(A + g B) = det A + g tr(adj(A) B) + g^2 tr(A adj(B)) + g^3 det B; take the
    // member with the larger determinant as B so that no root runs to infinity.
    let (a, b) = if d2.determinant().abs() >= d1.determinant().abs() {
        (d1, d2)
    } else {
        (d2, d1)
    };
    let cubic = [
        a.determinant(),
        trace_product(&adjugate_sym(&a), &b),
        trace_product(&a, &adjugate_sym(&b)),
        b.determinant(),
    ];
    let mut roots = Roots::new();
    real_roots(&cubic, &mut roots);
    // Among the degenerate members, the one that splits most clearly into two real
    // planes: non-zero eigenvalues of opposite signs, as balanced as possible.
    let mut best: Option<(f64, Matrix3<f64>)> = None;
    for &g in roots.as_slice() {
        let d0 = a + b * g;
        let tr = d0.trace();
        let m2 = principal_minors(&d0);
        if m2 >= 0.0 {
            continue;
        }
        let score = -m2 / (tr * tr - 2.0 * m2);
        if best.is_none_or(|(s, _)| score > s) {
            best = Some((score, d0));
        }
    }
    let Some((_, d0)) = best else { return };
    let tr = d0.trace();
    let m2 = principal_minors(&d0);
    let sp = 0.5 * (tr + (tr * tr - 4.0 * m2).sqrt());
    let sm = m2 / sp;
    let (Some(ep), Some(em)) = (eigenvector(&d0, sp), eigenvector(&d0, sm)) else {
        return;
    };
    // sigma+ (ep.L)^2 + sigma- (em.L)^2 = 0  <=>  L on one of these planes.
    let (wp, wm) = (sp.sqrt(), (-sm).sqrt());
    let a_sum = pb.a12 + pb.a13 + pb.a23;
    for plane in [ep * wp + em * wm, ep * wp - em * wm] {
        let nrm = plane.norm();
        if !(nrm > 0.0) {
            continue;
        }
        let nu = plane / nrm;
        let u = orthogonal_unit(&nu);
        let v = nu.cross(&u);
        // Restrict the better-conditioned of D1, D2 to the plane (on the plane they are
        // proportional).
        let q = |m: &Matrix3<f64>| (u.dot(&(m * u)), u.dot(&(m * v)), v.dot(&(m * v)));
        let (qa, qb) = (q(&d1), q(&d2));
        let size = |q: &(f64, f64, f64)| q.0 * q.0 + 2.0 * q.1 * q.1 + q.2 * q.2;
        let (q11, q12, q22) = if size(&qa) >= size(&qb) { qa } else { qb };
        let mut disc = q12 * q12 - q11 * q22;
        if disc < 0.0 {
            if disc > -1e-12 * (q12 * q12 + (q11 * q22).abs()) {
                disc = 0.0;
            } else {
                continue;
            }
        }
        // Null directions (alpha, beta) of q11 a^2 + 2 q12 a b + q22 b^2, division-free.
        let s = -(q12 + q12.signum() * disc.sqrt());
        for (al, be) in [(s, q11), (q22, s)] {
            let dir = u * al + v * be;
            let f = pb.lhs_sum(&dir);
            if !(f > 0.0) {
                continue;
            }
            let mut l = dir * (a_sum / f).sqrt();
            if l.x < 0.0 && l.y < 0.0 && l.z < 0.0 {
                l = -l;
            }
            pb.polish(&mut l);
            if !(l.x > 0.0 && l.y > 0.0 && l.z > 0.0) {
                continue;
            }
            let p1 = y[0] * l.x;
            let y1 = p1 - y[1] * l.y;
            let y2 = p1 - y[2] * l.z;
            let ymat = Matrix3::from_columns(&[y1, y2, y1.cross(&y2)]);
            let r = ymat * xinv;
            out.push(Rigid {
                r,
                t: p1 - r * world[0],
            });
        }
    }
}
