//! One record, end to end: the MAP, the posterior, its summaries, the
//! identifiability report and, given the released force and the static
//! friction, the posterior of the physical quantities of Table 8.2.
//!
//! This is what `hbis fit` runs; library users get the same in one call.
//!
//! ```no_run
//! use hbis::data::Record;
//! use hbis::inference::Noise;
//! use hbis::study::{fit_record, FitOptions};
//!
//! let data = Record::read("record.csv".as_ref())?.aligned(None)?;
//! let model: hbis::model::Model = "trilinear+lcfm+viscous+offset".parse()?;
//! let fit = fit_record(model, data, None, Noise::White, &FitOptions::default(), &mut |_| {})?;
//! for (name, s) in fit.names().iter().zip(fit.summaries.as_ref().unwrap()) {
//!     println!("{name}: {:.5} ± {:.5}", s.mean, s.sd);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::PathBuf;

use rand::rngs::StdRng;
use rand::SeedableRng;
use thiserror::Error;

use crate::data::Aligned;
use crate::inference::basins::{self, Basin};
use crate::inference::design::{design_table, DesignError, DesignInput, DesignTable};
use crate::inference::identifiability::{self, Identifiability, ParamInfo, Segments};
use crate::inference::pipeline::{compare, fit_map, laplace_evidence, Comparison, PipelineError};
use crate::inference::summary::{covariance, ParamSummary};
use crate::inference::{
    conditional_scales, sample_posterior, MapError, MapEstimate, MapSettings, Noise, Posterior,
    PosteriorError, PosteriorSample, PriorError, Priors, Progress, SampleError, SampleSettings,
};
use crate::model::physical::Physical;
use crate::model::{ForwardModel, Model, ModelSpec, Response, SimError};

