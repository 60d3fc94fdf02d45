//! Which parameters the record determines, how well, and why the weakest is
//! weak.
//!
//! Per parameter, from the posterior draws and the prior:
//! - **contraction** `1 - (sd_post / sd_prior)^2`: how much the record
//!   narrowed the prior;
//! - **variance inflation** `sd_post / sd_cond`, with `sd_cond =
//!   1/sqrt((Sigma^-1)_kk)` the sd it would have with all other parameters
//!   known (Gaussian approximation of the posterior covariance `Sigma`);
//! - its **strongest partner**, the parameter it is most correlated with;
//! - the **ranking**, best determined first, by relative precision (the
//!   posterior coefficient of variation `sd / |mean|`, the measure of the
//!   paper's Table 8.1). A parameter whose interval straddles zero has a
//!   large c.o.v.: the record cannot even fix its sign.
//!
//! The explanation of the weakest parameter is computed, not assumed: the
//! change of the model's acceleration for a one-sd change of the parameter
//! (finite differences at the MAP) against the noise level; the trade-off
//! with its partner; and where in the record its Fisher information
//! `sum (da_i/dtheta)^2` comes from, split by phase of motion, by half-cycle
//! and by closeness to reversals (where friction makes the acceleration
//! jump).
//!
//! # Formula
//! ```text
//! contraction = 1 - (sd_post/sd_prior)^2
//! inflation   = sd_post * sqrt((Sigma^-1)_kk)
//! share(G)    = sum_(i in G) s_i^2 / sum_i s_i^2,  s_i = (a_i(theta + h e_k) - a_i(theta - h e_k)) / 2h
//! ```
//!
//! ```
//! use hbis::inference::identifiability::variance_inflation;
//!
//! // Two parameters correlated at 0.9: each sd is 1/sqrt(1 - 0.81) = 2.29
//! // times the sd it would have with the other known.
//! let cov = vec![vec![1.0, 0.9], vec![0.9, 1.0]];
//! let vif = variance_inflation(&cov);
//! assert!((vif[0] - 2.294).abs() < 1e-3);
//! ```

use nalgebra::DMatrix;
use serde::Serialize;

use super::summary::ParamSummary;

/// The identifiability of one parameter.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParamIdentifiability {
    /// Prior-to-posterior contraction, `1 - (sd_post/sd_prior)^2`.
    pub contraction: f64,
    /// Posterior sd over prior sd.
    pub sd_ratio: f64,
    /// Posterior c.o.v., `sd / |mean|` (the ranking key).
    pub cov: f64,
    /// Marginal sd over the sd with the other parameters known.
    pub variance_inflation: f64,
    /// The sd it would have with the other parameters known.
    pub sd_conditional: f64,
    /// The parameter it is most correlated with.
    pub partner: String,
    /// That correlation.
    pub partner_correlation: f64,
    /// RMS change of the model acceleration for a one-sd change (m/s^2).
    pub effect_rms: f64,
}

/// Labels of the record's samples, for locating information.
#[derive(Debug, Clone)]
pub struct Segments {
    /// Phase of motion at each sample (e.g. `elastic`, `plastic2`, `rest`).
    pub phase: Vec<String>,
    /// Half-cycle index (reversals passed) at each sample.
    pub half_cycle: Vec<usize>,
    /// Whether the sample lies within two steps of a reversal.
    pub near_reversal: Vec<bool>,
    /// Displacement amplitude of each half-cycle (m), if known.
    pub amplitude: Vec<f64>,
}

/// The report.
#[derive(Debug, Clone, Serialize)]
pub struct Identifiability {
    /// Per parameter, in the model's order.
    pub params: Vec<(String, ParamIdentifiability)>,
    /// Names, best determined first.
    pub ranking: Vec<String>,
    /// The least determined parameter.
    pub weakest: String,
    /// Why it is weak, in numbers and physical terms.
    pub explanation: String,
}

/// `sd_marginal / sd_conditional` for each parameter of a covariance matrix.
pub fn variance_inflation(cov: &[Vec<f64>]) -> Vec<f64> {
    let d = cov.len();
    let m = DMatrix::from_fn(d, d, |i, j| cov[i][j]);
    match m.clone().try_inverse() {
        Some(p) => (0..d).map(|k| (cov[k][k] * p[(k, k)]).sqrt()).collect(),
        None => vec![f64::INFINITY; d],
    }
}

