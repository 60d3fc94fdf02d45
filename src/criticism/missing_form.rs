//! The form of what is missing: the residual force per unit mass described
//! by a few physically named terms, chosen by sparse regression.
//!
//! The library of terms is built on the fitted model's motion (`u`, `v`,
//! time since release `t`, sliding `travel`):
//!
//! - `elastic`: `u^3`, `|u| u`; `viscous`: `v`, `|v| v`; `coulomb`:
//!   `sgn v`; `amplitude`: `|u| sgn v`; `travel`: `travel sgn v`,
//!   `travel u`; `time`: `t sgn v`, `t u`;
//! - `memory`: `u - q` with `dq/dt = (u - q) / tau`, `q = u0` at the
//!   release (a Maxwell element, a spring and a dashpot in series: a
//!   viscoelastic rubber; the velocity relaxed with the same `tau` is the
//!   same force over `tau`), for 25 time constants from 0.05 to 3 s evenly
//!   spaced in `ln tau` (neighbours 19 % apart);
//! - `hysteretic`: `z`, `dz/dt = (v - |v| z) / d` (a smooth hysteretic
//!   loop of yield displacement `d`, Bouc-Wen with exponent 1), for `d`
//!   from 0.5 to 10 mm.
//!
//! A force acts on the record through the motion it changes, over many
//! swings, more than directly: so each term's column is its
//! **sensitivity**, how the model's acceleration changes per unit of its
//! coefficient when the term is added as a force (the term written as an
//! effect file and run on the numerical engine at plus and minus a force
//! of a thousandth of the peak acceleration; of the two one-sided
//! differences the smaller at each sample, since a sample that a moved
//! reversal carries across a friction jump differs by the jump). Regressed
//! on the terms' values instead, a Maxwell record's residual picked `u^3`,
//! `|u| u` and a hysteretic term, and no memory term.
//!
//! The current model's tangent space (the finite-difference Jacobian of
//! its acceleration) is in every regression, so a term is credited only
//! with what the model's own parameters cannot absorb by moving. Under
//! AR(1) noise the residual and every column are whitened first. Terms
//! enter one at a time, the one that lowers the residual sum of squares
//! most, while that lowers BIC by more than [`SUPPORT`] (at most
//! [`MAX_TERMS`]; one memory and one hysteretic term at most):
//!
//! # Formula
//! ```text
//! delta BIC = n ln(RSS_(k+1) / RSS_k) + ln n
//! share_k   = (RSS_(k-1) - RSS_k) / RSS_0
//! ```
//!
//! A term's `share` is the share of the residual's variance it explains.
//! On a record with nothing missing no term passes (a term unrelated to
//! the residual lowers BIC by more than 10 only when its chi-square
//! exceeds 17.6, with probability 3e-5 per term). The selected terms are
//! then refitted with the model (their effect file's component added, from
//! the MAP with the terms at their linear estimates): linearised about a
//! model that lacks the force, a Maxwell element's 0.3 s came out 0.165 s;
//! refitted, 0.272 s. The report gives the refitted values, the refit's
//! `e2` and change of BIC, and the effect file
//! ([`MissingForm::effect_file`]) ready for `--effects`: each term's
//! coefficient a parameter, a memory term's time constant one too, with
//! the states memory and hysteresis need.
//!
//! Stepwise sparse regression over a library of candidate terms is SINDy's
//! idea (Brunton, Proctor & Kutz 2016) with BIC selection; with so few
//! columns and terms, least squares by SVD (`nalgebra`) is all it needs.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use super::ranking::{fit_model, priors_for, CriticismError, ModelFit, NUMERIC_BUDGET, SUPPORT};
use crate::data::Aligned;
use crate::inference::map::SAME_BASIN;
use crate::inference::{MapError, MapSettings, Noise, Polish, Posterior};
use crate::model::effect_file::FileEffect;
use crate::model::{ForwardModel, Model};

/// At most this many terms describe what is missing.
pub const MAX_TERMS: usize = 3;

/// Shortest and longest time constant of the memory terms (s).
pub const TAU_RANGE: (f64, f64) = (0.05, 3.0);

/// How many time constants the memory terms try.
const N_TAU: usize = 25;

/// Yield displacements of the hysteretic terms (m).
const HYSTERESIS_D: [f64; 5] = [0.0005, 0.001, 0.002, 0.005, 0.01];

/// One term of the missing force.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Term {
    /// `memory`, `elastic`, `viscous`, `coulomb`, `amplitude`, `travel`,
    /// `time` or `hysteretic`.
    pub kind: &'static str,
    /// The term, in the effect-file language (`u - q` with its state).
    pub expression: String,
    /// A memory term's relaxation time (s); a hysteretic term's yield
    /// displacement is in its expression.
    pub time_constant_s: Option<f64>,
    /// Its coefficient: force per unit mass per unit of the term.
    pub coefficient: f64,
    /// The share of the residual's variance it explains.
    pub share: f64,
}

/// What the residual says is missing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MissingForm {
    /// The terms, in the order they entered (empty: nothing is missing
    /// that the library can describe).
    pub terms: Vec<Term>,
    /// The terms as an effect file (TOML) for `--effects`, its component
    /// named `missing-form`; `None` without terms.
    pub effect_file: Option<String>,
    /// `e2` of the model refitted with the effect file's component.
    pub e2_with: Option<f64>,
    /// The change of BIC that refit makes.
    pub delta_bic: Option<f64>,
    /// What the figure draws (not in the JSON).
    #[serde(skip)]
    pub series: Option<FormSeries>,
    /// Its terms no catalog component makes (memory and hysteretic
    /// terms, travel and time terms that add force, `outside_catalog`)
    /// when the first term is one (not in the JSON; `None` otherwise).
    #[serde(skip)]
    pub out_of_catalog: Option<OutOfCatalog>,
    /// Its elastic, memory and hysteretic terms when the first term is
    /// elastic (`u^3`, `|u| u`): a stiffness law no catalog component
    /// makes once the model's spring law is the last the catalog offers
    /// (not in the JSON; `None` otherwise).
    #[serde(skip)]
    pub elastic_lead: Option<OutOfCatalog>,
    /// Its memory and hysteretic terms when they are in it but do not
    /// lead it (not in the JSON; `None` otherwise): asked of a candidate
    /// only where they alone gain more than every candidate does
    /// (`criticism::ranking`, gate 8).
    #[serde(skip)]
    pub memory_terms: Option<OutOfCatalog>,
    /// Its memory and hysteretic terms when it has others too, for
    /// [`MissingForm::stateful_alone`] (not in the JSON).
    #[serde(skip)]
    pub stateful: Option<Stateful>,
    /// Where it has no memory term: the same terms with a memory term in
    /// place of its hysteretic one (or beside them), for
    /// [`MissingForm::memory_instead`] (not in the JSON).
    #[serde(skip)]
    pub alternative: Option<Alternative>,
}

/// Terms the sparse regression did not choose, at their linear estimates,
/// with what they describe of the residual ([`FormSeries::described`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Alternative {
    cols: Vec<Column>,
    terms: Vec<Term>,
    described: Vec<f64>,
}

/// The terms of a [`MissingForm`] that no catalog component makes: memory
/// and hysteretic forces, a stiffness or friction that grows with travel
/// or time, and elastic ones where the spring law is final.
#[derive(Debug, Clone, PartialEq)]
pub struct OutOfCatalog {
    /// Them as an effect file (component `missing-form`).
    pub effect_file: String,
    /// Them in words (`memory term (u - q, ...)`).
    pub description: String,
    /// Their parameters' values in the form's refit (or linear estimates).
    pub values: Vec<(String, f64)>,
    /// Every parameter of the model refitted with exactly these terms, by
    /// name (the memory search's refit, [`MissingForm::memory_search`]);
    /// empty where they were refitted beside other terms or are linear
    /// estimates. A refit of the model with the terms starts there: from
    /// the current fit's values instead, a Maxwell record's refit
    /// (calibration seed 235684487, record 56) ended 126 above the
    /// search's BIC, and `friction-decay` took 16.5 of the difference.
    pub fitted: Vec<(String, f64)>,
}

