//! The `fit.json` report. Its keys are a contract documented in
//! `docs/cli.md`; add keys, never rename or remove them.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::data::Aligned;
use crate::inference::{MapEstimate, Noise};

/// Where the record came from and how it was aligned.
#[derive(Debug, Clone, Serialize)]
pub struct DataInfo {
    /// Path as given (or a description for embedded records).
    pub source: String,
    /// Samples used (from the release on).
    pub samples: usize,
    /// Sampling step (s).
    pub dt: f64,
    /// Release time in the record's clock (s).
    pub t0: f64,
    /// `"detected"` or `"given"`.
    pub t0_source: String,
}

impl DataInfo {
    /// From an aligned record.
    pub fn new(source: &str, data: &Aligned) -> Self {
        Self {
            source: source.to_string(),
            samples: data.a.len(),
            dt: data.dt,
            t0: data.t0,
            t0_source: data.source.as_str().to_string(),
        }
    }
}

/// One CMA-ES run.
#[derive(Debug, Clone, Serialize)]
pub struct RunInfo {
    /// Population size.
    pub popsize: usize,
    /// Evaluations used.
    pub evaluations: usize,
    /// Best log-posterior the run reached.
    pub log_posterior: f64,
    /// Why it ended.
    pub stop: String,
}

/// The polish step.
#[derive(Debug, Clone, Serialize)]
pub struct PolishInfo {
    /// Minus log-posterior before the polish.
    pub objective_before: f64,
    /// Minus log-posterior after.
    pub objective_after: f64,
    /// `e2` before.
    pub e2_before: f64,
    /// `e2` after.
    pub e2_after: f64,
    /// Simplex iterations.
    pub iterations: u64,
    /// Evaluations.
    pub evaluations: u64,
    /// Why it stopped.
    pub termination: String,
}

/// The contents of `fit.json`.
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// hbis version that wrote the file.
    pub hbis_version: String,
    /// Model spec.
    pub model: String,
    /// Seed of every random number used.
    pub seed: u64,
    /// Noise model, `"white"` or `"ar1"`.
    pub noise: String,
    /// The record.
    pub data: DataInfo,
    /// `e2` at the MAP.
    pub e2: f64,
    /// MAP values by parameter name.
    pub map: BTreeMap<String, f64>,
    /// Log-posterior at the MAP (up to the prior's normalisation).
    pub log_posterior: f64,
    /// Marginal log-likelihood at the MAP.
    pub log_likelihood: f64,
    /// Log-prior at the MAP.
    pub log_prior: f64,
    /// Residual standard deviation at the MAP, `sqrt(sse / n)` (m/s^2).
    pub sigma_hat: f64,
    /// Posterior evaluations in all (CMA-ES and polish).
    pub evaluations: u64,
    /// The CMA-ES runs.
    pub cmaes_runs: Vec<RunInfo>,
    /// The polish.
    pub polish: Option<PolishInfo>,
    /// Wall time of the MAP search (s); the only key that varies between
    /// runs with the same seed.
    pub wall_time_s: f64,
}

impl FitReport {
    /// Builds the report of a MAP search.
    pub fn from_map(
        model: &str,
        seed: u64,
        noise: Noise,
        data: DataInfo,
        map: &MapEstimate,
    ) -> Self {
        let sigma_hat = (map.eval.sse / data.samples as f64).sqrt();
        Self {
            hbis_version: env!("CARGO_PKG_VERSION").to_string(),
            model: model.to_string(),
            seed,
            noise: noise.as_str().to_string(),
            data,
            e2: map.eval.e2,
            map: map
                .names
                .iter()
                .cloned()
                .zip(map.theta.iter().copied())
                .collect(),
            log_posterior: map.eval.log_posterior,
            log_likelihood: map.eval.log_likelihood,
            log_prior: map.eval.log_prior,
            sigma_hat,
            evaluations: map.evaluations(),
            cmaes_runs: map
                .runs
                .iter()
                .map(|r| RunInfo {
                    popsize: r.popsize,
                    evaluations: r.evaluations,
                    log_posterior: -r.f_best,
                    stop: r.stop.as_str().to_string(),
                })
                .collect(),
            polish: map.polish.as_ref().map(|p| PolishInfo {
                objective_before: p.objective_before,
                objective_after: p.objective_after,
                e2_before: p.e2_before,
                e2_after: p.e2_after,
                iterations: p.iterations,
                evaluations: p.evaluations,
                termination: p.termination.clone(),
            }),
            wall_time_s: map.wall_time,
        }
    }
}
