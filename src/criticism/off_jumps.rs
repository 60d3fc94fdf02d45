//! A candidate's support away from the jumps at reversals.
//!
//! An instantaneous sensor reads the acceleration at a sample instant, and
//! the acceleration jumps by `2 F_F / m` where the sliding reverses (and
//! where the mass stops or breaks away). Which side of a jump a sample
//! falls on changes with the event time in steps: moving a reversal across
//! a sample instant moves one residual by the whole jump. Any extra
//! parameter that shifts reversals (friction near zero velocity, friction
//! that decays) can buy such steps. On a null record with sensor noise
//! (the out-of-sample calibration of 2026-11-29, seed 339995019999) the
//! refits of `velocity-friction` and `friction-decay` gained 40 nats each
//! over the start model (BIC -65.1 and -73.0), `velocity-friction` was
//! added, and on the samples away from the reversals their BIC rose (by
//! 30.9 and 12.2). A force the record shows acts all through a phase, not
//! on the one sample each side of its reversals: on the twelve
//! hidden-effect records of the same run looked at (velocity friction,
//! the third branch, `lcfm`, damping, asymmetric friction, degradation;
//! BIC -11.9 to -718.6) the change away from the reversals was 74 % to
//! 105 % of the whole.
//!
//! # Formula
//! ```text
//! J = {i-1, i : the velocity changes sign, stops or starts between samples i-1 and i,
//!      in the current model's motion or the candidate's}
//! w_i = r_i - rho r_(i-1)          (r_i itself for white noise)
//! l   = -(m / 2) ln(S / m),  S = sum of w_i^2 over the m samples i >= 1 with i, i-1 not in J
//! delta BIC off the jumps = -2 (l_candidate - l_current) + k ln m
//! ```
//! (`k`: the candidate's new parameters; each fit whitened with its own
//! `rho`; `sigma` profiled on the kept samples.)

use super::ranking::{CriticismError, ModelFit};
use super::residuals::whiten;
use crate::data::Aligned;
use crate::inference::Posterior;
use crate::model::Model;

/// The samples either side of each reversal, stop and start of `model`'s
/// motion at `theta` (its own part), marked in `mask`.
pub fn mark_jumps(
    model: &Model,
    theta: &[f64],
    data: &Aligned,
    mask: &mut [bool],
) -> Result<(), CriticismError> {
    let motion = model.motion_grid(theta, data.lag, data.dt, mask.len())?;
    for i in 1..motion.len() {
        let (a, b) = (motion[i - 1].v, motion[i].v);
        if a * b < 0.0 || (a == 0.0) != (b == 0.0) {
            mask[i - 1] = true;
            mask[i] = true;
        }
    }
    Ok(())
}

/// The sigma-profiled log-likelihood of `fit` (of `model`) on the samples
/// not in `mask` ([module formula](self)), and how many there are.
pub fn log_likelihood_off(
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
    mask: &[bool],
) -> Result<(f64, usize), CriticismError> {
    let layout = Posterior::layout_for(model, fit.noise);
    let rho = layout.values(&fit.theta, 1).first().copied();
    let mut accel = vec![0.0; data.a.len()];
    data.model_accel_into(model, layout.values(&fit.theta, 0), &mut accel)?;
    let r: Vec<f64> = data.a.iter().zip(&accel).map(|(a, m)| a - m).collect();
    let w = whiten(&r, rho);
    let kept = (1..w.len()).filter(|&i| !(mask[i] || mask[i - 1]));
    let (s, m) = kept.fold((0.0, 0usize), |(s, m), i| (s + w[i] * w[i], m + 1));
    Ok((-(m as f64) / 2.0 * (s / m as f64).ln(), m))
}

/// The change of BIC from `current` (fitted by `now`) to `extended`
/// (fitted by `refit`, `k` new parameters) on the samples away from
/// either model's jumps ([module formula](self)).
pub fn delta_bic_off(
    current: &Model,
    now: &ModelFit,
    extended: &Model,
    refit: &ModelFit,
    k: usize,
    data: &Aligned,
) -> Result<f64, CriticismError> {
    let mut mask = vec![false; data.a.len()];
    mark_jumps(current, now.model_theta(current), data, &mut mask)?;
    mark_jumps(extended, refit.model_theta(extended), data, &mut mask)?;
    let (before, m) = log_likelihood_off(current, now, data, &mask)?;
    let (after, _) = log_likelihood_off(extended, refit, data, &mask)?;
    Ok(delta_bic_of(before, after, k, m))
}

/// `-2 (after - before) + k ln m`: BIC's change for `k` more parameters
/// on `m` samples.
///
/// ```
/// use hbis::criticism::off_jumps::delta_bic_of;
/// // 7 nats lost away from the jumps, two parameters more: no support.
/// let d = delta_bic_of(6980.0, 6973.0, 2, 1900);
/// assert!((d - (14.0 + 2.0 * 1900f64.ln())).abs() < 1e-9);
/// ```
pub fn delta_bic_of(before: f64, after: f64, k: usize, m: usize) -> f64 {
    -2.0 * (after - before) + k as f64 * (m as f64).ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Record;
    use crate::inference::Noise;
    use crate::model::{ForwardModel, Params};

    /// Test 5 with a small alternating noise, `bump` added at sample `at`,
    /// and the model's fit at the truth.
    fn record_and_fit(bump: f64, at: usize) -> (Model, ModelFit, Aligned) {
        let model = Model::parse("trilinear+lcfm+viscous").unwrap();
        let theta = model
            .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
            .unwrap();
        let mut a = vec![0.0; 2001];
        model.accel_into(&theta, 0.005, &mut a).unwrap();
        for (i, v) in a.iter_mut().enumerate() {
            *v += if i % 3 == 0 { 1e-3 } else { -5e-4 };
        }
        a[at] += bump;
        let t = (0..a.len()).map(|i| i as f64 * 0.005).collect();
        let data = Record::new(t, a).unwrap().aligned(Some(0.0)).unwrap();
        let fit = ModelFit {
            model: model.name(),
            names: model.param_names(),
            theta,
            e2: f64::NAN,
            log_likelihood: f64::NAN,
            bic: f64::NAN,
            log_evidence: f64::NAN,
            sd: Vec::new(),
            evaluations: 0,
            noise: Noise::White,
            at_budget: false,
            best_repeated: None,
        };
        (model, fit, data)
    }

    #[test]
    fn a_residual_at_a_reversal_does_not_count_and_one_elsewhere_does() {
        let (model, fit, data) = record_and_fit(0.0, 0);
        let mut mask = vec![false; data.a.len()];
        mark_jumps(&model, fit.model_theta(&model), &data, &mut mask).unwrap();
        let marked: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
        // Test 5 reverses, and finally stops, a few times in 10 s: two
        // samples each.
        assert!(marked.len() >= 6 && marked.len() % 2 == 0, "{marked:?}");
        let (clean, m) = log_likelihood_off(&model, &fit, &data, &mask).unwrap();
        assert!(m < data.a.len() - marked.len() && m > 1900, "{m}");
        let at_jump = marked[2];
        let (model, fit, bumped) = record_and_fit(0.5, at_jump);
        let (at, _) = log_likelihood_off(&model, &fit, &bumped, &mask).unwrap();
        assert_eq!(at, clean);
        let (model, fit, bumped) = record_and_fit(0.5, at_jump + 40);
        let (away, _) = log_likelihood_off(&model, &fit, &bumped, &mask).unwrap();
        assert!(away < clean - 10.0, "{away} {clean}");
    }
}
