//! The likelihood of a record given model parameters, with the noise scale
//! marginalised.
//!
//! Measurement error is Gaussian with unknown standard deviation `sigma`.
//! Rather than sample `sigma`, it is integrated out analytically under
//! Jeffreys' prior `p(sigma) ~ 1/sigma`, which leaves a likelihood that
//! depends on the residuals only through their sum of squares. Two error
//! models:
//!
//! - [`Noise::White`]: independent errors.
//! - [`Noise::Ar1`]: `e_i = rho e_(i-1) + w_i` with stationary start; `rho`
//!   becomes one more sampled parameter (named `rho`). Residuals of real
//!   records are correlated (model error varies smoothly at 200 Hz), and
//!   white noise then overstates the information in the record: with lag-one
//!   correlation `rho`, intervals widen by about `sqrt((1 + rho)/(1 - rho))`
//!   (about 4.4 at `rho = 0.9`) — see `docs/inference.md`.
//!
//! # Formula
//! With `S` the sum of squared (pre-whitened, for AR(1)) residuals over `N`
//! samples,
//! ```text
//! white: ln L = ln Gamma(N/2) - ln 2 - (N/2) ln(pi S)
//! AR(1): ln L = ln Gamma(N/2) - ln 2 - (N/2) ln(pi S_rho) + ln(1 - rho^2)/2
//!        S_rho = (1 - rho^2) r_1^2 + sum_(i>1) (r_i - rho r_(i-1))^2
//! ```
//! and `e2 = sum r_i^2 / sum a_i^2` (model-notes.md).
//!
//! ```
//! use hbis::inference::Noise;
//!
//! let r = [0.1, -0.2, 0.05, 0.3];
//! let (ln_l, s) = Noise::White.log_likelihood(&r, None);
//! assert!((s - 0.1425).abs() < 1e-15);
//! let by_hand = statrs::function::gamma::ln_gamma(2.0) - 2f64.ln() - 2.0 * (std::f64::consts::PI * s).ln();
//! assert!((ln_l - by_hand).abs() < 1e-12);
//! ```

use serde::{Deserialize, Serialize};
use statrs::function::gamma::ln_gamma;

/// The measurement-error model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Noise {
    /// Independent Gaussian errors.
    #[default]
    White,
    /// First-order autoregressive Gaussian errors (adds parameter `rho`).
    Ar1,
}

impl Noise {
    /// `"white"` or `"ar1"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Noise::White => "white",
            Noise::Ar1 => "ar1",
        }
    }

    /// Parses `"white"` or `"ar1"`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "white" => Some(Noise::White),
            "ar1" => Some(Noise::Ar1),
            _ => None,
        }
    }

    /// Extra parameter names the noise model adds.
    pub fn extra_names(self) -> &'static [&'static str] {
        match self {
            Noise::White => &[],
            Noise::Ar1 => &["rho"],
        }
    }

    /// Marginal log-likelihood of residuals `r` and the (whitened) sum of
    /// squares. `rho` is needed for [`Noise::Ar1`].
    pub fn log_likelihood(self, r: &[f64], rho: Option<f64>) -> (f64, f64) {
        let (s, jac) = match (self, rho) {
            (Noise::Ar1, Some(rho)) => ar1_sum(r, rho),
            _ => (sum_of_squares(r), 0.0),
        };
        (marginal(r.len(), s) + jac, s)
    }
}

/// `ln Gamma(n/2) - ln 2 - (n/2) ln(pi s)`: the white-noise marginal for a
/// sum of squares `s` over `n` samples.
pub fn marginal(n: usize, s: f64) -> f64 {
    let n = n as f64;
    ln_gamma(n / 2.0) - std::f64::consts::LN_2 - 0.5 * n * (std::f64::consts::PI * s).ln()
}

/// Pre-whitened sum of squares of AR(1) residuals and the log-Jacobian
/// `ln(1 - rho^2)/2` of the stationary start.
pub fn ar1_sum(r: &[f64], rho: f64) -> (f64, f64) {
    let one_m = 1.0 - rho * rho;
    let mut s = one_m * r[0] * r[0];
    for w in r.windows(2) {
        let e = w[1] - rho * w[0];
        s += e * e;
    }
    (s, 0.5 * one_m.ln())
}

