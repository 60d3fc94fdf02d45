//! Laplace's approximation and transitional MCMC against a log-evidence
//! known in closed form: a model linear in its parameters, fitted with the
//! crate's own likelihood (the noise sd integrated out under Jeffreys'
//! prior, `likelihood.rs`) and uniform priors (what TMCMC accepts, and the
//! crate's default).
//!
//! # The closed form
//! With `y = X beta + e` (`N` samples, `d` parameters), `A = X'X`, the
//! least-squares `beta_hat` and its sum of squares `S0`, the sum of squares
//! is `S(beta) = S0 (1 + q / S0)`, `q = (beta - beta_hat)' A (beta - beta_hat)`,
//! and the likelihood `ln L = ln Gamma(N/2) - ln 2 - (N/2) ln(pi S)` is a
//! multivariate t kernel in `beta`. With
//! `int (1 + x'Bx)^(-a) dx = pi^(d/2) Gamma(a - d/2) / Gamma(a) det(B)^(-1/2)`
//! (`a = N/2`, `B = A / S0`) and a uniform prior of volume `V` (wide enough
//! that the tails it cuts off are negligible: 2,000 posterior sds here),
//! ```text
//! ln Z = -ln V - ln 2 - ((N - d)/2) ln(pi S0) + ln Gamma((N - d)/2) - (1/2) ln det A
//! ```
//! Laplace's approximation at `beta_hat` (Hessian `-N A / S0`) falls short
//! of it by `ln Gamma((N-d)/2) - ln Gamma(N/2) + (d/2) ln(N/2)`, about
//! `d (d + 2) / (4 N)` = 0.0019 nat here: the posterior is Gaussian to
//! that order.

use hbis::inference::pipeline::laplace_evidence;
use hbis::inference::tmcmc::{tmcmc, TmcmcSettings};
use hbis::inference::{Noise, Posterior, Priors};
use hbis::model::{ForwardModel, ParamSpec, SimError};
use nalgebra::{DMatrix, DVector};
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, Normal};
use statrs::function::gamma::ln_gamma;

/// `a(t) = sum_k theta_k phi_k(t)`: a decaying oscillation of known
/// frequency and decay, in cosine and sine amplitudes, plus a decaying
/// offset (correlated with the cosine term, so `A` is not diagonal). The
/// basis is tabulated on the record's grid (TMCMC evaluates it some 10^5
/// times per run).
#[derive(Debug, Clone)]
struct LinearModel {
    dt: f64,
    table: Vec<[f64; 3]>,
}

const NAMES: [&str; 3] = ["b_cos", "b_sin", "b_off"];

fn basis(t: f64) -> [f64; 3] {
    let decay = (-0.3 * t).exp();
    let w = 2.0 * std::f64::consts::PI * 0.4;
    [decay * (w * t).cos(), decay * (w * t).sin(), decay]
}

impl LinearModel {
    fn new(dt: f64, n: usize) -> Self {
        Self {
            dt,
            table: (0..n).map(|i| basis(i as f64 * dt)).collect(),
        }
    }
}

impl ForwardModel for LinearModel {
    fn name(&self) -> String {
        "linear-basis".into()
    }

    fn params(&self) -> Vec<ParamSpec> {
        NAMES
            .iter()
            .map(|n| ParamSpec::new(n, "m/s^2", BOUNDS, 0.0))
            .collect()
    }

    fn accel_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let tabulated = start == 0.0 && dt == self.dt && out.len() <= self.table.len();
        for (i, o) in out.iter_mut().enumerate() {
            let phi = if tabulated {
                self.table[i]
            } else {
                basis(start + i as f64 * dt)
            };
            *o = theta.iter().zip(phi).map(|(b, p)| b * p).sum();
        }
        Ok(())
    }
}

/// The uniform prior of every coefficient.
const BOUNDS: (f64, f64) = (-3.0, 3.0);

