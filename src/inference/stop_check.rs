//! Checks a stop rule's Monte Carlo standard errors against the spread
//! they claim to measure.
//!
//! A run stopped at an effective sample size `N` claims, for each
//! parameter, that its posterior mean is off by about
//! `MCSE = sd / sqrt(ESS)`. Over many independent runs on a target whose
//! means are known, the observed errors `mean - truth` must then have that
//! size: the ratio of their root mean square to the root mean square of
//! the claimed standard errors is 1 for an honest rule. An ESS taken from
//! a `tau` estimated on too short a window is too large, and the ratio
//! exceeds 1 (Sokal 1997, sec. 3; emcee's guidance of 50 `tau`, Foreman-
//! Mackey et al. 2013). [`check_rule`] measures the ratio, and the targets
//! here are the sampler tests' own: a correlated 10-D Gaussian and the
//! Rosenbrock density of Goodman & Weare (2010).
//!
//! The runs are started the way a fit starts them (a ball around the mode,
//! [`conditional_scales`] wide), so burn-in is part of what is checked.
//! No crate validates an MCMC stop rule; the computation is a few sums.

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rayon::prelude::*;
use thiserror::Error;

use super::ensemble::{FnDensity, LogDensity, SamplerError};
use super::likelihood::Noise;
use super::map::{find_map, MapError, MapSettings};
use super::posterior::{Posterior, PosteriorError};
use super::sample::{conditional_scales, sample_posterior, SampleError, SampleSettings};
use crate::data::{synthesize, RecordError};
use crate::model::{Model, ModelSpec, Params, SimError};

