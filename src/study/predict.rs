//! The posterior predictive response to an earthquake: each posterior draw
//! of a fit simulated from rest under a ground motion (closed form, see
//! [`model::forced`](crate::model::forced)), and the design quantities
//! summarised over the draws.
//!
//! Per draw: the peak isolator displacement, the residual displacement
//! after the tail, the peak base shear per unit mass `|F_S + F_F + c u'| /
//! m` and the peak total acceleration `|u'' + ag|`. In this model (a rigid
//! mass on the isolators) the two are one quantity, `m (u'' + ag) = -(F_S +
//! F_F + c u')`; both are computed (from the forces and from the motion) and
//! reported, and the base shear also in kN when the draws carry the mass of
//! eq. 8.1.
//!
//! ```
//! use hbis::model::{Params, Registry};
//! use hbis::predict::{predict, Draw, PredictOptions};
//!
//! let model = Registry::builtin().parse("trilinear+lcfm+viscous")?;
//! let theta = model.theta_from_params(&Params::table_8_1(5).unwrap(), &[])?;
//! let ag: Vec<f64> = (0..=300).map(|i| 2.0 * (0.05 * i as f64).sin()).collect();
//! let draws = vec![Draw::new(theta)];
//! let p = predict(&model, &draws, 0.01, &ag, &PredictOptions::default())?;
//! let d = &p.summary.peak_displacement;
//! // One parameter set: mean and quantiles are its value, sd is zero.
//! assert!(d.mean > 0.0 && d.q05 == d.mean && d.q95 == d.mean && d.sd == 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::cancel::{Cancel, Cancelled};
use crate::inference::summary::{quantile, ParamSummary};
use crate::model::forced::{Excitation, ForcedSink, Peaks};
use crate::model::{ForwardModel, Model, Registry, SimError};
use crate::report::outdir::FileEntry;
use crate::report::verify::{check_files, read_manifest, VerifyError};

/// What went wrong in a prediction.
#[derive(Debug, Error)]
pub enum PredictError {
    /// The prediction was cancelled ([`PredictOptions::cancel`]).
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
    /// A file of the fit could not be read.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// `fit.json` is not what `hbis fit` writes.
    #[error("{path}: {problem}")]
    Fit {
        /// The file.
        path: String,
        /// What is wrong.
        problem: String,
    },
    /// A chain file's row is not as expected.
    #[error("{path}, line {line}: {problem}")]
    Chain {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        problem: String,
    },
    /// A draw cannot be simulated.
    #[error("draw {draw}")]
    Draw {
        /// Index of the draw.
        draw: usize,
        /// Why.
        #[source]
        source: SimError,
    },
    /// Settings that cannot work.
    #[error("{0}")]
    Invalid(String),
    /// The fit folder is not what its run wrote.
    #[error(transparent)]
    Folder(#[from] VerifyError),
}

/// One parameter set to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct Draw {
    /// The model's parameters, in its layout's order.
    pub theta: Vec<f64>,
    /// Mass `m` of eq. 8.1 (t), when the fit was given the forces.
    pub mass: Option<f64>,
    /// Chain (1-based) and row within it, when taken from a fit.
    pub origin: Option<(usize, usize)>,
}

impl Draw {
    /// A parameter set without a mass.
    pub fn new(theta: Vec<f64>) -> Self {
        Self {
            theta,
            mass: None,
            origin: None,
        }
    }
}

/// Settings of a prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictOptions {
    /// Seconds simulated after the motion ends, so the system comes to rest.
    pub tail: f64,
    /// Displacement capacity of the isolators (m), if any.
    pub capacity: Option<f64>,
    /// Points of the response band over time (0: none).
    pub band_points: usize,
    /// Checked before each draw: once cancelled, the prediction ends with
    /// [`PredictError::Cancelled`].
    pub cancel: Option<Cancel>,
}

impl Default for PredictOptions {
    fn default() -> Self {
        Self {
            tail: 20.0,
            capacity: None,
            band_points: 0,
            cancel: None,
        }
    }
}