/// Why a study failed.
#[derive(Debug, Error)]
pub enum StudyError {
    /// Priors.
    #[error(transparent)]
    Prior(#[from] PriorError),
    /// The posterior.
    #[error(transparent)]
    Posterior(#[from] PosteriorError),
    /// The MAP search.
    #[error("MAP search")]
    Map(#[from] MapError),
    /// Posterior sampling.
    #[error("posterior sampling")]
    Sample(#[from] SampleError),
    /// Simulating at the MAP.
    #[error("simulation at the MAP")]
    Sim(#[from] SimError),
    /// A stage shared with criticism (MAP, release placement, evidence).
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The design table.
    #[error("design table")]
    Design(#[from] DesignError),
    /// Released force and static friction are inconsistent.
    #[error("physical quantities")]
    Physical(#[from] crate::model::physical::PhysicalError),
}

/// What to run.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Seed of every random number.
    pub seed: u64,
    /// The MAP search.
    pub map: MapSettings,
    /// The posterior run; `None` for the MAP only.
    pub sample: Option<SampleSettings>,
    /// Folder to checkpoint the posterior run in (and resume from).
    pub checkpoint: Option<PathBuf>,
    /// Released force `F0^n` and static friction `F_fS` (kN), for Table 8.2.
    pub forces: Option<(f64, f64)>,
    /// Text that identifies the record in the checkpoint's fingerprint.
    pub label: String,
    /// Also compute the Laplace log-evidence at the MAP (covariance from a
    /// finite-difference Hessian).
    pub evidence: bool,
    /// The design table's target for the weakest parameter: its sd as a
    /// fraction of today's, in (0, 1); `None` for no table.
    pub design_target: Option<f64>,
}

impl FitOptions {
    /// The MAP only (`hbis fit --map-only --no-design --seed SEED`): no
    /// posterior run, no design table.
    pub fn map_only(seed: u64) -> Self {
        Self {
            seed,
            sample: None,
            design_target: None,
            ..Self::default()
        }
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            map: MapSettings::default(),
            sample: Some(SampleSettings::default()),
            checkpoint: None,
            forces: None,
            label: String::new(),
            evidence: false,
            design_target: Some(0.5),
        }
    }
}

/// A fitted record.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The posterior (model, record, priors, noise).
    pub posterior: Posterior<Model>,
    /// The MAP.
    pub map: MapEstimate,
    /// The second MAP search, when the first left a structured residual.
    pub second_search: Option<SecondSearch>,
    /// BIC and the maximised log-likelihood at the MAP.
    pub comparison: Comparison,
    /// Laplace log-evidence at the MAP, if asked for.
    pub log_evidence: Option<f64>,
    /// The posterior sample, if run.
    pub sample: Option<PosteriorSample>,
    /// Per-parameter summaries of the sample.
    pub summaries: Option<Vec<ParamSummary>>,
    /// Posterior covariance matrix.
    pub covariance: Option<Vec<Vec<f64>>>,
    /// The identifiability report.
    pub identifiability: Option<Identifiability>,
    /// What test would determine the weakest parameter to the target.
    pub design: Option<DesignTable>,
    /// Posterior of `m, k0, k1, k2, kF, c` (Table 8.2 units), if forces were given.
    pub physical: Option<Vec<(String, ParamSummary)>>,
    /// The physical quantities at the MAP, if forces were given.
    pub physical_map: Option<Physical>,
    /// Released force `F0^n` and static friction `F_fS` (kN), if given.
    pub forces: Option<(f64, f64)>,
    /// The posterior's basins found by the MAP search, the MAP's first
    /// (one when the posterior has a single basin), each with its share
    /// of the kept draws once sampled.
    pub basins: Vec<Basin>,
}

impl Fit {
    /// Parameter names.
    pub fn names(&self) -> &[String] {
        self.posterior.names()
    }
}

pub use crate::inference::map::SecondSearch;

/// [`SecondSearch::reason`]: the first MAP's residual was structured.
pub const STRUCTURED: &str = "structured residual";
/// [`SecondSearch::reason`]: the first search's runs never ended twice in
/// its best basin ([`crate::inference::MapEstimate::best_repeated`]).
pub const NOT_REPEATED: &str = "best not found twice";

/// Fits `data` with `model`: MAP, then (if asked) the posterior and its
/// reports. `priors = None` uses the defaults the model's components
/// declare.
pub fn fit_record(
    model: impl Into<Model>,
    data: Aligned,
    priors: Option<Priors>,
    noise: Noise,
    options: &FitOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Fit, StudyError> {
    let model: Model = model.into();
    if options.forces.is_some() {
        crate::model::physical::check_convertible(&model)?;
    }
    let priors = priors.unwrap_or_else(|| Posterior::default_priors(&model, noise));
    let mut rng = StdRng::seed_from_u64(options.seed);
    let mut fit = fit_map(
        model.clone(),
        data,
        priors,
        noise,
        &options.map,
        None,
        &mut rng,
    )?;
    let structured = crate::criticism::sanity::structured_at(&fit.posterior, &fit.map.theta);
    let mut ends = fit.map.ends.clone();
    let reason = if structured.is_some() {
        Some(STRUCTURED)
    } else {
        (fit.map.best_repeated == Some(false)).then_some(NOT_REPEATED)
    };
    let second_search = if let Some(reason) = reason {
        let again = fit_map(
            model.clone(),
            fit.posterior.data().clone(),
            fit.posterior.priors().clone(),
            noise,
            &options.map.clone().with_initial(None)?,
            None,
            &mut rng,
        )?;
        let (first, second) = (fit.map.eval.log_posterior, again.map.eval.log_posterior);
        let s = SecondSearch {
            reason,
            first_log_posterior: first,
            second_log_posterior: second,
            evaluations: again.map.evaluations(),
            kept_second: second > first,
        };
        ends.extend(again.map.ends.iter().cloned());
        if s.kept_second {
            fit = again;
        }
        Some(s)
    } else {
        None
    };
    let (posterior, map) = (fit.posterior, fit.map);
    let lp = |x: &[f64]| posterior.log_posterior(x);
    let basins = basins::find(&lp, &map.theta, map.eval.log_posterior, &ends)?;
    let names = posterior.names().to_vec();
    let spec = model.spec();
    let comparison = compare(&posterior, &map.theta)?;
    let log_evidence = if options.evidence {
        Some(laplace_evidence(&posterior, &map.theta, map.eval.log_posterior)?.log_evidence)
    } else {
        None
    };
    let physical_map = match options.forces {
        Some((f, s)) => Some(Physical::from_params(
            &spec,
            &model
                .core_params(posterior.model_part(&map.theta))
                .map_err(SimError::from)?,
            f,
            s,
        )?),
        None => None,
    };
    let mut fit = Fit {
        posterior,
        map,
        second_search,
        comparison,
        log_evidence,
        sample: None,
        summaries: None,
        covariance: None,
        identifiability: None,
        design: None,
        physical: None,
        physical_map,
        forces: options.forces,
        basins,
    };
    let Some(settings) = &options.sample else {
        return Ok(fit);
    };
    let (lo, hi) = fit.posterior.priors().box_bounds();
    let range: Vec<f64> = lo.iter().zip(&hi).map(|(l, h)| h - l).collect();
    let scale =
        conditional_scales(&fit.posterior, &fit.map.theta, &range).map_err(SampleError::from)?;
    let label = format!("{} {} {}", model.name(), noise.as_str(), options.label);
    // Walkers start in every basin: the draws, not a Gaussian at the MAP,
    // then say how the posterior spreads over them.
    let settings = &settings
        .clone()
        .with_basins(fit.basins[1..].iter().map(|b| b.theta.clone()).collect());
    let sample = sample_posterior(
        &fit.posterior,
        &names,
        &fit.map.theta,
        &scale,
        settings,
        options.seed,
        options.checkpoint.as_deref(),
        &label,
        progress,
    )?;
    let draws = sample.draws();
    let summaries: Vec<ParamSummary> = sample.summaries();
    if fit.basins.len() > 1 {
        let sd: Vec<f64> = summaries.iter().map(|s| s.sd).collect();
        basins::shares(&mut fit.basins, &sample.points(), &sd);
    } else if let Some(b) = fit.basins.first_mut() {
        b.share = Some(1.0);
    }
    let cov = covariance(&draws);
    let prior_sd: Vec<f64> = fit
        .posterior
        .priors()
        .priors()
        .iter()
        .map(|p| p.sd())
        .collect();
    let effects = effects(&fit.posterior, &fit.map.theta, &summaries)?;
    let sigma = (fit.map.eval.sse / fit.posterior.data().a.len() as f64).sqrt();
    let segments = segments(
        &model,
        fit.posterior.model_part(&fit.map.theta),
        fit.posterior.data(),
    )?;
    let info = param_info(&model, &names);
    let mut ident = identifiability::report(
        &names,
        &info,
        &summaries,
        &cov,
        &prior_sd,
        &effects,
        sigma,
        Some(&segments),
    );
    if let Some(note) = basins_note(&fit.basins, &names, &ident.weakest) {
        ident.explanation = format!("{} {note}", ident.explanation);
    }
    if let Some(target) = options.design_target {
        let w = names.iter().position(|n| n == &ident.weakest).unwrap_or(0);
        let mean: Vec<f64> = summaries.iter().map(|s| s.mean).collect();
        let sd: Vec<f64> = summaries.iter().map(|s| s.sd).collect();
        let input = DesignInput {
            mean: &mean,
            sd: &sd,
            prior_sd: &prior_sd,
            sigma,
            parameter: w,
            unit: &info[w].unit,
            target_ratio: target,
            step: 0.2,
        };
        fit.design = Some(design_table(&fit.posterior, &input)?);
    }
    if let Some((f, s)) = options.forces {
        fit.physical = Some(physical_posterior(&fit.posterior, &sample, f, s)?);
    }
    fit.summaries = Some(summaries);
    fit.covariance = Some(cov);
    fit.identifiability = Some(ident);
    fit.sample = Some(sample);
    Ok(fit)
}

/// Where the posterior has several basins, the weakest parameter in each
/// and their shares of the draws: its interval spans them.
fn basins_note(basins: &[Basin], names: &[String], weakest: &str) -> Option<String> {
    let k = names.iter().position(|n| n == weakest)?;
    if basins.len() < 2 {
        return None;
    }
    let each: Vec<String> = basins
        .iter()
        .map(|b| {
            format!(
                "{weakest} = {:.4e} ({:.0} % of the draws)",
                b.theta[k],
                100.0 * b.share.unwrap_or(f64::NAN)
            )
        })
        .collect();
    Some(format!(
        "The posterior has {} basins (the MAP search ended in places {} nats of fall apart): {}; its interval spans them.",
        basins.len(),
        basins[1..]
            .iter()
            .map(|b| format!("{:.0}", b.barrier))
            .collect::<Vec<_>>()
            .join(", "),
        each.join(", ")
    ))
}

/// Each parameter's declared scale, unit and meaning (the noise model's
/// `rho` declared here).
fn param_info(model: &Model, names: &[String]) -> Vec<ParamInfo> {
    let specs = model.params();
    names
        .iter()
        .map(|n| match specs.iter().find(|s| &s.name == n) {
            Some(s) => ParamInfo {
                name: n.clone(),
                scale: s.scale,
                unit: s.unit.clone(),
                meaning: if s.shows.is_empty() {
                    s.meaning.clone()
                } else {
                    s.shows.clone()
                },
            },
            None => ParamInfo {
                name: n.clone(),
                scale: 0.01,
                unit: "-".into(),
                meaning: "the correlation of successive measurement errors".into(),
            },
        })
        .collect()
}

/// Change of the model acceleration for a one-sd change of each parameter
/// (central differences at the MAP, kept inside the prior's support).
fn effects(
    posterior: &Posterior<Model>,
    theta: &[f64],
    summaries: &[ParamSummary],
) -> Result<Vec<Vec<f64>>, StudyError> {
    let (lo, hi) = posterior.priors().box_bounds();
    let mut out = Vec::with_capacity(theta.len());
    let noise = posterior.layout().blocks()[1].range();
    for k in 0..theta.len() {
        if noise.contains(&k) {
            // Noise parameters do not move the model.
            out.push(vec![0.0; posterior.data().a.len()]);
            continue;
        }
        let h = summaries[k].sd;
        let mut plus = theta.to_vec();
        let mut minus = theta.to_vec();
        plus[k] = (theta[k] + h).min(hi[k]);
        minus[k] = (theta[k] - h).max(lo[k]);
        let span = plus[k] - minus[k];
        let (a, b) = (posterior.model_accel(&plus), posterior.model_accel(&minus));
        match (a, b) {
            (Ok(a), Ok(b)) if span > 0.0 => {
                out.push(a.iter().zip(&b).map(|(x, y)| (x - y) * h / span).collect())
            }
            _ => out.push(vec![0.0; posterior.data().a.len()]),
        }
    }
    Ok(out)
}

/// Phase, half-cycle and closeness to reversals of each sample at the MAP
/// `theta` (the model's parameters), from the closed-form core's motion.
pub fn segments(model: &Model, theta: &[f64], data: &Aligned) -> Result<Segments, StudyError> {
    let p = model.core_params(theta).map_err(SimError::from)?;
    let duration = data.duration();
    let r = Response::simulate(&model.spec(), &p, duration)?;
    let samples = r.sample_grid(data.dt)?;
    let n = data.a.len().min(samples.len());
    let mut half_cycle = vec![0usize; n];
    let mut reversal_at = Vec::new();
    let mut hc = 0;
    for i in 0..n {
        if i > 0 && samples[i - 1].v * samples[i].v < 0.0 {
            hc += 1;
            reversal_at.push(i);
        }
        half_cycle[i] = hc;
    }
    let mut near = vec![false; n];
    for &i in &reversal_at {
        for flag in &mut near[i.saturating_sub(2)..(i + 2).min(n)] {
            *flag = true;
        }
    }
    // The release is a reversal too (the mass starts at rest).
    for flag in near.iter_mut().take(2) {
        *flag = true;
    }
    let mut amplitude = vec![0.0f64; hc + 1];
    for i in 0..n {
        amplitude[half_cycle[i]] = amplitude[half_cycle[i]].max(samples[i].u.abs());
    }
    Ok(Segments {
        phase: samples[..n]
            .iter()
            .map(|s| s.phase.as_str().to_string())
            .collect(),
        half_cycle,
        near_reversal: near,
        amplitude,
    })
}

/// Table 8.2 quantities for (a thinned set of) posterior draws.
fn physical_posterior(
    posterior: &Posterior<Model>,
    sample: &PosteriorSample,
    released: f64,
    friction: f64,
) -> Result<Vec<(String, ParamSummary)>, StudyError> {
    let points = sample.points();
    let stride = (points.len() / 20_000).max(1);
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); 6];
    for x in points.iter().step_by(stride) {
        let q = physical_of(posterior, x, released, friction)?;
        for (c, v) in cols.iter_mut().zip(q) {
            c.push(v);
        }
    }
    Ok(PHYSICAL_NAMES
        .iter()
        .zip(cols)
        .map(|(n, c)| (n.to_string(), ParamSummary::from_draws(&c)))
        .collect())
}

/// The names of eq. 8.1's quantities per draw, in [`physical_of`]'s order.
pub const PHYSICAL_NAMES: [&str; 6] = ["m", "k0", "k1", "k2", "kF", "c"];

/// Eq. 8.1 of one posterior point `x` (all of the posterior's parameters):
/// `m, k0, k1, k2, kF, c` in Table 8.2's units, from the released force and
/// the static friction (kN).
pub fn physical_of(
    posterior: &Posterior<Model>,
    x: &[f64],
    released: f64,
    friction: f64,
) -> Result<[f64; 6], StudyError> {
    let model = posterior.model();
    let p = model
        .core_params(posterior.model_part(x))
        .map_err(SimError::from)?;
    let q = Physical::from_params(&model.spec(), &p, released, friction)?;
    Ok([q.m, q.k0, q.k1, q.k2, q.kf, q.c])
}

/// Lower and upper edges of a band, one value per sample.
pub type Band = (Vec<f64>, Vec<f64>);

/// The 90 % posterior-predictive band of the record: for up to `draws`
/// posterior points (evenly spaced through the kept draws), the model's
/// acceleration plus Gaussian noise of that point's residual level
/// `sqrt(sse/n)`; the 5 % and 95 % quantiles at each sample. Seeded.
pub fn predictive_band(fit: &Fit, draws: usize, seed: u64) -> Result<Option<Band>, StudyError> {
    use rand_distr::{Distribution, StandardNormal};
    let Some(sample) = &fit.sample else {
        return Ok(None);
    };
    let points = sample.points();
    let stride = (points.len() / draws.max(1)).max(1);
    let n = fit.posterior.data().a.len();
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5EED_BA4D_0000_0001);
    let mut sims: Vec<Vec<f64>> = Vec::new();
    for x in points.iter().step_by(stride).take(draws) {
        let a = fit.posterior.model_accel(x)?;
        let sse: f64 = a
            .iter()
            .zip(&fit.posterior.data().a)
            .map(|(m, d)| (d - m).powi(2))
            .sum();
        let sigma = (sse / n as f64).sqrt();
        sims.push(
            a.iter()
                .map(|m| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    m + sigma * z
                })
                .collect(),
        );
    }
    let mut lo = Vec::with_capacity(n);
    let mut hi = Vec::with_capacity(n);
    let mut col = vec![0.0; sims.len()];
    for i in 0..n {
        for (c, s) in col.iter_mut().zip(&sims) {
            *c = s[i];
        }
        col.sort_unstable_by(f64::total_cmp);
        lo.push(crate::inference::summary::quantile(&col, 0.05));
        hi.push(crate::inference::summary::quantile(&col, 0.95));
    }
    Ok(Some((lo, hi)))
}

/// Coverage of 90 % credible intervals on synthetic records.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Coverage {
    /// Model spec.
    pub model: String,
    /// Records fitted.
    pub records: usize,
    /// Parameter names.
    pub names: Vec<String>,
    /// How many records' 90 % interval (5-95 % quantiles) held the truth, per parameter.
    pub covered: Vec<usize>,
    /// Ranks of the truth among thinned posterior draws (0..=draws), per record and parameter, for SBC histograms.
    pub ranks: Vec<Vec<usize>>,
}

