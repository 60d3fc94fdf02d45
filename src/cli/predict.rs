//! `hbis predict`: the identified posterior's response to an earthquake.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use hbis::data::ground_motion::{GroundMotion, KanaiTajimi};
use hbis::data::validation::AccelUnits;
use hbis::model::{ForwardModel, Model};
use hbis::predict::{Draw, FitDraws, PredictOptions, Prediction, Stats};
use hbis::report::outdir::{InputEntry, OutDir};
use hbis::study::prediction::{write_prediction, PredictJob};

use super::inputs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder of a fit (`hbis fit --out`): its posterior draws are simulated.
    #[arg(long, conflicts_with_all = ["model", "params"], required_unless_present = "model")]
    fit: Option<PathBuf>,
    /// Model spec, to simulate one parameter set (with --params).
    #[arg(long, requires = "params")]
    model: Option<String>,
    #[command(flatten)]
    effects: inputs::EffectArgs,
    /// JSON file of the model's parameters, `{"u0": 0.1166, "uy": 0.01167, ...}`.
    #[arg(long, requires = "model")]
    params: Option<PathBuf>,
    /// Ground motion: a PEER NGA `.AT2` file, or two columns `t ag` (text
    /// or CSV; uniformly sampled).
    #[arg(
        long,
        conflicts_with = "synthetic",
        required_unless_present = "synthetic"
    )]
    motion: Option<PathBuf>,
    /// Unit of the motion's acceleration: `g`, `m/s2` or `mm/s2`. An
    /// `.AT2` file states its own (g); a two-column file needs this.
    #[arg(long)]
    motion_units: Option<String>,
    /// Scale factor applied to the motion.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    scale: f64,
    /// Instead of a file: a synthetic Kanai-Tajimi motion (firm soil, 40 s
    /// at 100 Hz) of seed --seed, scaled to --pga.
    #[arg(long)]
    synthetic: bool,
    /// Peak ground acceleration of the synthetic motion (m/s^2).
    #[arg(long, default_value_t = 0.3 * 9.80665, requires = "synthetic")]
    pga: f64,
    /// Seed of the synthetic motion (the draws are taken evenly through the
    /// chains, without randomness).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Posterior draws to simulate, evenly spaced through the chains.
    #[arg(long, default_value_t = 1000)]
    draws: usize,
    /// Seconds simulated after the motion ends, to come to rest.
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    tail: f64,
    /// Displacement capacity of the isolators (m): the probability that the
    /// peak displacement exceeds it is reported.
    #[arg(long, allow_negative_numbers = true)]
    capacity: Option<f64>,
    /// Mass `m` (t) for the base shear in kN (default: the fit's eq. 8.1
    /// mass per draw, when it was given the forces).
    #[arg(long, allow_negative_numbers = true)]
    mass: Option<f64>,
    /// Output folder.
    #[arg(long, default_value = "hbis-predict")]
    out: PathBuf,
    /// Print predict.json to standard output instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<()> {
    check(&a)?;
    let motion = motion(&a)?;
    let (model, draws, fit_seed) = draws(&a)?;
    let job = PredictJob {
        model,
        draws,
        fit: a.fit.clone(),
        fit_seed,
        params: a.params.clone(),
        motion,
        scale: a.scale,
        seed: a.seed,
        opts: PredictOptions {
            tail: a.tail,
            capacity: a.capacity,
            band_points: 2000,
            cancel: None,
        },
    };
    // The fit's folder is an input too: an output folder holding it would
    // clean its files away.
    let fit_json = a.fit.as_ref().map(|d| d.join("fit.json"));
    let inputs: Vec<&Path> = [
        a.motion.as_deref(),
        a.params.as_deref(),
        fit_json.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut dir = OutDir::open(&a.out, &inputs, "predict")?;
    let (p, json) = write_prediction(&mut dir, &job)?;
    let record = a.motion.as_deref().map(InputEntry::of).transpose()?;
    dir.finish("predict", a.seed, &job.model.name(), record)?;
    for w in &p.warnings {
        say!("warning: {w}");
    }
    if a.json {
        return super::print_stdout(&json);
    }
    let mut out = std::io::stdout().lock();
    print_summary(&mut out, &p, job.draws.len(), &job.motion)?;
    writeln!(
        out,
        "wrote {} and draws.csv, band.csv, response.png, peak-displacement.png beside it",
        a.out.join("predict.json").display()
    )?;
    Ok(())
}