/// Mean, sd and quantiles of one quantity over the draws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stats {
    /// Mean.
    pub mean: f64,
    /// Standard deviation (0 for one draw).
    pub sd: f64,
    /// 5 % quantile.
    pub q05: f64,
    /// Median.
    pub q50: f64,
    /// 95 % quantile.
    pub q95: f64,
}

impl Stats {
    /// Summary of values (type-7 quantiles; `sd` 0 for one value), as the
    /// posterior's parameters are summarised.
    pub fn of(values: &[f64]) -> Self {
        let s = ParamSummary::from_draws(values);
        Self {
            mean: s.mean,
            sd: s.sd,
            q05: s.q05,
            q50: s.q50,
            q95: s.q95,
        }
    }
}

/// The design quantities summarised over the draws (`predict.json`'s
/// `summary`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Peak isolator displacement `max |u|` (m).
    pub peak_displacement: Stats,
    /// Residual displacement `|u|` at the end of the tail (m).
    pub residual_displacement: Stats,
    /// Peak base shear per unit mass (m/s^2).
    pub peak_base_shear: Stats,
    /// Peak total acceleration `|u'' + ag|` (m/s^2).
    pub peak_total_acceleration: Stats,
    /// Peak base shear (kN), when the draws carry the mass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_base_shear_kn: Option<Stats>,
}

/// How far the draws went beyond what the release test identified.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Extrapolation {
    /// Share of draws whose peak displacement exceeds their release
    /// displacement `u0` (the largest amplitude the record showed).
    pub share_beyond_release: f64,
    /// Largest ratio of peak displacement to `u0` over the draws.
    pub max_ratio_to_release: f64,
    /// Median of that ratio.
    pub median_ratio_to_release: f64,
    /// Share of draws whose response entered an envelope branch (plastic
    /// phase) deeper than any their release test reached (its free
    /// vibration from `u0`, simulated for each draw).
    pub share_new_branch: f64,
    /// The deepest envelope branch any draw entered (0 elastic, 1-3 the
    /// paper's plastic phases).
    pub deepest_branch: u8,
    /// Share of draws whose friction amplitude `F_F0 + k_F |u|` fell to
    /// zero (floored there).
    pub share_friction_floored: f64,
    /// Share of draws still moving at the end of the tail (last speed above
    /// 1e-3 of their peak speed).
    pub share_still_moving: f64,
}

/// The outcome of one draw.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DrawOutcome {
    /// The peaks.
    pub peaks: Peaks,
    /// Peak base shear (kN), with the mass.
    pub peak_base_shear_kn: Option<f64>,
}

pub use crate::inference::summary::Band;

/// A posterior predictive run.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// The summaries.
    pub summary: Summary,
    /// Share of draws whose peak displacement exceeds the capacity.
    pub p_exceed_capacity: Option<f64>,
    /// Per draw, in the order given.
    pub outcomes: Vec<DrawOutcome>,
    /// Beyond the identified range.
    pub extrapolation: Extrapolation,
    /// Sentences backed by the numbers above, for the reader.
    pub warnings: Vec<String>,
    /// The displacement band, when asked for.
    pub band: Option<Band>,
}

/// Records `u` every `every` samples into a row of the band.
struct Decimated<'a> {
    every: usize,
    row: &'a mut [f64],
}

impl ForcedSink for Decimated<'_> {
    #[inline]
    fn sample(&mut self, i: usize, u: f64, _: f64, _: f64) {
        if i % self.every == 0 {
            if let Some(x) = self.row.get_mut(i / self.every) {
                *x = u;
            }
        }
    }
}

/// The largest and the last speed, to tell whether the motion had died
/// out by the end.
#[derive(Default)]
struct Speeds {
    peak: f64,
    last: f64,
}

impl Speeds {
    /// Still moving: the last speed above 1e-3 of the peak speed.
    fn moving(&self) -> bool {
        self.last > 1e-3 * self.peak
    }
}

impl ForcedSink for Speeds {
    #[inline]
    fn sample(&mut self, _: usize, _: f64, v: f64, _: f64) {
        self.last = v.abs();
        self.peak = self.peak.max(self.last);
    }
}

