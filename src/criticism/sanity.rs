//! Checks that say when a result is probably wrong: the `warnings` array of
//! `fit.json`, `diagnosis.json` and `ladder.json` (codes in `docs/cli.md`).
//! Every warning carries the numbers that triggered it.

use crate::data::Warning;
use crate::inference::Priors;

/// Above this `e2` the model explains less than half of the record's
/// energy: no fit of a release test by a model of it should.
pub const EXPLAINS_NOTHING_E2: f64 = 0.5;

/// A MAP closer than this fraction of its prior's range to a bound is
/// called "at the bound".
pub const AT_BOUND: f64 = 0.005;

/// `explains-nothing` when `e2` is above [`EXPLAINS_NOTHING_E2`].
///
/// ```
/// let w = hbis::criticism::sanity::explains_nothing(0.97).unwrap();
/// assert_eq!(w.code, "explains-nothing");
/// assert!(w.message.contains("3.0 %"));
/// assert!(hbis::criticism::sanity::explains_nothing(0.01).is_none());
/// ```
pub fn explains_nothing(e2: f64) -> Option<Warning> {
    (e2.is_nan() || e2 > EXPLAINS_NOTHING_E2).then(|| Warning {
        code: "explains-nothing".into(),
        message: format!(
            "the model explains only {:.1} % of the record's energy (e2 = {e2:.4}): \
             the result is probably wrong (a record of noise only, acceleration in other units, \
             a wrong release time, or a prior that excludes the truth)",
            100.0 * (1.0 - e2).max(0.0)
        ),
    })
}

/// `map-at-budget` when the MAP search of `model` stopped at its
/// evaluation budget (`evaluations` spent) instead of converging.
///
/// ```
/// let w = hbis::criticism::sanity::map_at_budget("bilinear+coulomb", true, 200_123).unwrap();
/// assert_eq!(w.code, "map-at-budget");
/// assert!(w.message.contains("200123 evaluations"));
/// assert!(hbis::criticism::sanity::map_at_budget("bilinear+coulomb", false, 5).is_none());
/// ```
pub fn map_at_budget(model: &str, at_budget: bool, evaluations: u64) -> Option<Warning> {
    at_budget.then(|| Warning {
        code: "map-at-budget".into(),
        message: format!(
            "the MAP search of `{model}` stopped at its evaluation budget ({evaluations} \
             evaluations) instead of converging: a better point may exist, and what is \
             compared with this fit (e2, BIC, evidence) may be off"
        ),
    })
}

/// `refits-at-budget` when candidate refits stopped at their evaluation
/// budget: `refits` names each (`effect`, or `step k: effect` in a ladder)
/// with its evaluations. Their BIC and `e2` bound what those models reach
/// from above.
///
/// ```
/// let w = hbis::criticism::sanity::refits_at_budget(&[("degradation".into(), 20_480)]).unwrap();
/// assert_eq!(w.code, "refits-at-budget");
/// assert!(w.message.contains("degradation (20480 evaluations)"));
/// assert!(hbis::criticism::sanity::refits_at_budget(&[]).is_none());
/// ```
pub fn refits_at_budget(refits: &[(String, u64)]) -> Option<Warning> {
    if refits.is_empty() {
        return None;
    }
    let list: Vec<String> = refits
        .iter()
        .map(|(what, n)| format!("{what} ({n} evaluations)"))
        .collect();
    Some(Warning {
        code: "refits-at-budget".into(),
        message: format!(
            "{} candidate refit(s) stopped at their evaluation budget instead of converging: {}; \
             their e2 and BIC bound what those models reach from above, so a candidate may be \
             ranked too low",
            refits.len(),
            list.join(", ")
        ),
    })
}

/// `refits-not-converged` when candidate refits did not converge (no two
/// runs reached their best: [`crate::criticism::ranking::SETTLE_ROUNDS`]):
/// `refits` names each. They are not ranked.
///
/// ```
/// let w = hbis::criticism::sanity::refits_not_converged(&["step 1: lcfm".into()]).unwrap();
/// assert_eq!(w.code, "refits-not-converged");
/// assert!(w.message.contains("step 1: lcfm"));
/// assert!(hbis::criticism::sanity::refits_not_converged(&[]).is_none());
/// ```
pub fn refits_not_converged(refits: &[String]) -> Option<Warning> {
    if refits.is_empty() {
        return None;
    }
    Some(Warning {
        code: "refits-not-converged".into(),
        message: format!(
            "{} candidate refit(s) did not converge (no two runs reached the best, and a local \
             search from it still gained more than one unit of log-likelihood): {}; they are \
             reported but not ranked, and may support their effect once refitted with a larger \
             budget",
            refits.len(),
            refits.join(", ")
        ),
    })
}

