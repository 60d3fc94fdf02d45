//! The stages every fit shares: `hbis fit`, `diagnose` and the ladder run
//! the same MAP search (with the white-noise start of an AR(1) fit and the
//! placement of a release detected between samples), the same model
//! comparison numbers and the same Laplace evidence.
//!
//! # Formula
//! ```text
//! ln L_hat = -(N/2) (ln(2 pi S/N) + 1) [+ ln(1 - rho^2)/2]   (sigma profiled; S whitened for AR(1))
//! BIC      = (d + 1) ln N - 2 ln L_hat                        (d parameters + sigma)
//! ln Z     = ln p(D|theta*) + ln p(theta*) + (d/2) ln 2 pi + (1/2) ln det Sigma
//! ```
//! with `p(D|theta)` the marginal likelihood of `docs/inference.md` and
//! `Sigma` the posterior covariance at the MAP (Laplace's approximation;
//! Beck & Yuen 2004), from a finite-difference Hessian of the log-posterior
//! (see [`laplace_evidence`]). The evidence shares the constant of Jeffreys'
//! improper prior on `sigma` across models of one record, so only
//! differences mean anything.
//!
//! ```
//! use hbis::inference::pipeline::profile_log_likelihood;
//! // Four residuals of sum of squares 0.1425, white noise:
//! let ln_l = profile_log_likelihood(4, 0.1425, None);
//! let by_hand = -2.0 * ((2.0 * std::f64::consts::PI * 0.1425 / 4.0).ln() + 1.0);
//! assert!((ln_l - by_hand).abs() < 1e-12);
//! ```

use rand::Rng;
use serde::Serialize;
use thiserror::Error;

use super::ensemble::SamplerError;
use super::laplace::{
    axis_scales, covariance_from, hessian, log_evidence, neighbourhood, scale_drop, Laplace, STEP,
};
use super::likelihood::{ar1_sum, sum_of_squares};
use super::release::{fit_lag, LagError};
use super::{
    find_map, MapError, MapEstimate, MapSettings, Noise, Posterior, PosteriorError, Priors,
};
use crate::data::Aligned;
use crate::model::{ForwardModel, SimError};