/// Refuses a value that must be a finite number > 0 (a mass, a capacity,
/// a PGA), in the words every front end uses: `name` is the flag or
/// argument (`--mass`, `masses[1]`).
///
/// ```
/// use hbis::predict::positive;
/// assert!(positive("mass", 5.0).is_ok());
/// let e = positive("--mass", -5.0).unwrap_err();
/// assert_eq!(e.to_string(), "--mass -5: expected a finite number > 0");
/// ```
pub fn positive(name: &str, v: f64) -> Result<(), PredictError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(PredictError::Invalid(format!(
            "{name} {v}: expected a finite number > 0"
        )))
    }
}

/// Simulates every draw under the ground acceleration `ag` (m/s^2, step
/// `dt`) from rest and summarises, in parallel (the result does not depend
/// on the number of threads).
pub fn predict(
    model: &Model,
    draws: &[Draw],
    dt: f64,
    ag: &[f64],
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    if draws.is_empty() {
        return Err(PredictError::Invalid("no draws to simulate".into()));
    }
    if let Some(c) = opts.capacity {
        positive("capacity", c)?;
    }
    for (i, d) in draws.iter().enumerate() {
        if let Some(m) = d.mass {
            positive(&format!("draw {i}: mass"), m)?;
        }
    }
    let ex = Excitation::new(dt, ag, opts.tail)
        .map_err(|e| PredictError::Invalid(format!("the ground motion: {e}")))?;
    // Every `every`-th sample of each draw's displacement, for the band.
    let (every, width) = match opts.band_points {
        0 => (1, 0),
        p => {
            let every = ex.len().div_ceil(p).max(1);
            (every, ex.len().div_ceil(every))
        }
    };
    let mut rows = vec![0.0; width * draws.len()];
    let mut chunks: Vec<&mut [f64]> = rows.chunks_mut(width.max(1)).collect();
    chunks.resize_with(draws.len(), Default::default);
    let results: Vec<Result<(DrawOutcome, bool), PredictError>> = draws
        .par_iter()
        .zip(chunks)
        .enumerate()
        .map(|(i, (d, row))| {
            if let Some(c) = &opts.cancel {
                c.check()?;
            }
            let mut sink = (Decimated { every, row }, Speeds::default());
            let peaks = model
                .forced(&d.theta, &ex, &mut sink)
                .map_err(|source| PredictError::Draw { draw: i, source })?;
            let moving = sink.1.moving();
            Ok((
                DrawOutcome {
                    peaks,
                    peak_base_shear_kn: d.mass.map(|m| m * peaks.peak_base_shear),
                },
                moving,
            ))
        })
        .collect();
    let mut outcomes = Vec::with_capacity(draws.len());
    let mut moving = 0usize;
    for r in results {
        let (o, m) = r?;
        outcomes.push(o);
        moving += usize::from(m);
    }
    let col = |f: fn(&Peaks) -> f64| outcomes.iter().map(|o| f(&o.peaks)).collect::<Vec<_>>();
    let peak_u = col(|p| p.peak_displacement);
    let kn: Option<Vec<f64>> = outcomes.iter().map(|o| o.peak_base_shear_kn).collect();
    let summary = Summary {
        peak_displacement: Stats::of(&peak_u),
        residual_displacement: Stats::of(&col(|p| p.residual_displacement)),
        peak_base_shear: Stats::of(&col(|p| p.peak_base_shear)),
        peak_total_acceleration: Stats::of(&col(|p| p.peak_total_acceleration)),
        peak_base_shear_kn: kn.as_deref().map(Stats::of),
    };
    let n = draws.len() as f64;
    let p_exceed_capacity = opts
        .capacity
        .map(|c| peak_u.iter().filter(|&&u| u > c).count() as f64 / n);
    let extrapolation = extrapolation(model, draws, &outcomes, moving);
    let warnings = warnings(&extrapolation, ag);
    let band = (width > 0).then(|| band(&rows, width, every, dt));
    Ok(Prediction {
        summary,
        p_exceed_capacity,
        outcomes,
        extrapolation,
        warnings,
        band,
    })
}