/// Why a target could not be built.
#[derive(Debug, Error)]
pub enum TargetError {
    /// The record could not be simulated.
    #[error("simulating the record")]
    Simulate(#[from] SimError),
    /// The record could not be aligned.
    #[error("aligning the record")]
    Record(#[from] RecordError),
    /// The posterior could not be set up.
    #[error("setting up the posterior")]
    Posterior(#[from] PosteriorError),
    /// The MAP search failed.
    #[error("finding the MAP")]
    Map(#[from] MapError),
    /// The sampler failed (the starting scales or the reference run).
    #[error("the reference run")]
    Sample(#[from] SampleError),
    /// The sampler's density failed.
    #[error("the starting scales")]
    Sampler(#[from] SamplerError),
}

/// A target density with known means, and where a run starts.
pub struct Target {
    /// A name for reports.
    pub name: String,
    density: Box<dyn LogDensity + Send>,
    /// The true mean of each coordinate.
    pub mean: Vec<f64>,
    mode: Vec<f64>,
    /// How far [`conditional_scales`] may look from the mode.
    range: Vec<f64>,
}

impl Target {
    /// `density` with true means `mean`, runs started around `mode`, whose
    /// starting scales are searched within `range` of it.
    pub fn new(
        name: &str,
        density: Box<dyn LogDensity + Send>,
        mean: Vec<f64>,
        mode: Vec<f64>,
        range: Vec<f64>,
    ) -> Self {
        Self {
            name: name.to_string(),
            density,
            mean,
            mode,
            range,
        }
    }

    /// A 10-D Gaussian with covariance `Q diag(lambda) Q^T`, `lambda`
    /// log-spaced from 0.01 to 100 (condition number 1e4), `Q` a rotation
    /// drawn from seed 2024, and mean `(1, 2, ..., 10)`.
    pub fn correlated_gaussian() -> Self {
        let d = 10;
        let mut rng = StdRng::seed_from_u64(2024);
        let a = DMatrix::from_fn(d, d, |_, _| rng.sample::<f64, _>(StandardNormal));
        let q = a.qr().q();
        let lambda = DVector::from_fn(d, |i, _| 10f64.powf(-2.0 + 4.0 * i as f64 / (d - 1) as f64));
        let prec = &q * DMatrix::from_diagonal(&lambda.map(|l| 1.0 / l)) * q.transpose();
        let mean: Vec<f64> = (1..=d).map(|i| i as f64).collect();
        let m = mean.clone();
        let f = move |x: &[f64]| {
            let v = DVector::from_fn(d, |i, _| x[i] - m[i]);
            -0.5 * (v.transpose() * &prec * &v)[0]
        };
        Self::new(
            "gaussian-10d",
            Box::new(FnDensity::new(d, f)),
            mean.clone(),
            mean,
            vec![100.0; d],
        )
    }

    /// The Rosenbrock density `exp(-(100 (x2 - x1^2)^2 + (1 - x1)^2) / 20)`:
    /// `x1 ~ N(1, 10)`, `x2 | x1 ~ N(x1^2, 0.1)`, so `E x = (1, 11)`; mode
    /// `(1, 1)`. A banana with a heavy tail in `x2`.
    pub fn rosenbrock() -> Self {
        let f = |x: &[f64]| -(100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2)) / 20.0;
        Self::new(
            "rosenbrock",
            Box::new(FnDensity::new(2, f)),
            vec![1.0, 11.0],
            vec![1.0, 1.0],
            vec![100.0, 100.0],
        )
    }
}

impl Target {
    /// The posterior of `trilinear+lcfm+viscous` (default priors, white
    /// noise) on a record of Test 5 (Table 8.1 column 5, 10 s at 200 Hz,
    /// noise sd 1.5 % of the peak, seed 3: the inference bench's), runs
    /// started at its MAP. Its means are those of one long run of the
    /// default sampler stopped at ESS `reference_ess` (seed `u64::MAX`,
    /// not one a check uses): at 100,000 their error is a tenth in sd of
    /// that of runs stopped at 1,000.
    pub fn test5_posterior(reference_ess: f64) -> Result<Self, TargetError> {
        let spec = ModelSpec::FULL;
        let truth = Params::table_8_1(5).expect("column 5").to_theta(&spec);
        let mut rng = StdRng::seed_from_u64(3);
        let syn = synthesize(&Model::from(spec), &truth, 0.005, 2001, 0.015, &mut rng)?;
        let data = syn.record.aligned(None)?;
        let post = Posterior::with_default_priors(Model::from(spec), data, Noise::White)?;
        let map = find_map(
            &post,
            &MapSettings::default(),
            &mut StdRng::seed_from_u64(1),
        )?;
        let (lo, hi) = post.priors().box_bounds();
        let range: Vec<f64> = lo.iter().zip(&hi).map(|(l, h)| h - l).collect();
        let scale = conditional_scales(&post, &map.theta, &range)?;
        let long = SampleSettings::default()
            .with_ess(reference_ess)?
            .with_max_steps(200_000)?;
        let names = post.names().to_vec();
        let s = sample_posterior(
            &post,
            &names,
            &map.theta,
            &scale,
            &long,
            u64::MAX,
            None,
            "",
            &mut |_| {},
        )?;
        let mean = s
            .draws()
            .iter()
            .map(|x| x.iter().sum::<f64>() / x.len() as f64)
            .collect();
        Ok(Self::new(
            "test5-posterior",
            Box::new(post),
            mean,
            map.theta,
            range,
        ))
    }
}

/// What [`check_rule`] measured over its runs.
#[derive(Debug, Clone)]
pub struct RuleCheck {
    /// Runs made.
    pub runs: usize,
    /// Runs the stop rule ended (the rest spent their budget).
    pub converged: usize,
    /// Per coordinate: RMS of `mean - truth` over the runs, divided by the
    /// RMS of the claimed `sd / sqrt(ESS)`.
    pub ratio: Vec<f64>,
    /// The same ratio pooled over coordinates, each coordinate's errors
    /// measured in its claimed standard errors: `sqrt(mean z^2)`.
    pub pooled: f64,
    /// Monte Carlo standard error of `pooled` (delta method on the runs'
    /// mean `z^2`, which keeps the coordinates of one run together).
    pub pooled_se: f64,
    /// Mean steps per ensemble.
    pub steps: f64,
    /// Mean log-density evaluations per run.
    pub evaluations: f64,
}

/// Runs `runs` independent samplers with `settings` on `target`, run `r`
/// seeded `seed + r`, and measures the claimed against the observed errors
/// of the posterior means.
pub fn check_rule(
    target: &Target,
    settings: &SampleSettings,
    runs: usize,
    seed: u64,
) -> Result<RuleCheck, SampleError> {
    let d = target.mean.len();
    let names: Vec<String> = (0..d).map(|k| format!("x{k}")).collect();
    let density = &*target.density;
    let scale = conditional_scales(density, &target.mode, &target.range)?;
    let results = (0..runs)
        .into_par_iter()
        .map(|r| {
            let s = sample_posterior(
                density,
                &names,
                &target.mode,
                &scale,
                settings,
                seed.wrapping_add(r as u64),
                None,
                "",
                &mut |_| {},
            )?;
            let mut err2 = vec![0.0; d];
            let mut mcse2 = vec![0.0; d];
            for (k, x) in s.draws().iter().enumerate() {
                let n = x.len() as f64;
                let mean = x.iter().sum::<f64>() / n;
                let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
                err2[k] = (mean - target.mean[k]).powi(2);
                mcse2[k] = var / s.ess[k];
            }
            Ok((err2, mcse2, s.converged, s.steps(), s.evaluations))
        })
        .collect::<Result<Vec<_>, SampleError>>()?;
    let n = runs as f64;
    let ratio = (0..d)
        .map(|k| {
            let e: f64 = results.iter().map(|r| r.0[k]).sum();
            let c: f64 = results.iter().map(|r| r.1[k]).sum();
            (e / c).sqrt()
        })
        .collect();
    let z2: Vec<f64> = results
        .iter()
        .map(|r| (0..d).map(|k| r.0[k] / r.1[k]).sum::<f64>() / d as f64)
        .collect();
    let m = z2.iter().sum::<f64>() / n;
    let var = z2.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    // d sqrt(m) = dm / (2 sqrt(m))
    let pooled_se = (var / n).sqrt() / (2.0 * m.sqrt());
    Ok(RuleCheck {
        runs,
        converged: results.iter().filter(|r| r.2).count(),
        ratio,
        pooled: m.sqrt(),
        pooled_se,
        steps: results.iter().map(|r| r.3 as f64).sum::<f64>() / n,
        evaluations: results.iter().map(|r| r.4 as f64).sum::<f64>() / n,
    })
}
