//! What test would determine a parameter better: the posterior sd of one
//! parameter under other release-test designs, from the Fisher information
//! re-evaluated on each simulated design.
//!
//! A design is the record's length, the release amplitude `u0`, the noise
//! level and the sampling rate. For each, the model's acceleration is
//! simulated at the posterior mean on that design's grid, its Jacobian taken
//! by one-sided differences (the smaller of the two: a friction jump that
//! crosses a sample within a step makes one side `jump / h`, the
//! likelihood's staircase, not information), and the Gaussian approximation
//! of the posterior
//! `Sigma = (J^T W J / sigma^2 + P)^-1` inverted, with `W` the whitening of
//! the fitted noise model and `P` the prior's precision (`1/sd_prior^2` on
//! the diagonal). The table reports each design's sd as the *sampled*
//! posterior sd times the Fisher ratio `sd_design / sd_current`, so the
//! part of the posterior that is not Gaussian carries over.
//!
//! Assumptions, stated so a reader can judge the numbers: the system is the
//! one identified (the posterior mean); the noise keeps its level per sample
//! when the length, amplitude or rate change; AR(1) noise is the sampling of
//! a continuous process, so at `r` times the rate its lag-one correlation is
//! `rho^(1/r)`; the release falls on a sample. A longer record adds
//! information only while the mass still moves: past the arrest the table
//! says so by not improving.
//!
//! # Formula
//! ```text
//! J_ik      = minmod((a_i(theta + h e_k) - a_i(theta)) / h, (a_i(theta) - a_i(theta - h e_k)) / h)
//! white:    F = J^T J / sigma^2
//! AR(1):    F = J_w^T J_w / (sigma^2 (1 - rho^2)),  (J_w)_ik = J_ik - rho J_(i-1)k
//! Sigma     = (F + diag(1/sd_prior^2))^-1
//! sd(d)     = sd_sampled * sqrt(Sigma(d)_kk / Sigma(current)_kk)
//! exponent  = d ln sd / d ln factor   (least squares over a knob's rows)
//! ```
//!
//! For a linear model the Fisher sd is the exact posterior sd: with the
//! noise halved it halves (up to the prior's share).
//!
//! ```
//! use hbis::inference::design::fisher_sd;
//!
//! // One parameter, a_i = theta * x_i with x = (1, 2, 2): F = 9 / sigma^2.
//! let jac = vec![vec![1.0, 2.0, 2.0]];
//! let sd = fisher_sd(&jac, 0.3, None, &[f64::INFINITY]).unwrap();
//! assert!((sd[0] - 0.1).abs() < 1e-12);
//! ```

use nalgebra::DMatrix;
use serde::Serialize;
use thiserror::Error;

use super::posterior::Posterior;
use crate::model::{ForwardModel, SimError};

/// Why the design table could not be computed.
#[derive(Debug, Error)]
pub enum DesignError {
    /// The model could not be simulated on a design.
    #[error("simulating the {design} design")]
    Sim {
        /// Which design.
        design: String,
        /// The model's error.
        #[source]
        source: SimError,
    },
    /// The information matrix is singular on the current design.
    #[error("the Fisher information is singular on the current record")]
    Singular,
    /// A bad target.
    #[error("design target {0} must lie in (0, 1): the fraction of today's sd to reach")]
    Target(f64),
}

/// One release test: the four things an experimenter chooses.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Design {
    /// Record length after the release (s).
    pub duration_s: f64,
    /// Release amplitude `u0` (m).
    pub amplitude_m: f64,
    /// Noise sd per sample (m/s^2; the marginal sd for AR(1) noise).
    pub noise: f64,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
}

/// One row of the table: one knob turned by one factor.
#[derive(Debug, Clone, Serialize)]
pub struct DesignRow {
    /// `duration`, `amplitude`, `noise` or `rate`.
    pub knob: String,
    /// Multiplier of the current value.
    pub factor: f64,
    /// The design.
    pub design: Design,
    /// Predicted posterior sd of the parameter (its unit).
    pub sd: f64,
    /// `sd / sd_current`.
    pub sd_ratio: f64,
}

