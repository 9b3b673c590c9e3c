//! Levenberg-Marquardt refinement of a pose on point and line correspondences jointly,
//! with a robust loss per correspondence, on the normalised image plane.
//!
//! Residuals: a point gives its 2D reprojection error; a line gives the signed
//! distances of its two detected endpoints to the projected world line. The loss acts
//! on the squared norm `s` of each correspondence's residual (iteratively reweighted
//! Gauss-Newton with Marquardt damping). The pose is updated in the camera frame
//! (`X_cam <- exp([w]x) X_cam + v`), which keeps the normal equations well conditioned
//! whatever the world origin.

use crate::normalized::{NLine, NPoint};
use crate::rigid::Rigid;
use nalgebra::{Matrix6, Vector3, Vector6};

/// Stand-in squared residual for a point behind the camera or a degenerate line: it
/// costs the loss's plateau (or nearly so) and carries no gradient.
const UNUSABLE: f64 = 1e12;

/// A robust loss `rho(s)` of a squared residual norm `s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Loss {
    /// `min(s, cap)`: the MSAC cost, for local optimisation inside RANSAC.
    Truncated { cap: f64 },
    /// `c^2 log(1 + s / c^2)` with `scale_sq = c^2`.
    Cauchy { scale_sq: f64 },
}

impl Loss {
    #[inline]
    fn rho(&self, s: f64) -> f64 {
        match *self {
            Loss::Truncated { cap } => s.min(cap),
            Loss::Cauchy { scale_sq } => scale_sq * (s / scale_sq).ln_1p(),
        }
    }

    /// `rho'(s)`: the weight of the residual in the normal equations.
    #[inline]
    fn weight(&self, s: f64) -> f64 {
        match *self {
            Loss::Truncated { cap } => {
                if s < cap {
                    1.0
                } else {
                    0.0
                }
            }
            Loss::Cauchy { scale_sq } => 1.0 / (1.0 + s / scale_sq),
        }
    }
}

/// Losses and iteration cap of one refinement.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Refinement {
    pub point_loss: Loss,
    pub line_loss: Loss,
    pub max_iterations: usize,
}

/// Point residual and its Jacobian rows (w.r.t. `(w, v)`); None behind the camera.
#[inline]
pub(crate) fn point_residual(m: &Rigid, p: &NPoint) -> Option<([f64; 2], [Vector6<f64>; 2])> {
    let c = m.r * p.world + m.t;
    if !(c.z > 0.0) {
        return None;
    }
    let iz = 1.0 / c.z;
    let (u, v) = (c.x * iz, c.y * iz);
    let r = [u - p.x.x, v - p.x.y];
    // d(u, v)/dc rows; dc = w x c + v, so d r / d w = c x row.
    let a = Vector3::new(iz, 0.0, -u * iz);
    let b = Vector3::new(0.0, iz, -v * iz);
    let ja = c.cross(&a);
    let jb = c.cross(&b);
    Some((
        r,
        [
            Vector6::new(ja.x, ja.y, ja.z, a.x, a.y, a.z),
            Vector6::new(jb.x, jb.y, jb.z, b.x, b.y, b.z),
        ],
    ))
}

/// Line residuals (signed endpoint distances) and Jacobian rows; None when the
/// projected line is degenerate.
#[inline]
pub(crate) fn line_residual(m: &Rigid, l: &NLine) -> Option<([f64; 2], [Vector6<f64>; 2])> {
    let p1 = m.r * l.a + m.t;
    let p2 = m.r * l.b + m.t;
    let n = p1.cross(&p2);
    let rho = (n.x * n.x + n.y * n.y).sqrt();
    if !(rho > 0.0 && rho.is_finite()) {
        return None;
    }
    let nn = n / rho;
    let r = [nn.dot(&l.x1), nn.dot(&l.x2)];
    // dn = w x n + v x (p2 - p1); d(nn)/dn = (I - nn m^T) / rho with m = (nn.x, nn.y, 0).
    let m3 = Vector3::new(nn.x, nn.y, 0.0);
    let d = p1 - p2;
    let row = |x: &Vector3<f64>, rk: f64| {
        let g = (x - m3 * rk) / rho;
        let jw = n.cross(&g);
        let jv = g.cross(&d);
        Vector6::new(jw.x, jw.y, jw.z, jv.x, jv.y, jv.z)
    };
    Some((r, [row(&l.x1, r[0]), row(&l.x2, r[1])]))
}

/// Robust cost, gradient and Gauss-Newton matrix at `m`.
fn linearize(
    m: &Rigid,
    points: &[NPoint],
    lines: &[NLine],
    opt: &Refinement,
    h: &mut Matrix6<f64>,
    g: &mut Vector6<f64>,
) -> f64 {
    h.fill(0.0);
    g.fill(0.0);
    let mut cost = 0.0;
    let mut add = |loss: &Loss, res: Option<([f64; 2], [Vector6<f64>; 2])>| match res {
        None => cost += loss.rho(UNUSABLE),
        Some((r, j)) => {
            let s = r[0] * r[0] + r[1] * r[1];
            cost += loss.rho(s);
            let w = loss.weight(s);
            if w > 0.0 {
                for k in 0..2 {
                    h.ger(w, &j[k], &j[k], 1.0);
                    g.axpy(w * r[k], &j[k], 1.0);
                }
            }
        }
    };
    for p in points {
        add(&opt.point_loss, point_residual(m, p));
    }
    for l in lines {
        add(&opt.line_loss, line_residual(m, l));
    }
    cost
}