fn extrapolation(
    model: &Model,
    draws: &[Draw],
    outcomes: &[DrawOutcome],
    moving: usize,
) -> Extrapolation {
    let n = draws.len() as f64;
    let u0 = model.param_names().iter().position(|p| p == "u0");
    let mut ratios: Vec<f64> = match u0 {
        Some(k) => draws
            .iter()
            .zip(outcomes)
            .map(|(d, o)| o.peaks.peak_displacement / d.theta[k].abs())
            .collect(),
        None => Vec::new(),
    };
    ratios.sort_unstable_by(f64::total_cmp);
    let beyond = ratios.iter().filter(|&&r| r > 1.0).count() as f64;
    let floored = outcomes.iter().filter(|o| o.peaks.friction_floored).count() as f64;
    let new_branch = draws
        .par_iter()
        .zip(outcomes)
        .filter(|(d, o)| {
            release_deepest(model, &d.theta).is_some_and(|r| o.peaks.deepest_branch > r)
        })
        .count() as f64;
    Extrapolation {
        share_beyond_release: beyond / n,
        max_ratio_to_release: ratios.last().copied().unwrap_or(f64::NAN),
        median_ratio_to_release: quantile(&ratios, 0.5),
        share_new_branch: new_branch / n,
        deepest_branch: outcomes
            .iter()
            .map(|o| o.peaks.deepest_branch)
            .max()
            .unwrap_or(0),
        share_friction_floored: floored / n,
        share_still_moving: moving as f64 / n,
    }
}

/// The deepest envelope branch the release test of `theta` reaches (the
/// loading to `u0`, then its free vibration until rest, at most 600 s);
/// `None` if it cannot be simulated.
fn release_deepest(model: &Model, theta: &[f64]) -> Option<u8> {
    use crate::model::SpringKind;
    let p = model.core_params(theta).ok()?;
    // The imposed displacement loads the virgin curve up to u0 first.
    let loading = match model.spec().spring {
        SpringKind::Trilinear if p.u0.abs() > p.u3 => 3,
        SpringKind::Trilinear | SpringKind::Bilinear if p.u0.abs() > p.uy => 2,
        _ => 0,
    };
    let system = model.system(theta).ok()?;
    let mut phases: Vec<crate::model::Phase> = Vec::new();
    system
        .run(600.0, &crate::model::SimOptions::default(), &mut phases)
        .ok()?;
    phases
        .iter()
        .map(|p| match p.kind {
            crate::model::PhaseKind::Plastic1 => 1,
            crate::model::PhaseKind::Plastic2 => 2,
            crate::model::PhaseKind::Plastic3 => 3,
            _ => 0,
        })
        .chain([loading])
        .max()
}

/// Sentences, each printed only when its number says so.
fn warnings(x: &Extrapolation, ag: &[f64]) -> Vec<String> {
    let mut w = Vec::new();
    if x.share_beyond_release > 0.0 {
        w.push(format!(
            "{:.1} % of the draws move the isolators beyond their release displacement u0, the largest amplitude \
             the release test identified (median peak/u0 {:.2}, largest {:.2}): the spring and friction laws are \
             extrapolated there",
            100.0 * x.share_beyond_release,
            x.median_ratio_to_release,
            x.max_ratio_to_release
        ));
    }
    if x.share_new_branch > 0.0 {
        w.push(format!(
            "{:.1} % of the draws drive the spring onto an envelope branch their release test never reached \
             (deepest: plastic phase {}): its slope there is the prior's and the other branches' guess, not measured",
            100.0 * x.share_new_branch,
            x.deepest_branch
        ));
    }
    if x.share_friction_floored > 0.0 {
        w.push(format!(
            "{:.1} % of the draws reach displacements where the friction amplitude (uF0 + rF0 |u|) k0 falls to zero \
             (rF0 < 0); it is floored at zero there",
            100.0 * x.share_friction_floored
        ));
    }
    if x.share_still_moving > 0.0 {
        w.push(format!(
            "{:.1} % of the draws are still moving at the end of the tail: the residual displacement is not final \
             (lengthen --tail)",
            100.0 * x.share_still_moving
        ));
    }
    let pga = ag.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    if pga > 30.0 {
        w.push(format!(
            "the motion's peak ground acceleration is {pga:.3} m/s^2 ({:.2} g): is it in cm/s^2 or mm/s^2 rather than m/s^2?",
            pga / 9.80665
        ));
    } else if pga < 0.01 {
        w.push(format!(
            "the motion's peak ground acceleration is {pga:.3e} m/s^2: is it in g rather than m/s^2?"
        ));
    }
    w
}

