//! `hbis fit`: the MAP and the posterior of a model for a measured record.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use hbis::data::Aligned;
use hbis::inference::{
    CheckpointStatus, MapEstimate, MapSettings, Noise, Posterior, Priors, Progress, SampleSettings,
};
use hbis::model::{ForwardModel, Model};
use hbis::report::outdir::{InputEntry, OutDir};
use hbis::study::outputs::{release_line, write_fit, ChainOptions, FitRun};
use hbis::study::{fit_record, Fit, FitOptions};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::inputs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Record: CSV with columns `t` (s) and `a` (m/s^2), or whitespace-separated text.
    #[arg(long)]
    data: PathBuf,
    /// Model: a spring law, optional friction law and damper, and any
    /// catalog components, e.g. `trilinear+lcfm+viscous`,
    /// `bilinear+coulomb` or `trilinear+lcfm+viscous+velocity-friction+offset`.
    #[arg(long, default_value = "trilinear+lcfm+viscous")]
    model: String,
    #[command(flatten)]
    effects: inputs::EffectArgs,
    /// Prior file (JSON, or TOML if it ends in .toml); default: uniform within physical bounds.
    #[arg(long)]
    prior: Option<PathBuf>,
    /// Seed of every random number (results depend on nothing else).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output folder.
    #[arg(long, default_value = "hbis-fit")]
    out: PathBuf,
    /// Also print fit.json to standard output.
    #[arg(long)]
    json: bool,
    /// Release time in the record's clock (s); default: detected.
    #[arg(long, allow_negative_numbers = true)]
    t0: Option<f64>,
    #[command(flatten)]
    record: inputs::RecordArgs,
    /// Measurement-error model: `white` or `ar1`.
    #[arg(long, default_value = "white")]
    noise: String,
    /// CMA-ES evaluation budget.
    #[arg(long, default_value_t = 200_000)]
    max_evals: usize,
    /// The MAP only: skip the posterior sampling.
    #[arg(long)]
    map_only: bool,
    /// Walkers per ensemble (default max(32, 8 x parameters)).
    #[arg(long)]
    walkers: Option<usize>,
    /// Independent ensembles (for R-hat; at least 2).
    #[arg(long, default_value_t = hbis::inference::sample::DEFAULT_ENSEMBLES)]
    ensembles: usize,
    /// Run until the kept chain is this many autocorrelation times long
    /// (and at least 5, the length from which the estimate is trusted).
    #[arg(long, default_value_t = 50.0)]
    tau_multiple: f64,
    /// Run until the smallest effective sample size reaches N (instead of
    /// --tau-multiple).
    #[arg(long)]
    ess: Option<f64>,
    /// Sampler moves mixed by weight, e.g. `stretch`, `gaussian:0.8,stretch:0.2`
    /// (`stretch`, `de`, `gaussian`).
    #[arg(long, default_value = hbis::inference::sample::DEFAULT_MOVES)]
    moves: String,
    /// Budget: most steps per ensemble.
    #[arg(long, default_value_t = 20_000)]
    max_steps: usize,
    /// Released force F0^n (kN), for the posterior of the Table 8.2 quantities.
    #[arg(long, requires = "static_friction")]
    released_force: Option<f64>,
    /// Static friction F_fS (kN), with --released-force.
    #[arg(long, requires = "released_force")]
    static_friction: Option<f64>,
    /// Also compute the Laplace log-evidence at the MAP (`log_evidence` in
    /// fit.json; covariance from a finite-difference Hessian).
    #[arg(long)]
    evidence: bool,
    /// The design table's target: the weakest parameter's sd as a fraction
    /// of today's, in (0, 1) (`identifiability.design` in fit.json).
    #[arg(long, default_value_t = 0.5)]
    design_target: f64,
    /// Skip the design table.
    #[arg(long)]
    no_design: bool,
    /// Exit 0 even when the posterior sample did not converge (by default
    /// such a fit writes every output, then exits 3).
    #[arg(long)]
    allow_unconverged: bool,
    #[command(flatten)]
    chains: ChainArgs,
}

/// What becomes of the draws and the checkpoint after a fit; the default
/// (the demo's) is thinned chains written and no checkpoint left.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ChainArgs {
    /// Write every N-th step of the chains (default: half the largest
    /// autocorrelation time, `sampling.thin` in fit.json; 1 keeps all).
    #[arg(long, value_name = "N")]
    pub thin: Option<usize>,
    /// Write no chain files (fit.json still has the summaries).
    #[arg(long)]
    pub no_chains: bool,
    /// Keep the sampler's checkpoint after a successful run (by default it
    /// is removed once every output is written; a run that fails keeps it
    /// to resume from).
    #[arg(long)]
    pub keep_checkpoint: bool,
}