/// Which bound of the finite range `[lo, hi]` `x` lies within
/// [`AT_BOUND`] of the range from, if any. A lower bound of exactly 0 is
/// left out: there a parameter at the bound means the effect is absent
/// (no damping, no friction slope), a result, not a failure.
///
/// ```
/// use hbis::criticism::sanity::bound_reached;
/// assert_eq!(bound_reached(0.0005, 0.0005, 0.05), Some(("lower", 0.0005)));
/// assert_eq!(bound_reached(0.0, 0.0, 0.2), None);
/// assert_eq!(bound_reached(0.2, 0.0, 0.2), Some(("upper", 0.2)));
/// ```
pub fn bound_reached(x: f64, lo: f64, hi: f64) -> Option<(&'static str, f64)> {
    let tol = AT_BOUND * (hi - lo);
    if x - lo <= tol && lo != 0.0 {
        Some(("lower", lo))
    } else if hi - x <= tol {
        Some(("upper", hi))
    } else {
        None
    }
}

/// `at-bound`, one per parameter whose MAP lies on a finite bound of its
/// prior ([`bound_reached`]).
pub fn at_bounds(names: &[String], theta: &[f64], priors: &Priors) -> Vec<Warning> {
    let mut out = Vec::new();
    for ((name, &x), p) in names.iter().zip(theta).zip(priors.priors()) {
        let (lo, hi) = p.support();
        if !(lo.is_finite() && hi.is_finite()) {
            continue;
        }
        if let Some((side, b)) = bound_reached(x, lo, hi) {
            out.push(Warning {
                code: "at-bound".into(),
                message: format!(
                    "parameter `{name}` = {x:.6} is at its prior's {side} bound {b} \
                     (within {:.1} % of the range [{lo}, {hi}]): the bound, not the record, \
                     decides it; check the units of the record or widen the prior",
                    100.0 * AT_BOUND
                ),
            });
        }
    }
    out
}

/// Below this Ljung-Box p-value a fit's residual is called structured.
/// On 62 records from random parameter sets (`examples/map_robustness.rs`)
/// every MAP that missed the noise floor by 3 % of `e2` or more had
/// p < 2e-4, and no MAP that reached it had p < 0.01.
pub const STRUCTURED_P: f64 = 1e-3;

/// `structured-residual` when the residual of a fit (`measured - model`,
/// whitened by the AR(1) coefficient `rho` if the noise model has one)
/// fails the Ljung-Box test at [`STRUCTURED_P`]: a MAP in a local basin,
/// an effect the model lacks and noise coloured beyond the noise model
/// all leave one, and the intervals of such a fit are too narrow.
///
/// ```
/// use hbis::criticism::sanity::structured_residual;
/// // A residual that is a slow sine, not noise.
/// let r: Vec<f64> = (0..2000).map(|i| (i as f64 * 0.05).sin()).collect();
/// let w = structured_residual(&r, None).unwrap();
/// assert_eq!(w.code, "structured-residual");
/// assert!(w.message.contains("lag-one correlation 1.00"));
/// // White noise passes.
/// use rand::SeedableRng;
/// use rand_distr::{Distribution, Normal};
/// let mut rng = rand::rngs::StdRng::seed_from_u64(1);
/// let noise: Vec<f64> = (0..2000).map(|_| Normal::new(0.0, 1e-2).unwrap().sample(&mut rng)).collect();
/// assert!(structured_residual(&noise, None).is_none());
/// // AR(1) noise is structured as white noise, not under its own rho.
/// let mut ar = noise.clone();
/// for i in 1..ar.len() {
///     ar[i] += 0.5 * ar[i - 1];
/// }
/// assert!(structured_residual(&ar, None).is_some());
/// assert!(structured_residual(&ar, Some(0.5)).is_none());
/// ```
pub fn structured_residual(residual: &[f64], rho: Option<f64>) -> Option<Warning> {
    use crate::criticism::residuals::{autocorrelation, ljung_box, whiten};
    if residual.len() < 8 {
        return None;
    }
    let w = whiten(residual, rho);
    let (_, p) = ljung_box(&w);
    (p < STRUCTURED_P).then(|| Warning {
        code: "structured-residual".into(),
        message: format!(
            "the residual{} is not white noise (Ljung-Box p {}, lag-one correlation {:.2}): \
             the MAP may be a local basin (try another --seed or a larger --max-evals), \
             the model may miss an effect (`hbis diagnose` tells which), or the noise is coloured \
             (`--noise ar1`); until that is resolved, intervals from this fit cannot be trusted",
            if rho.is_some() {
                " (whitened by the fitted AR(1))"
            } else {
                ""
            },
            if p < 1e-16 {
                "< 1e-16".to_string()
            } else {
                format!("= {p:.1e}")
            },
            autocorrelation(&w, 1)
        ),
    })
}

