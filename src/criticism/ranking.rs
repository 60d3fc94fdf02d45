//! Which catalog effect is missing: screen, refit, compare; and the ladder
//! that adds the best supported effect until none is.
//!
//! For each catalog effect absent from the current model:
//! - a **score test** at the current MAP (the new effect switched off):
//!   `S = (sum r_i g_i)^2 / (sigma^2 sum g_i^2)` per new parameter, `g` the
//!   derivative of the acceleration with respect to it (one-sided finite
//!   difference into its support), summed over the new parameters; about
//!   chi-square with that many degrees of freedom if the effect is absent;
//! - a **warm-started refit** (CMA-ES + polish, first run from the current
//!   MAP with the effect off, so the fit can only improve; retried with the
//!   new parameters moved into their support when the score test is large
//!   but the refit gained nothing), giving `e2`, the
//!   change of the maximised log-likelihood, of BIC and of the log-evidence
//!   by Laplace's approximation at the MAP (Beck & Yuen 2004);
//! - the diagnostic signature it explains.
//!
//! Candidates are ranked by BIC, best first. An effect is **supported**
//! when it lowers BIC by more than 10 (Kass & Raftery's "very strong");
//! otherwise it does not pay for its parameters.
//!
//! # Formula
//! ```text
//! ln L_hat = -(N/2) (ln(2 pi S/N) + 1)            (sigma profiled)
//! BIC      = (d + 1) ln N - 2 ln L_hat             (d model parameters + sigma)
//! ln Z     = ln p(D|theta*) + ln p(theta*) + (d/2) ln 2 pi + (1/2) ln det Sigma
//! ```
//! with `p(D|theta)` the marginal likelihood of `docs/inference.md` and
//! `Sigma` the posterior covariance (the inverse Hessian of the negative
//! log-posterior at the MAP in Laplace's approximation; here estimated by a
//! short ensemble run, see [`fit_model`]). Checked against transitional MCMC
//! (`inference::tmcmc`) in `tests/evidence.rs`. The evidence shares the
//! constant of Jeffreys' improper prior on `sigma` across models of one
//! record, so only differences mean anything.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use serde::Serialize;
use thiserror::Error;

use super::effects::{candidates, Composite};
use super::residuals::{diagnose, Diagnostics};
use crate::data::Aligned;
use crate::inference::summary::covariance;
use crate::inference::Polish;
use crate::inference::{
    conditional_scales, find_map, sample_posterior, MapError, MapSettings, Noise, Posterior,
    PosteriorError, Prior, Priors, SampleError, SampleSettings,
};
use crate::model::{ForwardModel, SimError};

