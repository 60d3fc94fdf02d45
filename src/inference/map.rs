//! The maximum a posteriori estimate: bounded CMA-ES with IPOP restarts,
//! then a Nelder-Mead polish.
//!
//! CMA-ES searches the unit box that the priors' supports map onto linearly,
//! so every parameter has the same initial step (`sigma0 = 0.3` of its
//! range) whatever its unit. Each run starts from a uniform draw over the
//! supports: the identification landscape is multimodal (a tri-linear
//! spring whose `u3` lies beyond the largest amplitude is a flat basin;
//! model-notes.md), and restarts from new points with doubled populations
//! (IPOP), interleaved with small runs of random size and step (BIPOP),
//! escape it. The restart sequence ends when the budget is spent, all
//! restarts are used, or two runs have reached the same best value (within
//! `repeat_tol` in log-posterior units): the best basin has then been found
//! twice from independent starts.

use std::time::Instant;

use rand::{Rng, RngExt};
use thiserror::Error;

use super::bounds::BoxTransform;
use super::cmaes::{Cmaes, CmaesError, RunSummary, Start};
use super::polish::{Polish, PolishError};
use super::posterior::{Evaluation, Posterior, PosteriorError};
use crate::cancel::{Cancel, Cancelled};
use crate::model::ForwardModel;

