//! Which catalog effect is missing: screen, refit, compare (the ladder that
//! searches over models with these rankings is [`super::search`]).
//!
//! For each catalog effect absent from the current model:
//! - a **score test** at the current MAP (the new effect switched off):
//!   `S = (sum r_i g_i)^2 / (sigma^2 sum g_i^2)` per new parameter, `g` the
//!   derivative of the acceleration with respect to it (one-sided finite
//!   difference into its support), summed over the new parameters; about
//!   chi-square with that many degrees of freedom if the effect is absent.
//!   Where the likelihood is continuous (an averaging sensor) it screens:
//!   a candidate whose score is below [`screen_threshold`] is not
//!   refitted ([`Ranking::screened`]); under the instantaneous sensor it is
//!   only reported;
//! - a **multi-start refit** (CMA-ES + polish): from the current MAP with
//!   the effect off (so the fit can only improve), and from spread starts
//!   with the new parameters at a quarter and three quarters of their range
//!   (mid-range only on the numerical engine, which costs some 12 to 30
//!   times the closed form; a start where the effect does nothing moves to
//!   where it acts); each start runs a local search (one CMA-ES run and the
//!   polish), and where the starts disagree by more than one unit of
//!   log-likelihood a global search runs from the best of them (not on the
//!   numerical engine with the instantaneous sensor, where it ran to its
//!   budget without converging); the best is kept and the report says how
//!   many starts reached it. Other warm-started refits are local too. It
//!   gives `e2`, the change of the maximised
//!   log-likelihood, of BIC and of the log-evidence by Laplace's
//!   approximation at the MAP (Beck & Yuen 2004);
//! - the diagnostic signature it explains.
//!
//! A candidate that needs the numerical engine is compared with the current
//! model refitted on that engine ([`Model::numerically`]): the engines
//! place an event to about 1e-9 s, and a closed-form MAP can sit where a
//! reversal falls on a sample instant, so one sample lands on the other
//! side of a friction jump; any extra parameter can move the reversal back,
//! which would pass for support. That baseline is also refitted from the
//! current model's part of the best numerical refit when that is better.
//!
//! Candidates are ranked by BIC, best first. An effect is **supported**
//! when it lowers BIC by more than 10 (Kass & Raftery's "very strong"),
//! and lowers it on the samples away from the reversals too
//! ([`super::off_jumps`]); otherwise it does not pay for its parameters.
//!
//! BIC, the maximised log-likelihood and the Laplace evidence are those of
//! [`crate::inference::pipeline`], which `hbis fit` reports too; checked
//! against transitional MCMC (`inference::tmcmc`) in `tests/it/evidence.rs`.
//!
//! The candidates come from a [`Registry`]: the built-in catalog, or one a
//! library user extended with their own components.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use super::features::{Feature, FeatureKind};
use super::missing_form::{missing_form, MissingForm, OutOfCatalog};
use super::off_jumps;
use super::residuals::{diagnose, short_lag_rho, Diagnostics, LJUNG_BOX_LAGS};
use super::sanity::bound_reached;
use super::search::carried;
use crate::data::Aligned;
use crate::inference::pipeline::{
    compare, fit_map, laplace_evidence, Comparison, MapFit, PipelineError,
};
use crate::inference::Polish;
use crate::inference::{MapError, MapSettings, Noise, Posterior, PosteriorError, Priors};
use crate::model::effect_file::FileEffect;
use crate::model::{Candidate, ForceComponent, ForwardModel, Model, Registry, SimError};

