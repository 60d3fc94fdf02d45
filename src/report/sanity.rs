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
/// let w = hbis::report::sanity::explains_nothing(0.97).unwrap();
/// assert_eq!(w.code, "explains-nothing");
/// assert!(w.message.contains("3.0 %"));
/// assert!(hbis::report::sanity::explains_nothing(0.01).is_none());
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

/// `at-bound`, one per parameter whose MAP lies within [`AT_BOUND`] of its
/// prior's range from a finite bound. A lower bound of exactly 0 is left
/// out: there a parameter at the bound means the effect is absent (no
/// damping, no friction slope), a result, not a failure.
pub fn at_bounds(names: &[String], theta: &[f64], priors: &Priors) -> Vec<Warning> {
    let mut out = Vec::new();
    for ((name, &x), p) in names.iter().zip(theta).zip(priors.priors()) {
        let (lo, hi) = p.support();
        if !(lo.is_finite() && hi.is_finite()) {
            continue;
        }
        let tol = AT_BOUND * (hi - lo);
        let side = if x - lo <= tol && lo != 0.0 {
            Some(("lower", lo))
        } else if hi - x <= tol {
            Some(("upper", hi))
        } else {
            None
        };
        if let Some((side, b)) = side {
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

/// Both checks of a fitted model.
pub fn fit_warnings(names: &[String], theta: &[f64], e2: f64, priors: &Priors) -> Vec<Warning> {
    let mut w: Vec<Warning> = explains_nothing(e2).into_iter().collect();
    w.extend(at_bounds(names, theta, priors));
    w
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
