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
use crate::data::ground_motion::GroundMotion;
use crate::inference::proportion::{self, Clustered};
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

/// How far the draws went beyond what the release test identified (shares
/// of the draw-motion pairs; of the draws for one motion).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Extrapolation {
    /// Share of pairs whose peak displacement exceeds their release
    /// displacement `u0` (the largest amplitude the record showed).
    pub share_beyond_release: f64,
    /// Largest ratio of peak displacement to `u0` over the pairs.
    pub max_ratio_to_release: f64,
    /// Median of that ratio.
    pub median_ratio_to_release: f64,
    /// Share of pairs whose response entered an envelope branch (plastic
    /// phase) deeper than any their release test reached (its free
    /// vibration from `u0`, simulated for each draw).
    pub share_new_branch: f64,
    /// The deepest envelope branch any pair entered (0 elastic, 1-3 the
    /// paper's plastic phases).
    pub deepest_branch: u8,
    /// Share of pairs whose friction amplitude `F_F0 + k_F |u|` fell to
    /// zero (floored there).
    pub share_friction_floored: f64,
    /// Share of pairs still moving at the end of the tail (last speed above
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
    /// The summaries, over the pairs.
    pub summary: Summary,
    /// Share of pairs whose peak displacement exceeds the capacity.
    pub p_exceed_capacity: Option<f64>,
    /// That share with its 95 % interval, the motions taken as clusters.
    pub exceedance: Option<Clustered>,
    /// Per pair, in the order of `pairs`.
    pub outcomes: Vec<DrawOutcome>,
    /// The draw and motion of each outcome ([`pairs`]); with one motion,
    /// the draws in the order given.
    pub pairs: Vec<Pair>,
    /// Beyond the identified range.
    pub extrapolation: Extrapolation,
    /// Sentences backed by the numbers above, for the reader.
    pub warnings: Vec<String>,
    /// The displacement band, when asked for.
    pub band: Option<Band>,
}

/// Records `u` into the band's row: the first sample at or after each
/// grid time `j every dt_ref` (the motions of a suite may have their own
/// steps).
struct Decimated<'a> {
    /// Grid bins per sample, `dt / (every dt_ref)`.
    per_sample: f64,
    last: Option<usize>,
    row: &'a mut [f64],
}

impl ForcedSink for Decimated<'_> {
    #[inline]
    fn sample(&mut self, i: usize, u: f64, _: f64, _: f64) {
        if self.row.is_empty() {
            return;
        }
        // The nudge keeps `i = j every` in bin j despite rounding.
        let j = (i as f64 * self.per_sample + 1e-9).floor() as usize;
        if self.last != Some(j) {
            self.last = Some(j);
            if let Some(x) = self.row.get_mut(j) {
                *x = u;
            }
        }
    }
}