impl ChainArgs {
    /// As the runners take them.
    pub fn options(&self) -> ChainOptions {
        ChainOptions {
            thin: self.thin,
            no_chains: self.no_chains,
            keep_checkpoint: self.keep_checkpoint,
        }
    }

    /// Rejects `--thin 0`.
    pub fn check(&self) -> Result<()> {
        if self.thin == Some(0) {
            anyhow::bail!("--thin 0: expected a whole number of steps >= 1 (1 keeps every step)");
        }
        Ok(())
    }
}

/// Checks every option as [`run`] does, without reading the record or
/// computing: `hbis batch` calls it for every item before running any.
pub fn check(a: &Args) -> Result<()> {
    let registry = a.effects.registry()?;
    let model = inputs::model(&registry, &a.model)?;
    let noise = parsed_noise(a)?;
    checked_model(a, &model)?;
    priors(a, &model, noise)?;
    options(a, &model, noise)?;
    Ok(())
}

fn parsed_noise(a: &Args) -> Result<Noise> {
    Noise::parse(&a.noise)
        .with_context(|| format!("--noise `{}`: expected `white` or `ar1`", a.noise))
}

fn checked_model(a: &Args, model: &Model) -> Result<()> {
    if a.released_force.is_some() {
        hbis::model::physical::check_convertible(model).context("--released-force")?;
    }
    Ok(())
}

fn priors(a: &Args, model: &Model, noise: Noise) -> Result<Priors> {
    let defaults = Posterior::default_priors(model, noise);
    match &a.prior {
        Some(p) => defaults
            .read(p)
            .with_context(|| format!("in prior file {}", p.display())),
        None => Ok(defaults),
    }
}

/// The fit's settings from the flags, each checked and named.
fn options(a: &Args, model: &Model, noise: Noise) -> Result<FitOptions> {
    a.chains.check()?;
    if !(a.design_target > 0.0 && a.design_target < 1.0) {
        anyhow::bail!(
            "--design-target {}: expected a fraction of today's sd in (0, 1), e.g. 0.5",
            a.design_target
        );
    }
    let forces = match (a.released_force, a.static_friction) {
        (Some(f), Some(s)) => Some((f, s)),
        _ => None,
    };
    let mut sample = SampleSettings::default()
        .with_ensembles(a.ensembles)
        .context("--ensembles")?
        .with_tau_multiple(a.tau_multiple)
        .context("--tau-multiple")?
        .with_max_steps(a.max_steps)
        .context("--max-steps")?;
    if let Some(w) = a.walkers {
        sample = sample.with_walkers(w).context("--walkers")?;
    }
    if let Some(n) = a.ess {
        sample = sample.with_ess(n).context("--ess")?;
    }
    let moves = hbis::inference::ensemble::Moves::parse(&a.moves)
        .map_err(|e| anyhow::anyhow!("--moves `{}`: {e}", a.moves))?;
    sample = sample.with_moves(moves);
    if !a.map_only {
        let dim = Posterior::<Model>::names_for(model, noise).len();
        hbis::data::limits::sampler(dim, sample.walkers_for(dim), a.ensembles, a.max_steps)?;
    }
    Ok(FitOptions {
        seed: a.seed,
        map: MapSettings::default()
            .with_max_evals(a.max_evals)
            .context("--max-evals")?,
        sample: (!a.map_only).then_some(sample),
        checkpoint: Some(a.out.join("checkpoint")),
        forces,
        label: a.data.display().to_string(),
        evidence: a.evidence,
        design_target: (!a.no_design).then_some(a.design_target),
    })
}