/// Sum of squares with four partial sums (a fixed order, so the result is
/// the same on every run; four chains let the CPU overlap the adds).
pub fn sum_of_squares(r: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let chunks = r.chunks_exact(4);
    let tail: f64 = chunks.remainder().iter().map(|v| v * v).sum();
    for c in chunks {
        for k in 0..4 {
            acc[k] += c[k] * c[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// `sum (a_i - m_i)^2` in one pass, without storing the residuals: the
/// same sums in the same order as [`sum_of_squares`] of the residuals, so
/// the same value to the last bit.
///
/// ```
/// use hbis::inference::likelihood::{sum_of_squared_differences, sum_of_squares};
/// let (a, m) = ([1.0, 2.0, 3.0, 4.0, 5.0], [0.5, 2.5, 2.0, 4.0, 3.0]);
/// let r: Vec<f64> = a.iter().zip(&m).map(|(a, m)| a - m).collect();
/// assert_eq!(sum_of_squared_differences(&a, &m), sum_of_squares(&r));
/// assert_eq!(sum_of_squares(&r), 0.25 + 0.25 + 1.0 + 0.0 + 4.0);
/// ```
pub fn sum_of_squared_differences(a: &[f64], m: &[f64]) -> f64 {
    assert_eq!(a.len(), m.len(), "two series of one length");
    let (ca, cm) = (a.chunks_exact(4), m.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cm.remainder())
        .map(|(a, m)| (a - m) * (a - m))
        .sum();
    let mut acc = [0.0f64; 4];
    for (x, y) in ca.zip(cm) {
        for k in 0..4 {
            let r = x[k] - y[k];
            acc[k] += r * r;
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-pass sum is the two-pass sum to the last bit, for every
    /// length modulo the four accumulators.
    #[test]
    fn one_pass_sum_of_squares_is_the_two_pass_sum() {
        let mut x = 0.3f64;
        let mut next = || {
            x = (x * 3.7 + 0.123).fract();
            x - 0.5
        };
        for n in [0usize, 1, 2, 3, 4, 5, 7, 8, 9, 2001] {
            let a: Vec<f64> = (0..n).map(|_| next()).collect();
            let m: Vec<f64> = (0..n).map(|_| 1e-3 * next()).collect();
            let r: Vec<f64> = a.iter().zip(&m).map(|(a, m)| a - m).collect();
            let (one, two) = (sum_of_squared_differences(&a, &m), sum_of_squares(&r));
            assert_eq!(one.to_bits(), two.to_bits(), "n = {n}: {one} vs {two}");
        }
    }

    /// The marginal equals a numerical integral over sigma of the Gaussian
    /// likelihood times 1/sigma.
    #[test]
    fn marginal_matches_numerical_integral_over_sigma() {
        let r = [0.3, -0.1, 0.25, -0.4, 0.05, 0.2];
        let n = r.len() as f64;
        let s: f64 = r.iter().map(|v| v * v).sum();
        let integrand = |ls: f64| {
            let sigma = ls.exp();
            // d sigma / sigma = d ln sigma
            (-0.5 * n * (2.0 * std::f64::consts::PI * sigma * sigma).ln()
                - s / (2.0 * sigma * sigma))
                .exp()
        };
        let (a, b, m) = (-8.0, 4.0, 200_000);
        let h = (b - a) / m as f64;
        let integral: f64 = (0..m)
            .map(|i| integrand(a + (i as f64 + 0.5) * h))
            .sum::<f64>()
            * h;
        let (ln_l, _) = Noise::White.log_likelihood(&r, None);
        assert!(
            (ln_l - integral.ln()).abs() < 1e-8,
            "{ln_l} vs {}",
            integral.ln()
        );
    }

    #[test]
    fn ar1_with_rho_zero_is_white() {
        let r = [0.3, -0.1, 0.25, -0.4];
        assert_eq!(
            Noise::Ar1.log_likelihood(&r, Some(0.0)),
            Noise::White.log_likelihood(&r, None)
        );
    }

    /// For AR(1) residuals the AR(1) likelihood peaks near the true rho.
    #[test]
    fn ar1_likelihood_peaks_near_the_true_rho() {
        use rand::{rngs::StdRng, SeedableRng};
        use rand_distr::{Distribution, Normal};
        let mut rng = StdRng::seed_from_u64(5);
        let w = Normal::new(0.0, 1.0).unwrap();
        let mut r = vec![0.0f64; 4000];
        for i in 1..r.len() {
            r[i] = 0.8 * r[i - 1] + w.sample(&mut rng);
        }
        let best = (-99..100)
            .map(|k| k as f64 / 100.0)
            .max_by(|a, b| {
                let la = Noise::Ar1.log_likelihood(&r, Some(*a)).0;
                let lb = Noise::Ar1.log_likelihood(&r, Some(*b)).0;
                la.total_cmp(&lb)
            })
            .unwrap();
        // sd of the estimate is sqrt((1 - 0.64)/4000) = 0.0095
        assert!((best - 0.8).abs() < 0.03, "rho_hat = {best}");
    }
}