/// Why a criticism step failed.
#[derive(Debug, Error)]
pub enum CriticismError {
    /// The posterior.
    #[error(transparent)]
    Posterior(#[from] PosteriorError),
    /// The MAP search settings.
    #[error("MAP search")]
    Map(#[from] MapError),
    /// A simulation.
    #[error("simulation")]
    Sim(#[from] SimError),
    /// A stage shared with `hbis fit` (MAP, release placement, evidence).
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
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
    /// Posterior standard deviations at the MAP (Laplace covariance), one
    /// per coordinate of `theta`.
    pub sd: Vec<f64>,
    /// Posterior evaluations spent.
    pub evaluations: u64,
    /// The noise model of the fit (`theta` ends with its parameters).
    pub noise: Noise,
    /// Whether its MAP search stopped at its evaluation budget instead of
    /// converging ([`crate::inference::MapEstimate::at_budget`]).
    pub at_budget: bool,
    /// Whether its global search reached its best value twice
    /// ([`crate::inference::MapEstimate::best_repeated`]; `None` for a
    /// local search).
    #[serde(skip)]
    pub best_repeated: Option<bool>,
}

impl ModelFit {
    /// The model's part of the MAP (without the noise model's `rho`).
    pub fn model_theta(&self, model: &Model) -> &[f64] {
        Posterior::layout_for(model, self.noise).values(&self.theta, 0)
    }
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
    /// Change of BIC on the samples away from either model's reversals,
    /// stops and starts ([`off_jumps`]); `None` under an averaging
    /// sensor, whose reading has no step in the event times.
    pub delta_bic_off_jumps: Option<f64>,
    /// Change of the Laplace log-evidence.
    pub delta_log_evidence: f64,
    /// Its refit's raw `e2` over the current model's (not whitened): a
    /// refit beyond [`raw_e2_limit`] is not supported.
    pub raw_e2_ratio: f64,
    /// Whether it pays for its parameters (BIC lower by more than 10, and
    /// lower away from the reversals too) with a raw `e2` no worse than
    /// the noise explains.
    pub supported: bool,
    /// The residual pattern it explains.
    pub signature: String,
    /// Starts of the refit (the warm start and spread starts).
    pub starts: usize,
    /// How many of them reached the best refit (within one unit of
    /// log-likelihood).
    pub agreeing: usize,
    /// Whether its refit converged: two runs reached the best (two of its
    /// starts, or a local search from the best so far that gained at most
    /// one unit of log-likelihood; [`SETTLE_ROUNDS`] searches at most). A
    /// refit that did not converge is not supported, not ranked (it is
    /// listed after the ranked ones) and `reason` says so.
    pub converged: bool,
    /// Whether the best refit's search stopped at its evaluation budget
    /// instead of converging: its BIC and `e2` bound what the model can
    /// reach from above, and `reason` says so.
    pub at_budget: bool,
    /// Posterior evaluations of the best refit's search.
    pub evaluations: u64,
    /// The residual structure it targets (empty: serial correlation).
    pub targets: Vec<FeatureKind>,
    /// Whether the evidence supports it (log Bayes factor above
    /// [`EVIDENCE`]).
    pub evidence_supports: bool,
    /// How far its own parameters are from their neutral values: the
    /// profile-likelihood ratio against the refitted current model as a
    /// normal quantile ([`profile_z`]).
    pub moved_z: f64,
    /// The largest distance of its own parameters from their neutral
    /// values in units of their physical scale
    /// ([`crate::model::ParamSpec::scale`]),
    /// over the parameters whose neutral value switches the effect off
    /// (not the spring's shape); `None` when it has none.
    pub physical_size: Option<f64>,
    /// Whether `moved_z` is beyond [`MOVED_Z`] (the 99 % profile interval
    /// excludes the neutral values) and `physical_size` at least 1.
    pub moved: bool,
    /// The targeted feature's magnitude before (current model) and after
    /// (refit), for the target that shrank most.
    pub target_before: f64,
    /// See `target_before`.
    pub target_after: f64,
    /// Whether it fell to at most [`SHRINK`] of its value.
    pub shrinks: bool,
    /// Supported, evidence, moved and shrinks: the ladder may add it.
    pub accepted: bool,
    /// Why it is accepted or not, with the numbers.
    pub reason: String,
    /// The refit.
    #[serde(skip)]
    pub fit: ModelFit,
    /// The extended model.
    #[serde(skip)]
    pub extended: Model,
    /// The parameter of the current model its refit puts on a prior bound,
    /// when that alone keeps it out (every other gate passes, the missing
    /// form's stand-in check included): the ladder may swap it for the
    /// effect that parameter belongs to ([`super::search`], "unpin").
    #[serde(skip)]
    pub pinned_only: Option<String>,
    /// The residual structure its refit makes significant where it was
    /// not, when that alone keeps it out (every other gate passes, the
    /// missing form's stand-in check included): the ladder may add it
    /// with a candidate that removes that structure again
    /// ([`super::search`], "unmask").
    #[serde(skip)]
    pub worsens_only: Option<FeatureKind>,
}

/// CMA-ES budget of a refit on the numerical engine.
pub const NUMERIC_BUDGET: usize = 20_000;

/// BIC threshold for support.
pub const SUPPORT: f64 = 10.0;

/// The least share of a candidate's BIC gain that must lie on the
/// samples away from the reversals ([`off_jumps`]). Chosen on seed
/// 261492124 (docs/criticism.md, 2026-12-05): there a sensor-noise
/// null's addition had 4 % of its gain away from them, the hidden
/// effects' own refits 61.5 % to 108.5 %, and a true asymmetric friction
/// of `tests/it/components.rs`, whose constant force ends where the mass
/// stops, 30 %.
pub const OFF_JUMPS_SHARE: f64 = 0.2;

/// Log Bayes factor (Laplace) a candidate needs: Kass & Raftery's
/// "positive" (`2 ln B > 2`).
pub const EVIDENCE: f64 = 1.0;

/// How far (as a normal quantile of the profile-likelihood ratio) a
/// candidate's own parameters must be from their neutral values: the
/// 99 % profile interval excludes them.
pub const MOVED_Z: f64 = 2.576;

/// A targeted feature must fall to this fraction of its value.
pub const SHRINK: f64 = 0.9;

/// When the best candidate is not clearly told from another: both
/// supported, and the runner-up reaches at least half of the best's BIC
/// gain or comes within [`SUPPORT`] of it. The sentence names both, their
/// numbers, and whether the difference decides (at least [`SUPPORT`]).
///
/// ```
/// use hbis::criticism::ranking::caution_for;
/// // A distant runner-up: nothing to say.
/// assert_eq!(caution_for(&[("trilinear", -978.5), ("velocity-friction", -65.4)]), None);
/// // Friction that decays with travel mistaken for lcfm (docs/components.md).
/// let s = caution_for(&[("lcfm", -24.7), ("friction-decay", -13.2)]).unwrap();
/// assert!(s.contains("friction-decay") && s.contains("53 %") && s.contains("11.5"));
/// assert!(caution_for(&[("a", -30.0), ("b", -25.0)]).unwrap().contains("does not tell them apart"));
/// ```
pub fn caution_for(ranked: &[(&str, f64)]) -> Option<String> {
    let (best, b) = *ranked.first()?;
    let &(rival, d) = ranked.get(1)?;
    let close = d - b < SUPPORT.max(0.5 * b.abs());
    if b >= -SUPPORT || d >= -SUPPORT || !close {
        return None;
    }
    let share = 100.0 * d / b;
    let verdict = if d - b < SUPPORT {
        format!(
            "the difference, {:.1} in BIC, is under {SUPPORT} and does not tell them apart: this record does not say which of them it holds",
            d - b
        )
    } else {
        format!(
            "the difference, {:.1} in BIC, favours `{best}`, but one may stand in for the other; the ladder adds `{rival}` next only if it is still accepted",
            d - b
        )
    };
    Some(format!(
        "`{best}` (delta BIC {b:+.1}) and `{rival}` (delta BIC {d:+.1}) both explain much of the residual (`{rival}` reaches {share:.0} % of the best's gain in BIC): {verdict}."
    ))
}

/// What a criticism step concludes: the candidate added and why, or why
/// none is, and (when none is) the residual structure left unexplained,
/// in numbers.
pub fn conclusion(diagnosis: &Diagnostics, ranked: &[RankedCandidate]) -> String {
    if let Some(c) = ranked.iter().find(|c| c.accepted) {
        return format!("`{}` {}.", c.effect, c.reason);
    }
    let left: Vec<String> = diagnosis
        .features
        .iter()
        .filter(|f| f.significant)
        .map(|f| {
            let name = kind_name(f.kind);
            if f.z.is_finite() {
                format!("{name} {:.3} ({:.1} standard errors)", f.magnitude, f.z)
            } else {
                format!("{name} {:.3}", f.magnitude)
            }
        })
        .collect();
    let best = ranked
        .first()
        .map(|c| format!(" The best candidate, `{}`, is {}.", c.effect, c.reason))
        .unwrap_or_default();
    if diagnosis.e2.is_nan() || diagnosis.e2 > crate::criticism::sanity::EXPLAINS_NOTHING_E2 {
        format!(
            "No conclusion: the model explains only {:.1} % of the record (e2 = {:.4}), so no effect can be judged on its residual.{best}",
            100.0 * (1.0 - diagnosis.e2).max(0.0),
            diagnosis.e2
        )
    } else if left.is_empty() {
        format!("No effect is added: the residual shows no structure left.{best}")
    } else {
        format!(
            "No catalog effect explains the residual's remaining structure: {}.{best}",
            left.join("; ")
        )
    }
}

/// [`caution_for`] of the supported candidates among `ranked`.
pub fn caution(ranked: &[RankedCandidate]) -> Option<String> {
    let pairs: Vec<(&str, f64)> = ranked
        .iter()
        .filter(|c| c.supported)
        .map(|c| (c.effect.as_str(), c.delta_bic))
        .collect();
    caution_for(&pairs)
}

/// The longest correlation time (s) criticism lets the measurement error
/// have.
///
/// Sensor noise is correlated by the data acquisition's anti-alias filter
/// and the sensor's own dynamics, over milliseconds: the calibration's
/// sensor chain ([`super::calibration::sensor_noise`]: AR(1) noise with
/// coefficient 0.5 through a 40 Hz Butterworth filter) has a lag-one
/// correlation of 0.82 at 200 Hz, a correlation time of 25 ms. A misfit of
/// the structure's motion (periods of 0.5 s and longer) is correlated over
/// a tenth of a period and more: at 200 Hz its lag-one correlation is 0.99
/// and above. With `rho` free up to 0.999, an AR(1) error model whitens
/// such a misfit away (the whitened residual keeps a thousandth of it) and
/// buys a BIC gain with a worse fit.
pub const NOISE_MEMORY_S: f64 = 0.1;

/// The bound on `|rho|` for samples `dt` apart: `exp(-dt / NOISE_MEMORY_S)`.
///
/// # Formula
/// `rho_max = exp(-dt / tau_max)`, the lag-one correlation of an error
/// with correlation time `tau_max` ([`NOISE_MEMORY_S`]).
///
/// ```
/// use hbis::criticism::ranking::rho_max;
/// // 200 Hz: 0.951; 1 kHz: 0.990.
/// assert!((rho_max(0.005) - 0.9512).abs() < 1e-4);
/// assert!((rho_max(0.001) - 0.9900).abs() < 1e-4);
/// ```
pub fn rho_max(dt: f64) -> f64 {
    (-dt / NOISE_MEMORY_S).exp()
}

/// Uniform priors over the bounds the model's components declare, and for
/// AR(1) noise `rho` uniform on `[-rho_max, rho_max]` ([`rho_max`] of the
/// record's sampling interval `dt`): criticism's error model must not
/// absorb a misfit of the structure's motion.
pub fn priors_for(model: &Model, noise: Noise, dt: f64) -> Priors {
    let layout = Posterior::layout_for(model, noise);
    let r = rho_max(dt);
    let bounds: Vec<(f64, f64)> = layout
        .names()
        .iter()
        .zip(layout.bounds())
        .map(|(n, b)| if n == "rho" { (-r, r) } else { b })
        .collect();
    Priors::uniform(layout.names(), &bounds).expect("one bound per name")
}

/// `data` with a release detected between two samples placed by a fit of
/// `model` (the stage `hbis fit` runs, [`fit_map`]); other records as they
/// are. Every later fit of the record (candidates, ladder) keeps this
/// placement.
pub fn place_release(
    model: &Model,
    data: Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<Aligned, CriticismError> {
    if !data.lag_unknown() {
        return Ok(data);
    }
    let mut rng = StdRng::seed_from_u64(seed);
    let priors = priors_for(model, Noise::White, data.dt);
    let fit = fit_map(
        model.clone(),
        data,
        priors,
        Noise::White,
        settings,
        None,
        &mut rng,
    )?;
    Ok(fit.posterior.data().clone())
}

/// The release placed again by `model` from parameters `theta` near its
/// MAP: the record with the new lag, and the parameters that go with it.
pub(super) fn replace_release(
    model: &Model,
    data: &Aligned,
    theta: &[f64],
) -> Result<(Aligned, Vec<f64>), CriticismError> {
    let post = Posterior::new(
        model.clone(),
        data.clone(),
        priors_for(model, Noise::White, data.dt),
        Noise::White,
    )?;
    let lagged = crate::inference::release::fit_lag(&post, theta).map_err(PipelineError::from)?;
    Ok((data.clone().placed(lagged.lag), lagged.theta))
}

/// Fits `model` to `data` (default priors, `noise`) with the MAP stage
/// `hbis fit` runs, or from `start` (the model's parameters) if given, by
/// a local search (one CMA-ES run and the polish); BIC and the Laplace
/// evidence at the MAP.
pub fn fit_model(
    model: &Model,
    data: &Aligned,
    noise: Noise,
    start: Option<Vec<f64>>,
    settings: &MapSettings,
    seed: u64,
) -> Result<ModelFit, CriticismError> {
    let settings = &local_from_warm(start.is_some(), settings)?;
    let (fit, cmp) = map_of(model, data, noise, start, settings, seed)?;
    with_evidence(model, &fit, cmp)
}

/// The start model's fit: a global search, and a second one from new
/// starts where the first never reached its best value twice
/// ([`crate::inference::map::found_twice`]); the better of the two is
/// kept. On a model that lacks what the record holds the global search's
/// runs can end far apart: of 12 cold fits of `trilinear+lcfm+viscous` on
/// four Maxwell records of the calibration generator, 4 ended more than 2
/// nats below the best of six; with the second search where the runs
/// disagreed (7 of the 12), 1 did (docs/criticism.md, 2026-11-30). Where
/// the runs agree, nothing changes.
pub fn start_fit(
    model: &Model,
    data: &Aligned,
    noise: Noise,
    settings: &MapSettings,
    seed: u64,
) -> Result<ModelFit, CriticismError> {
    let fit = fit_model(model, data, noise, None, settings, seed)?;
    if fit.best_repeated != Some(false) {
        return Ok(fit);
    }
    let again = fit_model(model, data, noise, None, settings, seed ^ SECOND_START)?;
    let evaluations = fit.evaluations + again.evaluations;
    let mut kept = if again.log_likelihood > fit.log_likelihood {
        again
    } else {
        fit
    };
    kept.evaluations = evaluations;
    Ok(kept)
}

/// Mixed into the seed of [`start_fit`]'s second search.
const SECOND_START: u64 = 0x5EC0_4D5E_A4C8;

/// A warm-started search runs locally: one CMA-ES run from its start
/// (step 0.02 of the unit box) and the polish, without the global
/// restarts. On the demo's `record.csv` its runs ended by `tol_fun` after
/// 1,700 to 5,800 evaluations, where the global sequence from the same
/// start used up to its whole budget.
fn local_from_warm(warm: bool, settings: &MapSettings) -> Result<MapSettings, MapError> {
    if warm {
        settings.clone().with_restarts(0)
    } else {
        Ok(settings.clone())
    }
}

/// Whether starts of a refit that disagree lead to a global search from
/// the best of them. Not on the numerical engine with the instantaneous
/// sensor: there the global search ran to its 20,000-evaluation budget on
/// every numerical candidate of the demo's `record.csv` without
/// converging, and without it the calibration study's totals stayed the
/// same (40 records, seed 146544: 0 of 16 null records with an effect
/// added, 24 of 24 hidden effects first, 16 accepted; docs/criticism.md;
/// records were not compared one by one).
fn escalates(model: &Model) -> bool {
    model.closed_form() || model.interval_mean()
}

/// The MAP stage alone (no evidence), with its comparison numbers.
fn map_of(
    model: &Model,
    data: &Aligned,
    noise: Noise,
    start: Option<Vec<f64>>,
    settings: &MapSettings,
    seed: u64,
) -> Result<(MapFit<Model>, Comparison), CriticismError> {
    let mut rng = StdRng::seed_from_u64(seed);
    let fit = fit_map(
        model.clone(),
        data.clone(),
        priors_for(model, noise, data.dt),
        noise,
        settings,
        start,
        &mut rng,
    )?;
    let cmp = compare(&fit.posterior, &fit.map.theta)?;
    Ok((fit, cmp))
}

/// A MAP with its Laplace evidence.
fn with_evidence(
    model: &Model,
    fit: &MapFit<Model>,
    cmp: Comparison,
) -> Result<ModelFit, CriticismError> {
    let map = &fit.map;
    let laplace = laplace_evidence(&fit.posterior, &map.theta, map.eval.log_posterior)?;
    let log_evidence = laplace.log_evidence;
    let sd = (0..map.theta.len()).map(|k| laplace.sd(k)).collect();
    Ok(ModelFit {
        model: model.name(),
        names: map.names.clone(),
        theta: map.theta.clone(),
        e2: map.eval.e2,
        log_likelihood: cmp.log_likelihood,
        bic: cmp.bic,
        log_evidence,
        sd,
        evaluations: map.evaluations(),
        noise: fit.posterior.noise(),
        at_budget: map.at_budget(),
        best_repeated: map.best_repeated,
    })
}

/// Fractions of the prior range tried, in order, for a spread start whose
/// requested fraction leaves the new component without effect.
const FALLBACK: [f64; 7] = [0.25, 0.75, 0.125, 0.375, 0.625, 0.875, 0.0625];

/// A start changes the prediction by less than this fraction of its RMS:
/// the new component has no effect there (the engine's own error is
/// some 1e-8 relative).
const NO_EFFECT: f64 = 1e-6;

/// Starts of a candidate's refit: the warm start (the new parameters
/// switched off), then one spread start per entry of `spread`, the new
/// parameters at that fraction of their prior range (the others at the
/// current MAP).
///
/// A spread start where the component does nothing on this record sits on
/// a plateau that the search may never leave: mid-range, a stopper's
/// `gap` lay beyond the release amplitude, and whether CMA-ES found the
/// stopper then hung on 1e-6 changes in the engine. Such a start moves to
/// the first [`FALLBACK`] fraction (not already used) where the component
/// acts; if none does, it stays.
fn starts(c: &Candidate, new: &[usize], spread: &[f64], data: &Aligned) -> Vec<Vec<f64>> {
    let bounds = c.model.bounds();
    let at = |f: f64| {
        let mut s = c.start.clone();
        for &k in new {
            s[k] = fraction_of(bounds[k], f);
        }
        s
    };
    let mut warm = vec![0.0; data.a.len()];
    // A start the engine cannot solve is left to the search to reject.
    let checked = data.model_accel_into(&c.model, &c.start, &mut warm).is_ok();
    let scale = NO_EFFECT * rms(&warm);
    let mut buf = vec![0.0; warm.len()];
    let mut acts = |s: &[f64]| {
        !checked
            || data.model_accel_into(&c.model, s, &mut buf).is_err()
            || rms_diff(&buf, &warm) > scale
    };
    let mut used: Vec<f64> = spread.to_vec();
    let mut out = vec![c.start.clone()];
    for &f in spread {
        let mut chosen = at(f);
        if !acts(&chosen) {
            if let Some(&g) = FALLBACK
                .iter()
                .filter(|g| !used.contains(g))
                .find(|&&g| acts(&at(g)))
            {
                used.push(g);
                chosen = at(g);
            }
        }
        out.push(chosen);
    }
    out
}

/// The point at fraction `f` of the range `(lo, hi)`: on a log scale
/// where the range spans two decades or more from a positive bound, as
/// [`crate::inference::find_map`] searches it. Mid-range on a linear
/// scale, the example effect file's Maxwell time constant (0.02-5 s)
/// started at 2.5 s; on a record with 0.3 s the ladder's refit of
/// `maxwell-file` from there and from the warm start fell short of the
/// missing form's memory term of 0.306 s (BIC -63.7), and the ladder
/// refused it as a stand-in for that term (2026-12-04, on the exact flow,
/// `memory_fit::the_ladder_adds_the_maxwell_effect_file`).
fn fraction_of((lo, hi): (f64, f64), f: f64) -> f64 {
    if crate::inference::map::log_scaled(lo, hi) {
        lo * (hi / lo).powf(f)
    } else {
        lo + f * (hi - lo)
    }
}

fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    let sq: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    (sq / a.len().max(1) as f64).sqrt()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Refits `c` from each start, each start's seed drawn from `rng` in
/// order; the fits, to be settled by [`converged_best`].
fn multi_start(
    c: &Candidate,
    starts: Vec<Vec<f64>>,
    cold: bool,
    data: &Aligned,
    noise: Noise,
    settings: &MapSettings,
    rng: &mut StdRng,
) -> Result<Started, CriticismError> {
    // Each start runs a local search; the global search runs only where
    // the starts disagree, from the best of them.
    let per_start = local_from_warm(true, settings)?;
    let n = starts.len();
    let mut fits = Vec::new();
    // The seeds drawn in order, the starts run side by side: the same fits
    // as one after the other (each depends on its seed alone).
    let seeded: Vec<(Vec<f64>, u64)> = starts.into_iter().map(|s| (s, rng.random())).collect();
    let confirm_seed = seeded.first().map_or(0, |s| s.1);
    let results: Vec<_> = seeded
        .into_par_iter()
        .map(|(s, seed)| map_of(&c.model, data, noise, Some(s), &per_start, seed))
        .collect();
    for result in results {
        match result {
            Ok(fit) => fits.push(fit),
            // A spread start where the density is zero, which a local
            // search cannot leave.
            Err(CriticismError::Pipeline(PipelineError::Map(MapError::NothingFeasible {
                ..
            }))) if !fits.is_empty() => {}
            Err(e) => return Err(e),
        }
    }
    if cold {
        fits.push(map_of(&c.model, data, noise, None, settings, rng.random())?);
    }
    let n = n + usize::from(cold);
    if agreeing(&fits) < n && escalates(&c.model) {
        let from = fits.get(best_of(&fits)).map(|(f, _)| {
            Posterior::layout_for(&c.model, noise)
                .values(&f.map.theta, 0)
                .to_vec()
        });
        fits.push(map_of(&c.model, data, noise, from, settings, rng.random())?);
    }
    Ok(Started {
        fits,
        per_start,
        confirm_seed,
    })
}

/// A candidate's fits from its starts ([`multi_start`]), with the
/// settings and seed its searches from the best use ([`settle`]).
struct Started {
    fits: Vec<Refitted>,
    per_start: MapSettings,
    confirm_seed: u64,
}

/// The best of a candidate's fits once settled ([`settle`]), with its
/// evidence and how many runs reached it. Depends on `started` alone (no
/// shared generator): candidates are settled side by side, since a
/// settling search is one run after another.
fn converged_best(
    c: &Candidate,
    started: Started,
    data: &Aligned,
    noise: Noise,
) -> Result<(ModelFit, Runs), CriticismError> {
    let Started {
        mut fits,
        per_start,
        confirm_seed,
    } = started;
    let unsettled = settle(c, &mut fits, data, noise, &per_start, confirm_seed)?;
    let runs = Runs {
        starts: fits.len(),
        agreeing: agreeing(&fits),
        unsettled,
    };
    let (fit, cmp) = fits.swap_remove(best_of(&fits));
    Ok((with_evidence(&c.model, &fit, cmp)?, runs))
}

/// The runs of a candidate's refit ([`multi_start`]).
struct Runs {
    /// Its starts, the global search and the searches from its best.
    starts: usize,
    /// How many reached the best within one unit of log-likelihood.
    agreeing: usize,
    /// What the last search from its best still gained where the refit
    /// did not converge ([`settle`]).
    unsettled: Option<f64>,
}

/// Local searches from the best refit where no second start reached it
/// (within one unit of log-likelihood), each from the best so far, until
/// one gains no more than one unit, at most [`SETTLE_ROUNDS`]: a refit
/// counts as converged once two of its starts agree or such a search
/// confirms its best. `None` when it converged; else what
/// the last search from its best still gained (nats): the refit is
/// reported as not converged and not ranked.
fn settle(
    c: &Candidate,
    fits: &mut Vec<Refitted>,
    data: &Aligned,
    noise: Noise,
    per_start: &MapSettings,
    seed: u64,
) -> Result<Option<f64>, CriticismError> {
    if fits.is_empty() || agreeing(fits) >= 2 {
        return Ok(None);
    }
    let mut gained = 0.0;
    for round in 0..SETTLE_ROUNDS {
        let best = &fits[best_of(fits)];
        let before = best.1.log_likelihood;
        let from = Posterior::layout_for(&c.model, noise)
            .values(&best.0.map.theta, 0)
            .to_vec();
        let seed = seed ^ (SETTLE_SEED + round as u64);
        fits.push(map_of(&c.model, data, noise, Some(from), per_start, seed)?);
        gained = fits[fits.len() - 1].1.log_likelihood - before;
        // Ending below its start is no sign of a better point: the local
        // search does not keep its start (the noise level is refitted).
        if gained <= 1.0 {
            return Ok(None);
        }
    }
    Ok(Some(gained))
}

/// Why a refit did not converge, if it did not: the last search from its
/// best still gained `gained` (nats; [`settle`]). A best search that
/// stopped at its budget is reported (`at_budget`) but still ranked: a
/// global search spends its whole budget on restarts, and on the demo's
/// criticism record `viscous`, the missing effect, had its best refit at
/// 200,941 evaluations with three of four runs agreeing (2026-12-02).
fn unsettled_reason(gained: Option<f64>) -> Option<String> {
    gained.map(|g| {
        format!(
            "no two runs reached its best; the last of {SETTLE_ROUNDS} local searches, each from the best before it, still gained {g:.1} in log-likelihood"
        )
    })
}

/// Most local searches run from a refit's best where no second start
/// reached it ([`RankedCandidate::converged`]). Two were too few: the
/// user's gap spring of `tests/it/components.rs` still gained 40.5 nats
/// in its second (2026-12-02).
pub const SETTLE_ROUNDS: usize = 6;

/// Mixed into the seed of [`settle`]'s searches (derived from the first
/// start's, so that no draw of the candidates' generator moves).
const SETTLE_SEED: u64 = 0x5E77_1E00;

/// A refit with its comparison numbers.
type Refitted = (MapFit<Model>, Comparison);

/// Index of the refit with the highest log-likelihood (the last of equals;
/// 0 if there is none).
fn best_of(fits: &[Refitted]) -> usize {
    (0..fits.len())
        .max_by(|&a, &b| {
            fits[a]
                .1
                .log_likelihood
                .total_cmp(&fits[b].1.log_likelihood)
        })
        .unwrap_or(0)
}

/// How many refits end within one unit of log-likelihood of the best.
fn agreeing(fits: &[Refitted]) -> usize {
    let best = fits
        .get(best_of(fits))
        .map_or(f64::NEG_INFINITY, |f| f.1.log_likelihood);
    fits.iter()
        .filter(|(_, cmp)| cmp.log_likelihood > best - 1.0)
        .count()
}

/// Whether a physical parameter of the current fit sits on a prior bound
/// ([`bound_reached`], as the `at-bound` warning judges it): the model strains against something it lacks, and the
/// record may need the candidate far from the current basin, where no
/// warm start reaches. Then each candidate's refit also runs a cold,
/// global search. On a calibration record with a hidden stiffness
/// degradation (`kappa_k` 0.38, seed 372849118615) the fit without it put
/// `uy` and `zeta0` on their bounds; the warm refits of `degradation`
/// (from `kappa_k` 0 to 1.5) gained nothing, a cold fit 1,378 nats.
fn strained(current: &Model, theta: &[f64]) -> bool {
    current
        .bounds()
        .iter()
        .zip(theta)
        .any(|(&(lo, hi), &x)| bound_reached(x, lo, hi).is_some())
}

/// Screens, refits and ranks every registered component absent from
/// `current`.
pub fn rank_candidates(
    registry: &Registry,
    current: &Model,
    fit: &ModelFit,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<Ranking, CriticismError> {
    rank_from(
        registry,
        current,
        fit,
        data,
        settings,
        seed,
        Asked {
            again: true,
            form: false,
        },
    )
}

/// [`rank_candidates`], with the missing form of [`Ranking::current`]
/// always described ([`Ranking::form`] set): beside the numerical
/// baseline's improvement, where the gates would describe it later.
pub fn rank_described(
    registry: &Registry,
    current: &Model,
    fit: &ModelFit,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<Ranking, CriticismError> {
    let asked = Asked {
        again: true,
        form: true,
    };
    rank_from(registry, current, fit, data, settings, seed, asked)
}

/// What [`rank_from`] does besides ranking.
#[derive(Debug, Clone, Copy)]
struct Asked {
    /// Rank again (once) from a better fit of the current model.
    again: bool,
    /// Describe the missing form whatever the gates say (a diagnosis
    /// reports it): it is then computed beside the numerical baseline's
    /// improvement instead of after it.
    form: bool,
}

/// The current model's fit improved by more than this (nats) while the
/// candidates were refitted: they are ranked again from the better fit.
pub const RERANK: f64 = 10.0;

/// [`rank_candidates`]; when the baseline's refits from the candidates'
/// basins improve the current fit by more than [`RERANK`] and `asked.again`,
/// the warm starts came from the wrong basin, and the ranking is made
/// again (once) from the better fit. On a calibration record with a hidden
/// stiffness degradation (seed 372849118615) the current fit improved by
/// some 1,390 nats from a cold refit's basin.
fn rank_from(
    registry: &Registry,
    current: &Model,
    fit: &ModelFit,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
    asked: Asked,
) -> Result<Ranking, CriticismError> {
    let noise = fit.noise;
    let theta_now = fit.model_theta(current);
    let cands = registry.candidates(current, theta_now);
    let spring_final = !cands.iter().any(|c| changes_spring(current, &c.model));
    let mut model_now = vec![0.0; data.a.len()];
    data.model_accel_into(current, theta_now, &mut model_now)?;
    let nuisance = jacobian(current, theta_now, &model_now, data);
    let mut rng = StdRng::seed_from_u64(seed);
    // The numerical engine costs some 16 to 30 times the closed form: its
    // refits get a smaller budget (the warm start is already close).
    let numeric_budget = settings
        .clone()
        .with_max_evals(NUMERIC_BUDGET)?
        .with_polish(Some(Polish::default().with_max_iters(300).expect("valid")))?;
    // Candidates that need the numerical engine are compared with the
    // current model refitted on that engine when that fit is the better
    // one: a closed-form MAP can sit where a reversal falls on a sample
    // instant, which the engines resolve to either side of the jump
    // ([`Model::numerically`]). The engines' event times differ by some
    // 1e-7 s, so the numerical refit can also land on the worse side: on a
    // null record with sensor noise it stood 47 nats below the closed-form
    // fit of the same model, and a candidate that only recovered them
    // looked supported. The model is the same, so the better fit of it on
    // either engine is the baseline.
    // With an averaging sensor the likelihood has no such jump and the
    // engines agree to about 3e-6 m/s^2 per mean (some 0.04 nats at 1.5 %
    // noise): no second baseline.
    let baseline_seed: Option<u64> = (current.closed_form()
        && !current.interval_mean()
        && cands.iter().any(|c| !c.model.closed_form()))
    .then(|| rng.random());
    // The current model on the numerical engine (its baseline and gates).
    let numeric_current = current.clone().numerically();
    let numeric_baseline = || {
        baseline_seed
            .map(|seed| {
                let start = Some(theta_now.to_vec());
                fit_model(&numeric_current, data, noise, start, &numeric_budget, seed)
            })
            .transpose()
    };
    let old = current.param_names();
    let strained = strained(current, theta_now);
    // Beside the numerical baseline (its seed drawn first, as when it ran
    // first): the same fits.
    let refit_all = || -> Result<(Vec<Refit>, Vec<Screened>), CriticismError> {
        let mut refits = Vec::new();
        let mut screened = Vec::new();
        for c in cands {
            let new: Vec<usize> = c
                .model
                .param_names()
                .iter()
                .enumerate()
                .filter(|(_, n)| !old.contains(n))
                .map(|(i, _)| i)
                .collect();
            let budget = if c.model.closed_form() {
                settings
            } else {
                &numeric_budget
            };
            let score = score_test(&c.model, &c.start, &new, data, &nuisance);
            if let Some(out) = screen(current, &c, score, new.len(), data.a.len()) {
                screened.push(out);
                continue;
            }
            // The numerical engine costs some 16 to 30 times the closed form: one
            // spread start (mid-range) instead of two.
            let spread: &[f64] = if c.model.closed_form() {
                &[0.25, 0.75]
            } else {
                &[0.5]
            };
            let started = multi_start(
                &c,
                starts(&c, &new, spread, data),
                strained,
                data,
                noise,
                budget,
                &mut rng,
            )?;
            refits.push((c, score, started, new));
        }
        let refits = refits
            .into_par_iter()
            .map(|(c, score, started, new)| {
                let (fit, runs) = converged_best(&c, started, data, noise)?;
                Ok(Refit {
                    candidate: c,
                    score,
                    fit,
                    runs,
                    new,
                })
            })
            .collect::<Result<Vec<_>, CriticismError>>()?;
        Ok((refits, screened))
    };
    let (numeric_baseline, refitted) = rayon::join(numeric_baseline, refit_all);
    let mut numeric_baseline = numeric_baseline?;
    let (refits, screened) = refitted?;
    // A candidate must not look supported because its refit found a better
    // basin of the parameters the current model has too.
    let fit_in = fit;
    let mut fit = fit.clone();
    let current_budget = if current.closed_form() {
        settings
    } else {
        &numeric_budget
    };
    improve_baseline(
        current,
        &mut fit,
        &refits,
        data,
        current_budget,
        rng.random(),
        false,
    )?;
    if asked.again && fit.log_likelihood > fit_in.log_likelihood + RERANK {
        let asked = Asked {
            again: false,
            ..asked
        };
        return rank_from(registry, current, &fit, data, settings, rng.random(), asked);
    }
    let fit = &fit;
    let improve_seed: Option<u64> = numeric_baseline.is_some().then(|| rng.random());
    let improve_numeric = || -> Result<(), CriticismError> {
        if let (Some(base), Some(seed)) = (&mut numeric_baseline, improve_seed) {
            improve_baseline(
                &numeric_current,
                base,
                &refits,
                data,
                &numeric_budget,
                seed,
                true,
            )?;
        }
        Ok(())
    };
    let early_form = || {
        asked
            .form
            .then(|| missing_form(current, fit, data, settings))
            .transpose()
    };
    let (improved, early_form) = rayon::join(improve_numeric, early_form);
    improved?;
    let early_form = early_form?;
    // Kept only where it fits better than the closed-form fit (above).
    let numeric_baseline = numeric_baseline.filter(|b| b.log_likelihood > fit.log_likelihood);
    let features_now = diagnosis_of(current, fit, data)?.features;
    let features_numeric = match &numeric_baseline {
        Some(b) => Some(diagnosis_of(&numeric_current, b, data)?.features),
        None => None,
    };
    let mut out = Vec::new();
    let mut form: Option<MissingForm> = early_form;
    // The memory term of [`MissingForm::memory_search`], once asked.
    let mut memory: Option<Option<OutOfCatalog>> = None;
    let fit_now = fit;
    // The most any candidate lowers BIC, each against its own baseline.
    let best_delta = refits
        .iter()
        .map(|r| {
            let base = match &numeric_baseline {
                Some(b) if !r.candidate.model.closed_form() => b,
                _ => fit,
            };
            r.fit.bic - base.bic
        })
        .fold(f64::INFINITY, f64::min);
    for Refit {
        candidate: c,
        score,
        fit: refit,
        runs,
        new,
    } in refits
    {
        let physical_size = physical_size(&c.model, &refit.theta, &new);
        let (fit, before, base_model) = match (&numeric_baseline, &features_numeric) {
            (Some(b), Some(f)) if !c.model.closed_form() => (b, f, &numeric_current),
            _ => (fit, &features_now, current),
        };
        let delta_bic = refit.bic - fit.bic;
        // An averaging sensor's reading has no step in the event times.
        let delta_bic_off_jumps = if c.model.interval_mean() {
            None
        } else {
            Some(off_jumps::delta_bic_off(
                base_model,
                fit,
                &c.model,
                &refit,
                new.len(),
                data,
            )?)
        };
        let delta_log_evidence = refit.log_evidence - fit.log_evidence;
        let moved_z = profile_z(refit.log_likelihood - fit.log_likelihood, new.len());
        let after = diagnosis_of(&c.model, &refit, data)?.features;
        // A component that declares no structure is judged on the serial
        // correlation. (Every candidate judged on it too let
        // `velocity-friction` in on a record whose stiffness degrades:
        // it whitens some of what it does not explain.)
        let targets = if c.targets.is_empty() {
            vec![FeatureKind::Colour]
        } else {
            c.targets.clone()
        };
        let (target_before, target_after) = shrink_of(&targets, before, &after);
        let stands_in = absorbed(&targets, before, &after);
        let pin = pinned(current, fit.model_theta(current), &c.model, &refit.theta);
        let worse = worsened(&targets, before, &after);
        let mut gate = Gate {
            physical_size,
            stands_in,
            bounded: own_bound(&c.model, &refit.theta, &new),
            pins: pin.as_ref().map(|p| p.1.clone()),
            worsens: worse.as_ref().map(|w| w.1.clone()),
            remains: None,
            raw_e2_ratio: refit.e2 / fit.e2,
            raw_e2_limit: raw_e2_limit(fit, data.a.len()),
            delta_bic,
            delta_bic_off_jumps,
            delta_log_evidence,
            moved_z,
            target_before,
            target_after,
            whitens: whitened(before, &after),
            unsettled: unsettled_reason(runs.unsettled),
        };
        // Asked only of a candidate that would be added, or would be but
        // for a pin or a structure it unmasks, which the ladder's unpin
        // and unmask moves may undo (they must not put in a stand-in): it
        // costs the missing form and two refits on the engine.
        let but_for = |g: &Gate, pins: bool, worsens: bool| {
            Gate {
                pins: g.pins.clone().filter(|_| !pins),
                worsens: g.worsens.clone().filter(|_| !worsens),
                ..g.clone()
            }
            .accepted()
        };
        let but_for_pin = |g: &Gate| but_for(g, true, false);
        // A candidate refused only for its own parameter on a bound is
        // asked too: the form's term then names the physics it stood in
        // for (a Maxwell record, `criticism_calibration::
        // a_stiffening_with_travel_is_no_catalog_term`).
        let unbounded = Gate {
            bounded: None,
            ..gate.clone()
        };
        if but_for(&unbounded, true, true) {
            if form.is_none() {
                form = Some(missing_form(current, fit_now, data, settings)?);
            }
            let held = form
                .as_ref()
                .and_then(|f| held_by(f, spring_final, delta_bic, best_delta));
            let n = data.a.len();
            let decided = |held, beat| {
                form.as_ref().is_some_and(|f| {
                    outgains_form(f, held, fit_now, &refit, n) || short_of_beat(f, held, beat, n)
                })
            };
            // Only where the form leads with what no catalog component
            // makes: asked of every form with a memory term, a memory term
            // standing in for a missing damper refused `viscous` on the
            // README's record (see [`MEMORY_LEAD`]).
            let suspect = form.as_ref().is_some_and(|f| {
                f.out_of_catalog.is_some() || (f.elastic_lead.is_some() && spring_final)
            });
            if let Some((held, beat)) = held.filter(|&(h, beat)| !decided(h, beat)) {
                gate.remains = remains(
                    current,
                    fit,
                    &c.model,
                    &refit,
                    (held, beat),
                    data,
                    &numeric_budget,
                    seed ^ 0x5E_7A11,
                )?;
            }
            // The form's own terms, linear about a model that lacks the
            // force, can miss a memory force that a search finds
            // ([`MissingForm::memory_search`]), and then the candidate is
            // asked again, against that memory term.
            if suspect && gate.remains.is_none() {
                if memory.is_none() {
                    let f = form.as_ref().expect("computed above");
                    memory = Some(f.memory_search(current, fit_now, data, settings)?);
                }
                if let Some(Some(ooc)) = &memory {
                    gate.remains = remains(
                        current,
                        fit,
                        &c.model,
                        &refit,
                        (ooc, delta_bic),
                        data,
                        &numeric_budget,
                        seed ^ 0x5E_7A12,
                    )?;
                }
            }
        }
        // Every gate but the pin passes, the stand-in check included.
        let pinned_only = pin.filter(|_| but_for_pin(&gate)).map(|p| p.0);
        let worsens_only = worse.filter(|_| but_for(&gate, false, true)).map(|w| w.0);
        out.push(RankedCandidate {
            pinned_only,
            worsens_only,
            targets: c.targets.clone(),
            evidence_supports: gate.evidence(),
            moved_z,
            moved: gate.moved(),
            physical_size,
            target_before,
            target_after,
            shrinks: gate.shrinks(),
            accepted: gate.accepted(),
            reason: with_budget_note(gate.reason(&targets), &refit),
            at_budget: refit.at_budget,
            evaluations: refit.evaluations,
            effect: c.effect.clone(),
            model: refit.model.clone(),
            score,
            e2: refit.e2,
            delta_log_likelihood: refit.log_likelihood - fit.log_likelihood,
            delta_bic,
            delta_bic_off_jumps,
            delta_log_evidence,
            raw_e2_ratio: gate.raw_e2_ratio,
            supported: gate.supported(),
            signature: c.signature.clone(),
            starts: runs.starts,
            agreeing: runs.agreeing,
            converged: gate.unsettled.is_none(),
            fit: refit,
            extended: c.model.clone(),
        });
    }
    // Not converged: reported after the ranked ones.
    out.sort_by(|a, b| {
        (!a.converged)
            .cmp(&!b.converged)
            .then(a.delta_bic.total_cmp(&b.delta_bic))
    });
    Ok(Ranking {
        candidates: out,
        screened,
        current: fit.clone(),
        form,
    })
}

/// Screening margin: a candidate is not refitted, where the likelihood is
/// continuous, when even this many times its score statistic would not
/// reach the gain that support needs ([`screen_threshold`]).
pub const SCREEN_MARGIN: f64 = 20.0;

/// A candidate not refitted: its score test says it cannot matter.
#[derive(Debug, Clone, Serialize)]
pub struct Screened {
    /// The component's name.
    pub effect: String,
    /// The extended model.
    pub model: String,
    /// Its score statistic at the current MAP.
    pub score: f64,
    /// Its number of new parameters.
    pub df: usize,
    /// [`screen_threshold`], which `score` did not reach.
    pub threshold: f64,
    /// The sentence that reports it.
    pub reason: String,
}

/// `c` screened out, when the current model's likelihood is continuous in
/// the event times (an averaging sensor, [`Model::interval_mean`]) and
/// its score statistic is below [`screen_threshold`].
///
/// The score statistic approximates twice the log-likelihood a refit
/// gains, but from the slope at the warm start only, and it
/// underestimates: with the averaging sensor, on 26 records (seed 4242,
/// 136 candidates, 2026-11-30) twice the refit's gain was up to 8.8 times
/// the score where it exceeded 5 (5.8 at the smallest score, 1.49 against
/// 8.69). The margin of 20 keeps twice that. On the fresh seeds of its
/// check (calibration seed 501666, 49 averaging records; docs/criticism.md)
/// one record's every candidate was screened, and there `friction-decay`,
/// refitted without the screen, gained more than 14 times its score
/// (BIC -4.7: not supported). Under the instantaneous
/// sensor the score is no screen at all: a sample is an instantaneous
/// acceleration that jumps at each reversal, so the score's finite
/// difference measures the staircase (on the demo's record `viscous`
/// scored 148.8 and lost 7.6 in BIC, `friction-decay` scored 1.4 and
/// gained 180).
fn screen(current: &Model, c: &Candidate, score: f64, df: usize, n: usize) -> Option<Screened> {
    if !current.interval_mean() || df == 0 || !score.is_finite() {
        return None;
    }
    let threshold = screen_threshold(df, n);
    (score < threshold).then(|| Screened {
        effect: c.effect.clone(),
        model: c.model.name(),
        score,
        df,
        threshold,
        reason: format!(
            "screened out: its score statistic {score:.2} is below {threshold:.2}, 1/{SCREEN_MARGIN:.0} of the {:.1} (twice the log-likelihood gain) it needs to lower BIC by more than {SUPPORT}; not refitted",
            SCREEN_MARGIN * threshold
        ),
    })
}

/// The score below which a candidate with `df` new parameters is screened
/// out on `n` samples: the twice log-likelihood gain that lowers BIC by
/// [`SUPPORT`], over [`SCREEN_MARGIN`].
///
/// # Formula
/// ```text
/// S_min = (10 + df ln n) / 20
/// ```
///
/// ```
/// use hbis::criticism::ranking::screen_threshold;
/// // One new parameter on 2,401 samples: (10 + ln 2401) / 20.
/// assert!((screen_threshold(1, 2401) - 0.889182).abs() < 1e-6);
/// assert!((screen_threshold(2, 2401) - 1.278364).abs() < 1e-6);
/// ```
pub fn screen_threshold(df: usize, n: usize) -> f64 {
    (SUPPORT + df as f64 * (n as f64).ln()) / SCREEN_MARGIN
}

/// The least BIC change the terms `held` of `form` can make alone: the
/// form's whole refit ([`MissingForm::delta_bic`]) less the penalty of
/// the terms `held` leaves out. The held part is nested in all the terms,
/// so alone it cannot fit better than all of them by more than that
/// penalty. `None` where the form has no refit.
fn held_gain_floor(form: &MissingForm, held: &OutOfCatalog, n: usize) -> Option<f64> {
    let count = |text: &str| {
        FileEffect::from_toml(text, "missing-form").map(|e| ForceComponent::params(&e).len())
    };
    let (Some(delta), Some(all)) = (form.delta_bic, form.effect_file.as_deref()) else {
        return None;
    };
    let (Ok(all), Ok(kept)) = (count(all), count(&held.effect_file)) else {
        return None;
    };
    let left_out = all.saturating_sub(kept) as f64;
    Some(delta - left_out * (n as f64).ln())
}

/// Whether `refit` (a candidate's) fits better, by more than [`SUPPORT`]
/// in BIC, than the held part of the missing form can
/// ([`held_gain_floor`]): then it explains more than the held terms, and
/// [`remains`] would find nothing; its refit is not run. On the demo's
/// `record.csv` `trilinear` lowers BIC by 2,510 and the whole form by 920
/// to 1,649 (seeds 1 to 3), and the held part's refit took some 0.5 s of
/// a 3.5 s diagnosis.
fn outgains_form(
    form: &MissingForm,
    held: &OutOfCatalog,
    fit_now: &ModelFit,
    refit: &ModelFit,
    n: usize,
) -> bool {
    held_gain_floor(form, held, n).is_some_and(|floor| refit.bic < fit_now.bic + floor - SUPPORT)
}

/// Whether the held part of the missing form cannot lower BIC by more
/// than `beat` ([`held_gain_floor`] is not below it): [`remains`] would
/// return at its first refit, which is not run. In the demo's ladder
/// (`--seed 1`, step 1, from `trilinear+coulomb`) the form's memory term
/// did not lead it and had to beat twice `viscous`'s -1,034.2 while the
/// whole form gained 679.1: its refits for `lcfm` and `degradation` took
/// 1.48 s of the ladder's 11.0 s and decided nothing.
fn short_of_beat(form: &MissingForm, held: &OutOfCatalog, beat: f64, n: usize) -> bool {
    held_gain_floor(form, held, n).is_some_and(|floor| floor >= beat)
}

/// How many times the largest BIC change of any candidate the memory
/// terms of a missing form that do not lead it must gain before a
/// candidate is asked whether it stands in for them (gate 8, `remains`).
///
/// Where catalog effects are missing, a memory term can stand in for them
/// as much as a catalog effect for it. From `bilinear+coulomb` on the
/// README's record (the truth `trilinear+lcfm+viscous`; form `t sgn v`,
/// a memory term of 0.68 s, `sgn v`) the memory term alone lowered BIC by
/// 520.6 and `velocity-friction` by 359.4 (1.45 times less), and beside
/// it no candidate gained: asked there, nothing was added and the ladder
/// ended at the start model
/// (`search::the_readme_record_ends_no_worse_than_the_true_structure`).
/// On a Maxwell record (seed 17530, record 117) the memory term gained
/// 679.0 and the best candidate 58.3 (11.6 times less): a catalog effect
/// that takes a small slice of a force no catalog effect makes.
pub const MEMORY_LEAD: f64 = 2.0;

/// The terms of the missing form `f` a candidate may stand in for, with
/// the change of BIC they must beat ([`remains`]): the terms no catalog
/// component makes where they lead the form, or an elastic lead where no
/// candidate changes the spring law (`spring_final`), against the
/// candidate's own `delta_bic`; else its memory terms that do not lead,
/// against [`MEMORY_LEAD`] times `best_delta`, the most any candidate
/// lowers BIC.
fn held_by(
    f: &MissingForm,
    spring_final: bool,
    delta_bic: f64,
    best_delta: f64,
) -> Option<(&OutOfCatalog, f64)> {
    f.out_of_catalog
        .as_ref()
        .or(f.elastic_lead.as_ref().filter(|_| spring_final))
        .map(|h| (h, delta_bic))
        .or(f
            .memory_terms
            .as_ref()
            .map(|h| (h, MEMORY_LEAD * best_delta)))
}

/// Set when the terms `ooc` of the current fit's missing form, those no
/// catalog component makes (led by a memory or hysteretic term, or a
/// travel or time term that adds force, [`MissingForm::out_of_catalog`],
/// or by an elastic term where no
/// candidate changes the spring law, [`MissingForm::elastic_lead`]; or
/// its memory terms that do not lead it, [`MissingForm::memory_terms`]),
/// lower BIC by more than `beat` (the candidate's own change; for memory
/// terms that do not lead, [`MEMORY_LEAD`] times the largest change of
/// any candidate), and with
/// them in both models the candidate no longer lowers BIC by more than
/// [`SUPPORT`]: it stood in for them. On a Maxwell record of the
/// calibration (seed 17530, record 117: `tau_m` 1.00 s) the form was
/// `travel u` then a memory term of 0.97 s, which alone lowered BIC by
/// 679.0 against `velocity-friction`'s 58.3 (the best candidate), and
/// beside it `velocity-friction` changed BIC by +15.0. On two
/// Maxwell records of the calibration (seed 552985) `friction-decay`
/// lowered BIC by 12.5 and 31.5, the form's memory term by 124.2 and
/// 241.9, and beside it `friction-decay` gained nothing. (Refusing a candidate
/// whenever the whole form gains more refused `viscous` in the demo's
/// ladder, whose start lacked two catalog effects.)
///
/// Where the form has such terms, the candidate is asked again against
/// the memory term of [`MissingForm::memory_search`] (its own change to
/// beat), found by a global search: the form's regression is linear
/// about a model that lacks the force and can miss it. On the three
/// Maxwell records given a catalog stand-in in the calibration of commit
/// ea72fef (seed 245837807, records 56, 58 and 60) the forms were a
/// hysteretic term and `|u| u` (BIC -109.7, against
/// `asymmetric-friction`'s -235.7), `u^3` and `|u| u` (-34.0, against
/// `friction-decay`'s -25.6) and `|u| u`, a memory term of 1.84 s and
/// `travel sgn v`; the search's memory terms (0.51, 0.15 and 1.29 s for
/// truths of 0.46, 0.22 and 1.28 s) lowered BIC by 404.8, 113.4 and
/// 595.9, and beside them the candidates changed BIC by -1.7, +7.2 and
/// -3.4.
#[allow(clippy::too_many_arguments)]
fn remains(
    current: &Model,
    fit: &ModelFit,
    candidate: &Model,
    refit: &ModelFit,
    (ooc, beat): (&OutOfCatalog, f64),
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<Option<String>, CriticismError> {
    let Ok(effect) = FileEffect::from_toml(&ooc.effect_file, "missing-form") else {
        return Ok(None);
    };
    let effect = std::sync::Arc::new(effect);
    let value =
        |values: &[(String, f64)], name: &str| values.iter().find(|(n, _)| n == name).map(|v| v.1);
    let with = current.with_force(effect.clone());
    let now = current.layout();
    let theta = fit.model_theta(current);
    let start = with.layout().theta_from(&|p| {
        value(&ooc.fitted, &p.name)
            .or_else(|| now.get(theta, &p.name))
            .or_else(|| value(&ooc.values, &p.name))
            .unwrap_or(p.neutral)
    });
    let base = fit_model(&with, data, fit.noise, Some(start), settings, seed)?;
    let form_gain = base.bic - fit.bic;
    // The candidate explains more than the form's terms: it is no
    // stand-in for them, even where the two overlap (a stiffness
    // degradation and a memory force can, on one record).
    if base.log_likelihood <= fit.log_likelihood || form_gain >= beat {
        return Ok(None);
    }
    // From the form's fit, the candidate's own parameters at their refit:
    // the joint model nests it.
    let both = candidate.with_force(effect);
    let start = carried(&both, refit, candidate, &[(&base, &with)]);
    let joint = fit_model(&both, data, fit.noise, Some(start), settings, seed ^ 1)?;
    let delta = joint.bic - base.bic;
    Ok((delta > -SUPPORT)
        .then(|| remains_reason(&ooc.description, form_gain, delta, joint.bic - refit.bic)))
}

/// The reason gate 8 (`Gate::remains`) gives for refusing a candidate
/// beside the missing form's term `description`: the term lowers BIC by
/// `-form_gain`, the candidate changes it by `delta` beside the term, and
/// the term by `beyond` beside the candidate (the joint fit against the
/// candidate's refit). Only where the term still lowers BIC by more than
/// [`SUPPORT`] beside the candidate do the numbers show that the
/// candidate stands in for it; otherwise each stands in for the other as
/// far as the record tells, and the reason says so. (On a hidden
/// degradation record of 2026-12-05, seed 51758551 record 34, `u^3`
/// changed BIC by -10.5 beside the truth's effect: just past the
/// threshold, so it keeps the stand-in wording.) Either way the candidate
/// is not added: a catalog effect is added only where it explains what
/// the form's term does not.
///
/// ```
/// use hbis::criticism::ranking::remains_reason;
/// let stand_in = remains_reason("memory term (u - q, dq/dt = (u - q) / 0.510)", -404.8, -1.7, -350.0);
/// assert!(stand_in.contains("stands in for a force the catalog does not hold"), "{stand_in}");
/// let tie = remains_reason("elastic term (u^3)", -45.0, -3.0, -7.1);
/// assert!(tie.contains("cannot tell it from"), "{tie}");
/// assert!(tie.contains("-7.1") && tie.contains("-3.0") && tie.contains("45.0"), "{tie}");
/// assert!(!tie.contains("catalog does not hold"), "{tie}");
/// // Two terms are named as such.
/// let two = remains_reason("memory term (u - q, dq/dt = (u - q) / 0.376) and travel term (travel u)", -626.1, 15.4, -519.6);
/// assert!(two.contains("travel u) lower BIC by 626.1") && two.contains("with those terms in both"), "{two}");
/// ```
pub fn remains_reason(description: &str, form_gain: f64, delta: f64, beyond: f64) -> String {
    // `description` joins its terms with " and " (`held_anywhere`).
    let (those, term, lowers, changes) = if description.contains(" and ") {
        ("those", "terms", "lower", "change")
    } else {
        ("that", "term", "lowers", "changes")
    };
    if beyond <= -SUPPORT {
        format!(
            "the missing form's {description} {lowers} BIC by {:.1}, more than it does, and with {those} {term} in both models it changes BIC by {delta:+.1}, not below -{SUPPORT}, while the {term} {changes} it by {beyond:+.1} beside it: it stands in for a force the catalog does not hold",
            -form_gain
        )
    } else {
        format!(
            "the record cannot tell it from the missing form's {description}: {those} {term} {lowers} BIC by {:.1}, more than it does; with both in the model it changes BIC by {delta:+.1} beside the {term} and the {term} {beyond:+.1} beside it, neither below -{SUPPORT}; a catalog effect is added only where it explains what a force outside the catalog does not",
            -form_gain
        )
    }
}

/// Whether `extended` holds another spring law than `current`: an
/// upgrade of the slot's law or a law swapped in beside its linear one.
fn changes_spring(current: &Model, extended: &Model) -> bool {
    let laws = |m: &Model| m.forces().iter().filter(|f| f.spring_law()).count();
    extended.spec().spring != current.spec().spring || laws(extended) != laws(current)
}

/// `reason`, and whether the refit stopped at its evaluation budget.
fn with_budget_note(reason: String, refit: &ModelFit) -> String {
    if refit.at_budget {
        format!(
            "{reason}; its refit stopped at its evaluation budget ({} evaluations) instead of converging",
            refit.evaluations
        )
    } else {
        reason
    }
}

/// How far the profile-likelihood interval of `k` new parameters puts
/// their neutral values, as a normal quantile: the likelihood-ratio
/// statistic `2 dlogL`, chi-square with `k` degrees of freedom when they
/// are neutral, turned into the `z` with the same tail probability.
///
/// ```
/// use hbis::criticism::ranking::profile_z;
/// // One parameter: z = sqrt(2 dlogL).
/// assert!((profile_z(4.5, 1) - 3.0).abs() < 1e-6);
/// assert_eq!(profile_z(-2.0, 1), 0.0);
/// // Two parameters far from neutral stay finite.
/// assert!(profile_z(500.0, 2).is_finite() && profile_z(500.0, 2) > 20.0);
/// ```
pub fn profile_z(delta_log_likelihood: f64, k: usize) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};
    let stat = 2.0 * delta_log_likelihood.max(0.0);
    if stat == 0.0 || k == 0 {
        return 0.0;
    }
    if k == 1 {
        return stat.sqrt();
    }
    let tail = ChiSquared::new(k as f64).map_or(1.0, |c| c.sf(stat));
    if tail < 1e-15 {
        // Beyond what 1 - tail resolves: the Wilson-Hilferty cube-root
        // approximation.
        let kf = k as f64;
        let v = 2.0 / (9.0 * kf);
        return ((stat / kf).cbrt() - (1.0 - v)) / v.sqrt();
    }
    Normal::standard()
        .inverse_cdf(1.0 - 0.5 * tail.min(1.0))
        .max(0.0)
}

/// The largest `|theta_i - neutral_i| / scale_i` over the new parameters
/// `new` of `model` whose neutral value switches their effect off (the
/// spring's shape parameters have none).
fn physical_size(model: &Model, theta: &[f64], new: &[usize]) -> Option<f64> {
    let (layout, names) = (model.layout(), model.param_names());
    own_params(&names, new)
        .filter_map(|i| {
            let spec = layout.spec(&names[i])?;
            Some((theta[i] - spec.neutral).abs() / spec.scale)
        })
        .reduce(f64::max)
}

/// The indices among `new` that are not the spring's shape parameters:
/// those whose neutral value switches their effect off.
fn own_params<'a>(names: &'a [String], new: &'a [usize]) -> impl Iterator<Item = usize> + 'a {
    use crate::model::ParamName::{Uy, F0, F1, F2, U0, U3};
    let shape = [U0, Uy, F0, F1, F2, U3].map(|p| p.as_str());
    new.iter()
        .copied()
        .filter(move |&i| !shape.contains(&names[i].as_str()))
}

/// A new parameter of the candidate's own (not the spring's shape) that
/// its refit puts on a prior bound other than its neutral value: the
/// record asks for more of the effect than its physical range holds, so
/// the effect stands in for a force it does not model. (A parameter
/// whose neutral value is on that bound is the effect switched off, which
/// the other gates judge.) On a Bouc-Wen record of the calibration
/// (seed 226831318, record 62; 2026-12-07) `asymmetric-friction` was
/// added with `a_F` at 0.79999 of its bound 0.8 (BIC -54.9) through "the
/// residual turns white", with no missing form; the hidden
/// `asymmetric-friction` records are drawn at 0.45-0.6.
fn own_bound(model: &Model, theta: &[f64], new: &[usize]) -> Option<String> {
    let (layout, names) = (model.layout(), model.param_names());
    let (i, bound, (lo, hi)) = own_params(&names, new).find_map(|i| {
        let spec = layout.spec(&names[i])?;
        let bound = pinned_at(theta[i], spec.bounds)
            .filter(|&b| pinned_at(spec.neutral, spec.bounds) != Some(b))?;
        Some((i, bound, spec.bounds))
    })?;
    Some(format!(
        "its refit puts its own `{}` on its prior bound ({:.4}, the bound {bound} of [{lo}, {hi}]): the record asks for more of it than its physical range holds, so it stands in for a force it does not model",
        names[i], theta[i]
    ))
}

/// The bound of `(lo, hi)` that `x` is within [`PINNED`] of the range
/// from, if any: closer than `sanity::bound_reached`'s warning (0.5 %),
/// and a lower bound of 0 counts.
fn pinned_at(x: f64, (lo, hi): (f64, f64)) -> Option<f64> {
    [lo, hi]
        .into_iter()
        .find(|&b| (x - b).abs() <= PINNED * (hi - lo))
}

/// A specific structure (period, offset, spectral peak) that the
/// candidate does not target, significant before and gone after its
/// refit while the residual stays serially correlated: the candidate
/// stands in for an effect it does not model. (A candidate that leaves a
/// white residual explains the structure, whatever it targets: a missing
/// damper also shifts the fitted stiffness and shows as period drift.)
fn absorbed(targets: &[FeatureKind], before: &[Feature], after: &[Feature]) -> Option<String> {
    use FeatureKind::*;
    let coloured = after.iter().any(|f| f.kind == Colour && f.significant);
    if !coloured {
        return None;
    }
    before
        .iter()
        .filter(|f| f.significant && !targets.contains(&f.kind))
        .filter(|f| matches!(f.kind, PeriodDrift | PeriodAmplitude | SpectralPeak | Offset))
        .find_map(|f| {
            let a = after.iter().find(|g| g.kind == f.kind)?;
            (!a.significant).then(|| {
                format!(
                    "it removes the {} ({:.3} to {:.3}), which it does not produce: it stands in for an effect it does not model",
                    kind_name(f.kind),
                    f.magnitude,
                    a.magnitude
                )
            })
        })
}

/// A bound within this fraction of a parameter's range counts as reached.
pub const PINNED: f64 = 1e-3;

/// A parameter the current model has too that the candidate's refit puts
/// on a prior bound (within [`PINNED`] of its range) where the current fit
/// did not: the candidate's gain is bought by forcing another part of the
/// model to its limit (on a record with a viscoelastic rubber, a catalog
/// stand-in left `rF0` on its bound). The parameter's name, and the
/// sentence.
fn pinned(current: &Model, now: &[f64], model: &Model, refit: &[f64]) -> Option<(String, String)> {
    let layout = current.layout();
    let bounds = model.bounds();
    model
        .param_names()
        .iter()
        .enumerate()
        .find_map(|(i, name)| {
            let before = layout.get(now, name)?;
            let (lo, hi) = bounds[i];
            let at = |x: f64| pinned_at(x, (lo, hi)).is_some();
            (at(refit[i]) && !at(before)).then(|| {
                let why = format!(
                    "its refit puts `{name}` on its prior bound ({:.4} in [{lo}, {hi}]) where the current fit has {before:.4}: it needs another part of the model forced to a limit",
                    refit[i]
                );
                (name.clone(), why)
            })
        })
}

/// A residual structure the candidate does not target, not significant
/// before and significant after its refit: the fit got worse elsewhere.
fn worsened(
    targets: &[FeatureKind],
    before: &[Feature],
    after: &[Feature],
) -> Option<(FeatureKind, String)> {
    after
        .iter()
        .filter(|f| f.significant && !targets.contains(&f.kind))
        .find_map(|f| {
            let b = before.iter().find(|g| g.kind == f.kind)?;
            gained(b, f).then(|| {
                let why = format!(
                    "the residual gains a {} it does not target ({:.3} to {:.3}): the fit is worse elsewhere",
                    kind_name(f.kind),
                    b.magnitude,
                    f.magnitude
                );
                (f.kind, why)
            })
        })
}

/// Whether a structure turned significant by the candidate's refit was
/// gained: not significant before; for the four structures with a
/// standard error, at least [`GAINED_Z`] of them; and for the colour a
/// Ljung-Box `Q` higher by more than its standard deviation under white noise,
/// `sqrt(2 h)` (`Q` is chi-squared on `h` lags then). `Q` moves with any
/// change of the fit, and a threshold crossed by less is no misfit the
/// refit made: on a record of Table 8.1's row 6 (seed 20261407) `lcfm`
/// (BIC -44) moved it from 37.500 to 37.635, across p = 0.01, and was
/// refused for it.
///
/// # Formula
/// ```text
/// Q_after - Q_before > sqrt(2 h),   h = 20:  6.32
/// ```
fn gained(before: &Feature, after: &Feature) -> bool {
    let rise = after.magnitude - before.magnitude;
    !before.significant
        && match after.kind {
            FeatureKind::Colour => rise > (2.0 * LJUNG_BOX_LAGS as f64).sqrt(),
            FeatureKind::PeriodDrift
            | FeatureKind::DecayRate
            | FeatureKind::JumpSize
            | FeatureKind::JumpDirection => after.z > GAINED_Z,
            _ => true,
        }
}

/// How many standard errors a structure with a standard error (period
/// drift, decay rate, jump size, jump direction) must reach to count as
/// gained: three, Bonferroni-corrected over those four, so that a refit
/// of the true structure is refused for noise in one of them no more
/// often than one structure alone is reported significant by noise
/// (`P(|z| > 3) = 0.0027`).
///
/// A hidden damper (calibration record 223489868467704, AR(1) noise
/// chosen): `viscous` (BIC -509.8) was refused because its refit, at the
/// true parameters to 1 %, showed jumps at reversals 62 % larger in the
/// record than in the model at z = 3.26; the noise at those reversals
/// alone, measured the same way, made them so.
///
/// # Formula
/// ```text
/// 2 (1 - Phi(z)) = 0.0027 / 4:   z = 3.40
/// ```
pub const GAINED_Z: f64 = 3.40;

/// The Ljung-Box `Q` before and after when the residual is coloured before
/// the candidate's refit and white after: the candidate explains the
/// structure, whichever feature showed it. The targeted features are
/// blunt: on a calibration record (seed 787329362077) a missing third
/// spring branch showed in the jumps at the reversals, where the mass
/// turns at the largest displacements, not in the periods `trilinear`
/// targets (0.005 and 0.000 before); its refit (BIC -550.0) turned Q
/// 467.0 into 18.5, was refused, and `friction-decay` (BIC -14.7) was
/// added in its place. (A shrink of the colour alone is not enough:
/// `velocity-friction` whitens part of a degrading stiffness.)
///
/// White means white at the usual 5 %, not only no longer reported at
/// 1 %: `Q` after at most [`white_q`]. A `Q` moved across the 1 % line by
/// a hair is still coloured at 5 %: on two Bouc-Wen springs of the
/// calibration (seed 176469212, records 176469741407699 and
/// 176469741407700) catalog stand-ins were added as `Q` went from 41.9 to
/// 33.8 and from 46.8 to 34.5 (p 0.027 and 0.023), BIC -13.7 and -18.6;
/// the hidden effects accepted this way that day ended at 18.5-23.1.
///
/// Coloured before means coloured at the same 5 % (`Q` above
/// [`white_q`]) or reported coloured, not only `Q` beyond the 1 % line
/// (since 2026-12-07, session 33): two hidden `velocity-friction` records
/// on white noise (calibration seeds 243288580 record 25 and 114605778
/// record 24, BIC -94.4 and -39.7) were refused with `Q` going from 36.3
/// to 13.1 and from 32.1 to 24.0, their declared structures (jumps,
/// decay) below significance before and after.
fn whitened(before: &[Feature], after: &[Feature]) -> Option<(f64, f64)> {
    let colour = |fs: &[Feature]| {
        fs.iter()
            .find(|f| f.kind == FeatureKind::Colour)
            .map(|f| (f.significant, f.magnitude))
    };
    let (b, a) = (colour(before)?, colour(after)?);
    let white = white_q();
    // `b.0` keeps a residual reported coloured by its lag-1 correlation
    // alone (possible on short records) coloured, as before.
    ((b.0 || b.1 > white) && !a.0 && a.1 <= white).then_some((b.1, a.1))
}

/// The largest Ljung-Box `Q` on [`LJUNG_BOX_LAGS`] lags that white noise
/// passes at 5 %.
///
/// # Formula
/// ```text
/// Q_white = chi2_h^-1(0.95),   h = 20:  31.41
/// ```
fn white_q() -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    ChiSquared::new(LJUNG_BOX_LAGS as f64)
        .map(|c| c.inverse_cdf(0.95))
        .unwrap_or(f64::NAN)
}

/// The kebab-case name of a feature kind (as in the JSON).
pub(super) fn kind_name(k: FeatureKind) -> String {
    serde_json::to_value(k)
        .ok()
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_default()
}

/// The targeted feature that shrank most (by ratio): before and after.
///
/// Requiring the feature to be significant before (issue 35: a gate passed
/// on a jump size at 0.29 standard errors) was tried on 2026-11-28 and
/// undone: it kept `friction-decay` out of a Maxwell record, but also the
/// Maxwell effect itself out of another (its declared structures were not
/// significant there, only the residual's colour) and broke the ladder of
/// the full model; falling back on the colour let `velocity-friction` in
/// on the degrading-stiffness record.
/// Tried again on 2026-12-07 and not kept: on the calibration records of
/// seed 235684487 it refused two Maxwell stand-ins and 4 detectable
/// hidden effects, on white-noise records whose declared structure BIC
/// found below significance (docs/criticism.md, item 4).
fn shrink_of(targets: &[FeatureKind], before: &[Feature], after: &[Feature]) -> (f64, f64) {
    let find =
        |fs: &[Feature], k: FeatureKind| fs.iter().find(|f| f.kind == k).map(|f| f.magnitude);
    targets
        .iter()
        .filter_map(|&k| Some((find(before, k)?, find(after, k)?)))
        // A structure absent before cannot shrink (0/0 must not pass).
        .filter(|(b, a)| *b > 0.0 && a.is_finite())
        .min_by(|a, b| (a.1 / a.0).total_cmp(&(b.1 / b.0)))
        .unwrap_or((f64::NAN, f64::NAN))
}

/// The conditions for adding a candidate (false-discovery control).
///
/// ```
/// use hbis::criticism::ranking::Gate;
/// let g = Gate { physical_size: Some(4.0), stands_in: None, bounded: None, pins: None, worsens: None, remains: None, raw_e2_ratio: 0.9, raw_e2_limit: 1.05, delta_bic: -40.0, delta_bic_off_jumps: Some(-35.0), delta_log_evidence: 12.0, moved_z: 6.0, target_before: 3.0, target_after: 1.0, whitens: None, unsettled: None };
/// // A targeted structure that grows: not added, unless the residual turns white.
/// let u = Gate { unsettled: Some("a search from its best still gained 3.0".into()), ..g.clone() };
/// assert!(!u.supported() && !u.accepted() && u.reason(&[]).starts_with("not added: not ranked"));
/// let g3 = Gate { target_after: 4.0, ..g.clone() };
/// assert!(!g3.accepted() && g3.reason(&[]).contains("goes from 3.000 to 4.000"));
/// let g3 = Gate { whitens: Some((467.0, 18.5)), ..g3 };
/// assert!(g3.accepted() && g3.reason(&[]).contains("turns white (Ljung-Box Q from 467.0 to 18.5)"));
/// assert!(g.accepted());
/// // A gain made only at the reversals (a staircase): not supported.
/// let g1 = Gate { delta_bic_off_jumps: Some(29.6), ..g.clone() };
/// assert!(!g1.supported() && g1.reason(&[]).contains("away from the reversals BIC changes by +29.6"));
/// // Or almost only there: 5 % of it away from them (at least 20 % asked).
/// let g1 = Gate { delta_bic_off_jumps: Some(-2.0), ..g.clone() };
/// assert!(!g1.supported() && g1.reason(&[]).contains("BIC changes by -2.0, 5 % of its gain, less than 20 %"));
/// let g1 = Gate { delta_bic_off_jumps: Some(-8.0), ..g.clone() };
/// assert!(g1.supported());
/// // A BIC gain bought by the noise model while the raw error grows: not supported.
/// let g2 = Gate { raw_e2_ratio: 180.0, ..g.clone() };
/// assert!(!g2.supported() && g2.reason(&[]).contains("180.000x the current model's"));
/// // A parameter that stays at its neutral value: not added.
/// let g = Gate { moved_z: 1.2, ..g.clone() };
/// assert!(!g.accepted() && g.reason(&[]).contains("1.2 (profile z)"));
/// // One that moves less than its physical scale: not added either.
/// let g = Gate { moved_z: 9.0, physical_size: Some(0.04), ..g.clone() };
/// assert!(!g.accepted() && g.reason(&[]).contains("0.04 of their physical scale"));
/// // One that pins another parameter on its bound: not added.
/// let g = Gate { physical_size: Some(4.0), pins: Some("puts `rF0` on its prior bound".into()), ..g.clone() };
/// assert!(g.supported() && !g.accepted() && g.reason(&[]).contains("`rF0`"));
/// // One whose own parameter sits on its bound: not added.
/// let b = Gate { pins: None, bounded: Some("its refit puts its own `a_F` on its prior bound".into()), ..g.clone() };
/// assert!(b.supported() && !b.accepted() && b.reason(&[]).contains("own `a_F`"));
/// // One that a memory force the catalog lacks explains, gaining nothing
/// // beside it: a stand-in, not added.
/// let g = Gate { pins: None, remains: Some("the missing form's memory term lowers BIC by 241.9 ...".into()), ..g.clone() };
/// assert!(g.supported() && !g.accepted() && g.reason(&[]).contains("memory"));
/// ```
#[derive(Debug, Clone)]
pub struct Gate {
    /// Its parameters' distance from neutral in physical scales
    /// ([`RankedCandidate::physical_size`]).
    pub physical_size: Option<f64>,
    /// Set when it removes a structure it does not target: a period,
    /// offset or spectral structure gone while the residual stays
    /// coloured.
    pub stands_in: Option<String>,
    /// Set when its refit puts one of its own parameters on a prior bound
    /// other than its neutral value (`ranking::own_bound`): it stands in too.
    pub bounded: Option<String>,
    /// Set when its refit puts a parameter of the current model on a prior
    /// bound ([`PINNED`]).
    pub pins: Option<String>,
    /// Set when the residual gains a significant structure it does not
    /// target.
    pub worsens: Option<String>,
    /// Set when it stands in for a force no catalog component makes: the
    /// missing form's memory or hysteretic terms explain more, and beside
    /// them it gains nothing (docs/criticism.md, "When an effect is
    /// added", item 8). The reason says whether the terms still gain
    /// beside it or the record cannot tell the two apart
    /// ([`remains_reason`]).
    pub remains: Option<String>,
    /// Its refit's raw `e2` over the current model's (not whitened).
    pub raw_e2_ratio: f64,
    /// The most [`Gate::raw_e2_ratio`] the noise explains ([`raw_e2_limit`]).
    pub raw_e2_limit: f64,
    /// Change of BIC.
    pub delta_bic: f64,
    /// Change of BIC away from the reversals ([`off_jumps`]; `None`: not
    /// measured).
    pub delta_bic_off_jumps: Option<f64>,
    /// Change of the Laplace log-evidence.
    pub delta_log_evidence: f64,
    /// Distance of its own parameters from neutral ([`profile_z`]).
    pub moved_z: f64,
    /// Its targeted feature before.
    pub target_before: f64,
    /// And after.
    pub target_after: f64,
    /// The residual's Ljung-Box `Q` before and after, when its refit turns
    /// a coloured residual white (Ljung-Box `Q` above 31.41, the 5 % line on
    /// its 20 lags, before; at most it after).
    pub whitens: Option<(f64, f64)>,
    /// Set when its refit did not converge ([`RankedCandidate::converged`]):
    /// why, with the numbers.
    pub unsettled: Option<String>,
}

impl Gate {
    /// BIC lower by more than [`SUPPORT`], and lower on the samples away
    /// from the reversals too (a gain made only by moving reversals across
    /// sample instants is no force the record shows), and a raw `e2` no
    /// worse than the noise explains: an AR(1) noise model must not buy a
    /// BIC gain by absorbing a misfit into its correlation.
    pub fn supported(&self) -> bool {
        self.delta_bic < -SUPPORT
            && self.off_jumps()
            && self.raw_e2_ratio <= self.raw_e2_limit
            && self.unsettled.is_none()
    }
    /// BIC lower away from the reversals by at least [`OFF_JUMPS_SHARE`]
    /// of the whole gain, or not measured. A share, not [`SUPPORT`]: the
    /// whole record's BIC has shown the support, this only asks that it
    /// does not lie almost all at the reversals. Part of a true effect's
    /// can: asymmetric friction's constant force ends where the mass
    /// stops, and on one record (`tests/it/components.rs`, `a_F` -0.57)
    /// its BIC changed by -31.3 in all and by -9.5 (30 %) away from the
    /// reversals and stops.
    fn off_jumps(&self) -> bool {
        self.delta_bic_off_jumps
            .is_none_or(|d| d < 0.0 && d <= OFF_JUMPS_SHARE * self.delta_bic)
    }
    /// Log Bayes factor above [`EVIDENCE`].
    pub fn evidence(&self) -> bool {
        self.delta_log_evidence > EVIDENCE
    }
    /// A parameter beyond [`MOVED_Z`] sds from neutral.
    pub fn moved(&self) -> bool {
        self.moved_z > MOVED_Z && self.physical_size.is_none_or(|s| s >= 1.0)
    }
    /// The targeted feature at most [`SHRINK`] of its value.
    pub fn shrinks(&self) -> bool {
        self.target_shrinks() || self.whitens.is_some()
    }
    /// The targeted feature itself at most [`SHRINK`] of its value.
    fn target_shrinks(&self) -> bool {
        self.target_after <= SHRINK * self.target_before
    }
    /// All four, and it stands in for nothing, has none of its own
    /// parameters on a bound, pins no other parameter on a bound and
    /// leaves no new structure.
    pub fn accepted(&self) -> bool {
        self.supported()
            && self.evidence()
            && self.moved()
            && self.shrinks()
            && self.stands_in.is_none()
            && self.bounded.is_none()
            && self.pins.is_none()
            && self.worsens.is_none()
            && self.remains.is_none()
    }
    /// The reason, with the numbers (`targets` named).
    pub fn reason(&self, targets: &[FeatureKind]) -> String {
        let names: Vec<String> = targets.iter().map(|&t| kind_name(t)).collect();
        let mut why = Vec::new();
        if let Some(u) = &self.unsettled {
            why.push(format!("not ranked: its refit did not converge ({u})"));
        }
        if self.delta_bic >= -SUPPORT {
            why.push(format!(
                "BIC changes by {:+.1}, not below -{SUPPORT}",
                self.delta_bic
            ));
        }
        // Said only of a gain: without one there is nothing to place.
        if let Some(d) = self
            .delta_bic_off_jumps
            .filter(|_| self.delta_bic < -SUPPORT && !self.off_jumps())
        {
            let limit = if d >= 0.0 {
                "not below 0".to_string()
            } else {
                format!(
                    "{:.0} % of its gain, less than {:.0} %",
                    100.0 * d / self.delta_bic,
                    100.0 * OFF_JUMPS_SHARE
                )
            };
            why.push(format!(
                "on the samples away from the reversals BIC changes by {d:+.1}, {limit}: its gain is made at the reversals, where an instantaneous sensor's reading jumps as a reversal crosses a sample instant"
            ));
        }
        if self.raw_e2_ratio > self.raw_e2_limit {
            why.push(format!(
                "its refit's raw e2 is {:.3}x the current model's, beyond the {:.3}x the noise explains: the noise model absorbs a misfit",
                self.raw_e2_ratio, self.raw_e2_limit
            ));
        }
        if !self.evidence() {
            why.push(format!(
                "the log-evidence changes by {:+.1}, not above {EVIDENCE}",
                self.delta_log_evidence
            ));
        }
        if self.moved_z <= MOVED_Z {
            why.push(format!(
                "its parameters are {:.1} (profile z) from their neutral values, not beyond {MOVED_Z}",
                self.moved_z
            ));
        }
        if let Some(size) = self.physical_size.filter(|&s| s < 1.0) {
            why.push(format!(
                "its parameters move {size:.2} of their physical scale from neutral, less than one: an effect too small to matter, which lets the fit move reversals across sample instants"
            ));
        }
        if !self.shrinks() && self.target_before.is_nan() {
            why.push(format!(
                "none of the residual structure it targets ({}) is present",
                names.join(", ")
            ));
        } else if !self.shrinks() {
            why.push(format!(
                "the residual structure it targets ({}) goes from {:.3} to {:.3}, not below {:.0} % of it",
                names.join(", "),
                self.target_before,
                self.target_after,
                100.0 * SHRINK
            ));
        }
        for s in [
            &self.stands_in,
            &self.bounded,
            &self.pins,
            &self.worsens,
            &self.remains,
        ]
        .into_iter()
        .flatten()
        {
            why.push(s.clone());
        }
        if why.is_empty() {
            let shrink = match self.whitens {
                Some((b, a)) if !self.target_shrinks() => {
                    format!("the residual turns white (Ljung-Box Q from {b:.1} to {a:.1})")
                }
                _ => format!(
                    "{} from {:.3} to {:.3}",
                    names.join(", "),
                    self.target_before,
                    self.target_after
                ),
            };
            format!(
                "added: BIC {:+.1}, log-evidence {:+.1}, its parameters {:.1} (profile z) from neutral, {shrink}",
                self.delta_bic, self.delta_log_evidence, self.moved_z,
            )
        } else {
            format!("not added: {}", why.join("; "))
        }
    }
}

/// Standard errors of the noise's own sum of squares by which a refit's raw
/// `e2` may exceed the current model's.
pub const RAW_E2_SE: f64 = 3.0;

/// The most a refit's raw `e2` may be over `fit`'s on `n` samples:
/// `1 + 3 sqrt(2 / n_eff)`, the sum of squares of `n_eff = n (1 - |rho|) /
/// (1 + |rho|)` independent noise values varying by `sqrt(2 / n_eff)` of
/// itself (`rho`: the AR(1) coefficient of `fit`, 0 for white noise).
///
/// ```
/// // 2,001 white-noise samples: 9.5 % above is what noise explains.
/// let f = 1.0 + 3.0 * (2.0f64 / 2001.0).sqrt();
/// assert!((f - 1.0948).abs() < 1e-4);
/// ```
pub fn raw_e2_limit(fit: &ModelFit, n: usize) -> f64 {
    let rho = fit
        .names
        .iter()
        .position(|x| x == "rho")
        .map_or(0.0, |k| fit.theta[k].abs().min(0.999));
    e2_limit(rho, n)
}

/// `1 + RAW_E2_SE sqrt(2 / n_eff)`, `n_eff = n (1 - |rho|) / (1 + |rho|)`:
/// the most a raw `e2` may exceed another on the same record by the noise
/// alone, for noise of lag-one correlation `rho` (0: white).
fn e2_limit(rho: f64, n: usize) -> f64 {
    let rho = rho.abs().min(0.999);
    let n_eff = (n as f64 * (1.0 - rho) / (1.0 + rho)).max(1.0);
    1.0 + RAW_E2_SE * (2.0 / n_eff).sqrt()
}

/// A candidate's refit.
struct Refit {
    candidate: Candidate,
    /// Its score test ([`score_test`]).
    score: f64,
    fit: ModelFit,
    runs: Runs,
    /// The indices of its new parameters.
    new: Vec<usize>,
}

/// Ranked candidates, and the current model's fit they are compared with.
#[derive(Debug, Clone)]
pub struct Ranking {
    /// Best first (by BIC).
    pub candidates: Vec<RankedCandidate>,
    /// The candidates not refitted ([`SCREEN_MARGIN`]): none under the
    /// instantaneous sensor.
    pub screened: Vec<Screened>,
    /// The current model's fit: the one given, or a better one found from
    /// the current model's part of a candidate's refit.
    pub current: ModelFit,
    /// The missing form of [`Ranking::current`], where the gates needed
    /// it (a candidate passed the others): the same as [`missing_form`]
    /// of that fit gives, kept so that no caller computes it twice.
    pub form: Option<MissingForm>,
}

/// `base`, a fit of `current` (on its engine), refitted from the current
/// model's part of each candidate's refit that fits better than it, best
/// first; a refit that fits better replaces it. With `same_engine`, only
/// candidates on `current`'s engine are used (refits on the numerical
/// engine are costly).
///
/// Every such candidate is tried, not only the best: on a null record with
/// sensor noise the start model's fit stood 27 nats below the truth, and
/// three candidates 31 nats above it, each having found the truth's basin
/// of the parameters the start model has too. The part of the best of them
/// (`offset`) led to a worse fit; those of the next two led to the truth's
/// level, and `velocity-friction` no longer looked supported. A candidate
/// that fits worse than the current model cannot look supported, so it is
/// not tried.
fn improve_baseline(
    current: &Model,
    base: &mut ModelFit,
    refits: &[Refit],
    data: &Aligned,
    budget: &MapSettings,
    seed: u64,
    same_engine: bool,
) -> Result<(), CriticismError> {
    let post = Posterior::new(
        current.clone(),
        data.clone(),
        priors_for(current, base.noise, data.dt),
        base.noise,
    )?;
    let mut order: Vec<usize> = (0..refits.len())
        .filter(|&i| {
            !same_engine || refits[i].candidate.model.closed_form() == current.closed_form()
        })
        .collect();
    order.sort_by(|&a, &b| {
        refits[b]
            .fit
            .log_likelihood
            .total_cmp(&refits[a].fit.log_likelihood)
    });
    for i in order {
        let Refit {
            candidate: c,
            fit: refit,
            ..
        } = &refits[i];
        if refit.log_likelihood <= base.log_likelihood {
            continue;
        }
        let layout = c.model.layout();
        let start = current
            .layout()
            .theta_from(&|p| layout.get(&refit.theta, &p.name).unwrap_or(p.neutral));
        if post.log_posterior(&post.with_neutral_noise(&start))? == f64::NEG_INFINITY {
            continue;
        }
        let seed = seed.wrapping_add(i as u64);
        let again = fit_model(current, data, base.noise, Some(start), budget, seed)?;
        if again.log_likelihood > base.log_likelihood {
            *base = again;
        }
    }
    Ok(())
}

/// The score statistic of the new parameters at the warm start, with the
/// residual and its level of the extended model there (the current model's
/// motion, on the extended model's engine).
fn score_test(
    model: &Model,
    start: &[f64],
    new: &[usize],
    data: &Aligned,
    nuisance: &nalgebra::DMatrix<f64>,
) -> f64 {
    let mut base_accel = vec![0.0; data.a.len()];
    if data
        .model_accel_into(model, start, &mut base_accel)
        .is_err()
    {
        return 0.0;
    }
    let r: Vec<f64> = data.a.iter().zip(&base_accel).map(|(a, m)| a - m).collect();
    let sigma2 = r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64;
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
                .zip(&base_accel)
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
pub(super) fn jacobian(
    model: &Model,
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

/// Diagnoses a fit of `model`.
pub fn diagnosis_of(
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
) -> Result<Diagnostics, CriticismError> {
    let mut accel = vec![0.0; data.a.len()];
    let theta = fit.model_theta(model);
    data.model_accel_into(model, theta, &mut accel)?;
    let base = model.core_params(theta).map_err(SimError::from)?;
    let motion = model.motion_grid(theta, data.lag, data.dt, data.a.len())?;
    let rho = Posterior::layout_for(model, fit.noise)
        .values(&fit.theta, 1)
        .first()
        .copied();
    Ok(diagnose(
        &model.spec(),
        &base,
        &motion,
        &data.a,
        &accel,
        data.dt,
        rho,
    )?)
}

/// The fit of a candidate's model as the ladder adopts it: the refit, or on
/// the numerical engine (screened on a smaller budget) the better of it and
/// a refit from it with the full budget of `settings`.
pub fn adopt(
    c: &RankedCandidate,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<ModelFit, CriticismError> {
    if c.extended.closed_form() {
        return Ok(c.fit.clone());
    }
    let start = c.fit.model_theta(&c.extended).to_vec();
    let full = fit_model(&c.extended, data, c.fit.noise, Some(start), settings, seed)?;
    Ok(if full.log_likelihood > c.fit.log_likelihood {
        full
    } else {
        c.fit.clone()
    })
}

/// The noise model `--noise auto` picks for a criticism run: the start
/// model fitted with white and with AR(1) noise; AR(1) when its BIC is
/// lower and its raw `e2` no worse than the noise explains.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoiseChoice {
    /// The noise model chosen.
    pub chosen: Noise,
    /// BIC of the white-noise fit.
    pub bic_white: f64,
    /// BIC of the AR(1) fit (one parameter more).
    pub bic_ar1: f64,
    /// The AR(1) fit's lag-one coefficient.
    pub rho: f64,
    /// The AR(1) fit's raw `e2` over the white fit's.
    pub raw_e2_ratio: f64,
    /// The most [`NoiseChoice::raw_e2_ratio`] the noise explains: `1 +
    /// 3 sqrt(2 / n_eff)` ([`raw_e2_limit`]) with the AR(1) fit's `rho`
    /// when the sample-to-sample changes show colour
    /// ([`NoiseChoice::rho_short`] above its limit), else for white noise.
    pub raw_e2_limit: f64,
    /// The noise's lag-one coefficient read from the white fit's residual
    /// at the shortest lags ([`short_lag_rho`]), where a slow misfit does
    /// not reach.
    pub rho_short: f64,
    /// The least [`NoiseChoice::rho_short`] that is colour rather than
    /// white noise's scatter ([`short_lag_limit`]); at or below it, AR(1)
    /// chosen by BIC is said to fit a slow misfit (it is still chosen).
    pub rho_short_limit: f64,
}

impl NoiseChoice {
    /// One sentence with the numbers.
    pub fn sentence(&self) -> String {
        let why = if self.bic_ar1 < self.bic_white && self.raw_e2_ratio > self.raw_e2_limit {
            format!(
                "white: AR(1) has the lower BIC ({:.1} against {:.1}, rho = {:.2}) only by a fit whose raw e2 is {:.2}x the white fit's, beyond the {:.3}x the noise explains: its correlation absorbs a misfit, not sensor noise",
                self.bic_ar1, self.bic_white, self.rho, self.raw_e2_ratio, self.raw_e2_limit
            )
        } else {
            let slow = if self.chosen == Noise::Ar1 && self.rho_short <= self.rho_short_limit {
                format!(
                    "; but the residual's sample-to-sample changes show no colour (rho {:.3} from them, not above {:.3}): the correlation AR(1) fits is a slow misfit of the start model rather than sensor noise, and candidates are judged on a residual whitened of part of it",
                    self.rho_short, self.rho_short_limit
                )
            } else {
                String::new()
            };
            format!(
                "{} by BIC at the start model (white {:.1}, AR(1) {:.1} with rho = {:.2}){slow}",
                self.chosen.as_str(),
                self.bic_white,
                self.bic_ar1,
                self.rho
            )
        };
        format!("noise model: {why}")
    }
}

/// Fits `model` with white and with AR(1) noise and picks AR(1) when its
/// BIC is lower and its raw `e2` no more than [`NoiseChoice::raw_e2_limit`]
/// times the white fit's: a misfitted start model's residual is correlated
/// over the structure's motion, and an AR(1) fit that whitens it away (its
/// raw error growing) says nothing about the sensor.
///
/// That limit is white noise's unless the noise's colour shows from one
/// sample to the next, where a slow misfit hardly reaches: coloured noise
/// has fewer independent values (`n_eff`), and a white fit takes more of
/// it into its parameters. On a null record with sensor noise (`rho`
/// 0.83, `rho_short` far above its limit; commit seed 352442 of CI) the
/// AR(1) fit's raw `e2` was 1.119 times the white fit's, beyond white
/// noise's 1.095 but within the 1.312 of its colour, and white noise was
/// chosen where AR(1) was 1,987 lower in BIC. The models nest (AR(1)
/// with `rho = 0` is white noise), so each fit starts from the other's MAP
/// too: a search stuck in a worse basin must not decide the noise model.
///
/// It also reads the noise's colour from one sample to the next
/// ([`short_lag_rho`] of the white fit's residual, against
/// [`short_lag_limit`]), which a slow misfit hardly reaches, and its
/// [`NoiseChoice::sentence`] says when AR(1) won without it. Beyond
/// setting the raw-`e2` limit, that reading does not decide: on records with white noise and an effect the start
/// model lacks AR(1) won by 100 to 2,000 in BIC at a raw `e2` within 6 %
/// of the white fit's (`rho` 0.23-0.81) while the sample-to-sample
/// changes read -0.04 to 0.08 (1.9 on the calibration's sensor noise; 54
/// records, seeds 910000000000-053), but keeping white noise there (commit
/// 2db1439) made the calibration worse (seed 873642: four of ten Maxwell
/// records got a catalog stand-in, false additions 4 of 80; hidden
/// effects accepted 45 of 64, 45 of the 52 detectable; docs/criticism.md).
pub fn choose_noise(
    model: &Model,
    data: &Aligned,
    settings: &MapSettings,
    seed: u64,
) -> Result<NoiseChoice, CriticismError> {
    let (white_fit, white) = map_of(model, data, Noise::White, None, settings, seed)?;
    let white_theta = white_fit
        .posterior
        .model_part(&white_fit.map.theta)
        .to_vec();
    let (ar1_fit, ar1) = map_of(model, data, Noise::Ar1, Some(white_theta), settings, seed)?;
    let ar1_theta = ar1_fit.posterior.model_part(&ar1_fit.map.theta).to_vec();
    let (again_fit, again) = map_of(model, data, Noise::White, Some(ar1_theta), settings, seed)?;
    let (bic_white, e2_white, white_residual) = if again.bic < white.bic {
        (
            again.bic,
            again_fit.map.eval.e2,
            again_fit.posterior.residual(&again_fit.map.theta),
        )
    } else {
        (
            white.bic,
            white_fit.map.eval.e2,
            white_fit.posterior.residual(&white_fit.map.theta),
        )
    };
    let rho = ar1_fit
        .posterior
        .noise_part(&ar1_fit.map.theta)
        .first()
        .copied()
        .unwrap_or(0.0);
    let raw_e2_ratio = ar1_fit.map.eval.e2 / e2_white;
    let rho_short = short_lag_rho(&white_residual?);
    let rho_short_limit = short_lag_limit(data.a.len());
    let coloured = rho_short > rho_short_limit;
    let raw_e2_limit = e2_limit(if coloured { rho } else { 0.0 }, data.a.len());
    Ok(NoiseChoice {
        chosen: if ar1.bic < bic_white && raw_e2_ratio <= raw_e2_limit {
            Noise::Ar1
        } else {
            Noise::White
        },
        bic_white,
        bic_ar1: ar1.bic,
        rho,
        raw_e2_ratio,
        raw_e2_limit,
        rho_short,
        rho_short_limit,
    })
}

/// Four standard deviations of [`short_lag_rho`] on `n` samples of white
/// noise, `4 sqrt(2 / n)`: 0.126 on 2,001 samples.
///
/// ```
/// let l = hbis::criticism::short_lag_limit(2001);
/// assert!((l - 0.1265).abs() < 1e-3);
/// ```
pub fn short_lag_limit(n: usize) -> f64 {
    4.0 * (2.0 / n.max(1) as f64).sqrt()
}

/// What `hbis diagnose` computes, and the ladder's first step: the fit of
/// `model` (seed `seed`), its residual diagnosis, and every candidate
/// screened, refitted and ranked (seed `seed + 1`). The same inputs give
/// the same numbers in both.
pub fn diagnose_model(
    registry: &Registry,
    model: &Model,
    data: &Aligned,
    noise: Noise,
    settings: &MapSettings,
    seed: u64,
) -> Result<(ModelFit, Diagnostics, Vec<RankedCandidate>), CriticismError> {
    let (diagnosis, ranking) = diagnose_ranking(registry, model, data, noise, settings, seed)?;
    Ok((ranking.current, diagnosis, ranking.candidates))
}

/// [`diagnose_model`] with the whole [`Ranking`]: the start model's fit
/// in [`Ranking::current`], and the missing form of that fit in
/// [`Ranking::form`] (always set).
pub fn diagnose_ranking(
    registry: &Registry,
    model: &Model,
    data: &Aligned,
    noise: Noise,
    settings: &MapSettings,
    seed: u64,
) -> Result<(Diagnostics, Ranking), CriticismError> {
    let fit = start_fit(model, data, noise, settings, seed)?;
    let ranking = rank_described(registry, model, &fit, data, settings, seed.wrapping_add(1))?;
    let diagnosis = diagnosis_of(model, &ranking.current, data)?;
    Ok((diagnosis, ranking))
}

#[cfg(test)]
mod tests {

    /// Gate 8's terms: the form's out-of-catalog lead against the
    /// candidate's own change, an elastic lead only once the spring law is
    /// final, and else its memory terms against `MEMORY_LEAD` times the
    /// best candidate's change.
    #[test]
    fn the_form_holds_its_lead_or_else_its_memory_terms() {
        let term = |d: &str| OutOfCatalog {
            effect_file: String::new(),
            description: d.into(),
            values: Vec::new(),
            fitted: Vec::new(),
        };
        let mut f = MissingForm::none();
        assert!(held_by(&f, true, -30.0, -60.0).is_none());
        f.memory_terms = Some(term("memory"));
        let (h, beat) = held_by(&f, true, -30.0, -60.0).unwrap();
        assert_eq!(
            (h.description.as_str(), beat),
            ("memory", MEMORY_LEAD * -60.0)
        );
        f.elastic_lead = Some(term("elastic"));
        assert_eq!(
            held_by(&f, false, -30.0, -60.0).unwrap().0.description,
            "memory"
        );
        assert_eq!(
            held_by(&f, true, -30.0, -60.0).unwrap(),
            (&term("elastic"), -30.0)
        );
        f.out_of_catalog = Some(term("lead"));
        assert_eq!(
            held_by(&f, false, -30.0, -60.0).unwrap(),
            (&term("lead"), -30.0)
        );
    }

    /// An effect file of the missing form's shape with `k` coefficients.
    fn form_file(k: usize) -> String {
        let params: String = (1..=k)
            .map(|i| {
                format!(
                    "[[param]]\nname = \"c_{i}\"\nunit = \"-\"\nbounds = [-1.0, 1.0]\nneutral = 0.0\nscale = 0.1\nmeaning = \"c\"\n\n"
                )
            })
            .collect();
        let extra: Vec<String> = (1..=k).map(|i| format!("c_{i} * v")).collect();
        format!(
            "[effect]\nname = \"missing-form\"\nmeaning = \"m\"\n\n{params}[force]\nextra = \"{}\"\n",
            extra.join(" + ")
        )
    }

    /// A form of three terms whose refit lowered BIC by 100, and one of
    /// its terms held apart.
    fn three_terms_one_held() -> (MissingForm, OutOfCatalog) {
        let mut form = MissingForm::none();
        form.delta_bic = Some(-100.0);
        form.effect_file = Some(form_file(3));
        let held = OutOfCatalog {
            effect_file: form_file(1),
            description: String::new(),
            values: Vec::new(),
            fitted: Vec::new(),
        };
        (form, held)
    }

    #[test]
    fn a_candidate_beyond_the_whole_form_and_its_penalty_skips_the_held_refit() {
        let fit = |bic: f64| ModelFit {
            model: String::new(),
            names: Vec::new(),
            theta: Vec::new(),
            e2: 1.0,
            log_likelihood: 0.0,
            bic,
            log_evidence: 0.0,
            sd: Vec::new(),
            evaluations: 0,
            noise: Noise::White,
            at_budget: false,
            best_repeated: None,
        };
        let (mut form, held) = three_terms_one_held();
        let n = 2001;
        // The held term alone may beat all three by two terms' penalty.
        let edge = 1000.0 - 100.0 - 2.0 * (n as f64).ln() - SUPPORT;
        let now = fit(1000.0);
        assert!(outgains_form(&form, &held, &now, &fit(edge - 0.1), n));
        assert!(!outgains_form(&form, &held, &now, &fit(edge + 0.1), n));
        form.delta_bic = None;
        assert!(!outgains_form(&form, &held, &now, &fit(edge - 50.0), n));
    }

    #[test]
    fn held_terms_whose_least_gain_meets_the_beat_skip_the_refit() {
        let (mut form, held) = three_terms_one_held();
        let n = 2001;
        // Alone, the held term gains at most the whole form's 100 and the
        // two left-out terms' penalty.
        let floor = -100.0 - 2.0 * (n as f64).ln();
        assert!(short_of_beat(&form, &held, floor - 0.1, n));
        assert!(!short_of_beat(&form, &held, floor + 0.1, n));
        form.delta_bic = None;
        assert!(!short_of_beat(&form, &held, -1e9, n));
    }

    #[test]
    fn a_refit_that_moves_a_shared_parameter_onto_its_bound_pins_it() {
        let current = Model::parse("trilinear+lcfm+viscous").unwrap();
        let extended = Model::parse("trilinear+lcfm+viscous+offset").unwrap();
        let now = current
            .theta_from_params(&crate::model::Params::table_8_1(5).unwrap(), &[])
            .unwrap();
        let mut refit = now.clone();
        refit.push(0.01);
        assert_eq!(pinned(&current, &now, &extended, &refit), None);
        // rF0's bounds are [-0.1, 0.1].
        let k = current
            .param_names()
            .iter()
            .position(|n| n == "rF0")
            .unwrap();
        refit[k] = 0.1;
        let (name, why) = pinned(&current, &now, &extended, &refit).unwrap();
        assert_eq!(name, "rF0");
        assert!(why.contains("`rF0`"), "{why}");
        // Already there before: not the candidate's doing.
        let mut before = now.clone();
        before[k] = 0.1;
        assert_eq!(pinned(&current, &before, &extended, &refit), None);
    }

    #[test]
    fn an_effect_whose_own_size_sits_on_its_bound_stands_in() {
        let p = crate::model::Params::table_8_1(5).unwrap();
        let asym = Model::parse("trilinear+lcfm+viscous+asymmetric-friction").unwrap();
        let at = |a_f: f64| asym.theta_from_params(&p, &[("a_F", a_f)]).unwrap();
        let of = |m: &Model, name: &str| m.param_names().iter().position(|n| n == name).unwrap();
        let new = [of(&asym, "a_F")];
        // a_F's bounds are [-0.8, 0.8]; the calibration draws 0.45-0.6.
        assert_eq!(own_bound(&asym, &at(0.6), &new), None);
        let why = own_bound(&asym, &at(-0.79999), &new).unwrap();
        assert!(
            why.contains("own `a_F`") && why.contains("-0.8 of [-0.8, 0.8]"),
            "{why}"
        );
        // Not a new parameter: not the candidate's own.
        assert_eq!(own_bound(&asym, &at(0.8), &[]), None);
        // r_mu's neutral 1.0 is its upper bound: the effect switched off.
        let vf = Model::parse("trilinear+lcfm+viscous+velocity-friction").unwrap();
        let new = [of(&vf, "r_mu"), of(&vf, "v_t")];
        let theta = |r_mu: f64| {
            vf.theta_from_params(&p, &[("r_mu", r_mu), ("v_t", 0.05)])
                .unwrap()
        };
        assert_eq!(own_bound(&vf, &theta(1.0), &new), None);
        assert!(own_bound(&vf, &theta(0.05), &new).is_some());
    }

    #[test]
    fn a_structure_that_appears_where_the_candidate_does_not_aim_is_worse() {
        use crate::criticism::features::Feature;
        let f = |kind, significant| Feature::stub(kind, 1.0, 0.0, significant);
        let before = [
            f(FeatureKind::Offset, false),
            f(FeatureKind::JumpSize, false),
        ];
        let after = [f(FeatureKind::Offset, true), f(FeatureKind::JumpSize, true)];
        // It targets the jumps: the new offset counts against it.
        let why = worsened(&[FeatureKind::JumpSize], &before, &after)
            .unwrap()
            .1;
        assert!(why.contains("offset"), "{why}");
        assert_eq!(
            worsened(
                &[FeatureKind::JumpSize, FeatureKind::Offset],
                &before,
                &after
            ),
            None
        );
    }

    #[test]
    fn a_colour_that_crosses_its_threshold_by_a_hair_is_not_gained() {
        use crate::criticism::features::Feature;
        let colour =
            |q: f64, significant| Feature::stub(FeatureKind::Colour, q, f64::NAN, significant);
        // Row 6's `lcfm` refit (seed 20261407): across p = 0.01 by 0.135.
        let (before, after) = ([colour(37.500, false)], [colour(37.635, true)]);
        assert_eq!(worsened(&[FeatureKind::JumpSize], &before, &after), None);
        // By more than Q's sd under white noise (6.32): gained.
        let after = [colour(44.0, true)];
        let why = worsened(&[FeatureKind::JumpSize], &before, &after)
            .unwrap()
            .1;
        assert!(
            why.contains("colour") && why.contains("37.500 to 44.000"),
            "{why}"
        );
    }

    #[test]
    fn a_colour_moved_across_its_threshold_by_a_hair_is_not_turned_white() {
        use crate::criticism::features::Feature;
        let colour =
            |q: f64, significant| Feature::stub(FeatureKind::Colour, q, f64::NAN, significant);
        assert!((white_q() - 31.41).abs() < 0.01, "{}", white_q());
        // The Bouc-Wen springs of seed 176469212: no longer reported at
        // 1 %, still coloured at 5 %.
        for (b, a) in [(41.9, 33.8), (46.8, 34.5)] {
            assert_eq!(whitened(&[colour(b, true)], &[colour(a, false)]), None);
        }
        // The third spring branch of seed 787329362077: white.
        assert_eq!(
            whitened(&[colour(467.0, true)], &[colour(18.5, false)]),
            Some((467.0, 18.5))
        );
        // Coloured after, or white before: nothing turned white.
        assert_eq!(
            whitened(&[colour(467.0, true)], &[colour(18.5, true)]),
            None
        );
        assert_eq!(
            whitened(&[colour(30.0, false)], &[colour(18.5, false)]),
            None
        );
        // Coloured at 5 % but not reported at 1 % before, white after (a
        // hidden velocity friction, seed 243288580 record 25): white.
        assert_eq!(
            whitened(&[colour(36.3, false)], &[colour(13.1, false)]),
            Some((36.3, 13.1))
        );
        // Reported coloured by its lag-1 correlation alone (a short
        // record), white after: white, as before the 5 % line came in.
        assert_eq!(
            whitened(&[colour(25.0, true)], &[colour(10.0, false)]),
            Some((25.0, 10.0))
        );
    }

    #[test]
    fn a_structure_at_three_standard_errors_is_not_gained_beyond_its_bonferroni_level() {
        use crate::criticism::features::Feature;
        let jumps = |m: f64, z: f64| Feature::stub(FeatureKind::JumpSize, m, z, m > 0.1 && z > 3.0);
        // The hidden damper's `viscous` refit (record 223489868467704).
        let before = [jumps(0.080, 0.30)];
        assert_eq!(
            worsened(&[FeatureKind::DecayRate], &before, &[jumps(0.620, 3.26)]),
            None
        );
        let after = [jumps(0.620, 3.5)];
        let why = worsened(&[FeatureKind::DecayRate], &before, &after)
            .unwrap()
            .1;
        assert!(
            why.contains("jump-size") && why.contains("0.080 to 0.620"),
            "{why}"
        );
        // Targeted, it is never "gained".
        assert_eq!(worsened(&[FeatureKind::JumpSize], &before, &after), None);
    }
    use super::*;
    use crate::data::synthesize;
    use crate::model::{ForceComponent, Forces, Kinematics, ParamSpec, Params};
    use std::sync::Arc;

    /// A stopper beyond `|u| = gap`; mid-range, `gap` (0.155 m) lies
    /// beyond Test 5's release (0.117 m).
    struct Stopper;

    impl ForceComponent for Stopper {
        fn name(&self) -> &str {
            "stopper"
        }
        fn params(&self) -> Vec<ParamSpec> {
            vec![
                ParamSpec::new("k_gap", "1/s^2", (0.0, 20.0), 0.0),
                ParamSpec::new("gap", "m", (0.01, 0.3), 0.1),
            ]
        }
        fn meaning(&self) -> &str {
            "a stopper"
        }
        fn signature(&self) -> &str {
            "a stiffening beyond a displacement"
        }
        fn piecewise_linear(&self) -> bool {
            false
        }
        fn modify(&self, theta: &[f64], s: &Kinematics, f: &mut Forces) {
            let over = s.u.abs() - theta[1];
            if over > 0.0 {
                f.extra += theta[0] * over * s.u.signum();
            }
        }
    }

    fn setup() -> (Registry, Model, Vec<f64>, Aligned) {
        let mut registry = Registry::builtin();
        registry.register_force(Arc::new(Stopper)).unwrap();
        let model = registry.parse("trilinear+lcfm+viscous").unwrap();
        let p = Params::table_8_1(5).unwrap();
        let theta = model.theta_from_params(&p, &[]).unwrap();
        let mut rng = StdRng::seed_from_u64(1);
        let syn = synthesize(&model, &theta, 0.005, 2001, 0.015, &mut rng).unwrap();
        (registry, model, theta, syn.record.aligned(None).unwrap())
    }

    fn candidate(registry: &Registry, model: &Model, theta: &[f64], name: &str) -> Candidate {
        registry
            .candidates(model, theta)
            .into_iter()
            .find(|c| c.effect == name)
            .unwrap()
    }

    fn index(c: &Candidate, name: &str) -> usize {
        c.model
            .param_names()
            .iter()
            .position(|n| n == name)
            .unwrap()
    }

    /// The mid-range start of the stopper does nothing on this record; it
    /// moves to the first fallback fraction where the stopper engages.
    #[test]
    fn a_spread_start_on_a_plateau_moves_to_where_the_component_acts() {
        let (registry, model, theta, data) = setup();
        let c = candidate(&registry, &model, &theta, "stopper");
        let new = [index(&c, "k_gap"), index(&c, "gap")];
        let s = starts(&c, &new, &[0.5], &data);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0], c.start);
        // 0.25 of the range: k_gap 5, gap 0.0825 m, inside the motion.
        assert_eq!(
            [s[1][new[0]], s[1][new[1]]],
            [5.0, 0.01 + 0.25 * (0.3 - 0.01)]
        );
    }

    /// A start where the component acts is kept where it was asked for.
    #[test]
    fn a_spread_start_where_the_component_acts_stays() {
        let (registry, model, theta, data) = setup();
        let c = candidate(&registry, &model, &theta, "offset");
        let k = index(&c, "a_off");
        let s = starts(&c, &[k], &[0.25, 0.75], &data);
        assert!((s[1][k] + 0.1).abs() < 1e-12, "{}", s[1][k]);
        assert!((s[2][k] - 0.1).abs() < 1e-12, "{}", s[2][k]);
    }
}