impl Coverage {
    /// Fraction covered over all parameters and records.
    pub fn overall(&self) -> f64 {
        self.covered.iter().sum::<usize>() as f64 / (self.records * self.names.len()).max(1) as f64
    }
}

/// Simulation-based calibration: `records` synthetic records (10 s at
/// 200 Hz, `noise` times the peak |a|), each made from a truth drawn by
/// perturbing a Table 8.1 column (cycled) by up to ±`spread` (relative,
/// uniform) and restricted to `spec`; each fitted with `options` (its seed is
/// replaced by one per record, derived from `seed`).
pub fn coverage(
    spec: ModelSpec,
    records: usize,
    noise: f64,
    spread: f64,
    seed: u64,
    options: &FitOptions,
) -> Result<Coverage, StudyError> {
    use rand::RngExt;
    let names: Vec<String> = spec
        .param_names()
        .iter()
        .map(|p| p.as_str().to_string())
        .collect();
    let mut covered = vec![0usize; names.len()];
    let mut ranks = Vec::new();
    let tests = [3, 5, 6, 7, 8];
    for r in 0..records {
        let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(1_000_003).wrapping_add(r as u64));
        let base = crate::model::Params::table_8_1(tests[r % 5]).expect("Table 8.1");
        let base = spec.restrict(&base).map_err(SimError::from)?;
        // Redraw until the perturbed set is valid and reaches u3 (tri-linear).
        let truth = loop {
            let mut t = base.to_theta(&spec);
            for v in t.iter_mut() {
                *v *= 1.0 + spread * (2.0 * rng.random::<f64>() - 1.0);
            }
            if spec.params_from_slice(&t).is_ok() && spec.in_support(&t) {
                break t;
            }
        };
        let syn =
            crate::data::synthesize(&Model::from(spec), &truth, 0.005, 2001, noise, &mut rng)?;
        let data = syn.record.aligned(None).expect("a synthetic record aligns");
        let mut opts = options.clone();
        opts.seed = rng.random();
        opts.checkpoint = None;
        let fit = fit_record(spec, data, None, Noise::White, &opts, &mut |_| {})?;
        let (Some(sums), Some(sample)) = (&fit.summaries, &fit.sample) else {
            continue;
        };
        let draws = sample.draws();
        let mut rec_ranks = Vec::new();
        for k in 0..names.len() {
            if sums[k].q05 <= truth[k] && truth[k] <= sums[k].q95 {
                covered[k] += 1;
            }
            let stride = (draws[k].len() / 100).max(1);
            rec_ranks.push(
                draws[k]
                    .iter()
                    .step_by(stride)
                    .take(100)
                    .filter(|v| **v < truth[k])
                    .count(),
            );
        }
        ranks.push(rec_ranks);
    }
    Ok(Coverage {
        model: spec.to_string(),
        records,
        names,
        covered,
        ranks,
    })
}
