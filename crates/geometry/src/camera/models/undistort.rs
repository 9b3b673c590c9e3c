//! Inverting a distortion map `x -> D(x)` of the plane by Newton's method, the way
//! COLMAP lifts pixels of its polynomial models: start at the distorted point, limit
//! each step to a trust region, stop when the step is negligible, give up after a fixed
//! number of iterations.

use super::jet::Jet;

/// COLMAP allows 100 iterations. With an exact Jacobian Newton needs about 10 inside
/// the valid domain; running out means there is no preimage on the main branch (past
/// a fold), or the start is absurdly far out (1e9 px), where the trust region needs
/// more steps to come back.
const MAX_ITERATIONS: usize = 100;
/// Each step is at most `max(TRUST_RADIUS_REL * |x|, TRUST_RADIUS_ABS)` long, which
/// keeps the iteration on the branch through the origin instead of jumping across a
/// fold to a far root.
const TRUST_RADIUS_REL: f64 = 0.1;
const TRUST_RADIUS_ABS: f64 = 0.1;
/// Converged when `|D(x) - target|` is at rounding level...
const RESIDUAL_TOLERANCE: f64 = 1e-15;
/// ...or the Newton step is this small (relative): with quadratic convergence the
/// iterate is then at full precision even where rounding keeps the residual above the
/// first tolerance (large coefficients).
const STEP_TOLERANCE: f64 = 1e-12;
/// A point accepted through the step test must still reproduce the target to this
/// (relative) accuracy: about 1e-8 px at a focal length of 1000 px.
const ACCEPT_RESIDUAL: f64 = 1e-11;

/// Halvings of the starting point allowed; 2^-60 of any finite start is at the origin
/// to double precision, where every distortion is the identity to first order.
const MAX_START_HALVINGS: usize = 60;

/// The starting point: the target itself, as in COLMAP, unless the map folds over
/// there (`det J <= 0`, past the turning point of the lens polynomial). Newton started
/// past a fold converges to the root on the folded branch, a ray that does project to
/// the pixel but is not the one the camera sees there; so move the start towards the
/// origin until it is on the main branch.
fn start(target: (f64, f64), distort: &impl Fn(Jet, Jet) -> (Jet, Jet)) -> (f64, f64) {
    let (mut u, mut v) = target;
    for _ in 0..MAX_START_HALVINGS {
        let (du, dv) = distort(Jet::var(u, 0), Jet::var(v, 1));
        if du.d[0] * dv.d[1] - du.d[1] * dv.d[0] > 0.0 {
            break;
        }
        u *= 0.5;
        v *= 0.5;
    }
    (u, v)
}

/// Solves `distort(x) = target` for `x`, starting at `x = target` (see [`start`]).
/// `distort` returns the distorted point as jets (value and exact Jacobian).
///
/// Returns None when the iteration does not converge, leaves the finite numbers, or
/// converges to a point where the map reverses orientation (`det J <= 0`): such a point
/// lies beyond a fold of the distortion, where the model is not invertible.
pub(super) fn undistort(
    target: (f64, f64),
    distort: impl Fn(Jet, Jet) -> (Jet, Jet),
) -> Option<(f64, f64)> {
    let (tu, tv) = target;
    let scale = 1.0 + tu.hypot(tv);
    let (mut u, mut v) = start(target, &distort);
    for _ in 0..MAX_ITERATIONS {
        let (du, dv) = distort(Jet::var(u, 0), Jet::var(v, 1));
        let (ru, rv) = (du.value - tu, dv.value - tv);
        let det = du.d[0] * dv.d[1] - du.d[1] * dv.d[0];
        if !(ru.is_finite() && rv.is_finite() && det.is_finite()) {
            return None;
        }
        if ru.hypot(rv) <= RESIDUAL_TOLERANCE * scale {
            return (det > 0.0).then_some((u, v));
        }
        if det == 0.0 {
            return None;
        }
        // Newton step J^-1 r, by Cramer's rule.
        let mut su = (dv.d[1] * ru - du.d[1] * rv) / det;
        let mut sv = (du.d[0] * rv - dv.d[0] * ru) / det;
        let step = su.hypot(sv);
        let radius = (TRUST_RADIUS_REL * u.hypot(v)).max(TRUST_RADIUS_ABS);
        if step > radius {
            su *= radius / step;
            sv *= radius / step;
        }
        u -= su;
        v -= sv;
        if !(u.is_finite() && v.is_finite()) {
            return None;
        }
        if step <= STEP_TOLERANCE * (1.0 + u.hypot(v)) {
            let (du, dv) = distort(Jet::var(u, 0), Jet::var(v, 1));
            let residual = (du.value - tu).hypot(dv.value - tv);
            let det = du.d[0] * dv.d[1] - du.d[1] * dv.d[0];
            return (residual <= ACCEPT_RESIDUAL * scale && det > 0.0).then_some((u, v));
        }
    }
    None
}
