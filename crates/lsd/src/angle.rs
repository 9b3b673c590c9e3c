//! Angle comparisons. The reference code uses 3/2 pi and 2 pi rounded to 11 decimals;
//! they are kept as written, since alignment decisions at the tolerance boundary follow
//! them.

use crate::gradient::NOTDEF;
use crate::grid::Grid;
use std::f64::consts::PI;

/// 3/2 pi as the reference writes it.
const THREE_HALVES_PI: f64 = 4.71238898038;
/// 2 pi as the reference writes it (not `TAU`: the rounded value is the one whose
/// decisions pytlsd's output shows).
#[allow(clippy::approx_constant)]
const TWO_PI: f64 = 6.28318530718;

/// Whether pixel (x, y) has a level-line angle within `prec` of `theta` (both in
/// [-pi, pi]); pixels without one are never aligned.
#[inline]
pub(crate) fn is_aligned(x: usize, y: usize, angles: &Grid<f64>, theta: f64, prec: f64) -> bool {
    let a = angles.get(x, y);
    if a == NOTDEF {
        return false;
    }
    let mut d = (theta - a).abs();
    if d > THREE_HALVES_PI {
        d = (d - TWO_PI).abs();
    }
    d <= prec
}

/// `a - b` wrapped into (-pi, pi].
#[inline]
pub(crate) fn angle_diff_signed(a: f64, b: f64) -> f64 {
    let mut d = a - b;
    while d <= -PI {
        d += TWO_PI;
    }
    while d > PI {
        d -= TWO_PI;
    }
    d
}

/// |`a - b`| wrapped into [0, pi].
#[inline]
pub(crate) fn angle_diff(a: f64, b: f64) -> f64 {
    angle_diff_signed(a, b).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_wrap_around_pi() {
        assert!((angle_diff(3.0, -3.0) - (TWO_PI - 6.0)).abs() < 1e-12);
        assert!((angle_diff_signed(-3.0, 3.0) - (TWO_PI - 6.0)).abs() < 1e-12);
        assert_eq!(angle_diff(0.25, 0.5), 0.25);
    }

    #[test]
    fn alignment_wraps_and_refuses_undefined_angles() {
        let mut g = Grid::filled(2, 1, NOTDEF);
        g.set(0, 0, 3.1);
        assert!(is_aligned(0, 0, &g, -3.1, 0.1));
        assert!(!is_aligned(0, 0, &g, 2.9, 0.1));
        assert!(!is_aligned(1, 0, &g, NOTDEF, 1.0));
    }
}