/// A synthetic record's posterior and what the closed form needs.
struct Linear {
    post: Posterior<LinearModel>,
    /// The exact log-evidence.
    ln_z: f64,
    /// Least squares: the MAP.
    beta: DVector<f64>,
    /// `X'X`.
    a: DMatrix<f64>,
    /// The least sum of squares.
    s0: f64,
}

impl Linear {
    /// The record (10 s at 200 Hz, noise sd 0.02 m/s^2) and its fit.
    fn new() -> Self {
        let (n, dt) = (2001, 0.005);
        let truth = [-1.0, 0.4, 0.2];
        let noise = Normal::new(0.0, 0.02).unwrap();
        let mut rng = StdRng::seed_from_u64(31);
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let a: Vec<f64> = t
            .iter()
            .map(|&t| {
                let phi = basis(t);
                truth.iter().zip(phi).map(|(b, p)| b * p).sum::<f64>() + noise.sample(&mut rng)
            })
            .collect();
        let data = hbis::data::Record::new(t, a)
            .unwrap()
            .aligned(Some(0.0))
            .unwrap();
        let names: Vec<String> = NAMES.iter().map(|s| s.to_string()).collect();
        let priors = Priors::uniform(names, &[BOUNDS; 3]).unwrap();
        let post = Posterior::new(LinearModel::new(dt, n), data, priors, Noise::White).unwrap();
        // The design matrix on the posterior's own grid, column by column.
        let d = NAMES.len();
        let cols: Vec<Vec<f64>> = (0..d)
            .map(|k| {
                let mut e = vec![0.0; d];
                e[k] = 1.0;
                post.model_accel(&e).unwrap()
            })
            .collect();
        let y = DVector::from_column_slice(&post.data().a);
        let n = y.len();
        let x = DMatrix::from_fn(n, d, |i, k| cols[k][i]);
        let a = x.transpose() * &x;
        let beta = a.clone().cholesky().unwrap().solve(&(x.transpose() * &y));
        let s0 = (&y - &x * &beta).norm_squared();
        let (nf, df) = (n as f64, d as f64);
        let volume = (BOUNDS.1 - BOUNDS.0).powi(d as i32);
        let ln_z = -volume.ln()
            - std::f64::consts::LN_2
            - 0.5 * (nf - df) * (std::f64::consts::PI * s0).ln()
            + ln_gamma(0.5 * (nf - df))
            - 0.5 * a.determinant().ln();
        Self {
            post,
            ln_z,
            beta,
            a,
            s0,
        }
    }

    /// The posterior's log-likelihood from `S(beta) = S0 + q` (the same
    /// function as `Posterior::evaluate`, checked below, without
    /// simulating 2,001 samples per call).
    fn ln_like(&self, x: &[f64]) -> f64 {
        let n = self.post.data().a.len() as f64;
        let dev = DVector::from_column_slice(x) - &self.beta;
        let s = self.s0 + (dev.transpose() * &self.a * &dev)[0];
        ln_gamma(0.5 * n) - std::f64::consts::LN_2 - 0.5 * n * (std::f64::consts::PI * s).ln()
    }
}

