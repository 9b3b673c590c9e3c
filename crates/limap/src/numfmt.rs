//! The two number notations LIMAP writes.
//!
//! - Track files (C++ `std::fixed << std::setprecision(10)`) and `alltracks.txt` (Python
//!   `:.10f`): fixed notation, 10 decimals, correctly rounded. Rust's `{:.10}` rounds the
//!   exact binary value half-to-even like glibc and CPython, so it matches both.
//! - Segment files (Python `f"{x}"` of a float): `repr`, the shortest digits that read back
//!   to the same double, in positional notation when the decimal exponent is in [-4, 16)
//!   and scientific (`1e-05`, `1.5e+16`) otherwise, with `.0` added to integral values.

use std::fmt::Write;

/// C++ `std::fixed` with precision 10 (and Python `:.10f`) for a finite value.
pub(crate) fn push_fixed10(out: &mut String, x: f64) {
    let _ = write!(out, "{x:.10}");
}

/// Python's `repr(float)` for a finite value.
pub(crate) fn python_repr(x: f64) -> String {
    // `{:e}` gives the shortest round-trip digits as `d[.ddd]e<exp>`.
    let sci = format!("{x:e}");
    let (mantissa, exponent) = match sci.split_once('e') {
        Some(parts) => parts,
        None => return sci,
    };
    let Ok(exponent) = exponent.parse::<i32>() else {
        return sci;
    };
    let (sign, mantissa) = match mantissa.strip_prefix('-') {
        Some(m) => ("-", m),
        None => ("", mantissa),
    };
    let digits: String = mantissa.chars().filter(|c| *c != '.').collect();
    // Position of the decimal point relative to the digit string: value = 0.DIGITS * 10^point.
    let point = exponent + 1;
    let n = digits.len() as i32;
    let mut out = String::with_capacity(digits.len() + 8);
    out.push_str(sign);
    if !(-4 < point && point <= 16) {
        let (first, rest) = digits.split_at(1);
        out.push_str(first);
        if !rest.is_empty() {
            out.push('.');
            out.push_str(rest);
        }
        let _ = write!(
            out,
            "e{}{:02}",
            if exponent < 0 { '-' } else { '+' },
            exponent.unsigned_abs()
        );
    } else if point <= 0 {
        out.push_str("0.");
        out.extend(std::iter::repeat_n('0', (-point) as usize));
        out.push_str(&digits);
    } else if point >= n {
        out.push_str(&digits);
        out.extend(std::iter::repeat_n('0', (point - n) as usize));
        out.push_str(".0");
    } else {
        let (int_part, frac_part) = digits.split_at(point as usize);
        out.push_str(int_part);
        out.push('.');
        out.push_str(frac_part);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Expected strings printed by CPython 3 (`repr(x)` and `'%.10f' % x`), not by this code.
    #[test]
    fn python_repr_matches_cpython() {
        let cases: &[(f64, &str)] = &[
            (0.0, "0.0"),
            (-0.0, "-0.0"),
            (1.0, "1.0"),
            (123.0, "123.0"),
            (0.1, "0.1"),
            (1e-5, "1e-05"),
            (0.0001, "0.0001"),
            (0.00012345, "0.00012345"),
            (1.5e-7, "1.5e-07"),
            (1e16, "1e+16"),
            (1e15, "1000000000000000.0"),
            (12345678901234567.0, "1.2345678901234568e+16"),
            (1e300, "1e+300"),
            (5e-324, "5e-324"),
            (-2.5e-5, "-2.5e-05"),
            (319.4531555175781, "319.4531555175781"),
            (1.0 / 3.0, "0.3333333333333333"),
            (2.0f64.powi(60), "1.152921504606847e+18"),
            (123456789.125, "123456789.125"),
            (9999999999999998.0, "9999999999999998.0"),
        ];
        for (x, want) in cases {
            assert_eq!(python_repr(*x), *want, "repr of {x:e}");
        }
    }

    #[test]
    fn fixed10_matches_cpython_and_glibc() {
        let cases: &[(f64, &str)] = &[
            (0.0, "0.0000000000"),
            (-0.0, "-0.0000000000"),
            (-1e-12, "-0.0000000000"),
            // exact ties at the 11th decimal round half to even
            (0.00048828125, "0.0004882812"),
            (0.00146484375, "0.0014648438"),
            (1.23456789015, "1.2345678901"),
            (-3.75, "-3.7500000000"),
            (1e20, "100000000000000000000.0000000000"),
        ];
        for (x, want) in cases {
            let mut s = String::new();
            push_fixed10(&mut s, *x);
            assert_eq!(s, *want, "fixed of {x:e}");
        }
    }

    proptest::proptest! {
        #[test]
        fn python_repr_round_trips(bits in proptest::num::u64::ANY) {
            let x = f64::from_bits(bits);
            if x.is_finite() {
                let s = python_repr(x);
                proptest::prop_assert_eq!(s.parse::<f64>().ok().map(f64::to_bits), Some(x.to_bits()));
            }
        }
    }
}