/// The residual and the force the terms describe, on the sample grid.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FormSeries {
    /// Time since the release (s).
    pub t: Vec<f64>,
    /// The model's displacement (m).
    pub u: Vec<f64>,
    /// And velocity (m/s).
    pub v: Vec<f64>,
    /// Record minus model (m/s^2).
    pub residual: Vec<f64>,
    /// What the terms explain of the residual at their linear estimates,
    /// the model's own parameters re-adjusted to them (m/s^2).
    pub described: Vec<f64>,
}

impl MissingForm {
    /// Nothing is missing.
    pub fn none() -> Self {
        Self {
            terms: Vec::new(),
            effect_file: None,
            e2_with: None,
            delta_bic: None,
            series: None,
            out_of_catalog: None,
            elastic_lead: None,
            memory_terms: None,
            stateful: None,
            alternative: None,
        }
    }

    /// The form as a report gives it where no candidate is accepted
    /// (`any_accepted` false): [`MissingForm::memory_instead`], then
    /// [`MissingForm::stateful_alone`], then
    /// [`MissingForm::memory_starts`]. Otherwise the form unchanged.
    pub fn as_reported(
        self,
        any_accepted: bool,
        model: &Model,
        fit: &ModelFit,
        data: &Aligned,
        settings: &MapSettings,
    ) -> Result<Self, CriticismError> {
        if any_accepted {
            return Ok(self);
        }
        self.memory_instead(model, fit, data, settings)?
            .stateful_alone(model, fit, data, settings)?
            .memory_starts(model, fit, data, settings)
    }

    /// The form's memory term alone, refitted with the model from each
    /// time constant of [`TAU_STARTS`] (its coefficient from the form),
    /// where the best of those refits lowers BIC more than the form does.
    /// A refit is a local search, and the form's starts from the
    /// regression's grid value, which a model that lacks the force
    /// biases: on records of `examples/memory_records` a memory term came
    /// out at 0.07 s beside an elastic and a viscous term (`e2` 1.14 times
    /// the noise floor) for a truth of 0.53 s (docs/criticism.md). Its
    /// `share` stays the form's.
    ///
    /// Beside those local refits, a global search (`memory_global`, the
    /// best of three)
    /// fits the model with a memory term alone from its whole prior: the
    /// model's own parameters, fitted without the force, sit in a basin
    /// that a local refit does not leave (on a record of
    /// `examples/memory_records`, seed 336097008299, `tau_m` 0.567 s: every
    /// local refit from the fit ended 170-270 nats below the truth's
    /// refit; the global search ended 41 nats below it at 0.55 s, and the
    /// local refits from its point reached it, at 0.55 s). It also
    /// runs where the form has no memory term, and replaces such a form
    /// only where it lowers BIC by more than [`SUPPORT`] below it, as
    /// [`MissingForm::memory_instead`] does.
    pub fn memory_starts(
        self,
        model: &Model,
        fit: &ModelFit,
        data: &Aligned,
        settings: &MapSettings,
    ) -> Result<Self, CriticismError> {
        let Some(now) = self.delta_bic else {
            return Ok(self);
        };
        let memory = self.terms.iter().find(|t| t.kind == "memory");
        let local = refit_settings(settings)?;
        let (now_layout, theta) = (model.layout(), fit.model_theta(model));
        let from_fit = |name: &str| now_layout.get(theta, name);
        let starts = |core: &(dyn Fn(&str) -> Option<f64> + Sync), m: &Term| -> Vec<_> {
            TAU_STARTS
                .par_iter()
                .filter_map(|&tau| memory_alone(model, core, data, fit.noise, m, tau, &local))
                .collect()
        };
        let (mut refits, global): (Vec<_>, _) = rayon::join(
            || memory.map_or_else(Vec::new, |m| starts(&from_fit, m)),
            || memory_global(model, fit, data, memory, settings),
        );
        // The global search's basin of the model's own parameters, and its
        // time constant from spread starts again: in that basin the time
        // constant still has local optima (0.37 s against 0.20 s).
        if let Some((col, term, r, alone)) = global? {
            let (layout, at) = (alone.layout(), r.model_theta(&alone));
            let from_global = |name: &str| {
                (name != "c_1" && name != "tau_mem")
                    .then(|| layout.get(at, name))
                    .flatten()
            };
            refits.extend(starts(&from_global, &term));
            refits.push((col, term, r));
        }
        if let Some(c) = local.cancel() {
            c.check().map_err(MapError::from)?;
        }
        let margin = if memory.is_some() { 0.0 } else { SUPPORT };
        let Some((col, term, r)) = refits
            .into_iter()
            .min_by(|a, b| a.2.bic.total_cmp(&b.2.bic))
            .filter(|(_, _, r)| r.bic - fit.bic < now - margin)
        else {
            return Ok(self);
        };
        Ok(Self::of_stateful(&[&col], vec![term], &r, fit, self.series))
    }

    /// The memory term that [`MissingForm::memory_starts`] puts in the
    /// form's place, as terms no catalog component makes; `None` where it
    /// keeps the form (no memory term alone lowers BIC more), or where the
    /// term relaxes faster than the library's shortest time constant
    /// ([`TAU_RANGE`]).
    ///
    /// A Maxwell element whose relaxation is short against the motion is a
    /// damper (its force `c_1 (u - q)` tends to `c_1 tau v`), which the
    /// catalog holds. On a hidden-damper record (calibration seed
    /// 235684487, record 53) the search's term of 0.035 s lowered BIC by
    /// 929.7 against `viscous`'s 928.2, and beside it `viscous` was refused
    /// as a stand-in once gate 8 refitted from the search's own fit
    /// ([`OutOfCatalog::fitted`]).
    pub fn memory_search(
        &self,
        model: &Model,
        fit: &ModelFit,
        data: &Aligned,
        settings: &MapSettings,
    ) -> Result<Option<OutOfCatalog>, CriticismError> {
        let found = self.clone().memory_starts(model, fit, data, settings)?;
        let replaced = found != *self
            && found.terms.iter().all(|t| {
                t.kind == "memory" && t.time_constant_s.is_some_and(|tau| tau >= TAU_RANGE.0)
            });
        Ok(found.out_of_catalog.filter(|_| replaced))
    }

    /// A form of memory or hysteretic terms `terms` (from `cols`) alone,
    /// with the values of their refit `r` (against `fit`), keeping the
    /// figure's `series`.
    fn of_stateful(
        cols: &[&Column],
        terms: Vec<Term>,
        r: &ModelFit,
        fit: &ModelFit,
        series: Option<FormSeries>,
    ) -> Self {
        let fitted = || {
            r.names
                .iter()
                .cloned()
                .zip(r.theta.iter().copied())
                .collect()
        };
        Self {
            effect_file: Some(effect_file_text(cols, &terms)),
            out_of_catalog: held_apart(cols, &terms, &|t| has_state(t.kind)).map(|held| {
                OutOfCatalog {
                    fitted: fitted(),
                    ..held
                }
            }),
            memory_terms: None,
            elastic_lead: None,
            terms,
            e2_with: Some(r.e2),
            delta_bic: Some(r.bic - fit.bic),
            series,
            stateful: None,
            alternative: None,
        }
    }

