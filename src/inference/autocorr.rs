//! Integrated autocorrelation time, as emcee's `autocorr.integrated_time`.
//!
//! The normalised autocorrelation function of each walker's series is
//! computed by FFT (zero-padded to avoid wrap-around), averaged over walkers,
//! and summed with Sokal's automatic window: the smallest `M` with
//! `M >= c tau(M)`, `c = 5` (Goodman & Weare 2010; Foreman-Mackey et al.
//! 2013, emcee's documentation "Autocorrelation analysis").
//!
//! # Formula
//! ```text
//! rho(k) = mean over walkers of  sum_t (x_t - m)(x_(t+k) - m) / sum_t (x_t - m)^2
//! tau(M) = 1 + 2 sum_(k=1..M) rho(k)
//! ```
//!
//! ```
//! use hbis::inference::autocorr::integrated_time;
//!
//! use rand::{rngs::StdRng, RngExt, SeedableRng};
//!
//! // Independent draws have tau = 1.
//! let mut rng = StdRng::seed_from_u64(1);
//! let x: Vec<f64> = (0..20_000).map(|_| rng.random::<f64>()).collect();
//! let tau = integrated_time(&[x], 5.0);
//! assert!((tau - 1.0).abs() < 0.1, "{tau}");
//! ```

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

/// Normalised autocorrelation function of one series (lags `0..n`).
pub fn autocorr_function(x: &[f64]) -> Vec<f64> {
    Acf::new(x.len()).compute(x)
}

/// FFT plans and a buffer for autocorrelation functions of one length, so
/// that many walkers' series share them.
struct Acf {
    n: usize,
    forward: std::sync::Arc<dyn rustfft::Fft<f64>>,
    inverse: std::sync::Arc<dyn rustfft::Fft<f64>>,
    buf: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl Acf {
    fn new(n: usize) -> Self {
        let size = (2 * n).next_power_of_two().max(2);
        let mut planner = FftPlanner::new();
        let forward = planner.plan_fft_forward(size);
        let inverse = planner.plan_fft_inverse(size);
        let scratch_len = forward
            .get_inplace_scratch_len()
            .max(inverse.get_inplace_scratch_len());
        Self {
            n,
            forward,
            inverse,
            buf: vec![Complex::new(0.0, 0.0); size],
            scratch: vec![Complex::new(0.0, 0.0); scratch_len],
        }
    }

    /// Adds `weight` times the normalised autocorrelation of `x` to `acc`.
    fn accumulate(&mut self, x: &[f64], weight: f64, acc: &mut [f64]) {
        let Some((m, r)) = standardizer(x) else {
            // A constant series: no information about its correlation.
            acc[0] += weight;
            return;
        };
        self.buf.fill(Complex::new(0.0, 0.0));
        for (b, v) in self.buf.iter_mut().zip(x) {
            b.re = (v - m) * r;
        }
        self.forward
            .process_with_scratch(&mut self.buf, &mut self.scratch);
        for c in self.buf.iter_mut() {
            *c = Complex::new(c.norm_sqr(), 0.0);
        }
        self.inverse
            .process_with_scratch(&mut self.buf, &mut self.scratch);
        self.finish(weight, acc, |c| c.re);
    }

    /// [`Acf::accumulate`] of two series at the cost of one: `x + i y`
    /// through one transform, the two spectra separated by symmetry
    /// (`X_k = (Z_k + conj Z_-k) / 2`, `Y_k = (Z_k - conj Z_-k) / 2i`),
    /// and both power spectra, real and even, back through one inverse as
    /// `|X|^2 + i |Y|^2`. Each series is scaled to unit sd first, so one
    /// cannot drown the other in round-off.
    fn accumulate_pair(&mut self, x: &[f64], y: &[f64], weight: f64, acc: &mut [f64]) {
        self.accumulate_pair_weighted(x, y, (weight, weight), acc);
    }

    /// [`Acf::accumulate_pair`] with a weight for each series.
    fn accumulate_pair_weighted(
        &mut self,
        x: &[f64],
        y: &[f64],
        (wx, wy): (f64, f64),
        acc: &mut [f64],
    ) {
        let (Some((mx, rx)), Some((my, ry))) = (standardizer(x), standardizer(y)) else {
            self.accumulate(x, wx, acc);
            self.accumulate(y, wy, acc);
            return;
        };
        self.buf.fill(Complex::new(0.0, 0.0));
        for ((b, u), v) in self.buf.iter_mut().zip(x).zip(y) {
            *b = Complex::new((u - mx) * rx, (v - my) * ry);
        }
        self.forward
            .process_with_scratch(&mut self.buf, &mut self.scratch);
        let size = self.buf.len();
        for k in 0..=size / 2 {
            let j = (size - k) % size;
            let (a, b) = (self.buf[k], self.buf[j].conj());
            let both = Complex::new(0.25 * (a + b).norm_sqr(), 0.25 * (a - b).norm_sqr());
            self.buf[k] = both;
            self.buf[j] = both;
        }
        self.inverse
            .process_with_scratch(&mut self.buf, &mut self.scratch);
        self.finish(wx, acc, |c| c.re);
        self.finish(wy, acc, |c| c.im);
    }

    /// Adds `weight` times the transformed buffer's part `part`, normalised
    /// by its lag-0 value, to `acc`.
    fn finish(&self, weight: f64, acc: &mut [f64], part: impl Fn(&Complex<f64>) -> f64) {
        let c0 = part(&self.buf[0]);
        for (a, c) in acc.iter_mut().zip(&self.buf[..self.n]) {
            *a += weight * part(c) / c0;
        }
    }

    fn compute(&mut self, x: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.n];
        if self.n > 0 {
            self.accumulate(x, 1.0, &mut out);
        }
        out
    }
}