fn band(rows: &[f64], width: usize, every: usize, dt: f64) -> Band {
    let draws = rows.len() / width;
    let mut b = Band {
        t: Vec::with_capacity(width),
        q05: Vec::with_capacity(width),
        q50: Vec::with_capacity(width),
        q95: Vec::with_capacity(width),
    };
    let mut column = vec![0.0; draws];
    for j in 0..width {
        for (k, x) in column.iter_mut().enumerate() {
            *x = rows[k * width + j];
        }
        column.sort_unstable_by(f64::total_cmp);
        b.t.push((j * every) as f64 * dt);
        b.q05.push(quantile(&column, 0.05));
        b.q50.push(quantile(&column, 0.5));
        b.q95.push(quantile(&column, 0.95));
    }
    b
}

/// A fit read back from its folder: the model and the pooled draws of its
/// chains.
#[derive(Debug, Clone)]
pub struct FitDraws {
    /// The fitted model.
    pub model: Model,
    /// The fit's seed.
    pub seed: u64,
    /// Every kept draw of every chain, chain by chain.
    pub draws: Vec<Draw>,
}

impl FitDraws {
    /// Reads `fit.json` and `chains/chain-*.csv` of a folder `hbis fit`
    /// wrote (built-in components only).
    pub fn read(dir: &Path) -> Result<Self, PredictError> {
        Self::read_with(dir, &Registry::builtin())
    }

    /// [`FitDraws::read`] with the model parsed by `registry` (a fit of a
    /// model with a user's components). Only the files the folder's
    /// manifest lists are read, each checked against its size and SHA-256
    /// ([`crate::report::verify`]).
    pub fn read_with(dir: &Path, registry: &Registry) -> Result<Self, PredictError> {
        let listed = read_manifest(dir)?;
        Self::read_listed(dir, registry, &listed.files)
    }

    /// [`FitDraws::read_with`] from the files `files` lists (names relative
    /// to `dir`, as a run in progress has written them), each checked.
    pub fn read_listed(
        dir: &Path,
        registry: &Registry,
        files: &[FileEntry],
    ) -> Result<Self, PredictError> {
        check_files(dir, files)?;
        let fit_path = dir.join("fit.json");
        let bad = |problem: String| PredictError::Fit {
            path: fit_path.display().to_string(),
            problem,
        };
        if !files.iter().any(|f| f.name == "fit.json") {
            return Err(bad(
                "not listed in the run's manifest (not a fit folder?)".into()
            ));
        }
        let text = read(&fit_path)?;
        let json: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
        let spec = json["model"]
            .as_str()
            .ok_or_else(|| bad("no `model` string".into()))?;
        let model = registry.parse(spec).map_err(|e| {
            bad(format!(
                "model `{spec}`: {e} (an effect file's component needs --effects FILE)"
            ))
        })?;
        let seed = json["seed"]
            .as_u64()
            .ok_or_else(|| bad("no `seed` integer".into()))?;
        let chains = listed_chains(dir, files)?;
        let mut draws = Vec::new();
        for (chain, name) in chains {
            read_chain(&dir.join(name), chain, &model, &mut draws)?;
        }
        if draws.is_empty() {
            return Err(bad(format!(
                "no posterior draws beside it ({} missing: was the fit run with --map-only?)",
                dir.join("chains").join("chain-1.csv").display()
            )));
        }
        Ok(Self { model, seed, draws })
    }

