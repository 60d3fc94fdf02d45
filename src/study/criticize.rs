//! `diagnose` and `ladder` end to end: the record set up (release placed,
//! noise model chosen), the runs, their reports (`diagnosis.json`,
//! `ladder.json`) and their figures and `report.html`.
//!
//! The reports are the values the runners return; the files are these
//! values serialised, and the Python package returns the same
//! serialisation, so a dict of `hbis.diagnose` has the keys of
//! `diagnosis.json`, value for value.
//!
//! ```no_run
//! use hbis::data::Record;
//! use hbis::inference::MapSettings;
//! use hbis::model::Registry;
//! use hbis::study::criticize::{diagnose, setup};
//!
//! let registry = Registry::builtin();
//! let data = Record::read("record.csv".as_ref())?.aligned(None)?;
//! let model = registry.parse("bilinear+coulomb")?;
//! let settings = MapSettings::default();
//! let s = setup(model, data, None, 1, "record.csv", Vec::new(), &settings)?;
//! let d = diagnose(&registry, &s, &settings)?;
//! println!("{}", d.report.conclusion);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::BTreeMap;

use serde::Serialize;
use thiserror::Error;

use crate::criticism::{
    choose_noise, diagnose_ranking, ladder_observed, missing_form, place_release, CriticismError,
    Diagnostics, MissingForm, ModelFit, Move, NoiseChoice, PathEnd, RankedCandidate, Screened,
    Step,
};
use crate::data::{Aligned, Warning};
use crate::inference::{MapSettings, Noise};
use crate::model::{ForwardModel, Model, Registry, SimError, SpecError};
use crate::report::html::CriticismInfo;
use crate::report::json::DataInfo;
use crate::report::outdir::{OutDir, OutError};

/// Most effects the ladder adds by default.
pub const MAX_LADDER_STEPS: usize = 6;

/// Seed offsets of the set-up's own searches, so that they draw numbers
/// apart from the runs that follow with the same seed.
const RELEASE_SEED: u64 = 0x7E1E_A5E0;
const NOISE_SEED: u64 = 0x0A17_0015;