pub fn run(a: Args) -> Result<()> {
    let registry = a.effects.registry()?;
    let model = inputs::model(&registry, &a.model)?;
    checked_model(&a, &model)?;
    let noise = parsed_noise(&a)?;
    let (data, record_warnings) = inputs::record(&a.data, &a.record, a.t0)?;
    let priors = priors(&a, &model, noise)?;
    let options = options(&a, &model, noise)?;
    // The folder is locked and checked before any computation: a busy or
    // unwritable --out costs nothing.
    let mut inputs_used: Vec<&Path> = vec![&a.data];
    if let Some(p) = &a.prior {
        inputs_used.push(p);
    }
    let mut dir = OutDir::open(&a.out, &inputs_used, "fit")?;
    let mut err = std::io::stderr().lock();
    let lag_unknown = data.lag_unknown();
    writeln!(err, "{}", release_line(&data))?;
    writeln!(
        err,
        "finding the MAP (CMA-ES with restarts, at most {} evaluations per search, plus the release placement and the polish; a structured residual starts a second search){}...",
        a.max_evals,
        if a.map_only {
            ""
        } else {
            ", then sampling the posterior"
        }
    )?;
    drop(err);
    let fit = run_fit(model.clone(), data, priors, noise, &options)?;
    let mut err = std::io::stderr().lock();
    if lag_unknown {
        let d = fit.posterior.data();
        writeln!(
            err,
            "release placed by the fit at t0 = {} s, {:.2} ms before the first sample",
            d.t0,
            1e3 * d.lag
        )?;
    }
    print_map(&mut err, &fit.map)?;
    if let Some(s) = &fit.second_search {
        writeln!(
            err,
            "  the first search's {}: a second search from new starts reached log-posterior {:.3} against {:.3} ({} evaluations); {} kept",
            if s.reason == hbis::study::STRUCTURED {
                "residual was structured"
            } else {
                "runs never ended twice in its best basin"
            },
            s.second_log_posterior,
            s.first_log_posterior,
            s.evaluations,
            if s.kept_second { "its MAP is" } else { "the first MAP is" }
        )?;
    }
    if let Some(s) = &fit.sample {
        if !matches!(
            s.checkpoint,
            CheckpointStatus::None | CheckpointStatus::Fresh
        ) {
            writeln!(err, "{}", s.checkpoint)?;
        }
    }
    if fit.sample.is_some() {
        print_posterior(&mut err, &fit)?;
    }
    let n_record = record_warnings.len();
    let run = FitRun {
        source: a.data.display().to_string(),
        seed: a.seed,
        noise,
        record_warnings,
        chains: a.chains.options(),
    };
    let report = write_fit(&fit, &mut dir, &run, None)?;
    inputs::print_warnings(&report.warnings[n_record..]);
    if !a.chains.keep_checkpoint {
        drop_checkpoint(&a.out.join("checkpoint"));
    }
    dir.finish("fit", a.seed, &model.name(), Some(InputEntry::of(&a.data)?))?;
    writeln!(err, "wrote {}", a.out.join("fit.json").display())?;
    if a.json {
        super::print_stdout(&(serde_json::to_string_pretty(&report)? + "\n"))?;
    }
    match &fit.sample {
        Some(s) if !s.converged && !a.allow_unconverged => Err(super::Unconverged {
            reason: s.not_converged.clone(),
        }
        .into()),
        _ => Ok(()),
    }
}

/// Removes a finished run's checkpoint; a failure is a warning, since the
/// fit itself is complete.
pub fn drop_checkpoint(dir: &Path) {
    if let Err(e) = hbis::study::outputs::drop_checkpoint(dir) {
        say!(
            "warning: could not remove the checkpoint {}: {e} (the fit is complete; remove it by hand)",
            dir.display()
        );
    }
}

/// Runs the study with a progress bar on stderr when it is a terminal.
pub fn run_fit(
    model: Model,
    data: Aligned,
    priors: Priors,
    noise: Noise,
    options: &FitOptions,
) -> Result<Fit> {
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template("sampling {bar:40} {pos}/{len} steps {msg} [{elapsed}]")
                .expect("a valid template"),
        );
        Some(b)
    } else {
        None
    };
    let mut progress = |p: Progress| {
        if let Some(b) = &bar {
            b.set_length(p.target_steps.max(p.steps) as u64);
            b.set_position(p.steps as u64);
            if p.tau_max.is_finite() {
                b.set_message(format!("(tau = {:.0})", p.tau_max));
            }
        }
    };
    let fit =
        fit_record(model, data, Some(priors), noise, options, &mut progress).context("fit")?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok(fit)
}

/// The MAP as a table, with the search's numbers.
pub fn print_map(out: &mut impl Write, map: &MapEstimate) -> Result<()> {
    writeln!(
        out,
        "MAP after {} evaluations ({} in {} CMA-ES runs, {} placing the release, {} polishing) in {:.2} s: e2 = {:.6}, log-posterior = {:.3}",
        map.evaluations(),
        map.cmaes_evaluations,
        map.runs.len(),
        map.preparation_evaluations,
        map.polish.as_ref().map_or(0, |p| p.evaluations),
        map.wall_time,
        map.eval.e2,
        map.eval.log_posterior
    )?;
    if let Some(p) = &map.polish {
        writeln!(
            out,
            "  polish (Nelder-Mead, {} iterations): objective {:.4} -> {:.4}, e2 {:.6} -> {:.6}",
            p.iterations, p.objective_before, p.objective_after, p.e2_before, p.e2_after
        )?;
    }
    for (n, v) in map.names.iter().zip(&map.theta) {
        writeln!(out, "  {n:6} = {v:>12.6}")?;
    }
    Ok(())
}