    /// The form with a memory term in place of its hysteretic term (or
    /// beside its terms where it has none), refitted with the model, where
    /// that lowers BIC by more than [`SUPPORT`] and more than the form's
    /// own refit ([`MissingForm::alternative`]). Linear about a model that
    /// lacks the force, the regression took a hysteretic or elastic term
    /// for a Maxwell element's: on records of `examples/memory_records`
    /// the form was `z` (yield 10 mm) alone, with `e2` 1.22 times the
    /// noise floor, for a memory force of 0.95 s (docs/criticism.md).
    pub fn memory_instead(
        self,
        model: &Model,
        fit: &ModelFit,
        data: &Aligned,
        settings: &MapSettings,
    ) -> Result<Self, CriticismError> {
        let Some(alt) = &self.alternative else {
            return Ok(self);
        };
        let cols: Vec<&Column> = alt.cols.iter().collect();
        let other = refined(model, fit, data, &cols, alt.terms.clone(), settings)?;
        let better = other
            .delta_bic
            .is_some_and(|a| a < -SUPPORT && self.delta_bic.is_none_or(|b| a < b));
        if !better {
            return Ok(self);
        }
        let series = self.series.map(|s| FormSeries {
            described: alt.described.clone(),
            ..s
        });
        Ok(Self { series, ..other })
    }

    /// The form as a report gives it: where it has memory or hysteretic
    /// terms beside others, those terms alone refitted with the model (from
    /// the whole form's refit), kept when that lowers BIC further. The
    /// sparse regression is linear about a model that lacks the force, and
    /// picks terms beside a memory term that the truth does not have; they
    /// move its time constant. On 20 Maxwell records of
    /// `examples/memory_records` (seed 332540) the memory term alone had
    /// the lower BIC on all 11 records with such a form. The figure's
    /// series stay the whole form's linear description.
    pub fn stateful_alone(
        self,
        model: &Model,
        fit: &ModelFit,
        data: &Aligned,
        settings: &MapSettings,
    ) -> Result<Self, CriticismError> {
        let (Some(st), Some(whole)) = (&self.stateful, self.delta_bic) else {
            return Ok(self);
        };
        let cols: Vec<&Column> = st.cols.iter().collect();
        let Ok(effect) = FileEffect::from_toml(&effect_file_text(&cols, &st.terms), "missing-form")
        else {
            return Ok(self);
        };
        let alone = model.with_force(std::sync::Arc::new(effect));
        let now = model.layout();
        let theta = fit.model_theta(model);
        let value = |name: &str| st.values.iter().find(|(n, _)| n == name).map(|v| v.1);
        let start = alone.layout().theta_from(&|p| {
            value(&p.name)
                .or_else(|| now.get(theta, &p.name))
                .unwrap_or(p.neutral)
        });
        let settings = refit_settings(settings)?;
        let refit = fit_model(
            &alone,
            data,
            fit.noise,
            Some(start),
            &settings,
            REFIT_SEED ^ 2,
        );
        if let Some(c) = settings.cancel() {
            c.check().map_err(MapError::from)?;
        }
        let Ok(r) = refit else {
            return Ok(self);
        };
        if r.bic - fit.bic >= whole {
            return Ok(self);
        }
        let mut terms = st.terms.clone();
        take_values(&mut terms, &alone, &r);
        Ok(Self::of_stateful(&cols, terms, &r, fit, self.series))
    }
}

/// Seed of the refit of the terms with the model.
const REFIT_SEED: u64 = 0x3155_F0E3;

/// Evaluations of the global search of [`MissingForm::memory_starts`]:
/// on the record of its example, a global fit of the true structure (the
/// built-in `maxwell`) ended 1,000 nats above the start model with
/// 20,000, within one nat of the truth's refit with 60,000 (2.8-3.5 s on
/// two cores, four seeds of four) and no better with 120,000.
pub const GLOBAL_BUDGET: usize = 60_000;

/// Seeds (mixed into the refit seed) of [`memory_global`]'s independent
/// searches, the best kept. One search depended on luck: on the record of
/// `MissingForm::memory_starts` a change of 1e-8 relative in the model's
/// acceleration (the exact flow in place of the adaptive integrator)
/// moved its end from 0.55 s to 1.52 s, for a truth of 0.567 s. With
/// three, on the exact flow, both global-search records of
/// `tests/it/missing_form.rs` end within 30 % of the truth (2026-12-04).
/// The third runs only where the first two end apart
/// ([`found_by_both`]).
const GLOBAL_SEEDS: [u64; 3] = [4, 5, 6];

/// Whether two searches `a` and `b` ended in one basin: their
/// log-likelihoods within [`SAME_BASIN`], the rule by which a MAP search
/// calls its best found twice. A third search is then not run: on the
/// demo's record (`hbis diagnose --model bilinear+coulomb`) all three
/// ended within 0.1 of BIC -159.5 at 1.45-1.49 s, each at its 60,000
/// evaluations, and the third cost a second of the diagnosis's 7
/// (2026-12-04); where a search was lucky (the record above, searches
/// ending 110, -1164 and 782 from the start model) the two disagree.
///
/// ```
/// # use hbis::criticism::missing_form::found_by_both;
/// assert!(found_by_both(-1000.0, -1000.9));
/// assert!(!found_by_both(-1000.0, -1001.0));
/// assert!(!found_by_both(f64::NAN, -1000.0));
/// ```
pub fn found_by_both(log_likelihood_a: f64, log_likelihood_b: f64) -> bool {
    (log_likelihood_a - log_likelihood_b).abs() < SAME_BASIN
}

/// The best (lowest `score`) of [`GLOBAL_SEEDS`]' searches: the first two
/// side by side, the third only where they did not end in one basin
/// ([`found_by_both`] on `log_likelihood`); a failed search (`None`) is
/// no agreement.
fn best_of_global<T: Send>(
    search: impl Fn(u64) -> Option<T> + Sync,
    log_likelihood: impl Fn(&T) -> f64,
    score: impl Fn(&T) -> f64,
) -> Option<T> {
    let (a, b) = rayon::join(|| search(GLOBAL_SEEDS[0]), || search(GLOBAL_SEEDS[1]));
    let agree = matches!((&a, &b), (Some(a), Some(b)) if found_by_both(log_likelihood(a), log_likelihood(b)));
    let c = if agree { None } else { search(GLOBAL_SEEDS[2]) };
    [a, b, c]
        .into_iter()
        .flatten()
        .min_by(|a, b| score(a).total_cmp(&score(b)))
}

/// The time constants (s) [`memory_global`] searches: two decades and
/// more, so that the search runs on a log scale
/// ([`crate::inference::find_map`]); on the library's [`TAU_RANGE`] it
/// ran on a linear one, where 0.2 s lies in the bottom 3 %.
const GLOBAL_TAU_RANGE: (f64, f64) = (0.025, 3.0);

/// The model with a memory term alone, fitted by [`GLOBAL_SEEDS`]'
/// global searches over its whole prior ([`GLOBAL_BUDGET`] evaluations
/// each; the third only where the first two disagree), the best kept. As in the built-in
/// `maxwell`, the search's coefficient is the Maxwell spring's stiffness
/// over the rubber's, `k0`, from 0 to 1, so that it moves with the
/// spring's as the search moves `f0` (with an absolute coefficient from 0
/// to `k0`, the search ended 180 nats below the truth's refit on the
/// record of `MissingForm::memory_starts`); the time constant spans
/// [`GLOBAL_TAU_RANGE`]. The term is reported with its
/// absolute coefficient at the refit's `k0`, the same force. `memory`
/// gives the term its share; without it the share is what the refit
/// explains of the residual's variance, `1 - e2_with / e2`. With the
/// column, the term, the refit and the model it fitted; `None` where the
/// model has no `f0` or the search fails.
fn memory_global(
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
    memory: Option<&Term>,
    settings: &MapSettings,
) -> Result<Option<(Column, Term, ModelFit, Model)>, CriticismError> {
    let tau = (TAU_RANGE.0 * TAU_RANGE.1).sqrt();
    let col = memory_column(tau, Vec::new());
    let relative = Column {
        code: format!("k0 * {}", col.code),
        ..col.clone()
    };
    let mut term = Term {
        kind: "memory",
        expression: col.expression.clone(),
        time_constant_s: Some(tau),
        coefficient: 0.1,
        share: memory.map_or(0.0, |m| m.share),
    };
    let text = effect_file_within(
        &[&relative],
        std::slice::from_ref(&term),
        Some(((0.0, 1.0), GLOBAL_TAU_RANGE)),
    );
    let Ok(effect) = FileEffect::from_toml(&text, "missing-form") else {
        return Ok(None);
    };
    let alone = model.with_force(std::sync::Arc::new(effect));
    let global = settings.clone().with_max_evals(GLOBAL_BUDGET)?;
    // A cancelled search is caught by the caller's check.
    let search = |s: u64| fit_model(&alone, data, fit.noise, None, &global, REFIT_SEED ^ s).ok();
    let Some(r) = best_of_global(search, |r| r.log_likelihood, |r| r.bic) else {
        return Ok(None);
    };
    let Some(f0) = alone.layout().get(r.model_theta(&alone), "f0") else {
        return Ok(None);
    };
    take_values(std::slice::from_mut(&mut term), &alone, &r);
    term.coefficient *= (2.0 * std::f64::consts::PI * f0).powi(2);
    if memory.is_none() {
        term.share = (1.0 - r.e2 / fit.e2).max(0.0);
    }
    Ok(Some((col, term, r, alone)))
}