/// What a parameter does physically, for the explanation.
pub fn mechanism(name: &str) -> &'static str {
    match name {
        "u0" => "sets the release displacement and so the amplitude of the whole record",
        "uy" => "sets where the rubber bearings yield: the elastic branch after each reversal is 2 uy wide",
        "uF0" => "sets the constant part of the friction force, F_F0 = uF0 k0, seen as the acceleration jump at every reversal",
        "rF0" => "makes the friction force grow with the displacement, F_F = (uF0 + rF0 |u|) k0; it changes the jump at a reversal in proportion to the amplitude there, so the record shows it only through how the jumps change from cycle to cycle",
        "zeta0" => "sets the viscous force c u', largest mid-swing at peak velocity, and with friction the decay of the amplitude",
        "f0" => "sets the elastic stiffness: the slope of the acceleration right after each reversal",
        "f1" => "sets the first post-yield stiffness, which governs the period of the large swings",
        "f2" => "sets the stiffness beyond u3, active only while the swing passes u3",
        "u3" => "sets where the third branch starts; it is seen only if the swing passes it",
        "rho" => "is the correlation of successive measurement errors",
        _ => "is a parameter of the model",
    }
}

/// Builds the report.
///
/// `effects[k]` is the change of the model acceleration at each sample for
/// a one-sd change of parameter `k` (central differences at the MAP);
/// `sigma` the noise level; `prior_sd[k]` the prior's sd.
pub fn report(
    names: &[String],
    summaries: &[ParamSummary],
    cov: &[Vec<f64>],
    prior_sd: &[f64],
    effects: &[Vec<f64>],
    sigma: f64,
    segments: Option<&Segments>,
) -> Identifiability {
    let d = names.len();
    let vif = variance_inflation(cov);
    let mut params = Vec::with_capacity(d);
    for k in 0..d {
        let s = &summaries[k];
        let (mut partner, mut best) = (String::from("-"), 0.0f64);
        for j in 0..d {
            if j != k {
                let r = cov[k][j] / (cov[k][k] * cov[j][j]).sqrt();
                if r.abs() > best.abs() {
                    best = r;
                    partner = names[j].clone();
                }
            }
        }
        let ratio = s.sd / prior_sd[k];
        let rms =
            (effects[k].iter().map(|v| v * v).sum::<f64>() / effects[k].len().max(1) as f64).sqrt();
        params.push((
            names[k].clone(),
            ParamIdentifiability {
                contraction: 1.0 - ratio * ratio,
                sd_ratio: ratio,
                cov: s.sd / s.mean.abs(),
                variance_inflation: vif[k],
                sd_conditional: s.sd / vif[k],
                partner,
                partner_correlation: best,
                effect_rms: rms,
            },
        ));
    }
    let mut order: Vec<usize> = (0..d).collect();
    order.sort_by(|&a, &b| params[a].1.cov.total_cmp(&params[b].1.cov).then(a.cmp(&b)));
    let ranking: Vec<String> = order.iter().map(|&k| names[k].clone()).collect();
    let w = *order.last().expect("at least one parameter");
    let explanation = explain(w, names, summaries, &params, &effects[w], sigma, segments);
    Identifiability {
        params,
        ranking: ranking.clone(),
        weakest: names[w].clone(),
        explanation,
    }
}