/// Robust cost at `m`.
#[cfg(test)]
fn cost(m: &Rigid, points: &[NPoint], lines: &[NLine], opt: &Refinement) -> f64 {
    let mut c = 0.0;
    for p in points {
        c += opt
            .point_loss
            .rho(point_residual(m, p).map_or(UNUSABLE, |(r, _)| r[0] * r[0] + r[1] * r[1]));
    }
    for l in lines {
        c += opt
            .line_loss
            .rho(line_residual(m, l).map_or(UNUSABLE, |(r, _)| r[0] * r[0] + r[1] * r[1]));
    }
    c
}

/// Refines `start`; returns the refined pose and the number of LM iterations (each
/// tried step counts). The result never has a higher cost than `start`.
pub(crate) fn refine(
    start: &Rigid,
    points: &[NPoint],
    lines: &[NLine],
    opt: &Refinement,
) -> (Rigid, usize) {
    let mut cur = *start;
    let (mut h, mut g) = (Matrix6::zeros(), Vector6::zeros());
    let mut cur_cost = linearize(&cur, points, lines, opt, &mut h, &mut g);
    let (mut h_new, mut g_new) = (Matrix6::zeros(), Vector6::zeros());
    let mut lambda = 1e-3;
    let mut iterations = 0;
    while iterations < opt.max_iterations {
        if g.amax() < 1e-16 {
            break;
        }
        iterations += 1;
        let mut damped = h;
        for i in 0..6 {
            damped[(i, i)] += lambda * h[(i, i)].max(1e-12);
        }
        let Some(chol) = damped.cholesky() else {
            lambda *= 10.0;
            if lambda > 1e10 {
                break;
            }
            continue;
        };
        let step = chol.solve(&(-g));
        let cand = cur.perturbed(
            &Vector3::new(step[0], step[1], step[2]),
            &Vector3::new(step[3], step[4], step[5]),
        );
        let cand_cost = linearize(&cand, points, lines, opt, &mut h_new, &mut g_new);
        if cand_cost < cur_cost {
            let gain = cur_cost - cand_cost;
            cur = cand;
            std::mem::swap(&mut h, &mut h_new);
            std::mem::swap(&mut g, &mut g_new);
            let before = cur_cost;
            cur_cost = cand_cost;
            lambda = (lambda * 0.1).max(1e-10);
            if gain <= 1e-12 * before || step.norm() < 1e-12 {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e10 {
                break;
            }
        }
    }
    (cur, iterations)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector2};

    fn model() -> Rigid {
        Rigid {
            r: Rotation3::from_euler_angles(0.2, -0.4, 1.1).into_inner(),
            t: Vector3::new(0.3, -0.2, 4.0),
        }
    }

    fn numeric(m: &Rigid, f: impl Fn(&Rigid) -> [f64; 2]) -> [Vector6<f64>; 2] {
        let mut j = [Vector6::zeros(); 2];
        let h = 1e-7;
        for k in 0..6 {
            let mut d = [0.0; 6];
            d[k] = h;
            let w = Vector3::new(d[0], d[1], d[2]);
            let v = Vector3::new(d[3], d[4], d[5]);
            let plus = f(&m.perturbed(&w, &v));
            let minus = f(&m.perturbed(&-w, &-v));
            for i in 0..2 {
                j[i][k] = (plus[i] - minus[i]) / (2.0 * h);
            }
        }
        j
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let m = model();
        let p = NPoint {
            x: Vector2::new(0.1, -0.05),
            world: Vector3::new(0.5, 1.0, -0.7),
        };
        let (_, j) = point_residual(&m, &p).unwrap();
        let jn = numeric(&m, |m| point_residual(m, &p).unwrap().0);
        for i in 0..2 {
            assert!((j[i] - jn[i]).amax() < 1e-6, "{} vs {}", j[i], jn[i]);
        }
        let l = NLine {
            x1: Vector3::new(0.1, 0.2, 1.0),
            x2: Vector3::new(-0.3, 0.25, 1.0),
            normal: Vector3::z(),
            a: Vector3::new(1.0, -0.5, 0.3),
            b: Vector3::new(-0.4, 0.9, 1.2),
            dir: Vector3::x(),
        };
        let (_, j) = line_residual(&m, &l).unwrap();
        let jn = numeric(&m, |m| line_residual(m, &l).unwrap().0);
        for i in 0..2 {
            assert!((j[i] - jn[i]).amax() < 1e-6, "{} vs {}", j[i], jn[i]);
        }
    }

    #[test]
    fn converges_from_a_perturbed_start() {
        let gt = model();
        let mut points = Vec::new();
        for i in 0..20 {
            let c = Vector3::new(
                (i % 5) as f64 * 0.3 - 0.6,
                (i / 5) as f64 * 0.3 - 0.5,
                3.0 + (i % 3) as f64,
            );
            let world = gt.r.transpose() * (c - gt.t);
            points.push(NPoint {
                x: Vector2::new(c.x / c.z, c.y / c.z),
                world,
            });
        }
        let start = gt.perturbed(
            &Vector3::new(0.02, -0.01, 0.015),
            &Vector3::new(0.05, 0.02, -0.1),
        );
        let opt = Refinement {
            point_loss: Loss::Cauchy { scale_sq: 1e-4 },
            line_loss: Loss::Cauchy { scale_sq: 1e-4 },
            max_iterations: 100,
        };
        let (r, _) = refine(&start, &points, &[], &opt);
        assert!((r.r - gt.r).amax() < 1e-10);
        assert!((r.t - gt.t).amax() < 1e-10);
        assert!(cost(&r, &points, &[], &opt) <= cost(&start, &points, &[], &opt));
    }
}