/// How the sd scales with one knob, and what it takes to reach the target.
#[derive(Debug, Clone, Serialize)]
pub struct KnobScaling {
    /// The knob.
    pub knob: String,
    /// `d ln sd / d ln factor` over the knob's rows (least squares).
    pub exponent: f64,
    /// The factor that reaches the target sd, if one within the knob's
    /// range does (`null` otherwise).
    pub factor_for_target: Option<f64>,
    /// The sd ratio at the end of the range (the best the knob can do
    /// there).
    pub ratio_at_limit: f64,
    /// The range searched, `[low, high]`.
    pub range: [f64; 2],
}

/// The design table for one parameter (`identifiability.design` in
/// `fit.json`).
#[derive(Debug, Clone, Serialize)]
pub struct DesignTable {
    /// The parameter (the weakest).
    pub parameter: String,
    /// Its unit.
    pub unit: String,
    /// The record as measured.
    pub current: Design,
    /// The sampled posterior sd on the current record.
    pub sd_sampled: f64,
    /// The Fisher (Gaussian) sd on the current record: its ratio to the
    /// sampled sd says how Gaussian the posterior is.
    pub sd_fisher: f64,
    /// The target, as a fraction of the current sd.
    pub target_ratio: f64,
    /// The target sd (unit of the parameter).
    pub target_sd: f64,
    /// The rows.
    pub rows: Vec<DesignRow>,
    /// Per knob: the scaling exponent and the factor for the target.
    pub scaling: Vec<KnobScaling>,
    /// One line per knob, with the numbers.
    pub summary: String,
}

/// The knobs, their tabulated factors and the range searched for a target.
const KNOBS: [(&str, &[f64], [f64; 2]); 4] = [
    ("duration", &[0.5, 2.0, 4.0], [1.0, 8.0]),
    ("amplitude", &[0.5, 1.5, 2.0], [1.0, 4.0]),
    ("noise", &[0.5, 0.25], [0.01, 1.0]),
    ("rate", &[2.0, 4.0], [1.0, 16.0]),
];

/// Largest design grid simulated, to keep the table cheap.
const MAX_SAMPLES: usize = 400_000;

/// Posterior sds from the Jacobian's columns (`cols[k][i]`: parameter `k`,
/// sample `i`), the noise sd, an AR(1) coefficient and the prior sds
/// (`INFINITY` for none). `None` when the information is singular.
pub fn fisher_sd(
    cols: &[Vec<f64>],
    sigma: f64,
    rho: Option<f64>,
    prior_sd: &[f64],
) -> Option<Vec<f64>> {
    let d = cols.len();
    let rho = rho.unwrap_or(0.0);
    let innovation = sigma * sigma * (1.0 - rho * rho);
    // The first sample of a stationary AR(1) has the marginal sd.
    let white: Vec<Vec<f64>> = cols
        .iter()
        .map(|c| {
            let mut w = Vec::with_capacity(c.len());
            if let Some(first) = c.first() {
                w.push(first * (1.0 - rho * rho).sqrt());
            }
            w.extend(c.windows(2).map(|p| p[1] - rho * p[0]));
            w
        })
        .collect();
    let mut f = DMatrix::<f64>::zeros(d, d);
    for a in 0..d {
        for b in a..d {
            let dot: f64 = white[a].iter().zip(&white[b]).map(|(x, y)| x * y).sum();
            f[(a, b)] = dot / innovation;
            f[(b, a)] = f[(a, b)];
        }
        f[(a, a)] += 1.0 / (prior_sd[a] * prior_sd[a]);
    }
    let cov = f.try_inverse()?;
    let sd: Vec<f64> = (0..d).map(|k| cov[(k, k)].sqrt()).collect();
    sd.iter().all(|s| s.is_finite() && *s > 0.0).then_some(sd)
}

/// What the table is computed from.
#[derive(Debug, Clone)]
pub struct DesignInput<'a> {
    /// The posterior mean of the model's parameters (noise parameters last).
    pub mean: &'a [f64],
    /// Posterior sds (finite-difference steps are a fifth of them).
    pub sd: &'a [f64],
    /// Prior sds.
    pub prior_sd: &'a [f64],
    /// Noise sd per sample on the current record (marginal, m/s^2).
    pub sigma: f64,
    /// The parameter the table is for.
    pub parameter: usize,
    /// Its unit.
    pub unit: &'a str,
    /// Target sd as a fraction of today's, in (0, 1).
    pub target_ratio: f64,
    /// Finite-difference step, as a fraction of each posterior sd.
    pub step: f64,
}