/// Carries each value forward over the bins no sample reached (a coarser
/// motion's, or a shorter motion's after it came to rest).
fn fill_forward(row: &mut [f64]) {
    let mut last = 0.0;
    for x in row {
        if x.is_nan() {
            *x = last;
        } else {
            last = *x;
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
/// on the number of threads). [`predict_suite`] with one motion.
pub fn predict(
    model: &Model,
    draws: &[Draw],
    dt: f64,
    ag: &[f64],
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    predict_suite(model, draws, &[(dt, ag)], opts)
}

/// One simulated pair: a draw under a motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Pair {
    /// Index of the draw.
    pub draw: usize,
    /// Index of the motion.
    pub motion: usize,
}

/// The pairs simulated for `draws` draws and `motions` motions: as many as
/// the larger of the two, pair `k` taking draw `k mod draws` and motion
/// `k mod motions`, so every draw and every motion is used and each motion
/// meets draws from all through the chains.
///
/// ```
/// use hbis::predict::{pairs, Pair};
/// let p = pairs(5, 2);
/// assert_eq!(p.len(), 5);
/// assert_eq!(p[3], Pair { draw: 3, motion: 1 });
/// assert_eq!(pairs(2, 3)[2], Pair { draw: 0, motion: 2 });
/// ```
pub fn pairs(draws: usize, motions: usize) -> Vec<Pair> {
    if draws == 0 || motions == 0 {
        return Vec::new();
    }
    (0..draws.max(motions))
        .map(|k| Pair {
            draw: k % draws,
            motion: k % motions,
        })
        .collect()
}

/// The posterior predictive response over a suite of ground motions
/// `(dt, ag)`: the draws paired with the motions ([`pairs`]), each pair
/// simulated from rest, and the design quantities summarised over the
/// pairs, so they carry both the posterior's uncertainty and the
/// record-to-record variability. The band's time grid is the longest
/// motion's; a shorter motion's response is held at its last value.
pub fn predict_suite(
    model: &Model,
    draws: &[Draw],
    motions: &[(f64, &[f64])],
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    check_inputs(draws, motions, opts)?;
    let ex: Vec<Excitation> = motions
        .iter()
        .enumerate()
        .map(|(j, &(dt, ag))| {
            Excitation::new(dt, ag, opts.tail).map_err(|e| {
                let which = match motions.len() {
                    1 => String::new(),
                    _ => format!(" {}", j + 1),
                };
                PredictError::Invalid(format!("the ground motion{which}: {e}"))
            })
        })
        .collect::<Result<_, _>>()?;
    let pairs = pairs(draws.len(), motions.len());
    let grid = BandGrid::of(&ex, opts.band_points);
    let mut rows = vec![f64::NAN; grid.width * pairs.len()];
    let mut chunks: Vec<&mut [f64]> = rows.chunks_mut(grid.width.max(1)).collect();
    chunks.resize_with(pairs.len(), Default::default);
    let results: Vec<Result<(DrawOutcome, bool), PredictError>> = pairs
        .par_iter()
        .zip(chunks)
        .map(|(pair, row)| {
            if let Some(c) = &opts.cancel {
                c.check()?;
            }
            let (d, e) = (&draws[pair.draw], &ex[pair.motion]);
            let band = Decimated {
                per_sample: e.dt() / grid.step,
                last: None,
                row,
            };
            let mut sink = (band, Speeds::default());
            let peaks =
                model
                    .forced(&d.theta, e, &mut sink)
                    .map_err(|source| PredictError::Draw {
                        draw: pair.draw,
                        source,
                    })?;
            fill_forward(sink.0.row);
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
    let mut outcomes = Vec::with_capacity(pairs.len());
    let mut moving = 0usize;
    for r in results {
        let (o, m) = r?;
        outcomes.push(o);
        moving += usize::from(m);
    }
    let summary = summarise(&outcomes);
    let peak_u: Vec<f64> = outcomes.iter().map(|o| o.peaks.peak_displacement).collect();
    let exceedance = opts
        .capacity
        .map(|c| exceedance(&pairs, &peak_u, motions.len(), c));
    let extrapolation = extrapolation(model, draws, &pairs, &outcomes, moving);
    let pga = motions
        .iter()
        .flat_map(|m| m.1)
        .fold(0.0f64, |m, a| m.max(a.abs()));
    // With a suite the shares are of (draw, motion) pairs.
    let of = if motions.len() == 1 {
        "the draws"
    } else {
        "the draw-motion pairs"
    };
    let warnings = warnings(&extrapolation, pga, of);
    let band = (grid.width > 0).then(|| band(&rows, grid.width, grid.step));
    Ok(Prediction {
        summary,
        p_exceed_capacity: exceedance.map(|e| e.p),
        exceedance,
        outcomes,
        pairs,
        extrapolation,
        warnings,
        band,
    })
}

fn check_inputs(
    draws: &[Draw],
    motions: &[(f64, &[f64])],
    opts: &PredictOptions,
) -> Result<(), PredictError> {
    if draws.is_empty() {
        return Err(PredictError::Invalid("no draws to simulate".into()));
    }
    if motions.is_empty() {
        return Err(PredictError::Invalid("no ground motion to simulate".into()));
    }
    if let Some(c) = opts.capacity {
        positive("capacity", c)?;
    }
    for (i, d) in draws.iter().enumerate() {
        if let Some(m) = d.mass {
            positive(&format!("draw {i}: mass"), m)?;
        }
    }
    Ok(())
}

/// The band's time grid: every `every`-th sample of the longest motion,
/// about `points` of them (`width` 0: no band).
struct BandGrid {
    step: f64,
    width: usize,
}

impl BandGrid {
    fn of(ex: &[Excitation], points: usize) -> Self {
        let span = |e: &Excitation| (e.len() - 1) as f64 * e.dt();
        let longest = ex
            .iter()
            .max_by(|a, b| span(a).total_cmp(&span(b)))
            .expect("at least one motion");
        let every = match points {
            0 => 1,
            p => longest.len().div_ceil(p).max(1),
        };
        Self {
            step: every as f64 * longest.dt(),
            width: match points {
                0 => 0,
                _ => longest.len().div_ceil(every),
            },
        }
    }
}

fn summarise(outcomes: &[DrawOutcome]) -> Summary {
    let col = |f: fn(&Peaks) -> f64| outcomes.iter().map(|o| f(&o.peaks)).collect::<Vec<_>>();
    let kn: Option<Vec<f64>> = outcomes.iter().map(|o| o.peak_base_shear_kn).collect();
    Summary {
        peak_displacement: Stats::of(&col(|p| p.peak_displacement)),
        residual_displacement: Stats::of(&col(|p| p.residual_displacement)),
        peak_base_shear: Stats::of(&col(|p| p.peak_base_shear)),
        peak_total_acceleration: Stats::of(&col(|p| p.peak_total_acceleration)),
        peak_base_shear_kn: kn.as_deref().map(Stats::of),
    }
}

/// The share of pairs beyond the capacity, with its interval: the pairs of
/// one motion share it, so the motions are the clusters
/// ([`proportion::clustered`]).
fn exceedance(pairs: &[Pair], peak_u: &[f64], motions: usize, capacity: f64) -> Clustered {
    let mut cl = vec![(0usize, 0usize); motions];
    for (p, u) in pairs.iter().zip(peak_u) {
        cl[p.motion].0 += usize::from(*u > capacity);
        cl[p.motion].1 += 1;
    }
    proportion::clustered(&cl, 0.95)
}

/// One point of a fragility curve (`predict.json`'s `fragility`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FragilityPoint {
    /// The peak ground acceleration every motion was scaled to (g).
    pub pga_g: f64,
    /// Share of pairs whose peak displacement exceeds the capacity.
    pub p_exceed: f64,
    /// Lower end of its 95 % interval (Korn-Graubard, the motions as
    /// clusters; [`proportion::clustered`]).
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// The effective number of independent pairs behind the interval.
    pub effective_pairs: f64,
    /// Pairs simulated.
    pub pairs: usize,
    /// The peak displacement over the pairs (m).
    pub peak_displacement: Stats,
}

/// Standard gravity (m/s^2), the `g` of `pga_g`.
pub const G: f64 = 9.80665;

/// The fragility curve of `capacity` (m): at each peak ground
/// acceleration of `pgas` (m/s^2) every motion is scaled to it and the
/// pairs simulated as in [`predict_suite`] (without a band).
pub fn fragility(
    model: &Model,
    draws: &[Draw],
    motions: &[GroundMotion],
    pgas: &[f64],
    capacity: f64,
    opts: &PredictOptions,
) -> Result<Vec<FragilityPoint>, PredictError> {
    let opts = PredictOptions {
        capacity: Some(capacity),
        band_points: 0,
        ..opts.clone()
    };
    pgas.iter()
        .map(|&pga| {
            let scaled: Vec<GroundMotion> = motions
                .iter()
                .map(|m| m.clone().scaled_to_pga(pga))
                .collect::<Result<_, _>>()
                .map_err(|e| PredictError::Invalid(e.to_string()))?;
            let suite: Vec<(f64, &[f64])> =
                scaled.iter().map(|m| (m.dt, m.ag.as_slice())).collect();
            fragility_point(pga, &predict_suite(model, draws, &suite, &opts)?)
        })
        .collect()
}

/// The fragility point of a prediction `p` made with every motion at the
/// peak ground acceleration `pga` (m/s^2) and a capacity.
pub fn fragility_point(pga: f64, p: &Prediction) -> Result<FragilityPoint, PredictError> {
    let e = p
        .exceedance
        .ok_or_else(|| PredictError::Invalid("a fragility point needs the capacity".into()))?;
    Ok(FragilityPoint {
        pga_g: pga / G,
        p_exceed: e.p,
        ci_low: e.low,
        ci_high: e.high,
        effective_pairs: e.effective_n,
        pairs: p.pairs.len(),
        peak_displacement: p.summary.peak_displacement,
    })
}

fn extrapolation(
    model: &Model,
    draws: &[Draw],
    pairs: &[Pair],
    outcomes: &[DrawOutcome],
    moving: usize,
) -> Extrapolation {
    let n = pairs.len() as f64;
    let u0 = model.param_names().iter().position(|p| p == "u0");
    let mut ratios: Vec<f64> = match u0 {
        Some(k) => pairs
            .iter()
            .zip(outcomes)
            .map(|(p, o)| o.peaks.peak_displacement / draws[p.draw].theta[k].abs())
            .collect(),
        None => Vec::new(),
    };
    ratios.sort_unstable_by(f64::total_cmp);
    let beyond = ratios.iter().filter(|&&r| r > 1.0).count() as f64;
    let floored = outcomes.iter().filter(|o| o.peaks.friction_floored).count() as f64;
    // Once per draw: a draw meets several motions.
    let deepest: Vec<Option<u8>> = draws
        .par_iter()
        .map(|d| release_deepest(model, &d.theta))
        .collect();
    let new_branch = pairs
        .iter()
        .zip(outcomes)
        .filter(|(p, o)| deepest[p.draw].is_some_and(|r| o.peaks.deepest_branch > r))
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
fn warnings(x: &Extrapolation, pga: f64, of: &str) -> Vec<String> {
    let mut w = Vec::new();
    if x.share_beyond_release > 0.0 {
        w.push(format!(
            "{:.1} % of {of} move the isolators beyond their release displacement u0, the largest amplitude \
             the release test identified (median peak/u0 {:.2}, largest {:.2}): the spring and friction laws are \
             extrapolated there",
            100.0 * x.share_beyond_release,
            x.median_ratio_to_release,
            x.max_ratio_to_release
        ));
    }
    if x.share_new_branch > 0.0 {
        w.push(format!(
            "{:.1} % of {of} drive the spring onto an envelope branch their release test never reached \
             (deepest: plastic phase {}): its slope there is the prior's and the other branches' guess, not measured",
            100.0 * x.share_new_branch,
            x.deepest_branch
        ));
    }
    if x.share_friction_floored > 0.0 {
        w.push(format!(
            "{:.1} % of {of} reach displacements where the friction amplitude (uF0 + rF0 |u|) k0 falls to zero \
             (rF0 < 0); it is floored at zero there",
            100.0 * x.share_friction_floored
        ));
    }
    if x.share_still_moving > 0.0 {
        w.push(format!(
            "{:.1} % of {of} are still moving at the end of the tail: the residual displacement is not final \
             (lengthen --tail)",
            100.0 * x.share_still_moving
        ));
    }
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

fn band(rows: &[f64], width: usize, step: f64) -> Band {
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
        b.t.push(j as f64 * step);
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

    fn suite(n: usize, duration: f64, dt: f64, seed: u64) -> Vec<GroundMotion> {
        let kt = crate::data::ground_motion::KanaiTajimi {
            pga: 3.0,
            duration,
            dt,
            ..Default::default()
        };
        kt.suite(n, seed).unwrap()
    }

    fn spread_draws(model: &Model, n: usize) -> Vec<Draw> {
        let p = Params::table_8_1(5).unwrap();
        (0..n)
            .map(|k| {
                let mut q = p;
                q.u0 *= 0.9 + 0.2 * k as f64 / n as f64;
                Draw::new(model.theta_from_params(&q, &[]).unwrap())
            })
            .collect()
    }

    /// Pair k is draw k mod D under motion k mod N, each pair simulated as
    /// that draw alone under that motion (motions of their own steps and
    /// lengths); the band's grid spans the longest motion and its tail.
    #[test]
    fn a_suite_pairs_draws_with_motions_each_as_if_alone() {
        let model = Registry::builtin().parse("trilinear+lcfm+viscous").unwrap();
        let draws = spread_draws(&model, 3);
        let (a, b) = (&suite(1, 15.0, 0.01, 1)[0], &suite(1, 10.0, 0.005, 2)[0]);
        let motions = [(a.dt, a.ag.as_slice()), (b.dt, b.ag.as_slice())];
        let opts = PredictOptions {
            band_points: 300,
            ..Default::default()
        };
        let s = predict_suite(&model, &draws, &motions, &opts).unwrap();
        let drawn: Vec<(usize, usize)> = s.pairs.iter().map(|p| (p.draw, p.motion)).collect();
        assert_eq!(drawn, [(0, 0), (1, 1), (2, 0)]);
        for (pair, o) in s.pairs.iter().zip(&s.outcomes) {
            let (dt, ag) = motions[pair.motion];
            let alone = predict(&model, &[draws[pair.draw].clone()], dt, ag, &opts).unwrap();
            assert_eq!(alone.outcomes[0], *o, "{pair:?}");
        }
        let band = s.band.unwrap();
        let end = 15.0 + opts.tail;
        let step = band.t[1] - band.t[0];
        let last = *band.t.last().unwrap();
        assert!(last <= end + 1e-9 && last > end - step, "{last} vs {end}");
        assert!(band.q05.iter().chain(&band.q95).all(|x| x.is_finite()));
    }

    /// The band keeps the first sample in each bin of its grid and holds
    /// the last value over bins no sample reached.
    #[test]
    fn the_band_grid_takes_each_bins_first_sample_and_holds_the_last() {
        let fill = |per_sample: f64, n: usize, width: usize| {
            let mut row = vec![f64::NAN; width];
            let mut d = Decimated {
                per_sample,
                last: None,
                row: &mut row,
            };
            for i in 0..n {
                d.sample(i, i as f64, 0.0, 0.0);
            }
            fill_forward(&mut row);
            row
        };
        // A finer motion (step half the grid's), ending early.
        assert_eq!(fill(0.5, 7, 6), [0.0, 2.0, 4.0, 6.0, 6.0, 6.0]);
        // A coarser one (twice the grid's step).
        assert_eq!(fill(2.0, 3, 6), [0.0, 0.0, 1.0, 1.0, 2.0, 2.0]);
        // The grid's own motion, every third sample: 1/3 rounds below.
        assert_eq!(fill(1.0 / 3.0, 10, 4), [0.0, 3.0, 6.0, 9.0]);
    }

    /// Every motion is scaled to each level and the pairs beyond the
    /// capacity are counted: checked against the pairs simulated one by
    /// one, the interval against the motions as clusters.
    #[test]
    fn fragility_counts_the_pairs_beyond_the_capacity_at_each_level() {
        let model = Registry::builtin().parse("bilinear+coulomb").unwrap();
        let draws = spread_draws(&model, 4);
        let motions = suite(3, 15.0, 0.01, 11);
        let pgas = [1.5, 4.0];
        let capacity = 0.08;
        let opts = PredictOptions::default();
        let f = fragility(&model, &draws, &motions, &pgas, capacity, &opts).unwrap();
        assert_eq!(f.len(), 2);
        for (point, &pga) in f.iter().zip(&pgas) {
            let mut cl = vec![(0usize, 0usize); motions.len()];
            for pair in pairs(draws.len(), motions.len()) {
                let m = &motions[pair.motion];
                let ag: Vec<f64> = m.ag.iter().map(|a| a * pga / m.pga()).collect();
                let ex = Excitation::new(m.dt, &ag, opts.tail).unwrap();
                let peak = model
                    .forced(&draws[pair.draw].theta, &ex, &mut ())
                    .unwrap()
                    .peak_displacement;
                cl[pair.motion].0 += usize::from(peak > capacity);
                cl[pair.motion].1 += 1;
            }
            let want = proportion::clustered(&cl, 0.95);
            assert_eq!(point.pairs, 4);
            assert!((point.pga_g - pga / G).abs() < 1e-15);
            assert_eq!(
                (point.p_exceed, point.ci_low, point.ci_high),
                (want.p, want.low, want.high),
                "{point:?}"
            );
        }
        assert!(f[0].p_exceed < f[1].p_exceed, "{f:?}");
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