/// Mean and reciprocal sd of `x`, or `None` when it is constant (a
/// series that is not finite gives NaN, which the caller passes on).
fn standardizer(x: &[f64]) -> Option<(f64, f64)> {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    (var != 0.0).then(|| (mean, 1.0 / var.sqrt()))
}

/// Integrated autocorrelation time of several walkers' series of one
/// parameter (each of the same length), with window constant `c`.
pub fn integrated_time(series: &[Vec<f64>], c: f64) -> f64 {
    let n = series.first().map_or(0, Vec::len);
    if n == 0 {
        return f64::NAN;
    }
    let mut f = vec![0.0; n];
    let mut acf = Acf::new(n);
    let w = 1.0 / series.len() as f64;
    let mut pairs = series.chunks_exact(2);
    for p in &mut pairs {
        acf.accumulate_pair(&p[0], &p[1], w, &mut f);
    }
    for s in pairs.remainder() {
        acf.accumulate(s, w, &mut f);
    }
    // taus[m] = 2 sum_(k<=m) f(k) - 1
    let mut cum = 0.0;
    for (m, &v) in f.iter().enumerate() {
        cum += v;
        let tau = 2.0 * cum - 1.0;
        if (m as f64) >= c * tau {
            return tau;
        }
    }
    2.0 * cum - 1.0
}

/// Effective sample size of the mean of several chains' series of one
/// parameter (each of the same length, at least 4), as ArviZ's
/// `ess(method="mean")` (Vehtari et al. 2021, eq. 10-11; Geyer 1992):
///
/// - each chain is split in halves, so a trend within a chain counts as
///   disagreement between chains;
/// - the autocorrelation at lag `t` is read against the variance *between*
///   chains as well as within them, so a slow mode that keeps each chain
///   near its own mean lowers the ESS even when no single chain shows it;
/// - the sum runs over Geyer's initial positive sequence of lag pairs,
///   made monotone.
///
/// NaN when a value is not finite; `M n` for a constant series.
///
/// # Formula
/// ```text
/// W = mean_m s_m^2 (ddof 1),  var+ = (n - 1)/n W + var_m(mean_m) (ddof 1)
/// rho(t) = 1 - (W - mean_m acov_m(t)) / var+        (acov with 1/n)
/// tau = -1 + 2 sum_(t <= T) rho(t),  ESS = M n / tau
/// ```
///
/// ```
/// use hbis::inference::autocorr::ess_mean;
///
/// // Two chains stuck at different levels: 4 x 500 split halves, but the
/// // between-chain spread says they are barely two independent draws.
/// let a: Vec<f64> = (0..1000).map(|i| 0.01 * ((i as f64) * 1.7).sin()).collect();
/// let b: Vec<f64> = a.iter().map(|x| x + 1.0).collect();
/// assert!(ess_mean(&[a.clone(), b]) < 10.0);
/// // One such chain alone looks independent: its values alternate.
/// assert!(ess_mean(&[a]) > 500.0);
/// ```
pub fn ess_mean(chains: &[Vec<f64>]) -> f64 {
    let n_draw = chains.first().map_or(0, Vec::len);
    if n_draw < 4 || chains.iter().any(|c| c.len() != n_draw) {
        return f64::NAN;
    }
    let half = n_draw / 2;
    let split: Vec<&[f64]> = chains
        .iter()
        .flat_map(|c| [&c[..half], &c[n_draw - half..]])
        .collect();
    ess_of_chains(&split)
}

/// The effective autocorrelation time `M n / ESS` of [`ess_mean`]: the
/// `tau` with which `ESS = M n / tau`.
pub fn effective_time(chains: &[Vec<f64>]) -> f64 {
    let total = chains.iter().map(Vec::len).sum::<usize>() as f64;
    total / ess_mean(chains)
}

