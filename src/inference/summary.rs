//! Posterior summaries from draws: moments, quantiles, highest-density
//! intervals and correlations.
//!
//! # Formula
//! Quantiles interpolate linearly between order statistics (Hyndman & Fan
//! type 7, as numpy's default): `q(p) = x_(floor(h)) + (h - floor(h))
//! (x_(floor(h)+1) - x_(floor(h)))`, `h = (n - 1) p` on 0-based sorted draws.
//! The highest-density interval is the shortest interval holding
//! `ceil(mass n)` consecutive sorted draws.
//!
//! ```
//! use hbis::inference::summary::quantile;
//!
//! let x = [1.0, 2.0, 3.0, 4.0, 5.0];
//! assert_eq!(quantile(&x, 0.5), 3.0);
//! assert_eq!(quantile(&x, 0.25), 2.0);
//! ```

use serde::Serialize;

/// Summary of one parameter's draws.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamSummary {
    /// Posterior mean.
    pub mean: f64,
    /// Posterior standard deviation.
    pub sd: f64,
    /// Coefficient of variation, `sd / |mean|`.
    pub cov: f64,
    /// 2.5 % quantile.
    pub q025: f64,
    /// 5 % quantile.
    pub q05: f64,
    /// Median.
    pub q50: f64,
    /// 95 % quantile.
    pub q95: f64,
    /// 97.5 % quantile.
    pub q975: f64,
    /// 90 % highest-density interval, lower end.
    pub hdi90_low: f64,
    /// 90 % highest-density interval, upper end.
    pub hdi90_high: f64,
}

/// Quantile of sorted draws (type 7).
pub fn quantile(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Shortest interval holding a fraction `mass` of sorted draws.
pub fn hdi(sorted: &[f64], mass: f64) -> (f64, f64) {
    let n = sorted.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let k = ((mass * n as f64).ceil() as usize).clamp(1, n);
    let mut best = (sorted[0], sorted[k - 1]);
    for i in 0..=n - k {
        let (a, b) = (sorted[i], sorted[i + k - 1]);
        if b - a < best.1 - best.0 {
            best = (a, b);
        }
    }
    best
}

impl ParamSummary {
    /// Summarises draws (in any order).
    pub fn from_draws(draws: &[f64]) -> Self {
        let n = draws.len() as f64;
        let mean = draws.iter().sum::<f64>() / n;
        let sd =
            (draws.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
        let mut sorted = draws.to_vec();
        sorted.sort_unstable_by(f64::total_cmp);
        let (hdi90_low, hdi90_high) = hdi(&sorted, 0.9);
        Self {
            mean,
            sd,
            cov: sd / mean.abs(),
            q025: quantile(&sorted, 0.025),
            q05: quantile(&sorted, 0.05),
            q50: quantile(&sorted, 0.5),
            q95: quantile(&sorted, 0.95),
            q975: quantile(&sorted, 0.975),
            hdi90_low,
            hdi90_high,
        }
    }
}

/// Covariance matrix of draws given as `draws[k]` = all draws of parameter `k`.
pub fn covariance(draws: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let d = draws.len();
    let n = draws.first().map_or(0, Vec::len) as f64;
    let means: Vec<f64> = draws.iter().map(|x| x.iter().sum::<f64>() / n).collect();
    let mut c = vec![vec![0.0; d]; d];
    for i in 0..d {
        for j in 0..=i {
            let v = draws[i]
                .iter()
                .zip(&draws[j])
                .map(|(a, b)| (a - means[i]) * (b - means[j]))
                .sum::<f64>()
                / (n - 1.0).max(1.0);
            c[i][j] = v;
            c[j][i] = v;
        }
    }
    c
}

/// Correlation matrix from a covariance matrix.
pub fn correlation(cov: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let d = cov.len();
    (0..d)
        .map(|i| {
            (0..d)
                .map(|j| cov[i][j] / (cov[i][i] * cov[j][j]).sqrt())
                .collect()
        })
        .collect()
}

/// Quantiles of a response over time: the posterior predictive band of
/// [`crate::study::predict`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Band {
    /// Times (s).
    pub t: Vec<f64>,
    /// 5 % quantile of `u` (m).
    pub q05: Vec<f64>,
    /// Median.
    pub q50: Vec<f64>,
    /// 95 % quantile.
    pub q95: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_and_hdi_of_a_skewed_sample() {
        // Exponential-like draws: the HDI hugs zero, the central interval does not.
        let x: Vec<f64> = (0..10_000)
            .map(|i| -(1.0 - (i as f64 + 0.5) / 10_000.0).ln())
            .collect();
        let s = ParamSummary::from_draws(&x);
        assert!((s.q50 - 2f64.ln()).abs() < 1e-3);
        assert!((s.q05 - (1.0f64 / 0.95).ln()).abs() < 1e-3);
        assert!(s.hdi90_low < 1e-3 && (s.hdi90_high - 10f64.ln()).abs() < 1e-2);
        assert!((s.mean - 1.0).abs() < 2e-3 && (s.sd - 1.0).abs() < 2e-2);
    }

    #[test]
    fn correlation_of_linear_relation_is_one() {
        let a: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let b: Vec<f64> = a.iter().map(|v| -2.0 * v + 1.0).collect();
        let r = correlation(&covariance(&[a, b]));
        assert!((r[0][1] + 1.0).abs() < 1e-12 && (r[1][1] - 1.0).abs() < 1e-12);
    }
}