fn explain(
    w: usize,
    names: &[String],
    summaries: &[ParamSummary],
    params: &[(String, ParamIdentifiability)],
    effect: &[f64],
    sigma: f64,
    segments: Option<&Segments>,
) -> String {
    let name = &names[w];
    let s = &summaries[w];
    let p = &params[w].1;
    let mut text = format!(
        "{name} is the least determined parameter: posterior mean {:.4e}, sd {:.2e} (c.o.v. {:.0} %), 90 % interval [{:.4e}, {:.4e}]{}.",
        s.mean,
        s.sd,
        100.0 * p.cov,
        s.q05,
        s.q95,
        if s.q05 < 0.0 && s.q95 > 0.0 {
            ", which includes zero: the record does not fix its sign"
        } else {
            ""
        }
    );
    // How other parameters compare, for scale.
    let others: Vec<f64> = params
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != w)
        .map(|(_, q)| q.1.cov)
        .collect();
    if let Some(next) = others
        .iter()
        .copied()
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
    {
        text.push_str(&format!(
            " The next weakest has c.o.v. {:.1} %.",
            100.0 * next
        ));
    }
    text.push_str(&format!(
        " The record barely responds to it: a one-sd change of {name} moves the acceleration by {:.2e} m/s^2 RMS, {:.0} % of the noise level (sigma = {:.2e} m/s^2); it takes the whole record to see it.",
        p.effect_rms,
        100.0 * p.effect_rms / sigma,
        sigma
    ));
    if p.partner != "-" {
        text.push_str(&format!(
            " It trades off with {} (correlation {:+.2}): with {} and the others known its sd would be {:.2e}, {:.1} times smaller.",
            p.partner, p.partner_correlation, p.partner, p.sd_conditional, p.variance_inflation
        ));
    }
    if let Some(seg) = segments {
        let info: Vec<f64> = effect.iter().map(|v| v * v).collect();
        let total: f64 = info.iter().sum();
        if total > 0.0 && seg.phase.len() == info.len() {
            let near: f64 = info
                .iter()
                .zip(&seg.near_reversal)
                .filter(|(_, n)| **n)
                .map(|(v, _)| v)
                .sum();
            let near_frac =
                seg.near_reversal.iter().filter(|n| **n).count() as f64 / info.len() as f64;
            // Fine sampling leaves few samples near reversals: keep a digit.
            let digits = if 100.0 * near_frac < 9.5 { 1 } else { 0 };
            text.push_str(&format!(
                " Where its information comes from: {:.0} % from the {:.*} % of samples within two steps of a reversal (the friction jumps)",
                100.0 * near / total,
                digits,
                100.0 * near_frac
            ));
            let mut phases: Vec<(String, f64)> = Vec::new();
            for (v, ph) in info.iter().zip(&seg.phase) {
                match phases.iter_mut().find(|(n, _)| n == ph) {
                    Some(e) => e.1 += v,
                    None => phases.push((ph.clone(), *v)),
                }
            }
            phases.sort_by(|a, b| b.1.total_cmp(&a.1));
            let list: Vec<String> = phases
                .iter()
                .filter(|(_, v)| *v / total >= 0.01)
                .map(|(n, v)| format!("{n} {:.0} %", 100.0 * v / total))
                .collect();
            text.push_str(&format!("; by phase: {}", list.join(", ")));
            let max_hc = seg.half_cycle.iter().copied().max().unwrap_or(0);
            let mut by_hc = vec![0.0; max_hc + 1];
            for (v, h) in info.iter().zip(&seg.half_cycle) {
                by_hc[*h] += v;
            }
            let first_two: f64 = by_hc.iter().take(2).sum();
            text.push_str(&format!(
                "; {:.0} % from the first two half-cycles{}",
                100.0 * first_two / total,
                match (seg.amplitude.first(), seg.amplitude.get(2)) {
                    (Some(a0), Some(a2)) => format!(
                        " (amplitudes {:.3} m and above, against {:.3} m by the third)",
                        a0.min(seg.amplitude.get(1).copied().unwrap_or(*a0)),
                        a2
                    ),
                    _ => String::new(),
                }
            ));
            text.push('.');
        }
    }
    text.push_str(&format!(" Physically, {name} {}.", mechanism(name)));
    if p.partner != "-" {
        text.push_str(&format!(
            " Its partner {} {}.",
            p.partner,
            mechanism(&p.partner)
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(mean: f64, sd: f64) -> ParamSummary {
        ParamSummary {
            mean,
            sd,
            cov: sd / mean.abs(),
            q025: mean - 2.0 * sd,
            q05: mean - 1.645 * sd,
            q50: mean,
            q95: mean + 1.645 * sd,
            q975: mean + 2.0 * sd,
            hdi90_low: mean - 1.645 * sd,
            hdi90_high: mean + 1.645 * sd,
        }
    }

    #[test]
    fn ranks_by_relative_precision_and_explains_the_weakest() {
        let names: Vec<String> = ["f0", "uF0", "rF0"].iter().map(|s| s.to_string()).collect();
        let sums = vec![
            summary(0.54, 0.0005),
            summary(0.0023, 0.00004),
            summary(0.0018, 0.0011),
        ];
        let r = -0.9;
        let cov = vec![
            vec![0.0005f64.powi(2), 0.0, 0.0],
            vec![0.0, 0.00004f64.powi(2), r * 0.00004 * 0.0011],
            vec![0.0, r * 0.00004 * 0.0011, 0.0011f64.powi(2)],
        ];
        let n = 100;
        let effects = vec![
            vec![0.01; n],
            vec![0.01; n],
            (0..n)
                .map(|i| if i % 10 == 0 { 0.02 } else { 0.001 })
                .collect(),
        ];
        let seg = Segments {
            phase: (0..n)
                .map(|i| {
                    if i < 50 {
                        "plastic2".to_string()
                    } else {
                        "elastic".to_string()
                    }
                })
                .collect(),
            half_cycle: (0..n).map(|i| i / 25).collect(),
            near_reversal: (0..n).map(|i| i % 10 == 0).collect(),
            amplitude: vec![0.1, 0.08, 0.05, 0.02],
        };
        let rep = report(
            &names,
            &sums,
            &cov,
            &[0.5, 0.005, 0.05],
            &effects,
            0.01,
            Some(&seg),
        );
        assert_eq!(rep.ranking, ["f0", "uF0", "rF0"]);
        assert_eq!(rep.weakest, "rF0");
        let p = &rep.params[2].1;
        assert_eq!(p.partner, "uF0");
        assert!((p.variance_inflation - 1.0 / (1.0f64 - 0.81).sqrt()).abs() < 1e-9);
        let e = &rep.explanation;
        assert!(e.contains("trades off with uF0 (correlation -0.90)"), "{e}");
        // 10 of 100 samples near reversals carry 0.04/(0.04+0.00009) of the information.
        assert!(
            e.contains("from the 10 % of samples within two steps of a reversal"),
            "{e}"
        );
        assert!(e.starts_with("rF0 is the least determined"), "{e}");
    }
}