/// Laplace's approximation of `hbis fit --evidence` (the pipeline's, with
/// its measured scales, finite-difference Hessian and neighbourhood value)
/// at the exact MAP. Besides the 0.0019 nat above, the Hessian's
/// differences over 2 and 4 conditional sds see the t kernel's quartic
/// term: each curvature comes out low by a relative 10 / N, the covariance
/// high by as much, `ln Z` high by about `5 d / N` = 0.0075 nat. So
/// Laplace should be 0.0056 nat above the exact value (measured: 0.0057);
/// the test allows 0.02, where a wrong constant (`ln 2 pi`), a wrong half
/// on the determinant or a Hessian off by a few percent fails.
#[test]
fn laplace_matches_the_exact_evidence_of_a_linear_model() {
    let lin = Linear::new();
    let beta: Vec<f64> = lin.beta.iter().copied().collect();
    let lp = lin.post.log_posterior(&beta).unwrap();
    let laplace = laplace_evidence(&lin.post, &beta, lp).unwrap();
    let (n, d) = (lin.post.data().a.len() as f64, beta.len() as f64);
    let gaussian_gap = ln_gamma(0.5 * (n - d)) - ln_gamma(0.5 * n) + 0.5 * d * (0.5 * n).ln();
    let exact = lin.ln_z;
    eprintln!(
        "exact ln Z = {exact:.5}; Laplace {:.5} ({:+.5}); textbook Laplace below exact by {gaussian_gap:.5}",
        laplace.log_evidence,
        laplace.log_evidence - exact
    );
    assert!(
        (laplace.log_evidence - exact).abs() < 0.02,
        "Laplace {} vs exact {exact}",
        laplace.log_evidence
    );
}

/// TMCMC with the settings of `tests/evidence.rs` (8,000 particles, 20
/// Metropolis steps per stage) against the exact value, over `SEEDS`
/// independent runs: their mean within 4 standard errors (sd over runs /
/// sqrt(SEEDS)) of the exact value, and the runs' sd below 0.25 nat, so
/// that TMCMC cannot pass by being noisy.
///
/// This likelihood is a t kernel, and its tempered versions `L^beta` are
/// t kernels of `beta N` degrees of freedom, heavy-tailed for the first
/// stages; with little mixing TMCMC under-estimates `ln Z` here (measured
/// over these 16 seeds: 0.94 nat low, sd 0.66, with the default 2,000
/// particles and 3 steps; 0.21 low with 10 steps; 0.11 with 20; 0.002
/// above, se 0.027, with 50), while on a Gaussian likelihood the defaults
/// are unbiased (`inference::tmcmc`'s tests). Measured with these
/// settings: 0.030 nat low, se 0.026, sd 0.10.
#[test]
fn tmcmc_matches_the_exact_evidence_of_a_linear_model() {
    const SEEDS: u64 = 16;
    let lin = Linear::new();
    // The shortcut is the posterior's own likelihood.
    let mut rng = StdRng::seed_from_u64(5);
    for _ in 0..20 {
        let x: Vec<f64> = lin
            .beta
            .iter()
            .map(|b| b + 0.01 * Normal::new(0.0, 1.0).unwrap().sample(&mut rng))
            .collect();
        let full = lin.post.evaluate(&x).unwrap().log_likelihood;
        assert!(
            (lin.ln_like(&x) - full).abs() < 1e-6,
            "{} vs {full}",
            lin.ln_like(&x)
        );
    }
    let (lower, upper): (Vec<f64>, Vec<f64>) = vec![BOUNDS; 3].into_iter().unzip();
    let settings = TmcmcSettings {
        particles: 8000,
        steps: 20,
        scale: 0.2,
    };
    let ln_like = |x: &[f64]| lin.ln_like(x);
    let runs: Vec<f64> = (0..SEEDS)
        .map(|seed| {
            let mut rng = StdRng::seed_from_u64(100 + seed);
            tmcmc(&ln_like, &lower, &upper, &settings, &mut rng).log_evidence
        })
        .collect();
    let exact = lin.ln_z;
    let k = SEEDS as f64;
    let mean = runs.iter().sum::<f64>() / k;
    let sd = (runs.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    let se = sd / k.sqrt();
    eprintln!(
        "exact ln Z = {exact:.4}; TMCMC mean {mean:.4} ({:+.4}, {:+.2} se), sd {sd:.4} over {SEEDS} runs",
        mean - exact,
        (mean - exact) / se
    );
    assert!(sd < 0.25, "TMCMC runs scatter by sd {sd}");
    assert!(
        (mean - exact).abs() < 4.0 * se,
        "TMCMC {mean} vs exact {exact} (se {se})"
    );
}
