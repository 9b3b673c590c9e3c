//! Doubles printed like C++ `stream << x` with `precision(17)` in the C locale, i.e.
//! printf's `%.17g`: 17 significant digits, correctly rounded, trailing zeros removed,
//! scientific notation when the exponent is < -4 or >= 17 (exponent with a sign and at
//! least two digits). COLMAP's text writer prints every double this way.

use std::fmt::Write;

const MAX_PRECISION: usize = 17;

/// A fixed buffer for one `{:e}` rendering (at most ~26 bytes for 17 digits).
struct Scratch {
    buf: [u8; 48],
    len: usize,
}

impl Write for Scratch {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        let end = self.len + s.len();
        let dst = self.buf.get_mut(self.len..end).ok_or(std::fmt::Error)?;
        dst.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// Appends `x` formatted as `%.17g`.
pub fn push_g17(out: &mut String, x: f64) {
    push_g(out, x, MAX_PRECISION);
}

/// Appends `x` formatted as `%.<precision>g` (precision clamped to 1..=17; C++'s
/// default stream precision is 6).
pub fn push_g(out: &mut String, x: f64, precision: usize) {
    let precision = precision.clamp(1, MAX_PRECISION);
    if x.is_nan() {
        out.push_str(if x.is_sign_negative() { "-nan" } else { "nan" });
        return;
    }
    if x.is_sign_negative() {
        out.push('-');
    }
    let a = x.abs();
    if a.is_infinite() {
        out.push_str("inf");
        return;
    }
    if a == 0.0 {
        out.push('0');
        return;
    }
    // Rust prints `{:.Ne}` exactly rounded: "d.ddd...e<exp>".
    let mut s = Scratch {
        buf: [0; 48],
        len: 0,
    };
    if write!(s, "{a:.*e}", precision - 1).is_err() {
        // Cannot happen (the rendering is < 48 bytes); fall back to Rust's shortest form.
        let _ = write!(out, "{a}");
        return;
    }
    let text = &s.buf[..s.len];
    let e_pos = text.iter().position(|&b| b == b'e').unwrap_or(text.len());
    let exp: i32 = std::str::from_utf8(&text[e_pos + 1..])
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or(0);
    let mut digits = [b'0'; MAX_PRECISION];
    let mut nd = 0;
    for &b in &text[..e_pos] {
        if b.is_ascii_digit() && nd < precision {
            digits[nd] = b;
            nd += 1;
        }
    }
    // Significant digits without trailing zeros (at least one).
    let mut sig = precision;
    while sig > 1 && digits[sig - 1] == b'0' {
        sig -= 1;
    }
    let digits = &digits[..sig];
    let push = |out: &mut String, d: &[u8]| {
        for &b in d {
            out.push(char::from(b));
        }
    };
    if exp < -4 || exp >= precision as i32 {
        push(out, &digits[..1]);
        if sig > 1 {
            out.push('.');
            push(out, &digits[1..]);
        }
        out.push('e');
        out.push(if exp < 0 { '-' } else { '+' });
        let e = exp.unsigned_abs();
        if e < 10 {
            out.push('0');
        }
        let _ = write!(out, "{e}");
    } else if exp >= 0 {
        let int_len = exp as usize + 1;
        if sig <= int_len {
            push(out, digits);
            for _ in sig..int_len {
                out.push('0');
            }
        } else {
            push(out, &digits[..int_len]);
            out.push('.');
            push(out, &digits[int_len..]);
        }
    } else {
        out.push_str("0.");
        for _ in 0..(-exp - 1) {
            out.push('0');
        }
        push(out, digits);
    }
}

#[cfg(test)]
mod tests {
    use super::push_g17;

    fn g(x: f64) -> String {
        let mut s = String::new();
        push_g17(&mut s, x);
        s
    }

    #[test]
    fn matches_colmap_written_values() {
        // Values as they appear in files pycolmap 4.2.1 wrote (the sample data, README.md "Tests").
        assert_eq!(g(0.999999), "0.99999899999999997");
        assert_eq!(g(8.68136e-05), "8.6813599999999998e-05");
        assert_eq!(g(1847.53), "1847.53");
        assert_eq!(g(959.5), "959.5");
        assert_eq!(g(390.0), "390");
        assert_eq!(g(-2.18007), "-2.1800700000000002");
        assert_eq!(g(838.75), "838.75");
        assert_eq!(g(495.9), "495.89999999999998");
    }

    #[test]
    fn printf_rules() {
        // Hand-derived from the %g rules of C99 7.19.6.1.
        assert_eq!(g(0.0), "0");
        assert_eq!(g(-0.0), "-0");
        assert_eq!(g(1.0), "1");
        assert_eq!(g(0.0001), "0.0001");
        assert_eq!(g(0.5e-4), "5.0000000000000002e-05");
        assert_eq!(g(1e16), "10000000000000000");
        assert_eq!(g(1e17), "1e+17");
        assert_eq!(g(1.5e300), "1.5000000000000001e+300");
        assert_eq!(g(5e-324), "4.9406564584124654e-324");
        assert_eq!(g(f64::INFINITY), "inf");
        assert_eq!(g(f64::NEG_INFINITY), "-inf");
        assert_eq!(g(f64::NAN), "nan");
        assert_eq!(g(123456789.0), "123456789");
        assert_eq!(g(0.1), "0.10000000000000001");
        // An exact tie at the 18th digit rounds to even, as glibc's printf does.
        assert_eq!(g((1u64 << 50) as f64 + 0.25), "1125899906842624.2");
    }

    #[test]
    fn other_precisions() {
        let g6 = |x: f64| {
            let mut s = String::new();
            super::push_g(&mut s, x, 6);
            s
        };
        // pycolmap's summary() prints these (default C++ precision 6).
        assert_eq!(g6(3.2290664100096245), "3.22907");
        assert_eq!(g6(0.34260043784408084), "0.3426");
        assert_eq!(g6(838.75), "838.75");
        assert_eq!(g6(1234567.0), "1.23457e+06");
        assert_eq!(g6(999999.5), "1e+06");
    }

    #[test]
    fn seventeen_digits_round_trip() {
        let mut state = 0x9E37_79B9_7F4A_7C15_u64;
        for _ in 0..100_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let x = f64::from_bits(state);
            if !x.is_finite() {
                continue;
            }
            let s = g(x);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
        }
    }
}