/// The design table of `input.parameter`.
pub fn design_table<M: ForwardModel>(
    posterior: &Posterior<M>,
    input: &DesignInput,
) -> Result<DesignTable, DesignError> {
    if !(input.target_ratio > 0.0 && input.target_ratio < 1.0) {
        return Err(DesignError::Target(input.target_ratio));
    }
    let eval = Evaluator::new(posterior, input);
    let current = eval.current;
    let base = eval.sd(&current, "current")?.ok_or(DesignError::Singular)?;
    let k = input.parameter;
    let sd_sampled = input.sd[k];
    let mut rows = Vec::new();
    let mut scaling = Vec::new();
    for (knob, factors, range) in KNOBS {
        let mut points = vec![(1.0f64, 1.0f64)];
        for &f in factors {
            let design = turned(&current, knob, f);
            let Some(sd) = eval.sd(&design, knob)? else {
                continue;
            };
            let ratio = sd / base;
            points.push((f, ratio));
            rows.push(DesignRow {
                knob: knob.into(),
                factor: f,
                design,
                sd: sd_sampled * ratio,
                sd_ratio: ratio,
            });
        }
        let range = eval.clamp_range(knob, range);
        let (factor_for_target, ratio_at_limit) =
            reach(&eval, &current, knob, range, base, input.target_ratio)?;
        scaling.push(KnobScaling {
            knob: knob.into(),
            exponent: slope(&points),
            factor_for_target,
            ratio_at_limit,
            range,
        });
    }
    let name = posterior.names()[k].clone();
    let summary = summarise(&name, input.target_ratio, &current, &scaling);
    Ok(DesignTable {
        parameter: name,
        unit: input.unit.into(),
        current,
        sd_sampled,
        sd_fisher: base,
        target_ratio: input.target_ratio,
        target_sd: input.target_ratio * sd_sampled,
        rows,
        scaling,
        summary,
    })
}

/// The design with one knob multiplied by `f`.
fn turned(d: &Design, knob: &str, f: f64) -> Design {
    let mut d = *d;
    match knob {
        "duration" => d.duration_s *= f,
        "amplitude" => d.amplitude_m *= f,
        "noise" => d.noise *= f,
        _ => d.rate_hz *= f,
    }
    d
}

/// Simulates designs and inverts their information.
struct Evaluator<'a, M> {
    posterior: &'a Posterior<M>,
    input: &'a DesignInput<'a>,
    current: Design,
    /// Index of `u0` among the model's parameters.
    u0: Option<usize>,
    /// The fitted AR(1) coefficient.
    rho: Option<f64>,
}

impl<'a, M: ForwardModel> Evaluator<'a, M> {
    fn new(posterior: &'a Posterior<M>, input: &'a DesignInput<'a>) -> Self {
        let data = posterior.data();
        let model = posterior.model_part(input.mean);
        let u0 = posterior.names().iter().position(|n| n == "u0");
        let rho = posterior.noise_part(input.mean).first().copied();
        Self {
            posterior,
            input,
            current: Design {
                duration_s: data.duration(),
                amplitude_m: u0.map_or(f64::NAN, |i| model[i]),
                noise: input.sigma,
                rate_hz: 1.0 / data.dt,
            },
            u0,
            rho,
        }
    }

    /// The Fisher sd of the parameter on a design (`None` if singular).
    fn sd(&self, d: &Design, label: &str) -> Result<Option<f64>, DesignError> {
        let jac = self.jacobian(d).map_err(|source| DesignError::Sim {
            design: label.into(),
            source,
        })?;
        let r = d.rate_hz / self.current.rate_hz;
        let rho = self.rho.map(|p| p.signum() * p.abs().powf(1.0 / r));
        Ok(
            fisher_sd(&jac, d.noise, rho, &self.input.prior_sd[..jac.len()])
                .map(|sd| sd[self.input.parameter]),
        )
    }