/// Time constants (s) [`MissingForm::memory_starts`] starts from: each
/// refit's bounds are a third to three times its start, so together
/// they span 0.04 to 3.9 s, the library's range ([`TAU_RANGE`]).
pub const TAU_STARTS: [f64; 3] = [0.12, 0.4, 1.3];

/// The memory term `memory` alone refitted with `model` from time
/// constant `tau`, the model's own parameters at `core`'s values (its
/// coefficient at `memory`'s or at zero, the denser start): its column,
/// the term with the refit's values, and the refit.
fn memory_alone(
    model: &Model,
    core: &dyn Fn(&str) -> Option<f64>,
    data: &Aligned,
    noise: Noise,
    memory: &Term,
    tau: f64,
    settings: &MapSettings,
) -> Option<(Column, Term, ModelFit)> {
    let col = memory_column(tau, Vec::new());
    let mut term = Term {
        expression: col.expression.clone(),
        time_constant_s: Some(tau),
        ..memory.clone()
    };
    let text = effect_file_text(&[&col], std::slice::from_ref(&term));
    let effect = FileEffect::from_toml(&text, "missing-form").ok()?;
    let alone = model.with_force(std::sync::Arc::new(effect));
    let neutral = alone
        .layout()
        .theta_from(&|p| core(&p.name).unwrap_or(p.neutral));
    let mut start = neutral.clone();
    let k = alone.param_names().iter().position(|n| *n == "c_1")?;
    start[k] = memory.coefficient;
    let start = better_start(&alone, data, noise, start, neutral);
    let r = fit_model(&alone, data, noise, Some(start), settings, REFIT_SEED ^ 3).ok()?;
    take_values(std::slice::from_mut(&mut term), &alone, &r);
    Some((col, term, r))
}

/// A library term: what it is, how the effect language writes it, and its
/// values on the model's motion.
#[derive(Debug, Clone, PartialEq)]
struct Column {
    kind: &'static str,
    /// For people (`u - q, dq/dt = (u - q) / 0.300`).
    expression: String,
    /// A memory term's relaxation time.
    tau: Option<f64>,
    /// The term in the effect language; `{tau}` stands for its time
    /// constant.
    code: String,
    /// Its state: name, rate (with `{tau}`), value at the release.
    state: Option<(&'static str, String, &'static str)>,
    /// Its values on the current model's motion (to size the probe).
    values: Vec<f64>,
}

impl Column {
    fn linear(kind: &'static str, expression: &str, code: &str, values: Vec<f64>) -> Self {
        Self {
            kind,
            expression: expression.to_string(),
            tau: None,
            code: code.to_string(),
            state: None,
            values,
        }
    }

    /// `text` with `{tau}` replaced by `tau`.
    fn with_tau(&self, text: &str, tau: &str) -> String {
        text.replace("{tau}", tau)
    }
}

/// The time constants of the memory terms.
pub fn time_constants() -> Vec<f64> {
    let (lo, hi) = TAU_RANGE;
    (0..N_TAU)
        .map(|i| lo * (hi / lo).powf(i as f64 / (N_TAU - 1) as f64))
        .collect()
}

/// `x` relaxed through `dq/dt = (x - q) / tau` from `q0`, exactly for `x`
/// linear between samples.
fn relaxed(x: &[f64], tau: f64, dt: f64, q0: f64) -> Vec<f64> {
    let e = (-dt / tau).exp();
    let lag = tau / dt;
    let mut q = q0;
    let mut out = Vec::with_capacity(x.len());
    for (i, &x1) in x.iter().enumerate() {
        if i > 0 {
            // Over a step x ramps by s; q trails a ramp by s tau / dt, and
            // any other offset decays by e.
            let x0 = x[i - 1];
            let s = x1 - x0;
            q = x1 - s * lag + e * (q - x0 + s * lag);
        }
        out.push(q);
    }
    out
}

/// A smooth hysteretic variable `z`, `dz/dt = (v - |v| z) / d`, from 0,
/// stepped on the displacement increments (exact for a constant sign of
/// `v` over a step: `z` relaxes towards `sgn v` by `exp(-|du| / d)`).
fn hysteretic(u: &[f64], d: f64) -> Vec<f64> {
    let mut z = 0.0;
    let mut out = Vec::with_capacity(u.len());
    for (i, &x) in u.iter().enumerate() {
        if i > 0 {
            let du = x - u[i - 1];
            let target = du.signum();
            z = target + (z - target) * (-du.abs() / d).exp();
        }
        out.push(z);
    }
    out
}

fn has_state(kind: &str) -> bool {
    kind == "memory" || kind == "hysteretic"
}

/// Whether no catalog component makes the term `t`: a memory or
/// hysteretic term, or a travel or time term of the sign the catalog
/// lacks. The catalog's forces that change with travel only lose:
/// `degradation` softens the rubber (`travel u` and `t u` below zero, the
/// term being a restoring force) and `friction-decay` lowers the friction
/// (`travel sgn v` and `t sgn v` below zero). A rubber that stiffens or a
/// friction that grows as the test goes on is outside it. On two Maxwell
/// records under AR(1) noise (calibration seeds 115766835 record 59 and
/// 235684487 record 60) the form was `travel u` alone, coefficient +2.57
/// and +0.74 m/s^2 per m^2 (the Maxwell element's force building up from
/// the release), `degradation` stayed at its neutral value, and, taken
/// for a catalog term, the form let `friction-decay` in (BIC -47.8 and
/// -38.8, the truth's refit -349.6 and -234.4).
fn outside_catalog(t: &Term) -> bool {
    let grows = matches!(t.kind, "travel" | "time") && t.coefficient > 0.0;
    has_state(t.kind) || grows
}