/// Why a shared stage failed.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// The posterior.
    #[error(transparent)]
    Posterior(#[from] PosteriorError),
    /// The MAP search.
    #[error("MAP search")]
    Map(#[from] MapError),
    /// Placing a release detected between two samples.
    #[error("placing the release between samples")]
    Lag(#[from] LagError),
    /// A simulation at the MAP.
    #[error("simulation at the MAP")]
    Sim(#[from] SimError),
    /// The sampler's density (while computing scales).
    #[error("conditional scales")]
    Scales(#[from] SamplerError),
}

/// A MAP fit: the posterior (with the record as placed) and its MAP.
#[derive(Debug, Clone)]
pub struct MapFit<M> {
    /// The posterior; its record carries the placed release.
    pub posterior: Posterior<M>,
    /// The MAP.
    pub map: MapEstimate,
}

/// The MAP of `model` for `data`, with `priors` (on the model's and the
/// noise model's parameters) and `noise`, from `start` (the model's
/// parameters) if given.
///
/// AR(1) noise can absorb a misfit, which gives the search broad false
/// basins: it starts from the white-noise MAP with `rho = 0`, which nests in
/// it. A release detected between two samples is placed with the model from
/// the white-noise MAP ([`fit_lag`]).
pub fn fit_map<M: ForwardModel + Clone, R: Rng + ?Sized>(
    model: M,
    data: Aligned,
    priors: Priors,
    noise: Noise,
    settings: &MapSettings,
    start: Option<Vec<f64>>,
    rng: &mut R,
) -> Result<MapFit<M>, PipelineError> {
    let clock = std::time::Instant::now();
    let mut preparation = 0;
    let mut data = data;
    let mut start = start;
    if noise != Noise::White || data.lag_unknown() {
        let layout = Posterior::layout_for(&model, noise);
        let model_names = layout.blocks()[0].params.len();
        let white_priors = priors.head(model_names);
        let white = Posterior::new(model.clone(), data.clone(), white_priors, Noise::White)?;
        let white_map = find_map(&white, &from(settings, start)?, rng)?;
        preparation += white_map.evaluations();
        let mut theta = white_map.theta;
        if data.lag_unknown() {
            let lagged = fit_lag(&white, &theta)?;
            preparation += lagged.evaluations;
            data = data.placed(lagged.lag);
            theta = lagged.theta;
        }
        start = Some(theta);
    }
    let posterior = Posterior::new(model, data, priors, noise)?;
    let start = start.map(|s| {
        if s.len() == posterior.dim() {
            s
        } else {
            posterior.with_noise_from_residual(&s)
        }
    });
    let mut map = find_map(&posterior, &from(settings, start)?, rng)?;
    map.preparation_evaluations += preparation;
    map.wall_time = clock.elapsed().as_secs_f64();
    Ok(MapFit { posterior, map })
}

/// `settings` started from `start` if given (else as they are).
fn from(settings: &MapSettings, start: Option<Vec<f64>>) -> Result<MapSettings, MapError> {
    match start {
        Some(s) => settings.clone().with_initial(Some(s)),
        None => Ok(settings.clone()),
    }
}

/// The numbers a model comparison needs, at a MAP.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Comparison {
    /// Maximised log-likelihood (sigma profiled).
    pub log_likelihood: f64,
    /// Bayesian information criterion.
    pub bic: f64,
    /// Samples.
    pub samples: usize,
    /// Parameters, `sigma` not counted.
    pub parameters: usize,
}

/// `ln L_hat` of `n` residuals whose (whitened) sum of squares is `s`;
/// `rho` adds the Jacobian of the AR(1) whitening.
pub fn profile_log_likelihood(n: usize, s: f64, rho: Option<f64>) -> f64 {
    let nf = n as f64;
    let white = -0.5 * nf * ((2.0 * std::f64::consts::PI * s / nf).ln() + 1.0);
    white + rho.map_or(0.0, |r| 0.5 * (1.0 - r * r).ln())
}

/// BIC and the maximised log-likelihood of `posterior` at `theta`: what
/// the neighbourhood of `theta` is worth ([`neighbourhood`]'s log-mean-exp
/// over a fixed design 1e-6 of each range away), so that a MAP on a corner
/// of the likelihood's knife edges, with no volume, does not count its
/// spike, while a favourable region with volume does.
pub fn compare<M: ForwardModel>(
    posterior: &Posterior<M>,
    theta: &[f64],
) -> Result<Comparison, PipelineError> {
    let (lo, hi) = posterior.priors().box_bounds();
    // Outside the prior's support (a constraint such as `f1 < f0`) the
    // model may not run: -inf there.
    let ll = |x: &[f64]| -> Result<f64, PipelineError> {
        if posterior.log_posterior(x)? == f64::NEG_INFINITY {
            return Ok(f64::NEG_INFINITY);
        }
        log_likelihood_at(posterior, x)
    };
    let log_likelihood = neighbourhood(&ll, theta, &lo, &hi)?
        .log_mean_exp
        .min(ll(theta)?);
    let n = posterior.data().a.len();
    let d = theta.len();
    Ok(Comparison {
        log_likelihood,
        bic: (d as f64 + 1.0) * (n as f64).ln() - 2.0 * log_likelihood,
        samples: n,
        parameters: d,
    })
}

/// The sigma-profiled log-likelihood of `posterior`'s record at `theta`.
fn log_likelihood_at<M: ForwardModel>(
    posterior: &Posterior<M>,
    theta: &[f64],
) -> Result<f64, PipelineError> {
    let r = posterior.residual(theta)?;
    let rho = posterior.noise_part(theta).first().copied();
    let s = match rho {
        Some(rho) => ar1_sum(&r, rho).0,
        None => sum_of_squares(&r),
    };
    Ok(profile_log_likelihood(r.len(), s, rho))
}

/// Laplace's approximation of the log-evidence at the MAP `theta`
/// (log-posterior `lp`), with the covariance from a finite-difference
/// Hessian of the log-posterior ([`super::laplace`]): deterministic, so the
/// same MAP gives the same evidence whatever the seed.
pub fn laplace_evidence<M: ForwardModel + Clone>(
    post: &Posterior<M>,
    theta: &[f64],
    lp: f64,
) -> Result<Laplace, PipelineError> {
    let (lo, hi) = post.priors().box_bounds();
    let range: Vec<f64> = lo.iter().zip(&hi).map(|(l, h)| h - l).collect();
    let f = |x: &[f64]| post.log_posterior(x);
    // The MAP's own value may be a spike above the bulk ([`bulk_value`]):
    // the curvature is the bulk's, and the centre is worth what its
    // neighbourhood is worth to the integral.
    let near = neighbourhood(&f, theta, &lo, &hi)?;
    let h: Vec<f64> = axis_scales(&f, theta, near.median.min(lp), &range, scale_drop(&near))?
        .iter()
        .zip(&range)
        .map(|(s, r)| (STEP * s).min(0.25 * r))
        .collect();
    let hess = hessian(&f, theta, &h, &lo, &hi)?;
    let (covariance, method) = covariance_from(&hess, &h);
    let laplace = log_evidence(near.log_mean_exp.min(lp), &covariance, &h);
    Ok(Laplace {
        log_evidence: laplace,
        covariance,
        method,
    })
}