    /// The Jacobian's columns (`[k][i]`) on the design's grid, from the
    /// release (lag 0, so every design is treated alike).
    fn jacobian(&self, d: &Design) -> Result<Vec<Vec<f64>>, SimError> {
        let mut theta = self.posterior.model_part(self.input.mean).to_vec();
        if let Some(i) = self.u0 {
            theta[i] = d.amplitude_m;
        }
        let dt = 1.0 / d.rate_hz;
        let n = ((d.duration_s / dt).round() as usize)
            .saturating_add(1)
            .clamp(2, MAX_SAMPLES);
        let model = self.posterior.model();
        let (lo, hi) = self.posterior.priors().box_bounds();
        let mut centre = vec![0.0; n];
        model.accel_grid_into(&theta, 0.0, dt, &mut centre)?;
        let mut cols = Vec::with_capacity(theta.len());
        let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..theta.len() {
            let h = self.input.step * self.input.sd[k];
            let (mut tp, mut tm) = (theta.clone(), theta.clone());
            tp[k] = (theta[k] + h).min(hi[k]);
            tm[k] = (theta[k] - h).max(lo[k]);
            let (up, down) = (tp[k] - theta[k], theta[k] - tm[k]);
            let mut col = vec![0.0; n];
            if up > 0.0 && down > 0.0 {
                model.accel_grid_into(&tp, 0.0, dt, &mut plus)?;
                model.accel_grid_into(&tm, 0.0, dt, &mut minus)?;
                for i in 0..n {
                    col[i] = minmod((plus[i] - centre[i]) / up, (centre[i] - minus[i]) / down);
                }
            }
            cols.push(col);
        }
        Ok(cols)
    }

    /// A knob's search range, kept inside the prior (amplitude) and the
    /// size limit (duration, rate).
    fn clamp_range(&self, knob: &str, [lo, hi]: [f64; 2]) -> [f64; 2] {
        let n_max = MAX_SAMPLES as f64 / (self.current.duration_s * self.current.rate_hz);
        let hi = match knob {
            "amplitude" => match self.u0 {
                Some(i) => {
                    hi.min(self.posterior.priors().box_bounds().1[i] / self.current.amplitude_m)
                }
                None => 1.0,
            },
            "duration" | "rate" => hi.min(n_max),
            _ => hi,
        };
        [lo, hi.max(lo)]
    }
}

/// The factor within `range` that brings the sd ratio to `target` (a
/// geometric scan, then bisection on the bracket), and the ratio at the
/// range's far end.
fn reach<M: ForwardModel>(
    eval: &Evaluator<M>,
    current: &Design,
    knob: &str,
    [lo, hi]: [f64; 2],
    base: f64,
    target: f64,
) -> Result<(Option<f64>, f64), DesignError> {
    // The noise knob improves downwards, the others upwards.
    let (from, to) = if knob == "noise" { (hi, lo) } else { (lo, hi) };
    let ratio = |f: f64| -> Result<f64, DesignError> {
        Ok(eval
            .sd(&turned(current, knob, f), knob)?
            .map_or(f64::INFINITY, |s| s / base))
    };
    let at_limit = ratio(to)?;
    let steps = 16;
    let mut prev = from;
    for j in 1..=steps {
        let f = from * (to / from).powf(j as f64 / steps as f64);
        if ratio(f)? <= target {
            let (mut a, mut b) = (prev, f);
            for _ in 0..30 {
                let m = (a * b).sqrt();
                if ratio(m)? <= target {
                    b = m;
                } else {
                    a = m;
                }
                if (b / a - 1.0).abs() < 1e-3 {
                    break;
                }
            }
            return Ok((Some(b), at_limit));
        }
        prev = f;
    }
    Ok((None, at_limit))
}

/// The one-sided difference of smaller magnitude (zero if they disagree in
/// sign). A reversal's acceleration jump that crosses a sample instant
/// within one step makes that side's difference huge (`jump / h`): that is
/// the likelihood's staircase, not information a posterior can use, and
/// it would grow without bound as the step shrinks. The other side is the
/// smooth derivative.
fn minmod(a: f64, b: f64) -> f64 {
    if a * b <= 0.0 {
        0.0
    } else if a.abs() < b.abs() {
        a
    } else {
        b
    }
}

