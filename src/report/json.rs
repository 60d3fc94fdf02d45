//! The `fit.json` report. Its keys are a contract documented in
//! `docs/cli.md`; add keys, never rename or remove them.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::data::{Aligned, Warning};
use crate::inference::design::DesignTable;
use crate::inference::identifiability::ParamIdentifiability;
use crate::inference::{MapEstimate, Noise, ParamSummary, PolishReport};
use crate::model::physical::Physical;

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
    /// Time from the release to the first sample used (s), in `[0, dt)`.
    pub lag: f64,
    /// `1`, or `-1` if the record was fitted mirrored (it starts with a > 0).
    pub polarity: f64,
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
            lag: data.lag,
            polarity: data.polarity,
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
    /// Maximised log-likelihood at the MAP, `sigma` profiled (the one BIC
    /// uses; for AR(1) noise on the whitened residuals).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_log_likelihood: Option<f64>,
    /// BIC at the MAP: `(d + 1) ln N - 2 max_log_likelihood`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bic: Option<f64>,
    /// Laplace log-evidence at the MAP (with `--evidence`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub log_evidence: Option<f64>,
    /// Residual standard deviation at the MAP, `sqrt(sse / n)` (m/s^2).
    pub sigma_hat: f64,
    /// Posterior evaluations in all (CMA-ES and polish).
    pub evaluations: u64,
    /// The CMA-ES runs.
    pub cmaes_runs: Vec<RunInfo>,
    /// The polish.
    pub polish: Option<PolishReport>,
    /// The second MAP search, present when the first left a structured
    /// residual ([`crate::inference::map::SecondSearch`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map_second_search: Option<crate::inference::map::SecondSearch>,
    /// Wall time of the MAP search (s); with `sampling.wall_time_s` the only
    /// keys that vary between runs with the same seed.
    pub wall_time_s: f64,
    /// Posterior summaries by parameter (present when sampled).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub posterior: Option<BTreeMap<String, ParamSummary>>,
    /// Parameter names, best determined first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ranking: Option<Vec<String>>,
    /// The least determined parameter.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weakest: Option<String>,
    /// Why it is weak.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub explanation: Option<String>,
    /// Per-parameter identifiability numbers, and under `design` the
    /// design table of the weakest parameter.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub identifiability: Option<IdentifiabilityReport>,
    /// Posterior correlation matrix, rows and columns in `names` order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub correlation: Option<Correlation>,
    /// Sampler diagnostics.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampling: Option<SamplingInfo>,
    /// Table 8.2 quantities at the MAP (when forces were given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub physical_map: Option<Physical>,
    /// Posterior of the Table 8.2 quantities (when forces were given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub physical: Option<BTreeMap<String, ParamSummary>>,
    /// The posterior's basins found by the MAP search, the MAP's first:
    /// one entry when the posterior has a single basin
    /// ([`crate::inference::basins`]).
    pub basins: Vec<BasinReport>,
    /// What makes this result probably wrong (empty when nothing does):
    /// codes and meanings in `docs/cli.md`.
    pub warnings: Vec<Warning>,
}

/// One entry of `basins` in fit.json.
#[derive(Debug, Clone, Serialize)]
pub struct BasinReport {
    /// Its best point, by parameter name.
    pub theta: BTreeMap<String, f64>,
    /// The log-posterior there.
    pub log_posterior: f64,
    /// Nats below the MAP.
    pub below_map: f64,
    /// The lowest fall of the log-posterior (nats) on the straight segment
    /// to a basin listed before it (0 for the first).
    pub barrier: f64,
    /// Share of the kept draws nearest to it (when sampled).
    pub share: Option<f64>,
}

/// `identifiability` in fit.json: one entry per parameter, and `design`.
#[derive(Debug, Clone, Serialize)]
pub struct IdentifiabilityReport {
    /// Per parameter, by name.
    #[serde(flatten)]
    pub params: BTreeMap<String, ParamIdentifiability>,
    /// What test would determine the weakest parameter to the target.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub design: Option<DesignTable>,
}

/// A correlation matrix with its names.
#[derive(Debug, Clone, Serialize)]
pub struct Correlation {
    /// Row and column names.
    pub names: Vec<String>,
    /// The matrix, row-major.
    pub matrix: Vec<Vec<f64>>,
}

/// How the posterior was sampled and how well.
#[derive(Debug, Clone, Serialize)]
pub struct SamplingInfo {
    /// Independent ensembles.
    pub ensembles: usize,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// Steps per ensemble, burn-in included.
    pub steps: usize,
    /// Burn-in steps discarded.
    pub burn_in: usize,
    /// Whether the stop rule held (`docs/inference.md`): the kept chain at
    /// least 50 and `--tau-multiple` autocorrelation times long (or the
    /// `--ess` target reached) and split R-hat at most 1.01 everywhere.
    pub converged: bool,
    /// Why not, with the numbers (absent when converged).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_converged: Option<String>,
    /// The moves and their weights, e.g. `stretch:1`.
    pub moves: String,
    /// Largest autocorrelation time over ensembles, by parameter (steps).
    pub tau: BTreeMap<String, f64>,
    /// Effective sample size by parameter.
    pub ess: BTreeMap<String, f64>,
    /// Rank-normalised split R-hat across ensembles, by parameter.
    pub rhat: BTreeMap<String, f64>,
    /// Acceptance fraction of each ensemble.
    pub acceptance: Vec<f64>,
    /// Log-posterior evaluations in this process.
    pub evaluations: u64,
    /// Chain files (CmdStan CSV, walker-major), relative to the output
    /// folder; empty with `--no-chains`.
    pub chains: Vec<String>,
    /// Every `thin`-th step after the burn-in is in the chain files
    /// (absent when none were written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thin: Option<usize>,
    /// Order of the rows in a chain file: `walker-major` (the draws of
    /// walker 1, then walker 2, ...).
    pub chain_layout: &'static str,
    /// Wall time of the sampling in this process (s).
    pub wall_time_s: f64,
    /// What became of the checkpoint: `{"status": "none" | "fresh"}`,
    /// `{"status": "resumed", "steps": N}` or `{"status": "discarded",
    /// "reason": "..."}` (a corrupted or foreign checkpoint, not resumed).
    pub checkpoint: crate::inference::CheckpointStatus,
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
            max_log_likelihood: None,
            bic: None,
            log_evidence: None,
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
            polish: map.polish.clone(),
            map_second_search: None,
            wall_time_s: map.wall_time,
            posterior: None,
            ranking: None,
            weakest: None,
            explanation: None,
            identifiability: None,
            correlation: None,
            sampling: None,
            physical_map: None,
            physical: None,
            basins: Vec::new(),
            warnings: Vec::new(),
        }
    }
}
