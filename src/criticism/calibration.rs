//! Calibration of criticism: how often the ladder adds an effect to a
//! record that lacks one (a false discovery), and how often it ranks a
//! hidden catalog effect first.
//!
//! - **Null records**: the truth is the start model,
//!   `trilinear+lcfm+viscous`, at a random parameter set
//!   ([`random_truth`]); with white noise of 1.5 % of the record's peak, or
//!   with coloured sensor noise ([`sensor_noise`]).
//! - **Hidden records**: the truth is a start model plus one catalog
//!   component ([`HIDDEN`]), at a random parameter set and a random size of
//!   the effect, with white noise of 1.5 % of the peak.
//! - **Out-of-catalog records**: the truth is the start model with physics
//!   the catalog does not offer ([`OUTSIDE`]: a viscoelastic memory force,
//!   a smooth Bouc-Wen spring, friction that falls as the slider heats and
//!   recovers as it cools), of a random size, with white noise of 1.5 %
//!   of the peak. Any effect added to one is a false addition: a stand-in.
//!
//! Every record is criticised as `hbis diagnose --noise auto` does it: the
//! noise model is chosen by BIC at the start model ([`choose_noise`]), then
//! the candidates are refitted and ranked ([`diagnose_model`], the
//! ladder's first step). A null or out-of-catalog record's outcome is a
//! false discovery when a candidate is *accepted* (the ladder would add
//! it); a hidden record's effect is found when it ranks first, and
//! recovered when it is the one accepted.
//!
//! A hidden effect's size is drawn from a stated range, not chosen to be
//! visible, so on some records even the truth does not beat the start
//! model by the ladder's [`SUPPORT`] in BIC (a friction decay that the
//! start model's `lcfm` absorbs, a velocity friction within the noise).
//! Each hidden record is therefore also refitted with the true structure
//! from the true parameters ([`Outcome::truth_delta_bic`]): recovery is
//! reported over all hidden records and over those where the effect is
//! detectable.
//!
//! Each record depends only on the study's seed and its index, so the
//! result does not depend on the number of threads.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use serde::Serialize;

use thiserror::Error;

use super::ranking::{
    choose_noise, diagnose_model, fit_model, CriticismError, ModelFit, RankedCandidate, SUPPORT,
};
use crate::data::{Aligned, Record, RecordError};
use crate::inference::{MapSettings, Noise};
use crate::model::effect_file::{EffectFileError, FileEffect};
use crate::model::{
    ForwardModel, Model, ParamError, ParamName, Params, Registry, SimError, SpecError,
};