/// Why a criticism step failed.
#[derive(Debug, Error)]
pub enum CriticismError {
    /// The posterior.
    #[error(transparent)]
    Posterior(#[from] PosteriorError),
    /// The MAP search.
    #[error("MAP search")]
    Map(#[from] MapError),
    /// A simulation.
    #[error("simulation")]
    Sim(#[from] SimError),
    /// The sampler's density (while computing scales).
    #[error("conditional scales")]
    Scales(#[from] crate::inference::ensemble::SamplerError),
    /// The short posterior run of the Laplace approximation.
    #[error("posterior covariance")]
    Sample(#[from] SampleError),
    /// Placing a release detected between two samples.
    #[error("placing the release between samples")]
    Lag(#[from] crate::inference::release::LagError),
}

/// A fitted model in the numbers the comparison needs.
#[derive(Debug, Clone, Serialize)]
pub struct ModelFit {
    /// Model name.
    pub model: String,
    /// Parameter names.
    pub names: Vec<String>,
    /// The MAP.
    pub theta: Vec<f64>,
    /// `e2` at the MAP.
    pub e2: f64,
    /// Maximised (sigma-profiled) log-likelihood.
    pub log_likelihood: f64,
    /// BIC.
    pub bic: f64,
    /// Log-evidence by Laplace's approximation (up to a constant shared by
    /// all models of one record).
    pub log_evidence: f64,
    /// Posterior evaluations spent.
    pub evaluations: u64,
}

/// A ranked candidate.
#[derive(Debug, Clone, Serialize)]
pub struct RankedCandidate {
    /// Catalog name.
    pub effect: String,
    /// The extended model's name.
    pub model: String,
    /// Score statistic at the current MAP.
    pub score: f64,
    /// `e2` after the refit.
    pub e2: f64,
    /// Change of the maximised log-likelihood.
    pub delta_log_likelihood: f64,
    /// Change of BIC (negative: better).
    pub delta_bic: f64,
    /// Change of the Laplace log-evidence.
    pub delta_log_evidence: f64,
    /// Whether it pays for its parameters (BIC lower by more than 10).
    pub supported: bool,
    /// The residual pattern it explains.
    pub signature: String,
    /// The refit.
    #[serde(skip)]
    pub fit: ModelFit,
    /// The extended model.
    #[serde(skip)]
    pub composite: Composite,
}

/// CMA-ES budget of a refit on the numerical engine.
pub const NUMERIC_BUDGET: usize = 20_000;

/// Score above which a refit without gain is retried from a moved start
/// (the 0.1 % point of chi-square with one degree of freedom is 10.8).
pub const SCORE_RETRY: f64 = 10.8;

/// BIC threshold for support.
pub const SUPPORT: f64 = 10.0;

/// Uniform priors over a composite model's default bounds.
pub fn priors_for(model: &Composite) -> Priors {
    let names = model.param_names();
    let priors = model
        .bounds()
        .into_iter()
        .map(|(lower, upper)| Prior::Uniform { lower, upper })
        .collect();
    Priors::from_parts(names, priors).expect("one bound per parameter")
}

/// `data` with a release detected between two samples placed by a fit of
/// `model` ([`crate::inference::release`]); other records as they are.
/// Every later fit of the record (candidates, ladder) keeps this placement.
pub fn place_release(
    model: &Composite,
    data: Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<Aligned, CriticismError> {
    if !data.lag_unknown() {
        return Ok(data);
    }
    let post = Posterior::new(model.clone(), data.clone(), priors_for(model), Noise::White)?;
    let mut rng = StdRng::seed_from_u64(seed);
    let map = find_map(&post, settings, &mut rng)?;
    Ok(replace_release(model, &data, &map.theta)?.0)
}

/// The release placed again by `model` from parameters `theta` near its
/// MAP: the record with the new lag, and the parameters that go with it.
fn replace_release(
    model: &Composite,
    data: &Aligned,
    theta: &[f64],
) -> Result<(Aligned, Vec<f64>), CriticismError> {
    let post = Posterior::new(model.clone(), data.clone(), priors_for(model), Noise::White)?;
    let lagged = crate::inference::release::fit_lag(&post, theta)?;
    Ok((data.clone().with_lag(lagged.lag), lagged.theta))
}

/// Fits `model` to `data` (white noise, default priors), warm-started from
/// `start` if given.
pub fn fit_model(
    model: &Composite,
    data: &Aligned,
    start: Option<Vec<f64>>,
    settings: &MapSettings,
    seed: u64,
) -> Result<ModelFit, CriticismError> {
    let post = Posterior::new(model.clone(), data.clone(), priors_for(model), Noise::White)?;
    let mut rng = StdRng::seed_from_u64(seed);
    let map = find_map(&post, &settings.clone().with_initial(start)?, &mut rng)?;
    let n = data.a.len() as f64;
    let d = map.theta.len();
    let log_l = -0.5 * n * ((2.0 * std::f64::consts::PI * map.eval.sse / n).ln() + 1.0);
    let bic = (d as f64 + 1.0) * n.ln() - 2.0 * log_l;
    let log_evidence = laplace(
        &post,
        &map.theta,
        map.eval.log_posterior,
        seed ^ 0x1A91_ACE0,
    )?;
    Ok(ModelFit {
        model: model.name(),
        names: map.names.clone(),
        theta: map.theta.clone(),
        e2: map.eval.e2,
        log_likelihood: log_l,
        bic,
        log_evidence,
        evaluations: map.evaluations(),
    })
}

/// Laplace's approximation of the log-evidence at the MAP, with the
/// posterior covariance estimated by a short ensemble run from the MAP (2
/// ensembles of `2 (d + 1)` walkers, 400 steps, the second half kept). A finite-difference Hessian
/// is not used: the likelihood is only piecewise smooth (reversals cross
/// sample instants as parameters change), and curvature measured over a
/// conditional sd mixes in those small jumps; on a 6-parameter test it put
/// ln Z 14 nats below the sampled-covariance value, which agrees with
/// transitional MCMC (`tests/evidence.rs`).
fn laplace(
    post: &Posterior<Composite>,
    theta: &[f64],
    lp: f64,
    seed: u64,
) -> Result<f64, CriticismError> {
    let d = theta.len();
    let (lo, hi) = post.priors().box_bounds();
    let range: Vec<f64> = lo.iter().zip(&hi).map(|(l, h)| h - l).collect();
    let h = conditional_scales(post, theta, &range)?;
    let walkers = 2 * (d + 1) + (2 * (d + 1)) % 2;
    let settings = SampleSettings::default()
        .with_ensembles(2)
        .and_then(|s| s.with_walkers(walkers.max(4)))
        .and_then(|s| s.with_max_steps(400))
        .and_then(|s| s.with_tau_multiple(1e9))
        .expect("valid settings");
    let sample = sample_posterior(
        post,
        post.names(),
        theta,
        &h,
        &settings,
        seed,
        None,
        "",
        &mut |_| {},
    )?;
    let cov = covariance(&sample.draws());
    let m = nalgebra::DMatrix::from_fn(d, d, |i, j| cov[i][j]);
    let half_log_det = match m.cholesky() {
        Some(c) => c.l().diagonal().iter().map(|v| v.ln()).sum::<f64>(),
        None => h.iter().map(|v| v.ln()).sum::<f64>(),
    };
    Ok(lp + 0.5 * d as f64 * (2.0 * std::f64::consts::PI).ln() + half_log_det)
}

/// Screens, refits and ranks every catalog effect absent from `current`.
pub fn rank_candidates(
    current: &Composite,
    fit: &ModelFit,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<Vec<RankedCandidate>, CriticismError> {
    let cands = candidates(current, &fit.theta);
    let mut model_now = vec![0.0; data.a.len()];
    data.model_accel_into(current, &fit.theta, &mut model_now)?;
    let r: Vec<f64> = data.a.iter().zip(&model_now).map(|(a, m)| a - m).collect();
    let sigma2 = r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64;
    let nuisance = jacobian(current, &fit.theta, &model_now, data);
    let mut rng = StdRng::seed_from_u64(seed);
    let mut out = Vec::new();
    for c in cands {
        let old = current.param_names();
        let new: Vec<usize> = c
            .model
            .param_names()
            .iter()
            .enumerate()
            .filter(|(_, n)| !old.contains(n))
            .map(|(i, _)| i)
            .collect();
        let score = score_test(
            &c.model, &c.start, &new, &model_now, &r, sigma2, data, &nuisance,
        );
        // The numerical engine costs some 30 times the closed form: its
        // refit gets a smaller budget (the warm start is already close).
        let budget = if c.model.velocity_friction() {
            settings
                .clone()
                .with_max_evals(NUMERIC_BUDGET)?
                .with_polish(Some(Polish::default().with_max_iters(300).expect("valid")))?
        } else {
            settings.clone()
        };
        let mut refit = fit_model(&c.model, data, Some(c.start.clone()), &budget, rng.random())?;
        // A large score with no gain means the refit stayed where the new
        // parameters are switched off (often on a bound): try again with
        // them a tenth of their range into the support.
        if score > SCORE_RETRY && refit.log_likelihood - fit.log_likelihood < 1.0 {
            let bounds = c.model.bounds();
            let mut start = c.start.clone();
            for &k in &new {
                let (lo, hi) = bounds[k];
                let step = 0.1 * (hi - lo);
                start[k] = if start[k] + step <= hi {
                    start[k] + step
                } else {
                    start[k] - step
                };
            }
            let second = fit_model(&c.model, data, Some(start), &budget, rng.random())?;
            if second.log_likelihood > refit.log_likelihood {
                refit = second;
            }
        }
        let delta_bic = refit.bic - fit.bic;
        out.push(RankedCandidate {
            effect: c.effect.clone(),
            model: refit.model.clone(),
            score,
            e2: refit.e2,
            delta_log_likelihood: refit.log_likelihood - fit.log_likelihood,
            delta_bic,
            delta_log_evidence: refit.log_evidence - fit.log_evidence,
            supported: delta_bic < -SUPPORT,
            signature: c.signature.clone(),
            fit: refit,
            composite: c.model.clone(),
        });
    }
    out.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    Ok(out)
}

/// The score statistic of the new parameters at the warm start.
#[allow(clippy::too_many_arguments)]
fn score_test(
    model: &Composite,
    start: &[f64],
    new: &[usize],
    base_accel: &[f64],
    r: &[f64],
    sigma2: f64,
    data: &Aligned,
    nuisance: &nalgebra::DMatrix<f64>,
) -> f64 {
    let bounds = model.bounds();
    // Projector onto the complement of the current model's tangent space:
    // the efficient score only counts what the current parameters cannot
    // already absorb.
    let qr = nuisance.clone().qr();
    let q = qr.q();
    let mut total = 0.0;
    let mut shifted = vec![0.0; r.len()];
    for &k in new {
        let (lo, hi) = &bounds[k];
        let mut probe = start.to_vec();
        let step = 1e-4 * (hi - lo);
        probe[k] = if start[k] + step <= *hi {
            start[k] + step
        } else {
            start[k] - step
        };
        if data.model_accel_into(model, &probe, &mut shifted).is_err() {
            continue;
        }
        let g = nalgebra::DVector::from_iterator(
            r.len(),
            shifted
                .iter()
                .zip(base_accel)
                .map(|(s, b)| (s - b) / (probe[k] - start[k])),
        );
        let g = &g - &q * (q.transpose() * &g);
        let gg: f64 = g.iter().map(|v| v * v).sum();
        if gg > 0.0 {
            let rg: f64 = r.iter().zip(&g).map(|(a, b)| a * b).sum();
            total += rg * rg / (sigma2 * gg);
        }
    }
    total
}

/// Finite-difference Jacobian of the model's acceleration (columns scaled
/// to unit length; only their span matters).
fn jacobian(
    model: &Composite,
    theta: &[f64],
    accel: &[f64],
    data: &Aligned,
) -> nalgebra::DMatrix<f64> {
    let bounds = model.bounds();
    let n = accel.len();
    let mut cols: Vec<nalgebra::DVector<f64>> = Vec::new();
    let mut shifted = vec![0.0; n];
    for (k, (lo, hi)) in bounds.iter().enumerate() {
        let mut x = theta.to_vec();
        let step = 1e-5 * (hi - lo);
        x[k] = if theta[k] + step <= *hi {
            theta[k] + step
        } else {
            theta[k] - step
        };
        if data.model_accel_into(model, &x, &mut shifted).is_err() {
            continue;
        }
        let c = nalgebra::DVector::from_iterator(n, shifted.iter().zip(accel).map(|(s, a)| s - a));
        let norm = c.norm();
        if norm > 0.0 {
            cols.push(c / norm);
        }
    }
    if cols.is_empty() {
        return nalgebra::DMatrix::zeros(n, 0);
    }
    nalgebra::DMatrix::from_columns(&cols)
}

/// One rung of the ladder.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Model after this step.
    pub model: String,
    /// Effect added at this step (`None` for the starting model).
    pub added: Option<String>,
    /// `e2`.
    pub e2: f64,
    /// BIC.
    pub bic: f64,
    /// Laplace log-evidence.
    pub log_evidence: f64,
    /// Time from the release to the first sample (s) this model was fitted
    /// with: a release detected between samples is placed again by each
    /// model of the ladder.
    pub lag: f64,
    /// The residual diagnosis of this model.
    #[serde(skip)]
    pub diagnosis: Diagnostics,
    /// The candidates considered after this model, best first.
    pub candidates: Vec<RankedCandidate>,
    /// The fit.
    #[serde(skip)]
    pub fit: ModelFit,
}

/// Diagnoses a fit of `model`.
pub fn diagnosis_of(
    model: &Composite,
    fit: &ModelFit,
    data: &Aligned,
) -> Result<Diagnostics, CriticismError> {
    let mut accel = vec![0.0; data.a.len()];
    data.model_accel_into(model, &fit.theta, &mut accel)?;
    let spec = model.spec();
    let base = spec
        .params_from_slice(&fit.theta[..model.n_spec()])
        .map_err(SimError::from)?;
    Ok(diagnose(&spec, &base, &data.a, &accel, data.dt)?)
}

/// From `start`: diagnose, add the best supported effect, refit, repeat
/// until nothing is supported (or `max_steps` effects were added).
pub fn ladder(
    start: Composite,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
    max_steps: usize,
) -> Result<Vec<Step>, CriticismError> {
    ladder_observed(start, data, settings, seed, max_steps, &mut |_| {})
}

/// [`ladder`], calling `on_step` with each step as soon as it is done (for
/// progress reports; the result does not depend on it).
pub fn ladder_observed(
    start: Composite,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
    max_steps: usize,
    on_step: &mut dyn FnMut(&Step),
) -> Result<Vec<Step>, CriticismError> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut model = start;
    let mut data = data.clone();
    let mut fit = fit_model(&model, &data, None, settings, rng.random())?;
    let mut added: Option<String> = None;
    let mut steps = Vec::new();
    for _ in 0..=max_steps {
        let diagnosis = diagnosis_of(&model, &fit, &data)?;
        let cands = rank_candidates(&model, &fit, &data, settings, rng.random())?;
        let next = cands.first().filter(|c| c.supported).cloned();
        steps.push(Step {
            model: model.name(),
            added: added.clone(),
            e2: fit.e2,
            bic: fit.bic,
            log_evidence: fit.log_evidence,
            lag: data.lag,
            diagnosis,
            candidates: cands,
            fit: fit.clone(),
        });
        on_step(steps.last().expect("just pushed"));
        match next {
            Some(c) if steps.len() <= max_steps => {
                added = Some(c.effect.clone());
                model = c.composite;
                fit = c.fit;
                if data.lag_unknown() {
                    // Placed by a model without this effect, the release
                    // may be off: the new model places it again.
                    let (placed, theta) = replace_release(&model, &data, &fit.theta)?;
                    data = placed;
                    fit = fit_model(&model, &data, Some(theta), settings, rng.random())?;
                }
            }
            _ => break,
        }
    }
    Ok(steps)
}
