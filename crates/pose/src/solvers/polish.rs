//! Newton polishing of a minimal solution on its six scalar equations.
//!
//! Every minimal problem here is six equations `a_k^T (R X_k + t) = 0`: a point gives two
//! (`a` spanning the plane orthogonal to its ray), a line gives two (`a` the plane
//! normal, `X` two points of the 3D line). Solvers that pass through an intermediate
//! unknown (P3P's depths) inherit that unknown's conditioning; a few Newton steps on
//! the pose itself recover the accuracy the data allow (nearly collinear points, points
//! near an image line).

use crate::rigid::{Rigid, orthogonal_unit};
use nalgebra::{Matrix6, Rotation3, UnitQuaternion, Vector3, Vector6};

/// One scalar equation `a^T (R X + t) = 0`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Equation {
    pub a: Vector3<f64>,
    pub x: Vector3<f64>,
}

/// The two equations of a point seen along `ray`.
pub(crate) fn point_equations(ray: &Vector3<f64>, x: &Vector3<f64>) -> [Equation; 2] {
    let y = ray.normalize();
    let p = orthogonal_unit(&y);
    let q = y.cross(&p);
    [Equation { a: p, x: *x }, Equation { a: q, x: *x }]
}

/// The two equations of a line (plane normal `l`, point `c`, unit direction `v`).
pub(crate) fn line_equations(
    l: &Vector3<f64>,
    c: &Vector3<f64>,
    v: &Vector3<f64>,
) -> [Equation; 2] {
    [Equation { a: *l, x: *c }, Equation { a: *l, x: c + v }]
}

fn residuals(p: &Rigid, eqs: &[Equation; 6]) -> Vector6<f64> {
    Vector6::from_fn(|k, _| eqs[k].a.dot(&p.apply(&eqs[k].x)))
}

/// Refines `p` in place, stopping when a Newton step no longer reduces the residual.
pub(crate) fn polish(p: &mut Rigid, eqs: &[Equation; 6]) {
    // Start from the nearest rotation: solvers that build R from noisy intermediate
    // quantities can be slightly off orthonormality when ill-conditioned.
    let guess = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(p.r));
    let rot = Rotation3::from_matrix_eps(&p.r, 1e-15, 20, guess.to_rotation_matrix());
    // Always continue from the rotation, even when its residual is larger than the
    // matrix's: the matrix's off-orthonormal part would come back when it is turned
    // into a quaternion.
    let mut cur = Rigid {
        r: rot.into_inner(),
        t: p.t,
    };
    let mut r = residuals(&cur, eqs);
    for _ in 0..5 {
        let mut j = Matrix6::zeros();
        for (k, e) in eqs.iter().enumerate() {
            let pc = cur.apply(&e.x);
            let w = pc.cross(&e.a);
            j.fixed_view_mut::<1, 3>(k, 0).copy_from(&w.transpose());
            j.fixed_view_mut::<1, 3>(k, 3).copy_from(&e.a.transpose());
        }
        let Some(step) = j.lu().solve(&(-r)) else {
            break;
        };
        let next = cur.perturbed(
            &Vector3::new(step[0], step[1], step[2]),
            &Vector3::new(step[3], step[4], step[5]),
        );
        let rn = residuals(&next, eqs);
        if !(rn.norm() < r.norm()) {
            break;
        }
        cur = next;
        r = rn;
    }
    if cur.is_finite() {
        *p = cur;
    }
}