/// ArviZ's `_ess` on chains already split.
fn ess_of_chains(chains: &[&[f64]]) -> f64 {
    let (m, n) = (chains.len(), chains[0].len());
    let all = chains.iter().flat_map(|c| c.iter());
    if all.clone().any(|x| !x.is_finite()) {
        return f64::NAN;
    }
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
        (l.min(x), h.max(x))
    });
    if hi - lo < 1e-15 {
        return (m * n) as f64;
    }
    let nf = n as f64;
    let means: Vec<f64> = chains.iter().map(|c| c.iter().sum::<f64>() / nf).collect();
    // Biased (1/n) variances: acov_m(t) = var_m rho_m(t).
    let vars: Vec<f64> = chains
        .iter()
        .zip(&means)
        .map(|(c, mu)| c.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / nf)
        .collect();
    let mut acov = vec![0.0; n];
    let mut acf = Acf::new(n);
    let w = 1.0 / m as f64;
    let mut k = 0;
    while k + 1 < m {
        acf.accumulate_pair_weighted(
            chains[k],
            chains[k + 1],
            (w * vars[k], w * vars[k + 1]),
            &mut acov,
        );
        k += 2;
    }
    if k < m {
        acf.accumulate(chains[k], w * vars[k], &mut acov);
    }
    let mean_var = acov[0] * nf / (nf - 1.0);
    let mut var_plus = mean_var * (nf - 1.0) / nf;
    if m > 1 {
        let mm = means.iter().sum::<f64>() / m as f64;
        var_plus += means.iter().map(|x| (x - mm).powi(2)).sum::<f64>() / (m as f64 - 1.0);
    }
    let rho = |t: usize| 1.0 - (mean_var - acov[t]) / var_plus;
    let mut rho_t = vec![0.0; n];
    rho_t[0] = 1.0;
    let (mut even, mut odd) = (1.0, rho(1));
    rho_t[1] = odd;
    // Geyer's initial positive sequence.
    let mut t = 1;
    while t + 3 < n && even + odd > 0.0 {
        even = rho(t + 1);
        odd = rho(t + 2);
        if even + odd >= 0.0 {
            rho_t[t + 1] = even;
            rho_t[t + 2] = odd;
        }
        t += 2;
    }
    // ArviZ's `max_t = t - 2`, never below 0 here since t >= 1 ... t - 2
    // may be -1 when the loop did not run: then only lag 0 counts.
    let max_t = t as isize - 2;
    if even > 0.0 && max_t + 1 >= 0 {
        rho_t[(max_t + 1) as usize] = even;
    }
    // Geyer's initial monotone sequence.
    let mut t = 1isize;
    while t <= max_t - 2 {
        let (i, j) = (t as usize, (t + 1) as usize);
        if rho_t[j] + rho_t[j + 1] > rho_t[i - 1] + rho_t[i] {
            rho_t[j] = (rho_t[i - 1] + rho_t[i]) / 2.0;
            rho_t[j + 1] = rho_t[j];
        }
        t += 2;
    }
    let total = (m * n) as f64;
    let upto = (max_t + 1).max(0) as usize;
    let mut tau = -1.0 + 2.0 * rho_t[..upto].iter().sum::<f64>();
    if max_t + 1 >= 0 && ((max_t + 1) as usize) < n {
        tau += rho_t[(max_t + 1) as usize];
    }
    let tau = tau.max(1.0 / total.log10());
    if rho_t.iter().any(|x| x.is_nan()) {
        return f64::NAN;
    }
    total / tau
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};

    /// 32 walkers of an AR(1) series `x_i = 0.9 x_(i-1) + noise`, 20,000
    /// steps each: tau = (1 + 0.9)/(1 - 0.9) = 19.
    fn ar1_walkers() -> Vec<Vec<f64>> {
        let mut rng = StdRng::seed_from_u64(1234);
        (0..32)
            .map(|_| {
                let mut x = vec![0.0f64; 20_000];
                for i in 1..x.len() {
                    let e: f64 = StandardNormal.sample(&mut rng);
                    x[i] = 0.9 * x[i - 1] + e;
                }
                x
            })
            .collect()
    }

    /// emcee's own test: the AR(1) series' tau of 19 within 20 %.
    #[test]
    fn finds_the_tau_of_an_ar1_series() {
        let tau = integrated_time(&ar1_walkers(), 5.0);
        assert!((tau - 19.0).abs() < 0.2 * 19.0, "tau = {tau}");
    }

    /// Two walkers through one transform give what each gives alone,
    /// also when their scales differ by eight orders of magnitude or one
    /// is constant.
    #[test]
    fn paired_walkers_match_single_ones() {
        let mut rng = StdRng::seed_from_u64(7);
        let mut ar = |scale: f64, rho: f64| {
            let mut x = vec![0.0f64; 1_000];
            for i in 1..x.len() {
                let e: f64 = StandardNormal.sample(&mut rng);
                x[i] = rho * x[i - 1] + scale * e;
            }
            x
        };
        let (a, b, c) = (ar(1.0, 0.9), ar(1e-8, 0.5), vec![3.0; 1_000]);
        for (x, y) in [(&a, &b), (&b, &a), (&a, &c), (&c, &b)] {
            let mut acf = Acf::new(1_000);
            let mut paired = vec![0.0; 1_000];
            acf.accumulate_pair(x, y, 0.5, &mut paired);
            let mut single = vec![0.0; 1_000];
            acf.accumulate(x, 0.5, &mut single);
            acf.accumulate(y, 0.5, &mut single);
            for (k, (p, s)) in paired.iter().zip(&single).enumerate() {
                assert!((p - s).abs() < 1e-12, "lag {k}: {p} vs {s}");
            }
        }
    }

    /// A series that is not finite gives NaN, never a plausible tau.
    #[test]
    fn a_nan_in_a_series_gives_nan() {
        let good: Vec<f64> = (0..100).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut bad = good.clone();
        bad[10] = f64::NAN;
        assert!(integrated_time(&[good.clone(), bad.clone()], 5.0).is_nan());
        assert!(integrated_time(&[bad, good.clone(), good], 5.0).is_nan());
    }

    #[test]
    fn the_function_matches_a_direct_sum() {
        let x: Vec<f64> = (0..200)
            .map(|i| ((i as f64) * 0.37).sin() + 0.1 * i as f64)
            .collect();
        let f = autocorr_function(&x);
        let m = x.iter().sum::<f64>() / 200.0;
        let c0: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
        for k in [0usize, 1, 5, 50, 199] {
            let ck: f64 = (0..200 - k).map(|t| (x[t] - m) * (x[t + k] - m)).sum();
            assert!((f[k] - ck / c0).abs() < 1e-12, "lag {k}");
        }
    }

    /// `m_count` AR(1) chains of `n` draws driven by a hash of the index,
    /// `frac(sin(k) 43758.5453) - 1/2` (`k = 100003 m + t`), chain `m`
    /// offset by `off m`: series numpy computes to the same digits, for
    /// comparisons with ArviZ.
    pub(crate) fn hashed_ar1(m_count: usize, n: usize, phi: f64, off: f64) -> Vec<Vec<f64>> {
        (0..m_count)
            .map(|m| {
                let mut x = 0.0;
                (0..n)
                    .map(|t| {
                        let k = (m * 100_003 + t) as f64;
                        let e = (k.sin() * 43_758.545_3).rem_euclid(1.0) - 0.5;
                        x = phi * x + e;
                        x + off * m as f64
                    })
                    .collect()
            })
            .collect()
    }

    /// The same numbers as ArviZ 0.23.4's `_ess_mean` on the same series:
    /// AR(1) chains driven by a hash of the index, `frac(sin(k) 43758.5453)`
    /// less 1/2 (ArviZ's values computed with numpy from that formula), with
    /// and without offsets between chains, a negative correlation (ESS
    /// above the draw count) and 11 draws (odd, the shortest sequence).
    #[test]
    fn ess_mean_matches_arviz() {
        let data = hashed_ar1;
        let d = data(4, 500, 0.8, 0.1);
        assert!((d[1][5] - -0.379_722_660_772_190_5).abs() < 1e-9);
        for ((m, n, phi, off), arviz) in [
            ((4, 500, 0.8, 0.1), 241.918_068_666_491_62),
            ((3, 11, 0.5, 0.0), 19.863_857_013_102_788),
            ((8, 300, 0.97, 0.0), 23.127_991_908_272_28),
            ((2, 1000, -0.6, 0.0), 6_602.059_991_327_962),
            ((6, 400, 0.9, 1.0), 6.781_387_070_818_389),
        ] {
            let ess = ess_mean(&data(m, n, phi, off));
            assert!(
                (ess / arviz - 1.0).abs() < 1e-9,
                "{m}x{n} phi {phi}: {ess} vs {arviz}"
            );
        }
    }

    /// The effective time of an AR(1) series is its tau, 19 for phi 0.9.
    #[test]
    fn effective_time_finds_the_tau_of_an_ar1_series() {
        let walkers = ar1_walkers();
        let tau = effective_time(&walkers);
        assert!((tau - 19.0).abs() < 0.05 * 19.0, "tau = {tau}");
        let mut bad = walkers[..2].to_vec();
        bad[1][7] = f64::NAN;
        assert!(effective_time(&bad).is_nan());
    }
}