/// The library on the model's motion (`u`, `v` at the samples, `t` from
/// the release).
fn library(u: &[f64], v: &[f64], t: &[f64], dt: f64, u0: f64) -> Vec<Column> {
    let n = u.len();
    let sgn: Vec<f64> = v
        .iter()
        .map(|x| if *x == 0.0 { 0.0 } else { x.signum() })
        .collect();
    let mut travel = vec![0.0; n];
    for i in 1..n {
        travel[i] = travel[i - 1] + (u[i] - u[i - 1]).abs();
    }
    let map = |f: &dyn Fn(usize) -> f64| (0..n).map(f).collect::<Vec<f64>>();
    let mut cols = vec![
        Column::linear("elastic", "u^3", "u * u * u", map(&|i| u[i].powi(3))),
        Column::linear(
            "elastic",
            "|u| u",
            "abs(u) * u",
            map(&|i| u[i].abs() * u[i]),
        ),
        Column::linear("viscous", "v", "v", v.to_vec()),
        Column::linear(
            "viscous",
            "|v| v",
            "abs(v) * v",
            map(&|i| v[i].abs() * v[i]),
        ),
        Column::linear("coulomb", "sgn v", "dir", sgn.clone()),
        Column::linear(
            "amplitude",
            "|u| sgn v",
            "abs(u) * dir",
            map(&|i| u[i].abs() * sgn[i]),
        ),
        Column::linear(
            "travel",
            "travel sgn v",
            "travel * dir",
            map(&|i| travel[i] * sgn[i]),
        ),
        Column::linear(
            "travel",
            "travel u",
            "travel * u",
            map(&|i| travel[i] * u[i]),
        ),
        Column::linear("time", "t sgn v", "t * dir", map(&|i| t[i] * sgn[i])),
        Column::linear("time", "t u", "t * u", map(&|i| t[i] * u[i])),
    ];
    for tau in time_constants() {
        // Held at u0 before the release: the dashpot has relaxed there.
        let q = relaxed(u, tau, dt, u0);
        cols.push(memory_column(
            tau,
            u.iter().zip(&q).map(|(a, b)| a - b).collect(),
        ));
    }
    for d in HYSTERESIS_D {
        cols.push(Column {
            kind: "hysteretic",
            expression: format!("z, dz/dt = (v - |v| z) / {d}"),
            tau: None,
            code: "z_hys".into(),
            state: Some(("z_hys", format!("(v - abs(v) * z_hys) / {d}"), "0")),
            values: hysteretic(u, d),
        });
    }
    cols
}

/// The memory term of time constant `tau` (a Maxwell element), with its
/// `values` on the model's motion.
fn memory_column(tau: f64, values: Vec<f64>) -> Column {
    Column {
        kind: "memory",
        expression: format!("u - q, dq/dt = (u - q) / {tau:.3}"),
        tau: Some(tau),
        code: "(u - q_mem)".into(),
        state: Some(("q_mem", "(u - q_mem) / {tau}".into(), "u0")),
        values,
    }
}

/// `e_i = x_i - rho x_(i-1)` (the first sample scaled by `sqrt(1 - rho^2)`).
fn whiten(x: &[f64], rho: f64) -> Vec<f64> {
    (0..x.len())
        .map(|i| {
            if i == 0 {
                x[0] * (1.0 - rho * rho).sqrt()
            } else {
                x[i] - rho * x[i - 1]
            }
        })
        .collect()
}

/// Least squares of `y` on the columns of `x`: coefficients and RSS.
fn least_squares(x: &DMatrix<f64>, y: &DVector<f64>) -> Option<(DVector<f64>, f64)> {
    if x.ncols() == 0 {
        return Some((DVector::zeros(0), y.norm_squared()));
    }
    let svd = x.clone().svd(true, true);
    let beta = svd.solve(y, 1e-10).ok()?;
    let rss = (y - x * &beta).norm_squared();
    Some((beta, rss))
}

/// An effect file of `terms` (each a column, a coefficient parameter
/// name and the term in words), with `tau` the memory term's time
/// constant as written (a number or the parameter `tau_mem`).
fn effect_toml(name: &str, params: &str, cols: &[(&Column, String, &str)], tau: &str) -> String {
    let mut states = String::new();
    for (c, _, _) in cols {
        if let Some((s, rate, release)) = &c.state {
            states.push_str(&format!(
                "\n[[state]]\nname = \"{s}\"\nunit = \"-\"\nmeaning = \"state of the {} term\"\nrelease = \"{release}\"\nrate = \"{}\"\n",
                c.kind,
                c.with_tau(rate, tau)
            ));
        }
    }
    let force: Vec<String> = cols
        .iter()
        .map(|(c, p, _)| format!("{p} * {}", c.with_tau(&c.code, tau)))
        .collect();
    let meaning: Vec<String> = cols
        .iter()
        .map(|(c, _, words)| format!("{} ({words})", c.kind))
        .collect();
    format!(
        "[effect]\nname = \"{name}\"\nmeaning = \"the missing force the residual describes: {}\"\n{params}{states}\n[force]\nextra = \"{}\"\n",
        meaning.join(", "),
        force.join(" + ")
    )
}

fn param_toml(
    name: &str,
    unit: &str,
    bounds: (f64, f64),
    neutral: f64,
    scale: f64,
    meaning: &str,
) -> String {
    format!(
        "\n[[param]]\nname = \"{name}\"\nunit = \"{unit}\"\nbounds = [{:e}, {:e}]\nneutral = {neutral:e}\nscale = {scale:e}\nmeaning = \"{meaning}\"\n",
        bounds.0, bounds.1
    )
}

/// How the current model's acceleration changes per unit coefficient of
/// the term `c` added as a force (central difference on the numerical
/// engine): the term's column in the regression. It carries the term's
/// effect through the motion, which dominates over a record of many
/// swings; the term's values alone would not. `None` where the engine
/// fails.
fn sensitivity(
    model: &Model,
    theta: &[f64],
    data: &Aligned,
    c: &Column,
    peak: f64,
) -> Option<Vec<f64>> {
    let size = c.values.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if size.is_nan() || size <= 0.0 {
        return None;
    }
    // A force of a thousandth of the peak acceleration: linear, and far
    // above the engine's tolerance.
    let delta = 1e-3 * peak / size;
    let tau = c.tau.map_or(String::new(), |t| format!("{t:e}"));
    let params = param_toml("c_probe", "-", (-1e300, 1e300), 0.0, 1.0, "probe");
    let text = effect_toml(
        "missing-probe",
        &params,
        &[(c, "c_probe".into(), &c.expression)],
        &tau,
    );
    let effect = FileEffect::from_toml(&text, "missing-form probe").ok()?;
    let probe = model.with_force(std::sync::Arc::new(effect));
    let n = data.a.len();
    let mut x = theta.to_vec();
    x.push(0.0);
    let mut run = |c: f64| {
        let mut out = vec![0.0; n];
        *x.last_mut().expect("pushed") = c;
        data.model_accel_into(&probe, &x, &mut out)
            .ok()
            .map(|_| out)
    };
    let (base, plus, minus) = (run(0.0)?, run(delta)?, run(-delta)?);
    // Of the two one-sided differences, the smaller at each sample: where
    // the probe moves a reversal across a sample instant, that sample
    // crosses a friction jump on one side, and its difference is the
    // jump over delta, not the term's effect.
    Some(
        (0..n)
            .map(|i| {
                let up = (plus[i] - base[i]) / delta;
                let down = (base[i] - minus[i]) / delta;
                if up.abs() < down.abs() {
                    up
                } else {
                    down
                }
            })
            .collect(),
    )
}