/// Why a calibration record could not be made or criticised.
#[derive(Debug, Error)]
pub enum CalibrationError {
    /// A model of [`HIDDEN`] is not in the registry.
    #[error("calibration model")]
    Spec(#[from] SpecError),
    /// A drawn parameter set is invalid.
    #[error("calibration parameters")]
    Param(#[from] ParamError),
    /// The truth could not be simulated.
    #[error("simulating a calibration record")]
    Sim(#[from] SimError),
    /// The record was refused.
    #[error("calibration record")]
    Record(#[from] RecordError),
    /// The criticism failed.
    #[error(transparent)]
    Criticism(#[from] CriticismError),
    /// An out-of-catalog truth's effect file was refused.
    #[error("calibration effect file")]
    EffectFile(#[from] EffectFileError),
}

/// Record length and sampling of every calibration record: 10 s at 200 Hz.
const DT: f64 = 0.005;
/// See [`DT`].
const N: usize = 2001;
/// The paper's full model: the truth of the null records and the start
/// model of most hidden and every out-of-catalog record.
const PAPER: &str = "trilinear+lcfm+viscous";
/// Table 8.1 columns the random parameter sets are drawn around, where a
/// kind does not need others.
const COLUMNS: &[u32] = &[3, 5, 6, 7, 8];
/// Noise sd as a fraction of the record's peak |a|.
pub const NOISE: f64 = 0.015;

/// A hidden catalog effect: the start model, the truth (the start model
/// plus the effect) and how its size is drawn.
pub struct Hidden {
    /// The candidate's name, as the ranking reports it.
    pub effect: &'static str,
    /// The model criticism starts from.
    pub start: &'static str,
    /// The model that makes the record.
    pub truth: &'static str,
    /// The effect's parameters (for core laws: the paper's, set on the
    /// random parameter set).
    pub draw: fn(&mut StdRng, &mut Params) -> Vec<(&'static str, f64)>,
    /// Table 8.1 columns the parameter set is drawn around.
    pub columns: &'static [u32],
}

fn either_sign(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    let v: f64 = rng.random_range(lo..hi);
    if rng.random_bool(0.5) {
        v
    } else {
        -v
    }
}

/// The hidden effects, one a kind: the five catalog components added to
/// the paper's model and the paper's three upgrades (a third stiffness
/// branch, friction growing with amplitude, a damper), each with a size
/// that changes the record by more than its noise.
pub const HIDDEN: [Hidden; 8] = [
    Hidden {
        effect: "velocity-friction",
        start: PAPER,
        truth: "trilinear+lcfm+viscous+velocity-friction",
        draw: |rng, _| {
            vec![
                ("r_mu", rng.random_range(0.2..0.5)),
                ("v_t", rng.random_range(0.02..0.08)),
            ]
        },
        columns: COLUMNS,
    },
    Hidden {
        effect: "offset",
        start: PAPER,
        truth: "trilinear+lcfm+viscous+offset",
        draw: |rng, _| vec![("a_off", either_sign(rng, 0.01, 0.03))],
        columns: COLUMNS,
    },
    Hidden {
        effect: "degradation",
        start: PAPER,
        truth: "trilinear+lcfm+viscous+degradation",
        draw: |rng, _| vec![("kappa_k", rng.random_range(0.15..0.4))],
        columns: COLUMNS,
    },
    Hidden {
        effect: "asymmetric-friction",
        start: PAPER,
        truth: "trilinear+lcfm+viscous+asymmetric-friction",
        // A constant force while sliding, which a shifted release absorbs
        // (docs/components.md): it shows only where friction grows with
        // amplitude, and Tests 7 and 8 have the largest |rF0| of Table 8.1.
        draw: |rng, _| vec![("a_F", either_sign(rng, 0.45, 0.6))],
        columns: &[7, 8],
    },
    Hidden {
        effect: "friction-decay",
        start: PAPER,
        truth: "trilinear+lcfm+viscous+friction-decay",
        draw: |rng, _| vec![("kappa_F", rng.random_range(1.5..3.0))],
        columns: COLUMNS,
    },
    Hidden {
        effect: "trilinear",
        start: "bilinear+lcfm+viscous",
        truth: PAPER,
        draw: |_, _| Vec::new(),
        columns: COLUMNS,
    },
    Hidden {
        effect: "lcfm",
        start: "trilinear+coulomb+viscous",
        truth: PAPER,
        draw: |rng, p| {
            p.rf0 = either_sign(rng, 0.01, 0.03);
            Vec::new()
        },
        columns: COLUMNS,
    },
    Hidden {
        effect: "viscous",
        start: "trilinear+lcfm",
        truth: PAPER,
        draw: |_, _| Vec::new(),
        columns: COLUMNS,
    },
];

/// Physics outside the default catalog that makes an out-of-catalog
/// record: its name, the truth, and how its size is drawn around a random
/// parameter set.
pub struct Outside {
    /// Its name (the component or effect file that makes it).
    pub effect: &'static str,
    /// What it is, physically.
    pub physics: &'static str,
    /// The model that makes the record (the start model is
    /// `trilinear+lcfm+viscous`).
    pub truth: &'static str,
    /// Its parameters, on the random parameter set `p`.
    pub draw: fn(&mut StdRng, &Params) -> Vec<(&'static str, f64)>,
}

/// `lo..hi` drawn uniformly on a log scale (a time constant).
fn log_uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo.ln()..hi.ln()).exp()
}

/// The friction-heating effect file of `examples/effects` (a state with
/// memory: the temperature index of the sliding surface).
pub const HEATING_EFFECT: &str = include_str!("../../examples/effects/friction-heating.toml");

/// The out-of-catalog physics, one a kind, with sizes drawn from stated
/// ranges rather than chosen to be visible:
/// - `maxwell`: a viscoelastic rubber, `r_m` uniform in [0.05, 0.3] of the
///   initial stiffness through a relaxation of `tau_m` log-uniform in
///   [0.1, 1.5] s (the range of `examples/memory_records.rs`);
/// - `bouc-wen`: the rubber's spring smooth instead of tri-linear, at the
///   parameter set's `f0`, `f2` and `uy`, sharpness `n` uniform in [1, 3]
///   and `beta` uniform in [0.3, 0.7];
/// - `friction-heating`: friction `F_F / (1 + T)` with `dT/dt = h_T |u'| -
///   T / tau_T`, `h_T` log-uniform in [0.3, 3] per metre of sliding and
///   `tau_T` log-uniform in [0.5, 5] s (a surface that cools within a few
///   swings; with a far longer `tau_T` heating is the catalog's travel
///   law, `friction-decay`).
pub const OUTSIDE: [Outside; 3] = [
    Outside {
        effect: "maxwell",
        physics: "a viscoelastic (Maxwell) memory force in the rubber",
        truth: "trilinear+lcfm+viscous+maxwell",
        draw: |rng, _| {
            vec![
                ("r_m", rng.random_range(0.05..0.3)),
                ("tau_m", log_uniform(rng, 0.1, 1.5)),
            ]
        },
    },
    Outside {
        effect: "bouc-wen",
        physics: "a smooth hysteretic (Bouc-Wen) rubber spring",
        truth: "bouc-wen+lcfm+viscous",
        draw: |rng, p| {
            vec![
                ("f2", p.f2),
                ("uy", p.uy),
                ("n", rng.random_range(1.0..3.0)),
                ("beta", rng.random_range(0.3..0.7)),
            ]
        },
    },
    Outside {
        effect: "friction-heating",
        physics: "friction that falls as the slider heats and recovers as it cools",
        truth: "trilinear+lcfm+viscous+friction-heating",
        draw: |rng, _| {
            vec![
                ("h_T", log_uniform(rng, 0.3, 3.0)),
                ("tau_T", log_uniform(rng, 0.5, 5.0)),
            ]
        },
    },
];

/// A random parameter set around a Table 8.1 column: every parameter
/// times a factor in [0.75, 1.25], `f1` and `f2` kept below `0.95 f0` (the spring
/// softens after yield), `u3` below `0.8 u0` (the release reaches the third
/// branch) and above `1.5 uy`.
pub fn random_truth(rng: &mut StdRng, columns: &[u32]) -> Params {
    let col = columns[rng.random_range(0..columns.len())];
    let mut p = Params::table_8_1(col).expect("a Table 8.1 column");
    for name in ParamName::ALL {
        let v = p.get(name) * rng.random_range(0.75..1.25);
        p.set(name, v);
    }
    p.f1 = p.f1.min(0.95 * p.f0);
    p.f2 = p.f2.min(0.95 * p.f0);
    p.u3 = p.u3.min(0.8 * p.u0).max(1.5 * p.uy);
    p
}

/// Coloured, filtered and quantised sensor noise added to `clean`: AR(1)
/// noise (`phi` 0.5) through a second-order Butterworth low-pass at 40 Hz
/// (the sensor's anti-alias filter), scaled to an sd of [`NOISE`] times
/// the peak, and the sum quantised to steps of a quarter of that sd.
pub fn sensor_noise(clean: &[f64], dt: f64, rng: &mut StdRng) -> Vec<f64> {
    let unit = Normal::new(0.0, 1.0).expect("unit normal");
    let mut e = 0.0;
    let ar: Vec<f64> = clean
        .iter()
        .map(|_| {
            e = 0.5 * e + unit.sample(rng);
            e
        })
        .collect();
    let filtered = low_pass(&ar, 40.0, dt);
    let sd = (filtered.iter().map(|v| v * v).sum::<f64>() / filtered.len() as f64).sqrt();
    let peak = clean.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (sigma, step) = (NOISE * peak, 0.25 * NOISE * peak);
    clean
        .iter()
        .zip(&filtered)
        .map(|(c, f)| ((c + sigma * f / sd) / step).round() * step)
        .collect()
}

/// A second-order Butterworth low-pass (bilinear transform, corner
/// pre-warped), run forward from rest.
///
/// # Formula
/// ```text
/// K = tan(pi fc dt),  norm = 1 / (1 + sqrt2 K + K^2)
/// b = (K^2, 2 K^2, K^2) norm,  a1 = 2 (K^2 - 1) norm,  a2 = (1 - sqrt2 K + K^2) norm
/// ```
/// ```
/// use hbis::criticism::calibration::low_pass;
/// // A constant passes unchanged once the filter has settled.
/// let y = low_pass(&[1.0; 400], 40.0, 0.005);
/// assert!((y[399] - 1.0).abs() < 1e-9);
/// // The Nyquist frequency (alternating signs) is removed.
/// let alt: Vec<f64> = (0..400).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// assert!(low_pass(&alt, 40.0, 0.005)[399].abs() < 1e-9);
/// ```
pub fn low_pass(x: &[f64], fc: f64, dt: f64) -> Vec<f64> {
    let k = (std::f64::consts::PI * fc * dt).tan();
    let s2 = std::f64::consts::SQRT_2;
    let norm = 1.0 / (1.0 + s2 * k + k * k);
    let (b0, b1, b2) = (k * k * norm, 2.0 * k * k * norm, k * k * norm);
    let (a1, a2) = (2.0 * (k * k - 1.0) * norm, (1.0 - s2 * k + k * k) * norm);
    let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
    x.iter()
        .map(|&v| {
            let y = b0 * v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
            (x2, x1, y2, y1) = (x1, v, y1, y);
            y
        })
        .collect()
}

/// What a calibration record is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    /// The start model, white noise.
    NullWhite,
    /// The start model, coloured sensor noise.
    NullColoured,
    /// One hidden effect (index into [`HIDDEN`]).
    Hidden(usize),
    /// Physics outside the catalog (index into [`OUTSIDE`]).
    Outside(usize),
}

/// The accelerometer's sampling in a study: every record is made, and
/// every model fitted, with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sensor {
    /// The value at each sample instant (the default).
    #[default]
    Instant,
    /// The mean over each sample interval (`+averaging`,
    /// [`crate::model::catalog::averaging`]).
    Averaging,
}

impl Sensor {
    /// The model `spec` under this sensor.
    fn model(self, registry: &Registry, spec: &str) -> Result<Model, SpecError> {
        match self {
            Sensor::Instant => registry.parse(spec),
            Sensor::Averaging => registry.parse(&format!("{spec}+averaging")),
        }
    }
}

/// The criticism of one calibration record.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    /// What the record is.
    pub kind: Kind,
    /// Its seed.
    pub seed: u64,
    /// The sensor that made it and that every fit assumes.
    pub sensor: Sensor,
    /// The catalog effect hidden in it (`None` for a null or an
    /// out-of-catalog record).
    pub hidden: Option<String>,
    /// The out-of-catalog physics in it ([`OUTSIDE`]'s name).
    pub outside: Option<String>,
    /// The hidden or out-of-catalog effect's parameters (name, value).
    pub hidden_values: Vec<(String, f64)>,
    /// The noise model `--noise auto` chose.
    pub noise: Noise,
    /// The best candidate by BIC.
    pub first: Option<String>,
    /// Its BIC change.
    pub first_delta_bic: f64,
    /// The candidate the ladder would add (the best accepted one).
    pub accepted: Option<String>,
    /// Its reason, or the best candidate's when none is accepted.
    pub reason: String,
    /// For a hidden effect: why its own candidate was or was not accepted
    /// (`None` where it was not refitted), so a miss says which gate kept
    /// it out even when another candidate was accepted or ranked first.
    pub hidden_reason: Option<String>,
    /// For a hidden effect: the BIC change from the start model's fit to
    /// the true structure, the better of its refit from the true
    /// parameters and its refit in the ranking.
    pub truth_delta_bic: Option<f64>,
    /// The candidates whose refit did not converge (still gaining after
    /// the searches from its best: not ranked).
    pub unconverged: Vec<String>,
    /// The candidates whose best search stopped at its evaluation budget
    /// (ranked, and reported so).
    pub at_budget: Vec<String>,
}

impl Outcome {
    /// A null or out-of-catalog record to which the ladder would add an
    /// effect.
    pub fn false_discovery(&self) -> bool {
        self.hidden.is_none() && self.accepted.is_some()
    }
    /// A hidden effect ranked first.
    pub fn found(&self) -> bool {
        self.hidden.is_some() && self.first == self.hidden
    }
    /// A hidden effect that the ladder would add.
    pub fn recovered(&self) -> bool {
        self.hidden.is_some() && self.accepted == self.hidden
    }
    /// A hidden effect that BIC can find on its record: the true
    /// structure refitted beats the start model by more than [`SUPPORT`].
    pub fn detectable(&self) -> bool {
        self.truth_delta_bic.is_some_and(|d| d < -SUPPORT)
    }
}

/// A calibration record and what made it.
#[derive(Debug, Clone)]
pub struct MadeRecord {
    /// The model criticism starts from.
    pub start: Model,
    /// The record.
    pub data: Aligned,
    /// The hidden or out-of-catalog effect's values (name, value).
    pub values: Vec<(String, f64)>,
    /// The model that made the record.
    pub truth: Model,
    /// Its parameters.
    pub truth_theta: Vec<f64>,
}

/// The record of `kind` under `sensor` with seed `seed`: the start model,
/// the record and the hidden effect's values. The sensor does not change
/// the draws.
pub fn make_record(
    registry: &Registry,
    kind: Kind,
    sensor: Sensor,
    seed: u64,
) -> Result<MadeRecord, CalibrationError> {
    let mut rng = StdRng::seed_from_u64(seed);
    let (start, truth_model, p, values) = match kind {
        Kind::NullWhite | Kind::NullColoured => {
            let m = sensor.model(registry, PAPER)?;
            let p = random_truth(&mut rng, COLUMNS);
            (m.clone(), m, p, Vec::new())
        }
        Kind::Hidden(k) => {
            let h = &HIDDEN[k];
            let mut p = random_truth(&mut rng, h.columns);
            let values = (h.draw)(&mut rng, &mut p);
            (
                sensor.model(registry, h.start)?,
                sensor.model(registry, h.truth)?,
                p,
                values,
            )
        }
        Kind::Outside(k) => {
            let o = &OUTSIDE[k];
            let p = random_truth(&mut rng, COLUMNS);
            let values = (o.draw)(&mut rng, &p);
            (
                sensor.model(registry, PAPER)?,
                sensor.model(&truth_registry(registry)?, o.truth)?,
                p,
                values,
            )
        }
    };
    let theta = truth_model.theta_from_params(&p, &values)?;
    let mut clean = vec![0.0; N];
    truth_model.accel_into(&theta, DT, &mut clean)?;
    let a = if kind == Kind::NullColoured {
        sensor_noise(&clean, DT, &mut rng)
    } else {
        let peak = clean.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let normal = Normal::new(0.0, NOISE * peak).expect("positive sd");
        clean.iter().map(|c| c + normal.sample(&mut rng)).collect()
    };
    let t = (0..N).map(|i| i as f64 * DT).collect();
    let data = Record::new(t, a)?.aligned(None)?;
    let values = values.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    Ok(MadeRecord {
        start,
        data,
        values,
        truth: truth_model,
        truth_theta: theta,
    })
}

/// `registry` with the out-of-catalog effect files registered, to make
/// records with (criticism keeps `registry` itself).
fn truth_registry(registry: &Registry) -> Result<Registry, CalibrationError> {
    let mut r = registry.clone();
    if r.get("friction-heating").is_none() {
        r.register_file_effect(FileEffect::from_toml(
            HEATING_EFFECT,
            "friction-heating.toml",
        )?)?;
    }
    Ok(r)
}

/// Criticises one record as `hbis diagnose --noise auto` does.
pub fn criticise(
    registry: &Registry,
    kind: Kind,
    sensor: Sensor,
    seed: u64,
) -> Result<Outcome, CalibrationError> {
    let made = make_record(registry, kind, sensor, seed)?;
    let (start, data) = (&made.start, &made.data);
    let settings = MapSettings::default();
    let noise = choose_noise(start, data, &settings, seed ^ 0x0A17_0015)?.chosen;
    let (current, _, ranked) = diagnose_model(registry, start, data, noise, &settings, seed)?;
    let accepted = ranked.iter().find(|c| c.accepted);
    let reason = accepted
        .or(ranked.first())
        .map_or(String::new(), |c| c.reason.clone());
    let hidden = match kind {
        Kind::Hidden(k) => Some(HIDDEN[k].effect.to_string()),
        _ => None,
    };
    let own = hidden
        .as_ref()
        .and_then(|effect| ranked.iter().find(|c| &c.effect == effect));
    let truth_delta_bic = match &hidden {
        Some(_) => Some(truth_delta_bic(&made, &current, noise, own, seed)?),
        None => None,
    };
    Ok(Outcome {
        kind,
        seed,
        sensor,
        hidden,
        outside: match kind {
            Kind::Outside(k) => Some(OUTSIDE[k].effect.to_string()),
            _ => None,
        },
        hidden_values: made.values,
        noise,
        first: ranked.first().map(|c| c.effect.clone()),
        first_delta_bic: ranked.first().map_or(0.0, |c| c.delta_bic),
        accepted: accepted.map(|c| c.effect.clone()),
        reason,
        hidden_reason: own.map(|c| c.reason.clone()),
        truth_delta_bic,
        unconverged: names(&ranked, |c| !c.converged),
        at_budget: names(&ranked, |c| c.at_budget),
    })
}

/// The effects of the candidates that `pick` selects, in ranking order.
fn names(ranked: &[RankedCandidate], pick: impl Fn(&RankedCandidate) -> bool) -> Vec<String> {
    ranked
        .iter()
        .filter(|c| pick(c))
        .map(|c| c.effect.clone())
        .collect()
}

/// The BIC change from the start model's fit `current` to the true
/// structure: the better of its refit from the true parameters and its
/// refit in the ranking (`refit`, when it was ranked).
///
/// It says whether a hidden effect of this size can be found on this
/// record at all: when even the truth, started where it made the record,
/// does not beat the start model by [`SUPPORT`], no gate on BIC adds it,
/// and missing it is the record's limit rather than the search's. Started
/// from the true parameters, this refit does not share the ranking's
/// starts, so a refit that the ranking failed to converge still counts
/// as a miss.
fn truth_delta_bic(
    made: &MadeRecord,
    current: &ModelFit,
    noise: Noise,
    refit: Option<&RankedCandidate>,
    seed: u64,
) -> Result<f64, CalibrationError> {
    let oracle = fit_model(
        &made.truth,
        &made.data,
        noise,
        Some(made.truth_theta.clone()),
        &MapSettings::default(),
        seed ^ 0x0AC1_E000,
    )?;
    let oracle = oracle.bic - current.bic;
    Ok(refit.map_or(oracle, |c| c.delta_bic.min(oracle)))
}

/// The records of the standard study: `nulls` null records of each noise
/// kind, `per_effect` records of each hidden effect, then `per_outside`
/// of each out-of-catalog physics.
pub fn standard(nulls: usize, per_effect: usize, per_outside: usize) -> Vec<Kind> {
    let mut kinds = Vec::new();
    for _ in 0..nulls {
        kinds.push(Kind::NullWhite);
        kinds.push(Kind::NullColoured);
    }
    for k in 0..HIDDEN.len() {
        kinds.extend(std::iter::repeat_n(Kind::Hidden(k), per_effect));
    }
    for k in 0..OUTSIDE.len() {
        kinds.extend(std::iter::repeat_n(Kind::Outside(k), per_outside));
    }
    kinds
}

/// Criticises the records `kinds` under `sensor`, the `i`-th with seed
/// `seed * 1000003 + i`, in parallel; `on_done` is called as each
/// finishes (for progress). The outcomes come back in the order of `kinds`.
pub fn study(
    registry: &Registry,
    kinds: &[Kind],
    sensor: Sensor,
    seed: u64,
    on_done: &(dyn Fn(&Outcome) + Sync),
) -> Result<Vec<Outcome>, CalibrationError> {
    let jobs: Vec<(Kind, u64)> = kinds
        .iter()
        .enumerate()
        .map(|(i, &k)| (k, seed.wrapping_mul(1_000_003).wrapping_add(i as u64)))
        .collect();
    jobs.into_par_iter()
        .map(|(k, s)| {
            let o = criticise(registry, k, sensor, s)?;
            on_done(&o);
            Ok(o)
        })
        .collect()
}

/// The table of a study: false discoveries by noise kind and by
/// out-of-catalog physics, hidden effects ranked first and accepted by
/// effect, then the rates with Clopper-Pearson 95 % intervals.
pub fn table(outcomes: &[Outcome]) -> String {
    let mut out =
        String::from("records                       n  first  accepted  false discoveries\n");
    let of = |kind: Kind| -> Vec<&Outcome> { outcomes.iter().filter(|o| o.kind == kind).collect() };
    for (label, kind) in [
        ("null, white noise", Kind::NullWhite),
        ("null, sensor noise", Kind::NullColoured),
    ] {
        let g = of(kind);
        let ar1 = g.iter().filter(|o| o.noise == Noise::Ar1).count();
        out.push_str(&format!(
            "{label:27} {:>3}      -         -  {:>3}   (AR(1) chosen in {ar1})\n",
            g.len(),
            g.iter().filter(|o| o.false_discovery()).count()
        ));
    }
    for (k, h) in HIDDEN.iter().enumerate() {
        let g = of(Kind::Hidden(k));
        if !g.is_empty() {
            let detectable: Vec<_> = g.iter().filter(|o| o.detectable()).collect();
            out.push_str(&format!(
                "hidden {:20} {:>3}    {:>3}       {:>3}        (detectable {}, accepted {} of them)\n",
                h.effect,
                g.len(),
                g.iter().filter(|o| o.found()).count(),
                g.iter().filter(|o| o.recovered()).count(),
                detectable.len(),
                detectable.iter().filter(|o| o.recovered()).count()
            ));
        }
    }
    for (k, o) in OUTSIDE.iter().enumerate() {
        let g = of(Kind::Outside(k));
        if !g.is_empty() {
            let added: Vec<&str> = g.iter().filter_map(|o| o.accepted.as_deref()).collect();
            out.push_str(&format!(
                "outside {:19} {:>3}      -         -  {:>3}{}\n",
                o.effect,
                g.len(),
                added.len(),
                if added.is_empty() {
                    String::new()
                } else {
                    format!("   ({})", added.join(", "))
                }
            ));
        }
    }
    let rate = |label: &str, k: usize, n: usize| -> String {
        if n == 0 {
            return String::new();
        }
        let (lo, hi) = crate::inference::proportion::clopper_pearson(k as f64, n as f64, 0.95);
        format!(
            "{label}: {k} of {n} ({:.1} %, 95 % interval {:.1}-{:.1} %)\n",
            100.0 * k as f64 / n as f64,
            100.0 * lo,
            100.0 * hi
        )
    };
    let count = |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|o| f(o)).count();
    let nulls = count(&|o| matches!(o.kind, Kind::NullWhite | Kind::NullColoured));
    let outside = count(&|o| o.outside.is_some());
    let hidden = count(&|o| o.hidden.is_some());
    let fd_nulls = count(&|o| o.outside.is_none() && o.false_discovery());
    let fd_outside = count(&|o| o.outside.is_some() && o.false_discovery());
    out.push_str(&rate("false additions, null records", fd_nulls, nulls));
    out.push_str(&rate(
        "false additions, out-of-catalog records",
        fd_outside,
        outside,
    ));
    out.push_str(&rate(
        "false additions, both",
        fd_nulls + fd_outside,
        nulls + outside,
    ));
    out.push_str(&rate(
        "hidden effects ranked first",
        count(&|o| o.found()),
        hidden,
    ));
    out.push_str(&rate(
        "hidden effects recovered (accepted)",
        count(&|o| o.recovered()),
        hidden,
    ));
    let detectable = count(&|o| o.detectable());
    out.push_str(&rate(
        "hidden effects detectable (the truth refitted beats the start by BIC -10)",
        detectable,
        hidden,
    ));
    out.push_str(&rate(
        "detectable hidden effects recovered (accepted)",
        count(&|o| o.detectable() && o.recovered()),
        detectable,
    ));
    out.push_str(&refits_line(outcomes));
    out
}

/// How many candidate refits did not converge or stopped at their
/// budget, over all records: a convergence failure in a miss shows here
/// even when the reason printed is another candidate's.
fn refits_line(outcomes: &[Outcome]) -> String {
    let total = |f: &dyn Fn(&Outcome) -> usize| outcomes.iter().map(f).sum::<usize>();
    let records = |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|o| f(o)).count();
    format!(
        "candidate refits not converged: {} (on {} of {} records); at their budget: {} (on {} of them)\n",
        total(&|o| o.unconverged.len()),
        records(&|o| !o.unconverged.is_empty()),
        outcomes.len(),
        total(&|o| o.at_budget.len()),
        records(&|o| !o.at_budget.is_empty()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The calibration's sensor noise is coloured from one sample to the
    /// next, its white noise is not (seeds 1 to 5 each).
    #[test]
    fn sensor_noise_is_coloured_at_the_shortest_lags_and_white_noise_is_not() {
        use crate::criticism::residuals::short_lag_rho;
        use crate::criticism::short_lag_limit;
        let limit = short_lag_limit(N);
        for seed in 1..=5 {
            let mut rng = StdRng::seed_from_u64(seed);
            // A release-test-like signal, for the noise's scale.
            let clean: Vec<f64> = (0..N)
                .map(|i| (std::f64::consts::TAU * 0.5 * i as f64 * DT).sin())
                .collect();
            let read = sensor_noise(&clean, DT, &mut rng);
            let noise: Vec<f64> = read.iter().zip(&clean).map(|(r, c)| r - c).collect();
            let coloured = short_lag_rho(&noise);
            let normal = Normal::new(0.0, 1.0).unwrap();
            let white: Vec<f64> = clean.iter().map(|_| normal.sample(&mut rng)).collect();
            let white = short_lag_rho(&white);
            eprintln!(
                "seed {seed}: sensor noise {coloured:.3}, white {white:.3}, limit {limit:.3}"
            );
            assert!(coloured > limit && white.abs() < limit);
        }
    }

    fn hidden(truth_delta_bic: f64, accepted: bool) -> Outcome {
        Outcome {
            kind: Kind::Hidden(4),
            seed: 0,
            sensor: Sensor::Instant,
            hidden: Some("friction-decay".into()),
            outside: None,
            hidden_values: Vec::new(),
            noise: Noise::White,
            first: Some("friction-decay".into()),
            first_delta_bic: truth_delta_bic,
            accepted: accepted.then(|| "friction-decay".into()),
            reason: String::new(),
            hidden_reason: None,
            truth_delta_bic: Some(truth_delta_bic),
            unconverged: Vec::new(),
            at_budget: Vec::new(),
        }
    }

    #[test]
    fn recovery_where_detectable_counts_only_records_the_truth_wins_by_ten() {
        let outcomes = [
            hidden(-40.0, true),
            hidden(-12.0, false),
            hidden(-9.9, false),
            hidden(3.0, false),
        ];
        assert!(outcomes[1].detectable() && !outcomes[2].detectable());
        let t = table(&outcomes);
        assert!(t.contains("(detectable 2, accepted 1 of them)"), "{t}");
        assert!(t.contains("beats the start by BIC -10): 2 of 4"), "{t}");
        assert!(
            t.contains("detectable hidden effects recovered (accepted): 1 of 2"),
            "{t}"
        );
    }

    #[test]
    fn refits_that_did_not_converge_are_counted_over_every_candidate() {
        let mut outcomes = [
            hidden(-40.0, true),
            hidden(-12.0, false),
            hidden(3.0, false),
        ];
        outcomes[0].unconverged = vec!["offset".into(), "lcfm".into()];
        outcomes[1].at_budget = vec!["viscous".into(), "offset".into(), "lcfm".into()];
        outcomes[2].unconverged = vec!["degradation".into()];
        let t = table(&outcomes);
        assert!(
            t.contains("not converged: 3 (on 2 of 3 records); at their budget: 3 (on 1 of them)"),
            "{t}"
        );
    }
}