/// Least-squares slope of `ln ratio` on `ln factor`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let xs: Vec<f64> = points.iter().map(|p| p.0.ln()).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.1.ln()).collect();
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    if sxx > 0.0 {
        sxy / sxx
    } else {
        f64::NAN
    }
}

fn summarise(name: &str, target: f64, current: &Design, scaling: &[KnobScaling]) -> String {
    let mut text = format!(
        "To bring the sd of {name} to {:.0} % of today's (Fisher information on simulated tests, same system):",
        100.0 * target
    );
    for s in scaling {
        let what = match s.knob.as_str() {
            "duration" => "a longer record",
            "amplitude" => "a larger release amplitude",
            "noise" => "a quieter sensor",
            _ => "a faster sampling rate",
        };
        let reach = match s.factor_for_target {
            Some(f) => {
                let d = turned(current, &s.knob, f);
                let value = match s.knob.as_str() {
                    "duration" => format!("{:.1} s", d.duration_s),
                    "amplitude" => format!("u0 = {:.1} mm", 1e3 * d.amplitude_m),
                    "noise" => format!("sd {:.2e} m/s^2", d.noise),
                    _ => format!("{:.0} Hz", d.rate_hz),
                };
                format!("reaches it at {f:.2} x today's value ({value})")
            }
            None => format!(
                "does not reach it within {:.2}-{:.2} x ({:.0} % at the limit)",
                s.range[0],
                s.range[1],
                100.0 * s.ratio_at_limit
            ),
        };
        text.push_str(&format!(" {what} (sd ~ factor^{:.2}) {reach};", s.exponent));
    }
    text.pop();
    text.push('.');
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_model_information_is_exact() {
        // a_i = theta * x_i: sd = sigma / |x|.
        let jac = vec![(0..100)
            .map(|i| (i as f64 * 0.1).sin())
            .collect::<Vec<f64>>()];
        let norm: f64 = jac[0].iter().map(|v| v * v).sum::<f64>().sqrt();
        let sd = fisher_sd(&jac, 0.02, None, &[f64::INFINITY]).unwrap();
        approx::assert_relative_eq!(sd[0], 0.02 / norm, max_relative = 1e-12);
        // A prior sd combines in precision.
        let sd = fisher_sd(&jac, 0.02, None, &[0.02 / norm]).unwrap();
        approx::assert_relative_eq!(sd[0], 0.02 / norm / 2f64.sqrt(), max_relative = 1e-12);
    }

    #[test]
    fn ar1_information_matches_the_whitened_sum() {
        // For a constant regressor, AR(1) errors carry less information:
        // F = (1 - rho^2 + (n - 1)(1 - rho)^2) / (sigma^2 (1 - rho^2)).
        let n = 50;
        let (sigma, rho) = (0.1, 0.6);
        let jac = vec![vec![1.0; n]];
        let sd = fisher_sd(&jac, sigma, Some(rho), &[f64::INFINITY]).unwrap();
        let f = (1.0 - rho * rho + (n - 1) as f64 * (1.0 - rho) * (1.0 - rho))
            / (sigma * sigma * (1.0 - rho * rho));
        approx::assert_relative_eq!(sd[0], 1.0 / f.sqrt(), max_relative = 1e-12);
    }

    #[test]
    fn singular_information_is_none() {
        let jac = vec![vec![1.0, 2.0], vec![2.0, 5.0]];
        assert!(fisher_sd(&jac, 1.0, None, &[f64::INFINITY; 2]).is_some());
        let jac = vec![vec![1.0, 2.0], vec![2.0, 4.0]];
        assert!(fisher_sd(&jac, 1.0, None, &[f64::INFINITY; 2]).is_none());
    }

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = [0.5, 1.0, 2.0, 4.0]
            .iter()
            .map(|&f: &f64| (f, f.powf(-0.5)))
            .collect();
        approx::assert_relative_eq!(slope(&pts), -0.5, max_relative = 1e-12);
    }
}