/// Settings refused before any work.
fn check(a: &Args) -> Result<()> {
    if !(a.tail.is_finite() && a.tail >= 0.0) {
        bail!("--tail {}: expected a finite time >= 0 s", a.tail);
    }
    if let Some(c) = a.capacity {
        hbis::predict::positive("--capacity", c)?;
    }
    if let Some(m) = a.mass {
        hbis::predict::positive("--mass", m)?;
    }
    if a.synthetic {
        hbis::predict::positive("--pga", a.pga)?;
    }
    if a.draws == 0 {
        bail!("--draws 0: expected at least one draw");
    }
    if !a.scale.is_finite() || a.scale == 0.0 {
        bail!("--scale {}: expected a finite, nonzero factor", a.scale);
    }
    Ok(())
}

fn motion(a: &Args) -> Result<GroundMotion> {
    let units = a
        .motion_units
        .as_deref()
        .map(|u| {
            u.parse::<AccelUnits>()
                .with_context(|| format!("--motion-units `{u}`"))
        })
        .transpose()?;
    let m = match &a.motion {
        Some(path) => {
            let at2 = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("at2"));
            if at2 {
                GroundMotion::read_at2(path, units)?
            } else {
                let Some(units) = units else {
                    bail!(
                        "--motion {}: state the unit of a two-column motion with --motion-units g, m/s2 or mm/s2",
                        path.display()
                    );
                };
                GroundMotion::read_columns(path, units)?
            }
        }
        None => {
            let kt = KanaiTajimi {
                pga: a.pga,
                ..KanaiTajimi::default()
            };
            kt.generate(a.seed)?
        }
    };
    Ok(m.scaled(a.scale)?)
}

/// The model and the parameter sets to simulate.
fn draws(a: &Args) -> Result<(Model, Vec<Draw>, Option<u64>)> {
    let (model, mut draws, seed) = match (&a.fit, &a.model, &a.params) {
        (Some(dir), _, _) => {
            let registry = a.effects.registry()?;
            let fit = FitDraws::read_with(dir, &registry)
                .with_context(|| format!("--fit {}", dir.display()))?;
            if fit.draws.len() < a.draws {
                say!(
                    "warning: the fit holds {} draws, fewer than --draws {}: all are used",
                    fit.draws.len(),
                    a.draws
                );
            }
            let d = fit.thinned(a.draws);
            (fit.model, d, Some(fit.seed))
        }
        (None, Some(spec), Some(path)) => {
            let model = inputs::model(&a.effects.registry()?, spec)?;
            let theta = inputs::model_params(&model, path)?;
            (model, vec![Draw::new(theta)], None)
        }
        _ => bail!("give --fit DIR, or --model SPEC with --params FILE"),
    };
    if let Some(m) = a.mass {
        draws.iter_mut().for_each(|d| d.mass = Some(m));
    }
    Ok((model, draws, seed))
}

pub(super) fn print_summary(
    out: &mut impl Write,
    p: &Prediction,
    n: usize,
    m: &GroundMotion,
) -> Result<()> {
    writeln!(
        out,
        "Response to {} (PGA {:.3} g), {n} parameter set{}, each from rest:",
        m.source,
        m.pga() / 9.80665,
        if n == 1 { "" } else { "s" }
    )?;
    writeln!(
        out,
        "  {:28} {:>11} {:>11} {:>11} {:>11} {:>11}",
        "", "mean", "sd", "q05", "q50", "q95"
    )?;
    let row = |out: &mut dyn Write, name: &str, s: &Stats, scale: f64| -> std::io::Result<()> {
        writeln!(
            out,
            "  {name:28} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>11.4}",
            scale * s.mean,
            scale * s.sd,
            scale * s.q05,
            scale * s.q50,
            scale * s.q95
        )
    };
    let s = &p.summary;
    row(out, "peak displacement (mm)", &s.peak_displacement, 1e3)?;
    row(
        out,
        "residual displacement (mm)",
        &s.residual_displacement,
        1e3,
    )?;
    row(out, "peak base shear / m (m/s^2)", &s.peak_base_shear, 1.0)?;
    if let Some(k) = &s.peak_base_shear_kn {
        row(out, "peak base shear (kN)", k, 1.0)?;
    }
    row(
        out,
        "peak total accel. (m/s^2)",
        &s.peak_total_acceleration,
        1.0,
    )?;
    if let Some(q) = p.p_exceed_capacity {
        writeln!(out, "  P(peak displacement > capacity) = {q:.4}")?;
    }
    Ok(())
}