/// The posterior table, diagnostics and the identifiability report.
pub fn print_posterior(out: &mut impl Write, fit: &Fit) -> Result<()> {
    let (Some(sample), Some(sums), Some(id)) = (&fit.sample, &fit.summaries, &fit.identifiability)
    else {
        return Ok(());
    };
    writeln!(
        out,
        "\nPosterior: {} ensembles x {} walkers, {} steps ({} burn-in), {} evaluations in {:.2} s; {}",
        sample.chains.len(),
        sample.chains[0].walkers(),
        sample.steps(),
        sample.burn,
        sample.evaluations,
        sample.wall_time,
        if sample.converged {
            "converged (chain long enough, split R-hat <= 1.01)".to_string()
        } else {
            format!("NOT converged: {}", sample.not_converged)
        }
    )?;
    writeln!(
        out,
        "  {:6} {:>12} {:>10} {:>7} {:>12} {:>12} {:>12} {:>7} {:>6}",
        "", "mean", "sd", "c.o.v.", "q05", "q50", "q95", "ESS", "R-hat"
    )?;
    for (k, (n, s)) in sample.names.iter().zip(sums).enumerate() {
        writeln!(
            out,
            "  {n:6} {:>12.6} {:>10.3e} {:>6.1}% {:>12.6} {:>12.6} {:>12.6} {:>7.0} {:>6.3}",
            s.mean,
            s.sd,
            100.0 * s.cov,
            s.q05,
            s.q50,
            s.q95,
            sample.ess[k],
            sample.rhat[k]
        )?;
    }
    writeln!(
        out,
        "  acceptance {:?}",
        sample
            .acceptance
            .iter()
            .map(|a| (a * 1000.0).round() / 1000.0)
            .collect::<Vec<_>>()
    )?;
    if let Some(phys) = &fit.physical {
        writeln!(out, "\nPhysical quantities (eq. 8.1), posterior:")?;
        for (n, s) in phys {
            writeln!(
                out,
                "  {n:3} mean {:>10.1}  sd {:>8.1}  90 % [{:.1}, {:.1}]",
                s.mean, s.sd, s.q05, s.q95
            )?;
        }
    }
    writeln!(
        out,
        "\nIdentifiability (best determined first, by posterior sd / prior sd): {}",
        id.ranking.join(", ")
    )?;
    writeln!(
        out,
        "  {:6} {:>9} {:>11} {:>9} {:>10} {:>9} {:>12}",
        "", "sd/prior", "contraction", "sd/scale", "inflation", "partner", "correlation"
    )?;
    for n in &id.ranking {
        let Some((_, p)) = id.params.iter().find(|(m, _)| m == n) else {
            continue;
        };
        writeln!(
            out,
            "  {n:6} {:>8.3}% {:>11.4} {:>9.3} {:>10.2} {:>9} {:>+12.2}",
            100.0 * p.sd_ratio,
            p.contraction,
            p.sd_scaled,
            p.variance_inflation,
            p.partner,
            p.partner_correlation
        )?;
    }
    writeln!(out, "\n{}", id.explanation)?;
    if let Some(d) = &fit.design {
        print_design(out, d)?;
    }
    Ok(())
}

/// The design table of the weakest parameter.
fn print_design(out: &mut impl Write, d: &hbis::inference::design::DesignTable) -> Result<()> {
    writeln!(
        out,
        "\nWhat would determine {} better (sd today {:.3e}{}, Fisher {:.3e}; target {:.0} %):",
        d.parameter,
        d.sd_sampled,
        match d.unit.as_str() {
            "-" | "" => String::new(),
            u => format!(" {u}"),
        },
        d.sd_fisher,
        100.0 * d.target_ratio
    )?;
    writeln!(
        out,
        "  {:10} {:>7} {:>10} {:>10} {:>9} {:>8} {:>11} {:>8}",
        "knob", "factor", "length s", "u0 mm", "noise", "rate Hz", "sd", "sd/today"
    )?;
    for r in &d.rows {
        writeln!(
            out,
            "  {:10} {:>7.2} {:>10.2} {:>10.2} {:>9.4} {:>8.1} {:>11.3e} {:>7.0}%",
            r.knob,
            r.factor,
            r.design.duration_s,
            1e3 * r.design.amplitude_m,
            r.design.noise,
            r.design.rate_hz,
            r.sd,
            100.0 * r.sd_ratio
        )?;
    }
    writeln!(out, "  {}", d.summary)?;
    Ok(())
}