/// Why a criticism run failed.
#[derive(Debug, Error)]
pub enum CriticizeError {
    /// Placing the release, choosing the noise model, or a run.
    #[error(transparent)]
    Criticism(#[from] CriticismError),
    /// A ladder step's model could not be rebuilt from its name.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// Simulating a fitted model for its figure.
    #[error("simulation for a figure")]
    Sim(#[from] SimError),
    /// A file of the output folder.
    #[error(transparent)]
    Out(#[from] OutError),
    /// Serialising a report.
    #[error("serialising the report")]
    Json(#[from] serde_json::Error),
    /// A figure.
    #[cfg(feature = "figures")]
    #[error(transparent)]
    Figure(#[from] crate::report::figures::FigureError),
}

/// A record set up for criticism: the start model, the record with its
/// release placed, the noise model and how `auto` chose it.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The start model.
    pub model: Model,
    /// The record, the release placed by a fit of the start model.
    pub data: Aligned,
    /// The measurement-error model of every fit.
    pub noise: Noise,
    /// How `auto` chose it; `None` when it was given.
    pub noise_choice: Option<NoiseChoice>,
    /// The seed of every random number.
    pub seed: u64,
    /// The record as the user named it (`data.source` in the reports).
    pub source: String,
    /// The record's own warnings, first in the reports' `warnings`.
    pub warnings: Vec<Warning>,
}

impl Setup {
    /// Whether the release was placed between samples by a fit.
    pub fn release_placed(&self) -> bool {
        self.data.lag > 0.0 && self.data.source == crate::data::ReleaseSource::Detected
    }
}

/// The noise model named by `text`: `Some(None)` for `auto` (the lower BIC
/// of `white` and `ar1` at the start model); `None` if unknown.
pub fn parse_noise(text: &str) -> Option<Option<Noise>> {
    match text {
        "auto" => Some(None),
        n => Noise::parse(n).map(Some),
    }
}

/// Places the release and, for `noise = None`, chooses the noise model.
pub fn setup(
    model: Model,
    data: Aligned,
    noise: Option<Noise>,
    seed: u64,
    source: &str,
    warnings: Vec<Warning>,
    settings: &MapSettings,
) -> Result<Setup, CriticizeError> {
    let data = place_release(&model, data, settings, seed ^ RELEASE_SEED)?;
    let (noise, noise_choice) = match noise {
        Some(n) => (n, None),
        None => {
            let c = choose_noise(&model, &data, settings, seed ^ NOISE_SEED)?;
            (c.chosen, Some(c))
        }
    };
    Ok(Setup {
        model,
        data,
        noise,
        noise_choice,
        seed,
        source: source.to_string(),
        warnings,
    })
}

/// The record's warnings and those of a fit of `model`.
fn with_fit_warnings(mut warnings: Vec<Warning>, model: &Model, fit: &ModelFit) -> Vec<Warning> {
    let priors = crate::inference::Posterior::default_priors(model, fit.noise);
    warnings.extend(crate::criticism::sanity::fit_warnings(
        &fit.names, &fit.theta, fit.e2, &priors,
    ));
    warnings.extend(crate::criticism::sanity::map_at_budget(
        &fit.model,
        fit.at_budget,
        fit.evaluations,
    ));
    warnings
}

/// `refits-at-budget` and `refits-not-converged` over `candidates`, each
/// named by `label`.
fn refit_warnings<'c>(
    candidates: impl Iterator<Item = (String, &'c RankedCandidate)>,
) -> Vec<Warning> {
    let candidates: Vec<_> = candidates.collect();
    let at: Vec<(String, u64)> = candidates
        .iter()
        .filter(|(_, c)| c.at_budget)
        .map(|(label, c)| (label.clone(), c.evaluations))
        .collect();
    let unsettled: Vec<String> = candidates
        .iter()
        .filter(|(_, c)| !c.converged)
        .map(|(label, _)| label.clone())
        .collect();
    crate::criticism::sanity::refits_at_budget(&at)
        .into_iter()
        .chain(crate::criticism::sanity::refits_not_converged(&unsettled))
        .collect()
}

/// `diagnosis.json`.
#[derive(Debug, Clone, Serialize)]
pub struct DiagnosisReport {
    /// The version of hbis that wrote it.
    pub hbis_version: String,
    /// The start model.
    pub model: String,
    /// The seed.
    pub seed: u64,
    /// The noise model.
    pub noise: &'static str,
    /// How `auto` chose it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_choice: Option<NoiseChoice>,
    /// The record.
    pub data: DataInfo,
    /// Normalised squared error at the MAP.
    pub e2: f64,
    /// BIC at the MAP.
    pub bic: f64,
    /// Laplace log-evidence at the MAP.
    pub log_evidence: f64,
    /// Whether the start model's MAP search stopped at its evaluation
    /// budget instead of converging.
    pub at_budget: bool,
    /// The MAP, by parameter name.
    pub map: BTreeMap<String, f64>,
    /// Every candidate, best first.
    pub candidates: Vec<RankedCandidate>,
    /// The candidates screened out by their score test and not refitted
    /// (only where the likelihood is continuous: an averaging sensor).
    pub screened_out: Vec<Screened>,
    /// When two candidates may stand in for each other.
    pub caution: Option<String>,
    /// The conclusion in one sentence.
    pub conclusion: String,
    /// The residual diagnostics.
    pub residual: Diagnostics,
    /// The residual's verdict.
    pub verdict: String,
    /// The form of what is missing ([`mod@crate::criticism::missing_form`]).
    pub missing_form: MissingForm,
    /// The record's and the fit's warnings.
    pub warnings: Vec<Warning>,
}

/// A diagnosis: its report and the fit behind it.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// What `diagnosis.json` holds.
    pub report: DiagnosisReport,
    /// The start model's fit.
    pub fit: ModelFit,
}

/// The missing form a report gives: where no catalog candidate is
/// accepted, a memory term in place of a hysteretic one where that fits
/// better ([`MissingForm::memory_instead`]), then its memory and
/// hysteretic terms alone where they beat the whole form
/// ([`MissingForm::stateful_alone`]), then its memory term alone from
/// spread time constants ([`MissingForm::memory_starts`];
/// [`MissingForm::as_reported`]). Where one is, the ladder
/// adds it next, and that refit (1.2 s on the demo's `record.csv` from
/// `bilinear+coulomb`, where it changed nothing) is not spent.
fn reported_form(
    form: MissingForm,
    candidates: &[RankedCandidate],
    (model, fit, data): (&Model, &ModelFit, &Aligned),
    settings: &MapSettings,
) -> Result<MissingForm, CriticismError> {
    let accepted = candidates.iter().any(|c| c.accepted);
    form.as_reported(accepted, model, fit, data, settings)
}

/// Fits the start model, diagnoses its residual, and refits and ranks every
/// candidate of `registry`.
pub fn diagnose(
    registry: &Registry,
    s: &Setup,
    settings: &MapSettings,
) -> Result<Diagnosis, CriticizeError> {
    let (residual, ranking) =
        diagnose_ranking(registry, &s.model, &s.data, s.noise, settings, s.seed)?;
    let (fit, candidates, screened_out) = (ranking.current, ranking.candidates, ranking.screened);
    let report = DiagnosisReport {
        hbis_version: env!("CARGO_PKG_VERSION").to_string(),
        model: s.model.name(),
        seed: s.seed,
        noise: s.noise.as_str(),
        noise_choice: s.noise_choice,
        data: DataInfo::new(&s.source, &s.data),
        e2: fit.e2,
        bic: fit.bic,
        log_evidence: fit.log_evidence,
        at_budget: fit.at_budget,
        map: fit
            .names
            .iter()
            .cloned()
            .zip(fit.theta.iter().copied())
            .collect(),
        caution: crate::criticism::caution(&candidates),
        conclusion: crate::criticism::conclusion(&residual, &candidates),
        verdict: residual.verdict.clone(),
        missing_form: reported_form(
            match ranking.form {
                Some(form) => form,
                None => missing_form(&s.model, &fit, &s.data, settings)?,
            },
            &candidates,
            (&s.model, &fit, &s.data),
            settings,
        )?,
        warnings: {
            let mut w = with_fit_warnings(s.warnings.clone(), &s.model, &fit);
            w.extend(refit_warnings(
                candidates.iter().map(|c| (c.effect.clone(), c)),
            ));
            w
        },
        candidates,
        screened_out,
        residual,
    };
    Ok(Diagnosis { report, fit })
}

/// Writes `diagnosis.json`, `residual.png`, `residual-map.png` and
/// `report.html`; returns the JSON text.
pub fn write_diagnosis(
    d: &Diagnosis,
    s: &Setup,
    out: &mut OutDir,
) -> Result<String, CriticizeError> {
    let report = &d.report;
    let text = serde_json::to_string_pretty(report)? + "\n";
    out.write("diagnosis.json", text.as_bytes())?;
    let mut svgs = Vec::new();
    let name = s.model.name();
    if let Some(svg) = residual_figure(out, "residual.png", &s.model, &d.fit, &s.data, None, &name)?
    {
        svgs.push((
            svg,
            "Measured and model acceleration; the residual below.".to_string(),
        ));
    }
    #[cfg(feature = "figures")]
    {
        let r = &report.residual;
        let map = |tmp: &std::path::Path| {
            crate::report::figures::residual_map_figure(
                tmp,
                &r.map_u_edges,
                &r.map_v_edges,
                &r.map_force,
                &format!("{name}: restoring-force residual (grey: no samples)"),
            )
        };
        out.write_with("residual-map.png", map)?;
        svgs.push((
            crate::report::figures::svg_text(map)?,
            "Mean residual force per unit mass over displacement and velocity (blue negative, red positive, grey: no sample)."
                .to_string(),
        ));
    }
    #[cfg(feature = "figures")]
    if let Some(f) = &report.missing_form.series {
        let draw = |tmp: &std::path::Path| {
            crate::report::figures::missing_form_figure(
                tmp,
                f,
                &format!("{name}: the residual force and what the missing-form terms describe"),
            )
        };
        out.write_with("missing-form.png", draw)?;
        svgs.push((
            crate::report::figures::svg_text(draw)?,
            "The residual force per unit mass (grey) and the part the missing-form terms describe (red), against time, displacement and velocity.".to_string(),
        ));
    }
    let noise_choice = report.noise_choice.as_ref().map(|c| c.sentence());
    let info = CriticismInfo {
        source: &report.data.source,
        model: &report.model,
        seed: report.seed,
        noise: report.noise,
        noise_choice: noise_choice.as_deref(),
    };
    let html = crate::report::html::diagnosis_page(
        &info,
        &d.fit,
        &report.residual,
        &report.candidates,
        &report.screened_out,
        &report.warnings,
        &svgs,
    );
    out.write("report.html", html.as_bytes())?;
    Ok(text)
}

/// `ladder.json`.
#[derive(Debug, Clone, Serialize)]
pub struct LadderReport {
    /// The version of hbis that wrote it.
    pub hbis_version: String,
    /// The start model.
    pub model: String,
    /// The seed.
    pub seed: u64,
    /// The noise model.
    pub noise: &'static str,
    /// How `auto` chose it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_choice: Option<NoiseChoice>,
    /// The record (the release as the last step placed it).
    pub data: DataInfo,
    /// The last step's model.
    pub final_model: String,
    /// Every step of the chosen path, the start model first.
    pub steps: Vec<LadderStep>,
    /// Where each search path ended (the chosen one has `chosen`).
    pub paths: Vec<PathEnd>,
    /// The form of what the final model misses
    /// ([`mod@crate::criticism::missing_form`]).
    pub missing_form: MissingForm,
    /// The record's warnings and those of the final model's fit.
    pub warnings: Vec<Warning>,
}

/// One step of `ladder.json`.
#[derive(Debug, Clone, Serialize)]
pub struct LadderStep {
    /// The model fitted at this step.
    pub model: String,
    /// The effect this step added (`None` at the start).
    pub added: Option<String>,
    /// The moves since the previous step: the addition, then any removal
    /// or swap of an effect added earlier.
    pub moves: Vec<Move>,
    /// Normalised squared error at the MAP.
    pub e2: f64,
    /// BIC at the MAP.
    pub bic: f64,
    /// Laplace log-evidence at the MAP.
    pub log_evidence: f64,
    /// The release lag of this step's fit (s).
    pub lag: f64,
    /// Whether this step's MAP search stopped at its evaluation budget.
    pub at_budget: bool,
    /// The residual's verdict.
    pub verdict: String,
    /// Every candidate, best first.
    pub candidates: Vec<RankedCandidate>,
    /// The candidates screened out by their score test and not refitted.
    pub screened_out: Vec<Screened>,
    /// When two candidates may stand in for each other.
    pub caution: Option<String>,
    /// The conclusion in one sentence.
    pub conclusion: String,
}

/// A ladder: its report and the steps behind it.
#[derive(Debug, Clone)]
pub struct Ladder {
    /// What `ladder.json` holds.
    pub report: LadderReport,
    /// Every step with its fit and diagnosis.
    pub steps: Vec<Step>,
}

/// Adds the best supported effect, refits, and repeats (at most
/// `max_steps` effects); `on_step` sees each step as it is made.
pub fn ladder(
    registry: &Registry,
    s: &Setup,
    settings: &MapSettings,
    max_steps: usize,
    on_step: &mut dyn FnMut(&Step),
) -> Result<Ladder, CriticizeError> {
    let search = ladder_observed(
        registry,
        s.model.clone(),
        &s.data,
        s.noise,
        settings,
        s.seed,
        max_steps,
        on_step,
    )?;
    let steps = search.steps;
    let mut warnings = match steps.last() {
        Some(last) => {
            with_fit_warnings(s.warnings.clone(), &registry.parse(&last.model)?, &last.fit)
        }
        None => s.warnings.clone(),
    };
    // Every refit of the path, and every step's own fit.
    warnings.extend(refit_warnings(steps.iter().enumerate().flat_map(
        |(k, st)| {
            st.candidates
                .iter()
                .map(move |c| (format!("step {k}: {}", c.effect), c))
        },
    )));
    for (k, st) in steps.iter().enumerate().take(steps.len().saturating_sub(1)) {
        warnings.extend(crate::criticism::sanity::map_at_budget(
            &format!("{} (step {k})", st.model),
            st.fit.at_budget,
            st.fit.evaluations,
        ));
    }
    let data = s
        .data
        .clone()
        .with_lag(steps.last().map_or(s.data.lag, |x| x.lag));
    // The last step's ranking described it, on the same samples and lag.
    let missing = match steps.last() {
        Some(last) => {
            let model = registry.parse(&last.model)?;
            let form = match &last.form {
                Some(form) => form.clone(),
                None => missing_form(&model, &last.fit, &data, settings)?,
            };
            reported_form(form, &last.candidates, (&model, &last.fit, &data), settings)?
        }
        None => MissingForm::none(),
    };
    let report = LadderReport {
        hbis_version: env!("CARGO_PKG_VERSION").to_string(),
        model: s.model.name(),
        seed: s.seed,
        noise: steps
            .first()
            .map_or(s.noise.as_str(), |x| x.fit.noise.as_str()),
        noise_choice: s.noise_choice,
        data: DataInfo::new(&s.source, &data),
        final_model: steps.last().map_or(String::new(), |x| x.model.clone()),
        steps: steps.iter().map(ladder_step).collect(),
        paths: search.paths,
        missing_form: missing,
        warnings,
    };
    Ok(Ladder { report, steps })
}

fn ladder_step(s: &Step) -> LadderStep {
    LadderStep {
        model: s.model.clone(),
        added: s.added.clone(),
        moves: s.moves.clone(),
        e2: s.e2,
        bic: s.bic,
        log_evidence: s.log_evidence,
        lag: s.lag,
        at_budget: s.fit.at_budget,
        verdict: s.diagnosis.verdict.clone(),
        candidates: s.candidates.clone(),
        screened_out: s.screened_out.clone(),
        caution: s.caution.clone(),
        conclusion: s.conclusion.clone(),
    }
}

/// Writes `ladder.json`, `ladder.png`, one residual figure per step
/// (`step-<k>.png`) and `report.html`; returns the JSON text.
pub fn write_ladder(
    registry: &Registry,
    l: &Ladder,
    s: &Setup,
    out: &mut OutDir,
) -> Result<String, CriticizeError> {
    let (report, steps, data) = (&l.report, &l.steps, &s.data);
    let text = serde_json::to_string_pretty(report)? + "\n";
    out.write("ladder.json", text.as_bytes())?;
    // The record's own noise level, whatever the models: what the error
    // can fall to (white noise assumed; coloured noise lies above it).
    let times: Vec<f64> = (0..data.a.len()).map(|i| data.time(i)).collect();
    let sigma_floor =
        crate::data::Record::new(times, data.a.clone()).map_or(f64::NAN, |r| r.noise_level());
    let mut svgs = Vec::new();
    #[cfg(feature = "figures")]
    {
        let e2_floor = data.a.len() as f64 * sigma_floor * sigma_floor / data.energy();
        // Each step named by the effect it added.
        let labels: Vec<String> = steps
            .iter()
            .map(|s| match &s.added {
                Some(effect) => format!("+{effect}"),
                None => s.model.clone(),
            })
            .collect();
        let e2: Vec<f64> = steps.iter().map(|s| s.e2).collect();
        let z: Vec<f64> = steps.iter().map(|s| s.log_evidence).collect();
        let draw = |tmp: &std::path::Path| {
            crate::report::figures::ladder_figure(tmp, &labels, &e2, &z, Some(e2_floor))
        };
        out.write_with("ladder.png", draw)?;
        svgs.push((
            crate::report::figures::svg_text(draw)?,
            "e2 and the log-evidence at each step.".to_string(),
        ));
    }
    // One residual scale for every step (the largest residual of any), and
    // the record's noise level as the floor, so the error is seen to fall
    // towards it.
    let mut half = 0.0f64;
    let mut models = Vec::new();
    for step in steps {
        let model = registry.parse(&step.model)?;
        let at_lag = data.clone().with_lag(step.lag);
        let mut accel = vec![0.0; at_lag.a.len()];
        at_lag.model_accel_into(&model, step.fit.model_theta(&model), &mut accel)?;
        for (m, a) in at_lag.a.iter().zip(&accel) {
            half = half.max((m - a).abs());
        }
        models.push((model, at_lag));
    }
    for (k, (step, (model, at_lag))) in steps.iter().zip(models).enumerate() {
        let title = match &step.added {
            Some(effect) => format!("step {k}: {} (added {effect})", step.model),
            None => format!("step {k}: {}", step.model),
        };
        let figure = residual_figure(
            out,
            &format!("step-{k}.png"),
            &model,
            &step.fit,
            &at_lag,
            Some((half, sigma_floor)),
            &title,
        )?;
        if let Some(svg) = figure {
            svgs.push((svg, title));
        }
    }
    let noise_choice = report.noise_choice.as_ref().map(|c| c.sentence());
    let info = CriticismInfo {
        source: &report.data.source,
        model: &report.model,
        seed: report.seed,
        noise: report.noise,
        noise_choice: noise_choice.as_deref(),
    };
    let html = crate::report::html::ladder_page(&info, steps, &report.warnings, &svgs);
    out.write("report.html", html.as_bytes())?;
    Ok(text)
}

/// Writes the measured-against-model figure `name` and returns it as SVG
/// for report.html (`None` without the `figures` feature).
/// `scale`: the residual axis and noise floor shared by a ladder's steps;
/// `None` for the figure's own (a diagnosis).
#[cfg_attr(not(feature = "figures"), allow(unused_variables))]
fn residual_figure(
    out: &mut OutDir,
    name: &str,
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
    scale: Option<(f64, f64)>,
    title: &str,
) -> Result<Option<String>, CriticizeError> {
    #[cfg(feature = "figures")]
    {
        use crate::report::figures::{fit_figure, svg_text, Overlays, ResidualScale};
        let mut accel = vec![0.0; data.a.len()];
        data.model_accel_into(model, fit.model_theta(model), &mut accel)?;
        let t: Vec<f64> = (0..accel.len()).map(|i| data.time(i)).collect();
        let (measured, accel) = (data.in_record_sign(&data.a), data.in_record_sign(&accel));
        let sigma = (fit.e2 * data.energy() / data.a.len().max(1) as f64).sqrt();
        let scale = match scale {
            Some((half, floor)) => ResidualScale {
                half,
                sigma: floor,
                label: "±σ: noise floor (white noise, from second differences)",
            },
            None => ResidualScale {
                half: 0.0,
                sigma,
                label: "±σ: residual RMS",
            },
        };
        let phases = crate::study::segments(model, fit.model_theta(model), data)
            .ok()
            .map(|s| s.phase);
        let draw = |tmp: &std::path::Path| {
            fit_figure(
                tmp,
                &t,
                &measured,
                &accel,
                &Overlays {
                    band: None,
                    scale: Some(scale),
                    phases: phases.as_deref(),
                },
                &format!("{title}: e2 = {:.5}", fit.e2),
            )
        };
        out.write_with(name, draw)?;
        Ok(Some(svg_text(draw)?))
    }
    #[cfg(not(feature = "figures"))]
    {
        Ok(None)
    }
}