/// Why the MAP search failed.
#[derive(Debug, Error)]
pub enum MapError {
    /// A setting is out of range.
    #[error("MAP setting `{name}`: {reason}")]
    Setting {
        name: &'static str,
        reason: &'static str,
    },
    /// CMA-ES failed.
    #[error("CMA-ES")]
    Cmaes(#[from] CmaesError),
    /// The polish failed.
    #[error("polish")]
    Polish(#[from] PolishError),
    /// The posterior failed (NaN).
    #[error("posterior")]
    Posterior(#[from] PosteriorError),
    /// No point with positive posterior density was found.
    #[error(
        "no parameter set with positive posterior density was found in {evaluations} evaluations"
    )]
    NothingFeasible { evaluations: usize },
    /// The search was cancelled ([`MapSettings::with_cancel`]).
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Settings of the MAP search.
#[derive(Debug, Clone)]
pub struct MapSettings {
    max_evals: usize,
    restarts: usize,
    min_runs: usize,
    repeat_tol: f64,
    tol_fun: f64,
    max_generations: usize,
    parallel: bool,
    polish: Option<Polish>,
    initial: Option<Vec<f64>>,
    cancel: Option<Cancel>,
}

impl Default for MapSettings {
    fn default() -> Self {
        Self {
            max_evals: 200_000,
            restarts: 19,
            min_runs: 3,
            repeat_tol: 0.05,
            tol_fun: 1e-3,
            max_generations: 1000,
            parallel: true,
            polish: Some(Polish::default()),
            initial: None,
            cancel: None,
        }
    }
}

impl MapSettings {
    /// Total CMA-ES evaluation budget (default 200,000).
    pub fn with_max_evals(mut self, n: usize) -> Result<Self, MapError> {
        if n < 100 {
            return Err(MapError::Setting {
                name: "max_evals",
                reason: "must be at least 100",
            });
        }
        self.max_evals = n;
        Ok(self)
    }

    /// The total CMA-ES evaluation budget.
    pub fn max_evals(&self) -> usize {
        self.max_evals
    }

    /// Most IPOP restarts after the first run (default 19).
    pub fn with_restarts(mut self, n: usize) -> Result<Self, MapError> {
        self.restarts = n;
        Ok(self)
    }

    /// Fewest large (IPOP) runs before the repeat rule may stop the
    /// sequence (default 3).
    pub fn with_min_runs(mut self, n: usize) -> Result<Self, MapError> {
        if n == 0 {
            return Err(MapError::Setting {
                name: "min_runs",
                reason: "must be at least 1",
            });
        }
        self.min_runs = n;
        Ok(self)
    }

    /// Two runs whose best log-posteriors differ by less than this found the
    /// same basin (default 0.05).
    pub fn with_repeat_tol(mut self, tol: f64) -> Result<Self, MapError> {
        if tol.is_nan() || tol < 0.0 {
            return Err(MapError::Setting {
                name: "repeat_tol",
                reason: "must be >= 0",
            });
        }
        self.repeat_tol = tol;
        Ok(self)
    }

    /// Evaluate populations in parallel (default true; results do not
    /// depend on it).
    pub fn with_parallel(mut self, parallel: bool) -> Result<Self, MapError> {
        self.parallel = parallel;
        Ok(self)
    }

    /// Start the first CMA-ES run from this point (e.g. the MAP of a nested
    /// model) instead of a uniform draw; later runs draw as usual.
    pub fn with_initial(mut self, theta: Option<Vec<f64>>) -> Result<Self, MapError> {
        if theta
            .as_ref()
            .is_some_and(|t| t.iter().any(|v| !v.is_finite()))
        {
            return Err(MapError::Setting {
                name: "initial",
                reason: "must be finite",
            });
        }
        self.initial = theta;
        Ok(self)
    }

    /// The polish to run after CMA-ES, or none.
    pub fn with_polish(mut self, polish: Option<Polish>) -> Result<Self, MapError> {
        self.polish = polish;
        Ok(self)
    }

    /// Stop with [`MapError::Cancelled`] at the next CMA-ES generation once
    /// `cancel` is cancelled; every search run with these settings (a fit's,
    /// each refit of a diagnosis or ladder) checks it.
    pub fn with_cancel(mut self, cancel: Option<Cancel>) -> Result<Self, MapError> {
        self.cancel = cancel;
        Ok(self)
    }

    /// The token given to [`MapSettings::with_cancel`], if any.
    pub fn cancel(&self) -> Option<&Cancel> {
        self.cancel.as_ref()
    }
}

/// The polish step in numbers (written as `polish` in `fit.json`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct PolishReport {
    /// Minus log-posterior before and after.
    pub objective_before: f64,
    /// Minus log-posterior after.
    pub objective_after: f64,
    /// `e2` before.
    pub e2_before: f64,
    /// `e2` after.
    pub e2_after: f64,
    /// Simplex iterations.
    pub iterations: u64,
    /// Cost evaluations.
    pub evaluations: u64,
    /// Why it stopped.
    pub termination: String,
}

/// The MAP estimate and how it was found.
#[derive(Debug, Clone)]
pub struct MapEstimate {
    /// Parameter names.
    pub names: Vec<String>,
    /// The MAP point.
    pub theta: Vec<f64>,
    /// The posterior there.
    pub eval: Evaluation,
    /// CMA-ES evaluations.
    pub cmaes_evaluations: usize,
    /// The CMA-ES runs (first, then restarts).
    pub runs: Vec<RunSummary>,
    /// Where each run ended (the log-posterior's coordinates, before the
    /// polish): ends apart with a fall of the log-posterior between them
    /// are separate basins ([`crate::inference::basins`]).
    pub ends: Vec<RunEnd>,
    /// The polish, if run.
    pub polish: Option<PolishReport>,
    /// Evaluations of the stages that prepared this search (the white-noise
    /// MAP that starts an AR(1) search, the placement of a release between
    /// samples); 0 from [`find_map`] alone.
    pub preparation_evaluations: u64,
    /// Wall time (s), preparation included.
    pub wall_time: f64,
    /// Whether the global search reached its best value twice (within
    /// [`SAME_BASIN`]), by two runs or by a run and its warm start: the
    /// best basin was found twice from independent starts
    /// ([`found_twice`]). `None` for a search of one run by design (no
    /// restarts: a local search from a warm start).
    pub best_repeated: Option<bool>,
}

/// Where one CMA-ES run ended.
#[derive(Debug, Clone, PartialEq)]
pub struct RunEnd {
    /// Its best point.
    pub theta: Vec<f64>,
    /// The log-posterior there.
    pub log_posterior: f64,
}

impl MapEstimate {
    /// Whether the search stopped because its evaluation budget was spent
    /// (its last CMA-ES run ended at `max_evals`) rather than by
    /// converging: the point may not be the best the model can reach.
    pub fn at_budget(&self) -> bool {
        self.runs
            .last()
            .is_some_and(|r| r.stop == super::cmaes::StopReason::MaxEvals)
    }