    /// `n` draws evenly spaced through the pooled chains (all of them when
    /// there are fewer).
    pub fn thinned(&self, n: usize) -> Vec<Draw> {
        let total = self.draws.len();
        if n >= total {
            return self.draws.clone();
        }
        (0..n).map(|i| self.draws[i * total / n].clone()).collect()
    }
}

/// The chain files the manifest lists, by chain number. A chain file in
/// the folder that the manifest does not list belongs to another run and
/// is refused rather than skipped: the folder is not what its run wrote.
fn listed_chains<'a>(
    dir: &Path,
    files: &'a [FileEntry],
) -> Result<Vec<(usize, &'a str)>, PredictError> {
    let number = |name: &str| -> Option<usize> {
        name.strip_prefix("chains/chain-")?
            .strip_suffix(".csv")?
            .parse()
            .ok()
    };
    let mut chains: Vec<(usize, &str)> = files
        .iter()
        .filter_map(|f| Some((number(&f.name)?, f.name.as_str())))
        .collect();
    chains.sort_unstable();
    if let Ok(entries) = std::fs::read_dir(dir.join("chains")) {
        for e in entries.flatten() {
            let name = format!("chains/{}", e.file_name().to_string_lossy());
            if number(&name).is_some() && !chains.iter().any(|(_, n)| *n == name) {
                return Err(PredictError::Folder(VerifyError::Changed {
                    path: dir.join(&name).display().to_string(),
                    problem: "a chain the run's manifest does not list (left by another run?)"
                        .into(),
                }));
            }
        }
    }
    Ok(chains)
}