/// The missing form of `fit` of `model` on `data`.
pub fn missing_form(
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
    settings: &MapSettings,
) -> Result<MissingForm, CriticismError> {
    let theta = fit.model_theta(model);
    let n = data.a.len();
    let mut accel = vec![0.0; n];
    data.model_accel_into(model, theta, &mut accel)?;
    let motion = model.motion_grid(theta, data.lag, data.dt, n)?;
    let u: Vec<f64> = motion.iter().map(|m| m.u).collect();
    let v: Vec<f64> = motion.iter().map(|m| m.v).collect();
    let t: Vec<f64> = (0..n).map(|i| data.lag + i as f64 * data.dt).collect();
    let u0 = u.first().copied().unwrap_or(0.0);
    let peak = data.a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let rho = Posterior::layout_for(model, fit.noise)
        .values(&fit.theta, 1)
        .first()
        .copied()
        .unwrap_or(0.0);
    let white = |x: &[f64]| {
        if rho == 0.0 {
            x.to_vec()
        } else {
            whiten(x, rho)
        }
    };
    let r: Vec<f64> = data.a.iter().zip(&accel).map(|(a, m)| a - m).collect();
    let y = DVector::from_vec(white(&r));
    let tangent = super::ranking::jacobian(model, theta, &accel, data);
    let tangent_cols: Vec<DVector<f64>> = (0..tangent.ncols())
        .map(|j| DVector::from_vec(white(tangent.column(j).as_slice())))
        .collect();
    let lib: Vec<(Column, DVector<f64>, Vec<f64>)> = library(&u, &v, &t, data.dt, u0)
        .into_iter()
        .filter_map(|c| {
            let s = sensitivity(model, theta, data, &c, peak)?;
            Some((c, DVector::from_vec(white(&s)), s))
        })
        .collect();
    let design = |chosen: &[usize]| {
        let mut cols = tangent_cols.clone();
        cols.extend(chosen.iter().map(|&k| lib[k].1.clone()));
        if cols.is_empty() {
            DMatrix::zeros(n, 0)
        } else {
            DMatrix::from_columns(&cols)
        }
    };
    let none = MissingForm::none();
    let Some((_, rss0)) = least_squares(&design(&[]), &y) else {
        return Ok(none);
    };
    let mut chosen: Vec<usize> = Vec::new();
    let mut rss_path = vec![rss0];
    while chosen.len() < MAX_TERMS {
        let rss_now = *rss_path.last().expect("rss0");
        let best = (0..lib.len())
            .filter(|k| !chosen.contains(k))
            // One memory and one hysteretic term at most: the effect
            // file has one state (and time constant) of each name.
            .filter(|&k| {
                !(has_state(lib[k].0.kind)
                    && chosen.iter().any(|&c| lib[c].0.kind == lib[k].0.kind))
            })
            .filter_map(|k| {
                let mut with = chosen.clone();
                with.push(k);
                least_squares(&design(&with), &y).map(|(_, rss)| (k, rss))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((k, rss)) = best else { break };
        let delta_bic = n as f64 * (rss / rss_now).ln() + (n as f64).ln();
        if delta_bic.is_nan() || delta_bic >= -SUPPORT {
            break;
        }
        chosen.push(k);
        rss_path.push(rss);
    }
    if chosen.is_empty() {
        return Ok(none);
    }
    let rss_of = |chosen: &[usize]| least_squares(&design(chosen), &y).map(|(_, rss)| rss);
    // The terms at their linear estimates, each with its share in the
    // order given, and what they describe of the residual: their effect
    // with the model's own parameters re-adjusted to it (most of a term's
    // effect, a stiffness or damping change, those parameters absorb).
    let linear = |chosen: &[usize]| -> (Vec<Term>, Vec<f64>) {
        let beta = match least_squares(&design(chosen), &y) {
            Some((beta, _)) => beta.as_slice().to_vec(),
            None => vec![0.0; tangent_cols.len() + chosen.len()],
        };
        let coefficients = &beta[tangent_cols.len()..];
        let path: Vec<f64> = (0..=chosen.len())
            .map(|k| rss_of(&chosen[..k]).unwrap_or(rss0))
            .collect();
        let terms = chosen
            .iter()
            .enumerate()
            .map(|(i, &k)| Term {
                kind: lib[k].0.kind,
                expression: lib[k].0.expression.clone(),
                time_constant_s: lib[k].0.tau,
                coefficient: coefficients[i],
                share: (path[i] - path[i + 1]) / rss0,
            })
            .collect();
        let described = (0..n)
            .map(|i| {
                let own: f64 = (0..tangent.ncols())
                    .map(|j| beta[j] * tangent[(i, j)])
                    .sum();
                let terms: f64 = chosen
                    .iter()
                    .zip(coefficients)
                    .map(|(&k, b)| b * lib[k].2[i])
                    .sum();
                own + terms
            })
            .collect();
        (terms, described)
    };
    let (terms, described) = linear(&chosen);
    let kinds: Vec<&str> = lib.iter().map(|c| c.0.kind).collect();
    let alternative = memory_variant(&kinds, &chosen, &rss_of).map(|alt| {
        let (terms, described) = linear(&alt);
        Alternative {
            cols: alt.iter().map(|&k| lib[k].0.clone()).collect(),
            terms,
            described,
        }
    });
    let cols: Vec<&Column> = chosen.iter().map(|&k| &lib[k].0).collect();
    let mut form = refined(model, fit, data, &cols, terms, settings)?;
    form.alternative = alternative;
    form.series = Some(FormSeries {
        t,
        u,
        v,
        residual: r,
        described,
    });
    Ok(form)
}

/// The terms refitted with the model (the effect file's component added,
/// from the MAP with the terms at their linear estimates): the
/// linearisation about a model that lacks the force biases a time
/// constant (0.165 s for a true 0.3 s on a Maxwell record, which the
/// refit puts at 0.290 s). Without a better refit, the linear estimates.
fn refined(
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
    cols: &[&Column],
    mut terms: Vec<Term>,
    settings: &MapSettings,
) -> Result<MissingForm, CriticismError> {
    let text = effect_file_text(cols, &terms);
    let refit = FileEffect::from_toml(&text, "missing-form")
        .ok()
        .and_then(|effect| {
            let extended = model.with_force(std::sync::Arc::new(effect));
            let now = model.layout();
            let theta = fit.model_theta(model);
            let start = extended
                .layout()
                .theta_from(&|p| now.get(theta, &p.name).unwrap_or(p.neutral));
            let neutral = start.clone();
            let mut start = start;
            for (i, t) in terms.iter().enumerate() {
                if let Some(k) = extended
                    .param_names()
                    .iter()
                    .position(|n| *n == format!("c_{}", i + 1))
                {
                    start[k] = t.coefficient;
                }
            }
            let start = better_start(&extended, data, fit.noise, start, neutral);
            let settings = refit_settings(settings).ok()?;
            let refit = fit_model(
                &extended,
                data,
                fit.noise,
                Some(start),
                &settings,
                REFIT_SEED,
            )
            .ok()?;
            (refit.log_likelihood > fit.log_likelihood).then_some((extended, refit))
        });
    // The refit's failures leave the linear estimates, but a cancelled
    // run must end, not report them.
    if let Some(c) = settings.cancel() {
        c.check().map_err(MapError::from)?;
    }
    let (e2_with, delta_bic) = match &refit {
        Some((extended, r)) => {
            take_values(&mut terms, extended, r);
            (Some(r.e2), Some(r.bic - fit.bic))
        }
        None => (None, None),
    };
    let stateful = refit
        .as_ref()
        .and_then(|(extended, r)| Stateful::of(cols, &terms, extended, r));
    Ok(MissingForm {
        stateful,
        effect_file: Some(effect_file_text(cols, &terms)),
        out_of_catalog: held_apart(cols, &terms, &outside_catalog),
        memory_terms: terms
            .first()
            .filter(|t| !has_state(t.kind))
            .and_then(|_| held_anywhere(cols, &terms, &|t| has_state(t.kind))),
        elastic_lead: terms
            .first()
            .filter(|t| t.kind == "elastic")
            .and_then(|_| held_apart(cols, &terms, &|t| t.kind == "elastic" || outside_catalog(t))),
        terms,
        e2_with,
        delta_bic,
        series: None,
        alternative: None,
    })
}

/// Where `chosen` (indices into the library, of `kinds`) has no memory
/// term: `chosen` with the memory term that fits best beside the others
/// (least `rss`) in place of its hysteretic term, or after its terms
/// where it has none. `None` where it has a memory term or is empty.
fn memory_variant(
    kinds: &[&str],
    chosen: &[usize],
    rss: &dyn Fn(&[usize]) -> Option<f64>,
) -> Option<Vec<usize>> {
    if chosen.is_empty() || chosen.iter().any(|&k| kinds[k] == "memory") {
        return None;
    }
    let slot = chosen.iter().position(|&k| kinds[k] == "hysteretic");
    let with = |m: usize| {
        let mut alt = chosen.to_vec();
        match slot {
            Some(i) => alt[i] = m,
            None => alt.push(m),
        }
        alt
    };
    (0..kinds.len())
        .filter(|&m| kinds[m] == "memory")
        .filter_map(|m| rss(&with(m)).map(|r| (m, r)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(m, _)| with(m))
}

/// The form's refits: a local search within the numerical engine's
/// budget, polished.
fn refit_settings(settings: &MapSettings) -> Result<MapSettings, MapError> {
    settings
        .clone()
        .with_max_evals(NUMERIC_BUDGET)?
        .with_polish(Some(Polish::default().with_max_iters(300)?))
}

/// The terms' coefficients and time constant from the refit `r` of
/// `extended` (the model with their effect file).
fn take_values(terms: &mut [Term], extended: &Model, r: &ModelFit) {
    let layout = extended.layout();
    let theta = r.model_theta(extended);
    for (i, t) in terms.iter_mut().enumerate() {
        if let Some(c) = layout.get(theta, &format!("c_{}", i + 1)) {
            t.coefficient = c;
        }
        if t.time_constant_s.is_some() {
            t.time_constant_s = layout.get(theta, "tau_mem");
            if let Some(tau) = t.time_constant_s {
                t.expression = format!("u - q, dq/dt = (u - q) / {tau:.3}");
            }
        }
    }
}

/// The form's memory and hysteretic terms when it has other terms too,
/// with every parameter's value in the whole form's refit: what
/// [`MissingForm::stateful_alone`] refits.
#[derive(Debug, Clone, PartialEq)]
pub struct Stateful {
    cols: Vec<Column>,
    terms: Vec<Term>,
    /// The whole form's refit, by parameter name (the kept terms'
    /// coefficients under their new names `c_1`, ...).
    values: Vec<(String, f64)>,
}

impl Stateful {
    fn of(cols: &[&Column], terms: &[Term], extended: &Model, r: &ModelFit) -> Option<Self> {
        let keep: Vec<usize> = (0..terms.len())
            .filter(|&i| has_state(terms[i].kind))
            .collect();
        if keep.is_empty() || keep.len() == terms.len() {
            return None;
        }
        let layout = extended.layout();
        let theta = r.model_theta(extended);
        let mut values: Vec<(String, f64)> = extended
            .param_names()
            .iter()
            .filter(|n| !is_coefficient(n))
            .filter_map(|n| layout.get(theta, n).map(|v| (n.to_string(), v)))
            .collect();
        for (j, &i) in keep.iter().enumerate() {
            if let Some(v) = layout.get(theta, &format!("c_{}", i + 1)) {
                values.push((format!("c_{}", j + 1), v));
            }
        }
        Some(Self {
            cols: keep.iter().map(|&i| cols[i].clone()).collect(),
            terms: keep.iter().map(|&i| terms[i].clone()).collect(),
            values,
        })
    }
}

/// Whether `name` is a form term's coefficient (`c_1`, `c_2`, ...).
fn is_coefficient(name: &str) -> bool {
    name.strip_prefix("c_")
        .is_some_and(|k| k.parse::<usize>().is_ok())
}

/// Of two starts of the form's refit, the one of higher posterior
/// density: the terms at their linear estimates (`linear`), or at zero
/// with the time constants at theirs (`neutral`, the current fit
/// itself). The linear estimates were made with the model's own
/// parameters free to move along their tangents, which the start leaves
/// where they are: on three Maxwell records of `examples/memory_records`
/// (seed 332540, records 6, 15, 17) that start lay some 3,000 nats of
/// log-posterior below the current fit, and the local refit from it ended
/// 13 nats above, 627 nats below and 103 nats below the refit from the
/// neutral start (time constants 0.25, 5.37 and 0.24 s against 0.25,
/// 1.52 and 0.36 s; the truths 1.14, 1.41 and 0.45 s).
fn better_start(
    model: &Model,
    data: &Aligned,
    noise: Noise,
    linear: Vec<f64>,
    neutral: Vec<f64>,
) -> Vec<f64> {
    let Ok(post) = Posterior::new(
        model.clone(),
        data.clone(),
        priors_for(model, noise, data.dt),
        noise,
    ) else {
        return linear;
    };
    let density = |theta: &[f64]| {
        post.log_posterior(&post.with_neutral_noise(theta))
            .unwrap_or(f64::NEG_INFINITY)
    };
    if density(&neutral) > density(&linear) {
        neutral
    } else {
        linear
    }
}

/// The ones of `terms` (from `cols`) of `kinds`, with their values as
/// parameters of their own effect file, when the first term (the one that
/// explains most) is one of them. Where a term a catalog effect
/// makes explains more, catalog effects are still missing, and a memory
/// term can stand in for them: from `bilinear+coulomb` on the README's
/// record (the truth `trilinear+lcfm+viscous`) the form was `t sgn v`, a
/// memory term of 0.68 s and `sgn v`, and that memory term alone lowered
/// BIC by 520.6, more than `viscous` (251.0), which gained nothing beside
/// it.
fn held_apart(
    cols: &[&Column],
    terms: &[Term],
    kinds: &dyn Fn(&Term) -> bool,
) -> Option<OutOfCatalog> {
    if !terms.first().is_some_and(kinds) {
        return None;
    }
    held_anywhere(cols, terms, kinds)
}

/// The ones of `terms` (from `cols`) of `kinds`, wherever they are in
/// the form; `None` if there are none.
fn held_anywhere(
    cols: &[&Column],
    terms: &[Term],
    kinds: &dyn Fn(&Term) -> bool,
) -> Option<OutOfCatalog> {
    if !terms.iter().any(kinds) {
        return None;
    }
    let keep: Vec<usize> = (0..terms.len()).filter(|&i| kinds(&terms[i])).collect();
    let cols: Vec<&Column> = keep.iter().map(|&i| cols[i]).collect();
    let terms: Vec<Term> = keep.iter().map(|&i| terms[i].clone()).collect();
    let mut values = Vec::new();
    for (i, t) in terms.iter().enumerate() {
        values.push((format!("c_{}", i + 1), t.coefficient));
        if let Some(tau) = t.time_constant_s {
            values.push(("tau_mem".to_string(), tau));
        }
    }
    let description: Vec<String> = terms
        .iter()
        .map(|t| format!("{} term ({})", t.kind, t.expression))
        .collect();
    Some(OutOfCatalog {
        effect_file: effect_file_text(&cols, &terms),
        description: description.join(" and "),
        values,
        fitted: Vec::new(),
    })
}

/// The effect file of `terms` (the columns they came from): each term's
/// coefficient a parameter within five times its estimate either side of
/// zero, a memory term's time constant within a factor of three.
fn effect_file_text(cols: &[&Column], terms: &[Term]) -> String {
    effect_file_within(cols, terms, None)
}

/// Bounds of a memory term's coefficient and time constant that replace
/// those made from its values (`±5 |c|`, a third to three times `tau`).
type MemoryBounds = ((f64, f64), (f64, f64));

/// [`effect_file_text`], a memory term's bounds `wide` where given.
fn effect_file_within(cols: &[&Column], terms: &[Term], wide: Option<MemoryBounds>) -> String {
    let mut params = String::new();
    let mut named = Vec::new();
    let mut tau = String::new();
    for (i, (c, t)) in cols.iter().zip(terms).enumerate() {
        let name = format!("c_{}", i + 1);
        let size = 5.0 * t.coefficient.abs();
        let wide = wide.filter(|_| t.time_constant_s.is_some());
        params.push_str(&param_toml(
            &name,
            "(m/s^2) per unit of the term",
            wide.map_or((-size, size), |w| w.0),
            0.0,
            0.2 * t.coefficient.abs(),
            &format!("coefficient of the {} term {}", t.kind, t.expression),
        ));
        if let Some(tc) = t.time_constant_s {
            params.push_str(&param_toml(
                "tau_mem",
                "s",
                wide.map_or((tc / 3.0, 3.0 * tc), |w| w.1),
                tc,
                0.1 * tc,
                "relaxation time of the memory term",
            ));
            tau = "tau_mem".into();
        }
        // The term's words, not the column's: a refit moves a memory
        // term's time constant away from the library's grid value.
        named.push((*c, name, t.expression.as_str()));
    }
    let pairs: Vec<(&Column, String, &str)> = named;
    format!(
        "# What the residual says is missing, as hbis described it: a force per\n# unit mass, the sum of the terms below. Load it with `--effects FILE`\n# and add `+missing-form` to the model.\n\n{}",
        effect_toml("missing-form", &params, &pairs, &tau)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relaxation_follows_a_ramp_with_its_lag() {
        // A ramp x = t from q = 0: q(t) = t - tau (1 - exp(-t / tau)).
        let dt = 0.01;
        let tau = 0.3;
        let x: Vec<f64> = (0..300).map(|i| i as f64 * dt).collect();
        let q = relaxed(&x, tau, dt, 0.0);
        for (i, qi) in q.iter().enumerate() {
            let t = i as f64 * dt;
            let exact = t - tau * (1.0 - (-t / tau).exp());
            assert!((qi - exact).abs() < 1e-12, "{i}: {qi} vs {exact}");
        }
    }

    /// The third global search runs exactly where the first two disagree
    /// (or one failed), and the best of those run is kept.
    #[test]
    fn the_third_global_search_runs_only_where_the_first_two_disagree() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        // Search results by seed: (log-likelihood, score = -2 logL).
        let run = |ends: [Option<f64>; 3]| {
            let calls = AtomicUsize::new(0);
            let search = |s: u64| {
                calls.fetch_add(1, Ordering::Relaxed);
                let i = GLOBAL_SEEDS.iter().position(|&g| g == s).unwrap();
                ends[i]
            };
            let best = best_of_global(search, |l| *l, |l| -2.0 * l);
            (best, calls.load(Ordering::Relaxed))
        };
        // One basin: two searches, the better kept.
        assert_eq!(
            run([Some(-100.0), Some(-100.5), Some(50.0)]),
            (Some(-100.0), 2)
        );
        // Apart: the third runs, and here it is the best.
        assert_eq!(
            run([Some(-100.0), Some(-300.0), Some(-20.0)]),
            (Some(-20.0), 3)
        );
        assert_eq!(
            run([Some(-300.0), Some(-100.0), Some(-400.0)]),
            (Some(-100.0), 3)
        );
        // A failed search is no agreement.
        assert_eq!(run([None, Some(-100.0), Some(-90.0)]), (Some(-90.0), 3));
        assert_eq!(run([None, None, None]), (None, 3));
    }

    /// The catalog's travel effects only lose force: `degradation` makes
    /// a restoring force `F_S (factor - 1)` against `u`, a `travel u`
    /// term below zero, and `friction-decay` a friction force against
    /// `sgn v`; terms of the other sign are outside the catalog.
    #[test]
    fn only_a_loss_with_travel_or_time_is_a_catalog_term() {
        use crate::model::catalog::Degradation;
        let term = |kind: &'static str, coefficient: f64| Term {
            kind,
            expression: String::new(),
            time_constant_s: None,
            coefficient,
            share: 0.1,
        };
        let (u, travel, spring_force) = (0.05, 0.4, 0.3);
        let change = spring_force * (Degradation::factor(0.5, travel) - 1.0);
        let made = change / (travel * u);
        assert!(made < 0.0, "{made}");
        assert!(!outside_catalog(&term("travel", made)));
        assert!(outside_catalog(&term("travel", -made)));
        for kind in ["time", "travel"] {
            assert!(outside_catalog(&term(kind, 1.0)), "{kind}");
            assert!(!outside_catalog(&term(kind, -1.0)), "{kind}");
        }
        for kind in ["elastic", "viscous", "coulomb", "amplitude"] {
            assert!(!outside_catalog(&term(kind, 1.0)), "{kind}");
            assert!(!outside_catalog(&term(kind, -1.0)), "{kind}");
        }
        assert!(outside_catalog(&term("memory", -1.0)));
        assert!(outside_catalog(&term("hysteretic", 1.0)));
    }

    #[test]
    fn hysteresis_saturates_at_the_sign_of_the_motion() {
        let u: Vec<f64> = (0..200).map(|i| 0.001 * i as f64).collect();
        let z = hysteretic(&u, 0.01);
        assert!((z[199] - (1.0 - (-0.199f64 / 0.01).exp())).abs() < 1e-12);
    }
}

#[cfg(test)]
mod probe_tests {
    use super::*;
    use crate::data::synthesize;
    use crate::model::Params;
    use rand::{rngs::StdRng, SeedableRng};

    #[test]
    fn a_memory_probe_is_a_maxwell_element() {
        let model = Model::parse("trilinear+lcfm+viscous").unwrap();
        let theta = model
            .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
            .unwrap();
        let mut rng = StdRng::seed_from_u64(1);
        let data = synthesize(&model, &theta, 0.005, 2001, 0.015, &mut rng)
            .unwrap()
            .record
            .aligned(None)
            .unwrap();
        let n = data.a.len();
        let motion = model.motion_grid(&theta, data.lag, data.dt, n).unwrap();
        let u: Vec<f64> = motion.iter().map(|m| m.u).collect();
        let v: Vec<f64> = motion.iter().map(|m| m.v).collect();
        let t: Vec<f64> = (0..n).map(|i| i as f64 * data.dt).collect();
        let lib = library(&u, &v, &t, data.dt, u[0]);
        let col = lib
            .iter()
            .find(|c| c.kind == "memory" && (c.tau.unwrap() - 0.5).abs() < 0.05)
            .unwrap();
        let tau = col.tau.unwrap();
        let peak = data.a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let s = sensitivity(&model, &theta, &data, col, peak).unwrap();
        let mx = Model::parse("trilinear+lcfm+viscous+maxwell").unwrap();
        let k0 = (2.0 * std::f64::consts::PI * 0.53979f64).powi(2);
        let mut th = theta.clone();
        th.extend([1e-4, tau]);
        let mut plus = vec![0.0; n];
        data.model_accel_into(&mx, &th, &mut plus).unwrap();
        th[theta.len()] = 0.0;
        let mut zero = vec![0.0; n];
        data.model_accel_into(&mx, &th, &mut zero).unwrap();
        let d: Vec<f64> = plus
            .iter()
            .zip(&zero)
            .map(|(p, z)| (p - z) / (1e-4 * k0))
            .collect();
        let norm = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diff: Vec<f64> = s.iter().zip(&d).map(|(a, b)| a - b).collect();
        eprintln!(
            "probe {} maxwell {} diff {}",
            norm(&s),
            norm(&d),
            norm(&diff)
        );

        assert!(norm(&diff) < 0.05 * norm(&d));
    }

    #[test]
    fn a_memory_variant_takes_the_hysteretic_terms_place_or_joins_the_terms() {
        let kinds = ["elastic", "hysteretic", "memory", "memory", "viscous"];
        // The residual sum of squares of each set: memory term 3 fits best.
        let rss = |set: &[usize]| Some(10.0 - set.iter().map(|&k| k as f64).sum::<f64>());
        assert_eq!(memory_variant(&kinds, &[0, 1], &rss), Some(vec![0, 3]));
        assert_eq!(memory_variant(&kinds, &[4, 0], &rss), Some(vec![4, 0, 3]));
        assert_eq!(memory_variant(&kinds, &[1, 2], &rss), None);
        assert_eq!(memory_variant(&kinds, &[], &rss), None);
        // A memory term the least squares cannot solve is not taken.
        let rss = |set: &[usize]| (!set.contains(&3)).then_some(1.0);
        assert_eq!(memory_variant(&kinds, &[1], &rss), Some(vec![2]));
    }
}
