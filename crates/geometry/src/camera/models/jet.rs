//! Forward-mode dual numbers with a 2-vector of derivatives. The distortion maps are
//! written once, generic over [`Scalar`], and evaluated with [`Jet`] to get the exact
//! 2x2 Jacobian the Newton undistortion needs (finite differences lose ~8 digits).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// The arithmetic the distortion polynomials and rational functions use.
pub(super) trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A constant (a camera parameter): zero derivative.
    fn cst(value: f64) -> Self;
}

impl Scalar for f64 {
    fn cst(value: f64) -> Self {
        value
    }
}

/// `value + d[0] * e0 + d[1] * e1` with `e0 e1 = e0^2 = e1^2 = 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Jet {
    pub value: f64,
    pub d: [f64; 2],
}

impl Jet {
    /// The independent variable number `index` (0 or 1) at `value`.
    pub fn var(value: f64, index: usize) -> Self {
        let mut d = [0.0; 2];
        d[index] = 1.0;
        Jet { value, d }
    }
}

impl Scalar for Jet {
    fn cst(value: f64) -> Self {
        Jet { value, d: [0.0; 2] }
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(self, o: Jet) -> Jet {
        Jet {
            value: self.value + o.value,
            d: [self.d[0] + o.d[0], self.d[1] + o.d[1]],
        }
    }
}

impl Sub for Jet {
    type Output = Jet;
    fn sub(self, o: Jet) -> Jet {
        Jet {
            value: self.value - o.value,
            d: [self.d[0] - o.d[0], self.d[1] - o.d[1]],
        }
    }
}

impl Mul for Jet {
    type Output = Jet;
    fn mul(self, o: Jet) -> Jet {
        Jet {
            value: self.value * o.value,
            d: [
                self.d[0] * o.value + self.value * o.d[0],
                self.d[1] * o.value + self.value * o.d[1],
            ],
        }
    }
}

impl Div for Jet {
    type Output = Jet;
    fn div(self, o: Jet) -> Jet {
        let q = self.value / o.value;
        Jet {
            value: q,
            d: [
                (self.d[0] - q * o.d[0]) / o.value,
                (self.d[1] - q * o.d[1]) / o.value,
            ],
        }
    }
}

impl Neg for Jet {
    type Output = Jet;
    fn neg(self) -> Jet {
        Jet {
            value: -self.value,
            d: [-self.d[0], -self.d[1]],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_rational_function() {
        // f(x, y) = (x^2 y + 3) / (1 + x y) at (2, 0.25), by hand: numerator n = 4,
        // denominator d = 1.5, f = 8/3, df/dx = (2 x y d - n y) / d^2 = 2/9,
        // df/dy = (x^2 d - n x) / d^2 = -8/9.
        let x = Jet::var(2.0, 0);
        let y = Jet::var(0.25, 1);
        let f = (x * x * y + Jet::cst(3.0)) / (Jet::cst(1.0) + x * y);
        assert!((f.value - 8.0 / 3.0).abs() < 1e-15);
        assert!((f.d[0] - 2.0 / 9.0).abs() < 1e-15);
        assert!((f.d[1] + 8.0 / 9.0).abs() < 1e-15);
        let g = -(x - y);
        assert_eq!(g.d, [-1.0, 1.0]);
    }
}