fn read(path: &Path) -> Result<String, PredictError> {
    std::fs::read_to_string(path).map_err(|source| PredictError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Appends the draws of one CmdStan-style chain file.
fn read_chain(
    path: &Path,
    chain: usize,
    model: &Model,
    out: &mut Vec<Draw>,
) -> Result<(), PredictError> {
    let text = read(path)?;
    let err = |line: usize, problem: String| PredictError::Chain {
        path: path.display().to_string(),
        line,
        problem,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.starts_with('#') && !l.trim().is_empty());
    let (hl, header) = lines.next().ok_or_else(|| err(1, "no header row".into()))?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |name: &str| cols.iter().position(|c| *c == name);
    let idx: Vec<usize> = model
        .param_names()
        .iter()
        .map(|p| find(p).ok_or_else(|| err(hl + 1, format!("no column `{p}`"))))
        .collect::<Result<_, _>>()?;
    let mass = find("m");
    for (row, (ln, line)) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let value = |k: usize| -> Result<f64, PredictError> {
            let s = fields.get(k).ok_or_else(|| {
                err(
                    ln + 1,
                    format!("{} fields, expected {}", fields.len(), cols.len()),
                )
            })?;
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    err(
                        ln + 1,
                        format!("column `{}`: `{s}` is not a finite number", cols[k]),
                    )
                })
        };
        let theta = idx.iter().map(|&k| value(k)).collect::<Result<_, _>>()?;
        let mass = mass.map(value).transpose()?;
        out.push(Draw {
            theta,
            mass,
            origin: Some((chain, row + 1)),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Params;

    fn shake(pga: f64) -> Vec<f64> {
        let kt = crate::data::ground_motion::KanaiTajimi {
            pga,
            duration: 15.0,
            ..Default::default()
        };
        kt.generate(3).unwrap().ag
    }

    /// A release from below `u3` never reaches plastic phase 3; a strong
    /// motion does: the share and the sentence say so. A falling friction
    /// is floored and reported; a gentle motion warns of neither.
    #[test]
    fn extrapolation_is_measured_and_reported() {
        let model = Registry::builtin().parse("trilinear+lcfm+viscous").unwrap();
        let mut p = Params::table_8_1(5).unwrap();
        p.u0 = 0.04; // below u3 = 0.0825
        p.rf0 = -0.05; // amplitude zero at |u| = 0.0468 m
        let theta = model.theta_from_params(&p, &[]).unwrap();
        let draws = vec![Draw::new(theta.clone()), Draw::new(theta)];
        let opts = PredictOptions::default();
        let strong = predict(&model, &draws, 0.01, &shake(5.0), &opts).unwrap();
        let x = &strong.extrapolation;
        assert_eq!(x.deepest_branch, 3, "{x:?}");
        assert_eq!(x.share_new_branch, 1.0);
        assert_eq!(x.share_friction_floored, 1.0);
        assert!(x.share_beyond_release == 1.0 && x.median_ratio_to_release > 1.0);
        let text = strong.warnings.join("\n");
        assert!(
            text.contains("100.0 % of the draws drive the spring onto an envelope branch"),
            "{text}"
        );
        assert!(text.contains("floored at zero"), "{text}");
        let gentle = predict(&model, &draws, 0.01, &shake(0.2), &opts).unwrap();
        let y = &gentle.extrapolation;
        assert!(
            y.share_new_branch == 0.0 && y.share_friction_floored == 0.0,
            "{y:?}"
        );
        assert!(gentle
            .warnings
            .iter()
            .all(|w| !w.contains("envelope branch")));
    }

    #[test]
    fn capacity_and_mass_are_applied_per_draw() {
        let model = Registry::builtin().parse("bilinear+coulomb").unwrap();
        let p = Params::table_8_1(5).unwrap();
        let theta = model.theta_from_params(&p, &[]).unwrap();
        let mut a = Draw::new(theta.clone());
        a.mass = Some(1000.0);
        let mut b = Draw::new(theta);
        b.mass = Some(2000.0);
        let ag = shake(3.0);
        let one = predict(&model, &[a.clone()], 0.01, &ag, &PredictOptions::default()).unwrap();
        let peak = one.summary.peak_displacement.mean;
        let opts = PredictOptions {
            capacity: Some(peak * 0.999),
            ..Default::default()
        };
        let two = predict(&model, &[a, b], 0.01, &ag, &opts).unwrap();
        assert_eq!(two.p_exceed_capacity, Some(1.0));
        let kn = two.summary.peak_base_shear_kn.unwrap();
        let shear = two.summary.peak_base_shear.mean;
        assert!((kn.mean - 1500.0 * shear).abs() < 1e-9 * kn.mean);
        assert!(predict(&model, &[], 0.01, &ag, &opts).is_err());
    }

    #[test]
    fn a_mass_or_capacity_that_is_not_positive_is_refused_naming_it() {
        let model = Registry::builtin().parse("trilinear+lcfm+viscous").unwrap();
        let p = Params::table_8_1(5).unwrap();
        let theta = model.theta_from_params(&p, &[]).unwrap();
        let ag = shake(1.0);
        let mut draws = vec![Draw::new(theta); 2];
        draws[0].mass = Some(5.0);
        draws[1].mass = Some(-1.0);
        let err = predict(&model, &draws, 0.01, &ag, &PredictOptions::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "draw 1: mass -1: expected a finite number > 0"
        );
        draws[1].mass = Some(5.0);
        let opts = PredictOptions {
            capacity: Some(f64::NAN),
            ..Default::default()
        };
        let err = predict(&model, &draws, 0.01, &ag, &opts).unwrap_err();
        assert_eq!(
            err.to_string(),
            "capacity NaN: expected a finite number > 0"
        );
        assert!(predict(&model, &draws, 0.01, &ag, &PredictOptions::default()).is_ok());
    }

    #[test]
    fn a_cancelled_prediction_ends_with_cancelled() {
        let model = Registry::builtin().parse("trilinear+lcfm+viscous").unwrap();
        let p = Params::table_8_1(5).unwrap();
        let theta = model.theta_from_params(&p, &[]).unwrap();
        let ag = shake(3.0);
        let cancel = Cancel::new();
        let opts = PredictOptions {
            cancel: Some(cancel.clone()),
            ..Default::default()
        };
        let draws = vec![Draw::new(theta); 4];
        assert!(predict(&model, &draws, 0.01, &ag, &opts).is_ok());
        cancel.cancel();
        let err = predict(&model, &draws, 0.01, &ag, &opts).unwrap_err();
        assert!(matches!(err, PredictError::Cancelled(_)), "{err}");
    }
}
