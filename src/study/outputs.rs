//! A fit's files: `fit.json`, `fit.csv`, the CmdStan chains, the figures
//! and `report.html`, each written atomically into a locked [`OutDir`]; the
//! checkpoint's removal once they are; the release in one line.
//!
//! `hbis fit`, `hbis demo`, `hbis batch` and the Python package's
//! `Fit.write` all write through [`write_fit`], so their files agree.

use std::collections::BTreeMap;
use std::path::Path;

use thiserror::Error;

use crate::data::{Aligned, Warning};
use crate::inference::Noise;
use crate::model::ForwardModel;
use crate::report::json::{
    BasinReport, Correlation, DataInfo, FitReport, IdentifiabilityReport, SamplingInfo,
};
use crate::report::outdir::{OutDir, OutError};
use crate::study::{predictive_band, Fit, StudyError};

/// Why a fit's files could not be written.
#[derive(Debug, Error)]
pub enum OutputError {
    /// A file of the output folder.
    #[error(transparent)]
    Out(#[from] OutError),
    /// Serialising a report.
    #[error("serialising the report")]
    Json(#[from] serde_json::Error),
    /// The predictive band or the MAP's response.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// The MAP's response.
    #[error("simulation at the MAP")]
    Sim(#[from] crate::model::SimError),
    /// A figure.
    #[cfg(feature = "figures")]
    #[error(transparent)]
    Figure(#[from] crate::report::figures::FigureError),
}

/// What becomes of the draws and the checkpoint after a fit; the default
/// (the demo's) is thinned chains written and no checkpoint left.
#[derive(Debug, Clone, Default)]
pub struct ChainOptions {
    /// Write every N-th step of the chains (`None`: half the largest
    /// autocorrelation time, `sampling.thin` in fit.json; 1 keeps all).
    pub thin: Option<usize>,
    /// Write no chain files (fit.json still has the summaries).
    pub no_chains: bool,
    /// Keep the sampler's checkpoint after a successful run.
    pub keep_checkpoint: bool,
}

/// How a fit was run, as its files record it.
#[derive(Debug, Clone)]
pub struct FitRun {
    /// The record as the user named it (`data.source` in fit.json).
    pub source: String,
    /// The seed of every random number.
    pub seed: u64,
    /// The measurement-error model.
    pub noise: Noise,
    /// The record's own warnings, first in fit.json's `warnings`.
    pub record_warnings: Vec<Warning>,
    /// Chains and checkpoint.
    pub chains: ChainOptions,
}

/// `fit.json`: the record's warnings first, then the fit's; `thin` is the
/// chains' thinning (`None` without a sample or chains).
pub fn fit_report(fit: &Fit, run: &FitRun, chains: Vec<String>, thin: Option<usize>) -> FitReport {
    let (model, seed, noise) = (fit.posterior.model().name(), run.seed, run.noise);
    let data = DataInfo::new(&run.source, fit.posterior.data());
    let mut r = FitReport::from_map(&model, seed, noise, data, &fit.map);
    r.map_second_search = fit.second_search;
    r.max_log_likelihood = Some(fit.comparison.log_likelihood);
    r.bic = Some(fit.comparison.bic);
    r.log_evidence = fit.log_evidence;
    let names = fit.names().to_vec();
    let by_name = |v: &[f64]| -> BTreeMap<String, f64> {
        names.iter().cloned().zip(v.iter().copied()).collect()
    };
    if let Some(s) = &fit.summaries {
        r.posterior = Some(names.iter().cloned().zip(s.iter().cloned()).collect());
    }
    if let Some(id) = &fit.identifiability {
        r.ranking = Some(id.ranking.clone());
        r.weakest = Some(id.weakest.clone());
        r.explanation = Some(id.explanation.clone());
        r.identifiability = Some(IdentifiabilityReport {
            params: id.params.iter().cloned().collect(),
            design: fit.design.clone(),
        });
    }
    if let Some(c) = &fit.covariance {
        r.correlation = Some(Correlation {
            names: names.clone(),
            matrix: crate::inference::summary::correlation(c),
        });
    }
    if let Some(s) = &fit.sample {
        let tau_max: Vec<f64> = (0..names.len())
            .map(|k| s.tau.iter().map(|t| t[k]).fold(0.0, f64::max))
            .collect();
        r.sampling = Some(SamplingInfo {
            ensembles: s.chains.len(),
            walkers: s.chains.first().map_or(0, |c| c.walkers()),
            steps: s.steps(),
            burn_in: s.burn,
            converged: s.converged,
            not_converged: (!s.converged).then(|| s.not_converged.clone()),
            moves: s.moves.clone(),
            tau: by_name(&tau_max),
            ess: by_name(&s.ess),
            rhat: by_name(&s.rhat),
            acceptance: s.acceptance.clone(),
            evaluations: s.evaluations,
            chains,
            thin,
            chain_layout: "walker-major",
            wall_time_s: s.wall_time,
            checkpoint: s.checkpoint.clone(),
        });
    }
    r.physical_map = fit.physical_map;
    r.physical = fit.physical.as_ref().map(|v| v.iter().cloned().collect());
    r.warnings = crate::criticism::sanity::fit_warnings(
        &names,
        &fit.map.theta,
        fit.map.eval.e2,
        fit.posterior.priors(),
    );
    r.warnings.extend(crate::criticism::sanity::map_at_budget(
        &fit.posterior.model().name(),
        fit.map.at_budget(),
        fit.map.evaluations(),
    ));
    r.warnings.extend(crate::criticism::sanity::structured_at(
        &fit.posterior,
        &fit.map.theta,
    ));
    if let Some(s) = &fit.sample {
        let worst = s.rhat.iter().copied().fold(f64::NAN, f64::max);
        if !s.converged {
            r.warnings.push(Warning {
                code: "not-converged".into(),
                message: format!(
                    "the posterior run is not converged ({}; largest R-hat {worst:.3}): intervals may be wrong; raise --max-steps",
                    s.not_converged
                ),
            });
        }
    }
    r.basins = fit
        .basins
        .iter()
        .map(|b| BasinReport {
            theta: by_name(&b.theta),
            log_posterior: b.log_posterior,
            below_map: b.below_map,
            barrier: b.barrier,
            share: b.share,
        })
        .collect();
    r.warnings.extend(crate::criticism::sanity::several_basins(
        &fit.basins,
        fit.log_evidence.is_some(),
    ));
    r.warnings.splice(0..0, run.record_warnings.iter().cloned());
    r
}

/// Writes fit.json, fit.csv, the chains and the figures into `out`, each
/// atomically.
pub fn write_fit(
    fit: &Fit,
    out: &mut OutDir,
    run: &FitRun,
    #[cfg_attr(not(feature = "figures"), allow(unused_variables))] truth: Option<&[f64]>,
) -> Result<FitReport, OutputError> {
    let (seed, chains) = (run.seed, &run.chains);
    let spec = fit.posterior.model().name();
    let spec = spec.as_str();
    let data = fit.posterior.data();
    let mut chain_files = Vec::new();
    let mut thin = None;
    if let Some(sample) = fit.sample.as_ref().filter(|_| !chains.no_chains) {
        let every = chains
            .thin
            .unwrap_or_else(|| crate::report::cmdstan::auto_thin(sample));
        // Eq. 8.1 per draw, when the fit was given the forces.
        let forces = fit.forces;
        let of = |x: &[f64]| match forces {
            Some((f, s)) => crate::study::physical_of(&fit.posterior, x, f, s)
                .map_or_else(|_| vec![f64::NAN; 6], |q| q.to_vec()),
            None => Vec::new(),
        };
        let derived = crate::report::cmdstan::Derived {
            names: &crate::study::PHYSICAL_NAMES,
            of: &of,
        };
        let derived = forces.map(|_| &derived);
        for e in 0..sample.chains.len() {
            let name = format!("chains/chain-{}.csv", e + 1);
            out.write_with(&name, |tmp| -> std::io::Result<()> {
                let f = std::fs::File::create(tmp)?;
                let mut w = std::io::BufWriter::new(f);
                crate::report::cmdstan::write_chain(&mut w, sample, e, spec, seed, every, derived)?;
                w.into_inner().map_err(|e| e.into_error())?.sync_all()
            })?;
            chain_files.push(name);
        }
        thin = Some(every);
    }
    let report = fit_report(fit, run, chain_files, thin);
    out.write(
        "fit.json",
        (serde_json::to_string_pretty(&report)? + "\n").as_bytes(),
    )?;
    // In the record's own sign (the fit sees it mirrored if it starts positive).
    let model = data.in_record_sign(&fit.posterior.model_accel(&fit.map.theta)?);
    let measured = data.in_record_sign(&data.a);
    let band = predictive_band(fit, 200, seed)?.map(|(lo, hi)| {
        let (lo, hi) = (data.in_record_sign(&lo), data.in_record_sign(&hi));
        if data.polarity < 0.0 {
            (hi, lo)
        } else {
            (lo, hi)
        }
    });
    let t: Vec<f64> = (0..model.len()).map(|i| data.time(i)).collect();
    let mut csv = String::from("t,a_measured,a_model,residual");
    if band.is_some() {
        csv.push_str(",a_q05,a_q95");
    }
    csv.push('\n');
    for i in 0..model.len() {
        csv.push_str(&format!(
            "{},{},{},{}",
            t[i],
            measured[i],
            model[i],
            measured[i] - model[i]
        ));
        if let Some((lo, hi)) = &band {
            csv.push_str(&format!(",{},{}", lo[i], hi[i]));
        }
        csv.push('\n');
    }
    out.write("fit.csv", csv.as_bytes())?;
    // Each figure as PNG, and as SVG (fewer points) for report.html.
    #[allow(unused_mut)]
    let mut svgs: Vec<(String, String)> = Vec::new();
    #[cfg(feature = "figures")]
    {
        use crate::report::figures;
        // The phases of the MAP motion, shaded behind the record.
        let phases = crate::study::segments(
            fit.posterior.model(),
            fit.posterior.model_part(&fit.map.theta),
            data,
        )
        .ok()
        .map(|s| s.phase);
        let fit_fig = |tmp: &Path| {
            figures::fit_figure(
                tmp,
                &t,
                &measured,
                &model,
                &figures::Overlays {
                    band: band.as_ref().map(|(l, h)| (l.as_slice(), h.as_slice())),
                    scale: Some(figures::ResidualScale {
                        half: 0.0,
                        sigma: report.sigma_hat,
                        label: "±σ: residual RMS at the MAP",
                    }),
                    phases: phases.as_deref(),
                },
                &format!("{spec}: MAP fit, e2 = {:.5}", fit.map.eval.e2),
            )
        };
        out.write_with("fit.png", fit_fig)?;
        svgs.push((
            figures::svg_text(fit_fig)?,
            "Measured and model acceleration with the 90 % predictive band; the residual below."
                .into(),
        ));
        if let Some(sample) = &fit.sample {
            let points = sample.points();
            // Each parameter with its unit, as its component declares it.
            let units = units_of(fit.posterior.model(), &sample.names);
            let labels: Vec<String> = sample
                .names
                .iter()
                .zip(&units)
                .map(|(n, u)| format!("{n} ({u})"))
                .collect();
            let corner = |tmp: &Path, n: usize| {
                let stride = (points.len() / n).max(1);
                let thin: Vec<Vec<f64>> = points.iter().step_by(stride).cloned().collect();
                figures::corner_figure(
                    tmp,
                    &labels,
                    &thin,
                    Some(&fit.map.theta),
                    truth,
                    &format!(
                        "{spec}: posterior (red: MAP{}; titles: median [90 % interval])",
                        if truth.is_some() {
                            ", black: truth"
                        } else {
                            ""
                        }
                    ),
                )
            };
            out.write_with("corner.png", |tmp| corner(tmp, 3000))?;
            // The page's copy: some 12,000 dots over all the pairs, so that
            // report.html stays small however many parameters.
            let d = labels.len();
            let shown = (12_000 / (d * d.saturating_sub(1) / 2).max(1)).clamp(100, 400);
            let shown = shown.min(points.len());
            svgs.push((
                figures::svg_text(|tmp| corner(tmp, shown))?,
                format!("Posterior: marginal histograms and pairwise draws ({shown} of them here; corner.png has 3,000); red: the MAP."),
            ));
            // Three walkers of every ensemble, one colour per ensemble.
            let picks: Vec<(usize, usize)> = sample
                .chains
                .iter()
                .enumerate()
                .flat_map(|(e, c)| {
                    let step = (c.walkers() / 3).max(1);
                    (0..c.walkers()).step_by(step).take(3).map(move |w| (e, w))
                })
                .collect();
            let ensemble: Vec<usize> = picks.iter().map(|p| p.0).collect();
            let steps = sample.steps();
            let traces: Vec<Vec<Vec<f64>>> = (0..sample.names.len())
                .map(|k| {
                    picks
                        .iter()
                        .map(|&(e, w)| {
                            let c = &sample.chains[e];
                            (0..steps).map(|s| c.get(s, w)[k]).collect()
                        })
                        .collect()
                })
                .collect();
            let trace = |tmp: &Path| {
                figures::trace_figure(
                    tmp,
                    &labels,
                    &traces,
                    &ensemble,
                    sample.burn,
                    &format!(
                        "{spec}: traces, 3 walkers of each of the {} ensembles (one colour each; black line: end of burn-in)",
                        sample.chains.len()
                    ),
                )
            };
            out.write_with("trace.png", trace)?;
            svgs.push((
                figures::svg_text(trace)?,
                "Traces of three walkers of every ensemble, one colour per ensemble (here each line keeps its lowest and highest value in each of 200 columns of steps; trace.png has every step); the black line ends the burn-in.".into(),
            ));
        }
    }
    let names = fit.names().to_vec();
    let units = units_of(fit.posterior.model(), &names);
    out.write(
        "report.html",
        crate::report::html::fit_page(&report, &names, &units, &svgs).as_bytes(),
    )?;
    Ok(report)
}

/// The unit of each of `names`, as the model's components declare it;
/// `-` for the noise model's own parameters (the AR(1) `rho`).
pub fn units_of<M: ForwardModel>(model: &M, names: &[String]) -> Vec<String> {
    let specs = model.params();
    names
        .iter()
        .map(|n| {
            specs
                .iter()
                .find(|p| &p.name == n)
                .map_or_else(|| "-".to_string(), |p| p.unit.clone())
        })
        .collect()
}

/// Removes a finished run's checkpoint (the outputs are written, so it is
/// only weight: 16 MB for the demo). `state.json` goes first, so that an
/// interrupted removal leaves no checkpoint that could be resumed. A
/// failure is the caller's to report, not fatal: the fit itself is
/// complete.
pub fn drop_checkpoint(dir: &Path) -> std::io::Result<()> {
    let gone = |r: std::io::Result<()>| match r {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    };
    gone(std::fs::remove_file(dir.join("state.json")))?;
    gone(std::fs::remove_dir_all(dir))
}

/// Where the release is and how it was found, in one line.
pub fn release_line(data: &Aligned) -> String {
    let first = data.t_first;
    let when = if data.lag_unknown() {
        format!(
            "release detected just before the sample at t = {first} s (placed between samples by the fit)"
        )
    } else if data.lag > 0.0 {
        format!(
            "release at t0 = {} s ({}), first sample {:.2} ms after it",
            data.t0,
            data.source.as_str(),
            1e3 * data.lag
        )
    } else {
        format!("release at t0 = {} s ({})", data.t0, data.source.as_str())
    };
    let mirrored = if data.polarity < 0.0 {
        "; the record starts with a > 0 (released towards negative displacement, or the sensor points the other way): fitted mirrored, u0 is the size of the release displacement"
    } else {
        ""
    };
    format!(
        "{when}, {} samples at dt = {} s{mirrored}",
        data.a.len(),
        data.dt
    )
}