    /// All posterior evaluations: preparation, CMA-ES and polish.
    pub fn evaluations(&self) -> u64 {
        self.preparation_evaluations
            + self.cmaes_evaluations as u64
            + self.polish.as_ref().map_or(0, |p| p.evaluations)
    }
}

/// Finds the MAP of `posterior`, drawing every random number from `rng`.
pub fn find_map<M, R>(
    posterior: &Posterior<M>,
    settings: &MapSettings,
    rng: &mut R,
) -> Result<MapEstimate, MapError>
where
    M: ForwardModel + Clone,
    R: Rng + ?Sized,
{
    let clock = Instant::now();
    let d = posterior.dim();
    let (lo, hi) = posterior.priors().box_bounds();
    // Scale parameters whose support spans two decades or more are searched on
    // a log scale: the MAP does not depend on the search coordinates, but
    // CMA-ES's uniform starts then spread evenly over orders of magnitude
    // instead of crowding the top decade (where, e.g., a `u3` beyond the
    // largest amplitude is a flat basin).
    let log_scale: Vec<bool> = (0..d).map(|i| log_scaled(lo[i], hi[i])).collect();
    let to_theta = |u: &[f64]| -> Vec<f64> {
        (0..d)
            .map(|i| {
                if log_scale[i] {
                    (lo[i] * (hi[i] / lo[i]).powf(u[i])).clamp(lo[i], hi[i])
                } else {
                    lo[i] + u[i] * (hi[i] - lo[i])
                }
            })
            .collect()
    };
    let to_unit = |theta: &[f64]| -> Vec<f64> {
        (0..d)
            .map(|i| {
                let t = theta[i].clamp(lo[i], hi[i]);
                if log_scale[i] {
                    (t / lo[i]).ln() / (hi[i] / lo[i]).ln()
                } else {
                    (t - lo[i]) / (hi[i] - lo[i])
                }
            })
            .collect()
    };
    let objective = |u: &[f64]| match posterior.log_posterior(&to_theta(u)) {
        Ok(lp) => -lp,
        Err(_) => f64::NAN,
    };
    let unit = BoxTransform::new(vec![0.0; d], vec![1.0; d]).expect("the unit box is valid");
    let start = Start::Uniform {
        lower: vec![0.0; d],
        upper: vec![1.0; d],
    };
    let mut best_u: Vec<f64> = Vec::new();
    let mut best_f = f64::INFINITY;
    let mut runs: Vec<RunSummary> = Vec::new();
    let mut ends: Vec<RunEnd> = Vec::new();
    let mut evaluations = 0;
    // Runs that reached the best value so far (within `repeat_tol`).
    let mut hits = 0;
    // The warm start's log-posterior: it came from a search of its own
    // (e.g. the white-noise MAP that starts an AR(1) search), so reaching
    // it again counts towards `best_repeated`.
    let mut start_lp = None;
    let base = 4 + (3.0 * (d as f64).ln()).floor() as usize;
    let (mut large_runs, mut large_evals, mut small_evals) = (0usize, 0usize, 0usize);
    for _ in 0..=settings.restarts {
        if evaluations >= settings.max_evals {
            break;
        }
        // BIPOP (Hansen 2009): large runs double the population (IPOP);
        // between them, while they have used less than the large runs,
        // small runs with a random population between the default and the
        // last large one and a step size down to 1 % of sigma0 probe for
        // narrow basins. One run at a time, so the repeat rule can stop the
        // sequence between runs.
        let small = large_runs > 0 && small_evals < large_evals;
        let (popsize, sigma0) = if small {
            let u: f64 = rng.random();
            let largest = (base << (large_runs - 1).min(20)) as f64;
            let pop = (base as f64 * (largest / base as f64).powf(u * u)).floor() as usize;
            (pop.max(base), 0.3 * 10f64.powf(-2.0 * rng.random::<f64>()))
        } else {
            (base << large_runs.min(20), 0.3)
        };
        let warm = settings.initial.is_some() && runs.is_empty();
        // A warm start is already near an optimum: a small step keeps the
        // first run in its basin.
        let sigma0 = if warm { 0.02 } else { sigma0 };
        let cmaes = Cmaes::new(sigma0)?
            .with_bounds(unit.clone())?
            .with_popsize(popsize)?
            .with_max_evals(settings.max_evals - evaluations)?
            .with_tol_fun(settings.tol_fun)?
            .with_max_generations(settings.max_generations)?
            .with_parallel(settings.parallel)?
            .with_cancel(settings.cancel.clone())?;
        let first = match (&settings.initial, warm) {
            (Some(theta), true) if theta.len() == d => {
                // The start itself is a candidate: CMA-ES never evaluates its mean.
                let u = to_unit(theta);
                let f = objective(&u);
                if f < best_f {
                    best_f = f;
                    best_u = u.clone();
                }
                start_lp = Some(-f);
                Some(Start::Point(u))
            }
            _ => None,
        };
        let result = cmaes
            .minimize(objective, first.as_ref().unwrap_or(&start), rng)
            .map_err(|e| match e {
                CmaesError::NaN { x } => MapError::Posterior(PosteriorError::NaN {
                    theta: to_theta(&x),
                }),
                CmaesError::Cancelled(c) => MapError::Cancelled(c),
                other => MapError::Cmaes(other),
            })?;
        evaluations += result.evaluations;
        if small {
            small_evals += result.evaluations;
        } else {
            large_evals += result.evaluations;
            large_runs += 1;
        }
        runs.push(result.runs[0].clone());
        ends.push(RunEnd {
            theta: to_theta(&result.x),
            log_posterior: -result.f,
        });
        if result.f < best_f - settings.repeat_tol {
            hits = 1;
        } else if (result.f - best_f).abs() <= settings.repeat_tol {
            hits += 1;
        }
        if result.f < best_f {
            best_f = result.f;
            best_u = result.x;
        }
        if hits >= 2 && large_runs >= settings.min_runs {
            break;
        }
    }
    if !best_f.is_finite() {
        return Err(MapError::NothingFeasible { evaluations });
    }
    let best_repeated = (settings.restarts > 0).then(|| found_twice(&ends, start_lp));
    let mut theta = to_theta(&best_u);
    let before = posterior.evaluate(&theta)?;
    let mut eval = before;
    let mut polish_report = None;
    if let Some(c) = &settings.cancel {
        c.check()?;
    }
    if let Some(polish) = &settings.polish {
        let scale: Vec<f64> = (0..d).map(|i| hi[i] - lo[i]).collect();
        let out = polish.run(posterior.clone(), &theta, &scale)?;
        theta = out.x;
        eval = posterior.evaluate(&theta)?;
        polish_report = Some(PolishReport {
            objective_before: out.cost_before,
            objective_after: out.cost_after,
            e2_before: before.e2,
            e2_after: eval.e2,
            iterations: out.iterations,
            evaluations: out.evaluations,
            termination: out.termination,
        });
    }
    Ok(MapEstimate {
        names: posterior.names().to_vec(),
        theta,
        eval,
        cmaes_evaluations: evaluations,
        runs,
        ends,
        polish: polish_report,
        preparation_evaluations: 0,
        wall_time: clock.elapsed().as_secs_f64(),
        best_repeated,
    })
}

/// Whether a parameter with support `(lo, hi)` is searched on a log
/// scale: a positive lower bound and two decades or more.
pub fn log_scaled(lo: f64, hi: f64) -> bool {
    lo > 0.0 && hi >= 100.0 * lo
}

/// Two runs ended within this (nats of log-posterior) are taken as the
/// same basin by [`MapEstimate::best_repeated`]: runs in one basin end
/// apart by a fraction of a nat on the likelihood's staircase (the
/// reversals' sample instants), which `repeat_tol` (0.05) does not
/// forgive, and criticism calls refits within one nat agreeing.
pub const SAME_BASIN: f64 = 1.0;

/// Whether at least two of the runs' `ends`, or a run and the warm
/// start (log-posterior `start_lp`), came within [`SAME_BASIN`] of the
/// best of them.
///
/// ```
/// use hbis::inference::map::{found_twice, RunEnd};
/// let end = |lp| RunEnd { theta: vec![], log_posterior: lp };
/// assert!(found_twice(&[end(10.0), end(9.5), end(3.0)], None));
/// assert!(!found_twice(&[end(10.0), end(8.0)], None));
/// // A run that came back to the warm start.
/// assert!(found_twice(&[end(9.9), end(4.0)], Some(10.0)));
/// assert!(!found_twice(&[end(7.0), end(4.0)], Some(10.0)));
/// ```
pub fn found_twice(ends: &[RunEnd], start_lp: Option<f64>) -> bool {
    let values = ends.iter().map(|e| e.log_posterior).chain(start_lp);
    let best = values.clone().fold(f64::NEG_INFINITY, f64::max);
    values.filter(|v| *v > best - SAME_BASIN).count() >= 2
}

/// A second MAP search from new starts, run when the first search's
/// residual is structured ([`crate::criticism::sanity::structured_residual`]):
/// such a MAP is often a local basin. On the 62 records of
/// `examples/map_robustness.rs`, 8 were searched twice; the second search
/// was higher on 7 and reached the noise floor on 3. It also runs where
/// the first search's runs never ended twice in its best basin
/// ([`MapEstimate::best_repeated`]): nothing corroborates that MAP (a
/// Maxwell record's fit with the memory term of its missing form, eleven
/// parameters, ended at `e2` 1.047 of the noise floor after 16 runs and
/// its whole budget, `tests/it/missing_form.rs`). The better of the two
/// is kept.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SecondSearch {
    /// Why it ran: `structured residual` or `best not found twice`.
    pub reason: &'static str,
    /// Log-posterior of the first search's MAP.
    pub first_log_posterior: f64,
    /// Log-posterior of the second search's MAP.
    pub second_log_posterior: f64,
    /// Evaluations of the second search.
    pub evaluations: u64,
    /// Whether the second search's MAP is kept (it is higher).
    pub kept_second: bool,
}
