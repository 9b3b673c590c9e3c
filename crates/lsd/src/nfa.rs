//! Number of False Alarms (IPOL paper, section "NFA computation"):
//! `NFA = NT * B(n, k, p)`, returned as `-log10(NFA)`, where `B` is the binomial tail of
//! `k` or more aligned pixels among `n` at precision `p` and `NT` the number of tests.
//!
//! The arithmetic follows the reference step by step (including multiplying by a stored
//! `1 / i` rather than dividing): the value decides which rectangle `rect_improve` keeps.

/// Whether `a` and `b` are equal up to 100 ulps of relative error (the reference's
/// `double_equal`; numbers below `f64::MIN_POSITIVE` are compared on its scale).
pub(crate) fn double_equal(a: f64, b: f64) -> bool {
    if a == b {
        return true;
    }
    let abs_diff = (a - b).abs();
    let abs_max = a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
    abs_diff / abs_max <= 100.0 * f64::EPSILON
}

/// ln |Gamma(x)| by the Lanczos approximation (good for small x).
fn log_gamma_lanczos(x: f64) -> f64 {
    const Q: [f64; 7] = [
        75122.6331530,
        80916.6278952,
        36308.2951477,
        8687.24529705,
        1168.92649479,
        83.8676043424,
        2.50662827511,
    ];
    let mut a = (x + 0.5) * (x + 5.5).ln() - (x + 5.5);
    let mut b = 0.0;
    for (n, q) in Q.iter().enumerate() {
        a -= (x + n as f64).ln();
        b += q * x.powf(n as f64);
    }
    a + b.ln()
}

/// ln |Gamma(x)| by Windschitl's formula (good for x > 15).
fn log_gamma_windschitl(x: f64) -> f64 {
    0.918938533204673 + (x - 0.5) * x.ln() - x
        + 0.5 * x * (x * (1.0 / x).sinh() + 1.0 / (810.0 * x.powf(6.0))).ln()
}

/// ln |Gamma(x)|: Windschitl above 15, Lanczos below.
pub(crate) fn log_gamma(x: f64) -> f64 {
    if x > 15.0 {
        log_gamma_windschitl(x)
    } else {
        log_gamma_lanczos(x)
    }
}

/// `-log10(NFA)` of `k` aligned pixels among `n` at probability `p`, with `log_nt` =
/// log10 of the number of tests. The tail sum stops once its truncation error is below
/// 10 % of the result. Requires `0 <= k <= n` and `0 < p < 1`.
pub(crate) fn nfa(n: u64, k: u64, p: f64, log_nt: f64) -> f64 {
    const TOLERANCE: f64 = 0.1;
    debug_assert!(k <= n && p > 0.0 && p < 1.0, "nfa({n}, {k}, {p})");
    if n == 0 || k == 0 {
        return -log_nt;
    }
    if n == k {
        return -log_nt - n as f64 * p.log10();
    }
    let p_term = p / (1.0 - p);
    let (nf, kf) = (n as f64, k as f64);
    // First term of the tail: bincoef(n, k) p^k (1-p)^(n-k), through log Gamma.
    let log1term = log_gamma(nf + 1.0) - log_gamma(kf + 1.0) - log_gamma((n - k) as f64 + 1.0)
        + kf * p.ln()
        + (n - k) as f64 * (1.0 - p).ln();
    let mut term = log1term.exp();
    if double_equal(term, 0.0) {
        // Underflow: past the mean the first term dominates, before it the tail is ~1.
        return if kf > nf * p {
            -log1term / std::f64::consts::LN_10 - log_nt
        } else {
            -log_nt
        };
    }
    let mut bin_tail = term;
    for i in k + 1..=n {
        // term_i = term_{i-1} * (n - i + 1) / i * p / (1 - p); the reference multiplies by
        // a cached 1 / i.
        let bin_term = (n - i + 1) as f64 * (1.0 / i as f64);
        let mult_term = bin_term * p_term;
        term *= mult_term;
        bin_tail += term;
        if bin_term < 1.0 {
            // From here the ratios decrease: the rest is bounded by a geometric series.
            let err = term * ((1.0 - mult_term.powf((n - i + 1) as f64)) / (1.0 - mult_term) - 1.0);
            if err < TOLERANCE * (-bin_tail.log10() - log_nt).abs() * bin_tail {
                break;
            }
        }
    }
    -bin_tail.log10() - log_nt
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ln((n-1)!) exactly enough for the comparison.
    fn ln_factorial(n: u64) -> f64 {
        (1..=n).map(|i| (i as f64).ln()).sum()
    }

    #[test]
    fn log_gamma_matches_factorials_on_both_branches() {
        for x in [1.0, 2.0, 3.0, 5.0, 10.0, 15.0] {
            let want = ln_factorial(x as u64 - 1);
            assert!((log_gamma(x) - want).abs() < 1e-8, "x={x}");
        }
        for x in [16.0, 20.0, 50.0, 171.0] {
            let want = ln_factorial(x as u64 - 1);
            assert!((log_gamma(x) - want).abs() < 1e-10 * want, "x={x}");
        }
        // Gamma(1/2) = sqrt(pi).
        let half = std::f64::consts::PI.sqrt().ln();
        assert!((log_gamma(0.5) - half).abs() < 1e-9);
    }

    /// -log10 of the exact binomial tail times NT.
    fn exact(n: u64, k: u64, p: f64, log_nt: f64) -> f64 {
        let mut tail = 0.0;
        for j in k..=n {
            let ln_c = ln_factorial(n) - ln_factorial(j) - ln_factorial(n - j);
            tail += (ln_c + j as f64 * p.ln() + (n - j) as f64 * (1.0 - p).ln()).exp();
        }
        -tail.log10() - log_nt
    }

    #[test]
    fn nfa_agrees_with_the_exact_tail_within_its_tolerance() {
        let log_nt = 5.0 * (512f64.log10() + 384f64.log10()) / 2.0 + 11f64.log10();
        for (n, k) in [(20, 10), (100, 40), (300, 290), (50, 7), (1000, 200)] {
            let got = nfa(n, k, 0.125, log_nt);
            let want = exact(n, k, 0.125, log_nt);
            // The reference accepts a 10 % error on the result (truncated tail).
            assert!(
                (got - want).abs() <= 0.1 * want.abs() + 1e-9,
                "n={n} k={k}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn nfa_trivial_cases() {
        assert_eq!(nfa(10, 0, 0.125, 3.0), -3.0);
        assert_eq!(nfa(0, 0, 0.125, 3.0), -3.0);
        assert_eq!(nfa(4, 4, 0.125, 1.0), -1.0 - 4.0 * 0.125f64.log10());
    }

    #[test]
    fn double_equal_is_relative() {
        assert!(double_equal(1.0, 1.0 + 10.0 * f64::EPSILON));
        assert!(!double_equal(1.0, 1.0 + 1e-10));
        assert!(double_equal(0.0, 1e-330));
        assert!(!double_equal(0.0, 1e-300));
    }
}