/// [`structured_residual`] of `posterior`'s residual at `theta`, whitened
/// by the noise model's AR(1) coefficient if it has one; `None` also when
/// the model cannot run there.
pub fn structured_at<M: crate::model::ForwardModel>(
    posterior: &crate::inference::Posterior<M>,
    theta: &[f64],
) -> Option<Warning> {
    let e = posterior.residual(theta).ok()?;
    let rho = posterior.noise_part(theta).first().copied();
    structured_residual(&e, rho)
}

/// Both checks of a fitted model.
pub fn fit_warnings(names: &[String], theta: &[f64], e2: f64, priors: &Priors) -> Vec<Warning> {
    let mut w: Vec<Warning> = explains_nothing(e2).into_iter().collect();
    w.extend(at_bounds(names, theta, priors));
    w
}

/// Share of the draws below which a basin close to the MAP counts as not
/// visited by the sampler.
pub const UNVISITED_SHARE: f64 = 0.01;

/// A basin this close to the MAP (nats) should hold draws.
pub const CLOSE_BASIN: f64 = 3.0;

/// `several-basins`: the posterior has more than one basin, with the
/// numbers that found them, where the intervals come from, and whether a
/// basin close to the MAP went unvisited.
pub fn several_basins(
    basins: &[crate::inference::basins::Basin],
    evidence: bool,
) -> Option<Warning> {
    if basins.len() < 2 {
        return None;
    }
    let rest = &basins[1..];
    let list = |f: &dyn Fn(&crate::inference::basins::Basin) -> String| {
        rest.iter().map(f).collect::<Vec<_>>().join(", ")
    };
    let mut message = format!(
        "the posterior has {} basins: the MAP search ended in places separated by falls of the log-posterior of {} nats, {} nats below the MAP; ",
        basins.len(),
        list(&|b| format!("{:.1}", b.barrier)),
        list(&|b| format!("{:.2}", b.below_map)),
    );
    if basins.iter().all(|b| b.share.is_some()) {
        let shares: Vec<String> = basins
            .iter()
            .map(|b| format!("{:.1} %", 100.0 * b.share.unwrap_or(0.0)))
            .collect();
        message += &format!(
            "the intervals are the sampler's, started in every basin (shares of the kept draws, the MAP's basin first: {}), not a Gaussian (Laplace) approximation at the MAP, which would describe its basin only",
            shares.join(", ")
        );
        let unvisited: Vec<String> = rest
            .iter()
            .filter(|b| b.below_map < CLOSE_BASIN && b.share.unwrap_or(0.0) < UNVISITED_SHARE)
            .map(|b| format!("{:.2}", b.below_map))
            .collect();
        if !unvisited.is_empty() {
            message += &format!(
                "; basins {} nats below the MAP hold under {:.0} % of the draws: the sampler may not have mixed between basins (check trace.png, raise --max-steps)",
                unvisited.join(", "),
                100.0 * UNVISITED_SHARE
            );
        }
    } else {
        message += "a Gaussian (Laplace) approximation at the MAP describes its basin only: sample the posterior for intervals";
    }
    if evidence {
        message += "; log_evidence is the Laplace evidence of the MAP's basin alone";
    }
    Some(Warning {
        code: "several-basins".into(),
        message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_at_a_bound_is_named_and_zero_lower_bounds_are_not() {
        let names: Vec<String> = ["u0", "zeta0", "f0"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let priors = Priors::defaults(&names).unwrap();
        let (lo, hi) = priors.box_bounds();
        // zeta0 at 0 (no damping) is a result; f0 at its upper bound is not.
        let theta = [0.1, lo[1], hi[2] - 1e-6];
        let w = at_bounds(&names, &theta, &priors);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].message.contains("`f0`") && w[0].message.contains("upper"));
        let inside = [0.1, 0.05, 0.5 * (lo[2] + hi[2])];
        assert!(at_bounds(&names, &inside, &priors).is_empty());
        let theta = [lo[0], 0.05, 1.0];
        assert!(at_bounds(&names, &theta, &priors)[0]
            .message
            .contains("lower"));
    }

    #[test]
    fn nan_e2_is_not_a_good_fit() {
        assert!(explains_nothing(f64::NAN).is_some());
        assert!(explains_nothing(0.51).is_some());
        assert!(explains_nothing(0.49).is_none());
    }
}
