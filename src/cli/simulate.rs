//! `hbis simulate`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use hbis::model::response::grid_len;
use hbis::model::{ForwardModel, Model, Response, SimError};
use hbis::report;
use hbis::report::outdir::{refuse_same_file, write_file_atomic, write_path_atomic};

use super::inputs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Model spec, e.g. `trilinear+lcfm+viscous`, `bilinear+coulomb`, or any
    /// registry model (`trilinear+lcfm+viscous+maxwell`, an effect file's).
    #[arg(long)]
    model: String,
    #[command(flatten)]
    effects: inputs::EffectArgs,
    /// JSON file of parameters, `{"u0": 0.1166, "uy": 0.01167, ...}`.
    #[arg(long)]
    params: PathBuf,
    /// Sampling step (s).
    #[arg(long, allow_negative_numbers = true)]
    dt: f64,
    /// Record length after release (s).
    #[arg(long, allow_negative_numbers = true)]
    duration: f64,
    /// CSV file for the samples (default: standard output).
    #[arg(long)]
    out: Option<PathBuf>,
    /// CSV file for the phase log.
    #[arg(long)]
    phases: Option<PathBuf>,
    /// Figure of the response (six panels, as the paper's Fig. 7.1); .png or .svg.
    #[arg(long)]
    figure: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let registry = a.effects.registry()?;
    let model = inputs::model(&registry, &a.model)?;
    if !model.is_core() {
        return run_model(&a, &model);
    }
    // The closed-form core: its phases and their events, exactly.
    let theta = inputs::model_params(&model, &a.params)?;
    let params = model.core_params(&theta)?;
    check_grid(&a)?;
    let spec = model.name();
    let response = Response::simulate(&model.spec(), &params, a.duration)?;
    let samples = response.sample_grid(a.dt)?;
    let mut csv = Vec::new();
    report::csv::write_samples(&mut csv, &samples).context("formatting the samples")?;
    match &a.out {
        Some(path) => write_file_atomic(path, &[&a.params], &csv)?,
        None => super::print_stdout(&String::from_utf8_lossy(&csv))?,
    }
    if let Some(path) = &a.phases {
        let mut text = Vec::new();
        report::csv::write_phases(&mut text, response.phases()).context("formatting the phases")?;
        write_file_atomic(path, &[&a.params], &text)?;
    }
    if let Some(path) = &a.figure {
        write_path_atomic(path, &[&a.params], |tmp| {
            super::demo::figure(
                tmp,
                &response,
                a.dt,
                &format!("{spec}: simulated release test"),
            )
        })?;
    }
    // The summary goes to stderr so that stdout can carry the CSV.
    let mut err = std::io::stderr().lock();
    super::demo::summary(&mut err, &response)?;
    err.flush()?;
    Ok(())
}

/// The grid and the outputs, checked before anything runs.
fn check_grid(a: &Args) -> Result<()> {
    check_positive("dt", a.dt)?;
    check_positive("duration", a.duration)?;
    if grid_len(a.dt, a.duration) < 2 {
        anyhow::bail!(
            "--duration {} is shorter than --dt {}: no samples after release",
            a.duration,
            a.dt
        );
    }
    distinct_outputs(a)?;
    Ok(hbis::data::limits::grid(a.dt, a.duration)?)
}

/// A model with components beyond the core: its motion by the engine the
/// model runs on, written as `t,u,v,a,phase` (`a` as the accelerometer
/// records it, output components included).
fn run_model(a: &Args, model: &Model) -> Result<()> {
    if let Some((flag, _)) = [("--phases", &a.phases), ("--figure", &a.figure)]
        .into_iter()
        .find(|(_, p)| p.is_some())
    {
        anyhow::bail!(
            "{flag}: only for the closed-form core models (spring, friction, damper); `{}` has other components",
            model.name()
        );
    }
    let theta = inputs::model_params(model, &a.params)?;
    check_grid(a)?;
    let n = grid_len(a.dt, a.duration);
    let motion = model.motion_grid(&theta, 0.0, a.dt, n)?;
    let mut accel = vec![0.0; n];
    model.accel_into(&theta, a.dt, &mut accel)?;
    let mut csv = String::from("t,u,v,a,phase\n");
    for (i, (m, acc)) in motion.iter().zip(&accel).enumerate() {
        csv += &format!(
            "{},{},{},{},{}\n",
            i as f64 * a.dt,
            m.u,
            m.v,
            acc,
            m.phase.as_str()
        );
    }
    match &a.out {
        Some(path) => write_file_atomic(path, &[&a.params], csv.as_bytes())?,
        None => super::print_stdout(&csv)?,
    }
    let peak = motion.iter().map(|m| m.u.abs()).fold(0.0, f64::max);
    let moving = motion
        .iter()
        .rposition(|m| m.v != 0.0)
        .map_or(0.0, |i| i as f64 * a.dt);
    let mut err = std::io::stderr().lock();
    writeln!(
        err,
        "{}: {n} samples; peak |u| {peak:.6} m; last moving sample at t = {moving:.3} s",
        model.name()
    )?;
    Ok(())
}

/// The samples, the phase log and the figure must go to three different
/// files, none of them the parameter file.
fn distinct_outputs(a: &Args) -> Result<()> {
    let outs: Vec<(&str, &PathBuf)> = [
        ("--out", &a.out),
        ("--phases", &a.phases),
        ("--figure", &a.figure),
    ]
    .into_iter()
    .filter_map(|(n, p)| p.as_ref().map(|p| (n, p)))
    .collect();
    for (i, (n, p)) in outs.iter().enumerate() {
        refuse_same_file(p, &[&a.params]).with_context(|| format!("{n} {}", p.display()))?;
        for (m, q) in &outs[i + 1..] {
            if refuse_same_file(p, &[q.as_path()]).is_err() {
                anyhow::bail!(
                    "{n} and {m} name the same file {}: give each its own",
                    p.display()
                );
            }
        }
    }
    Ok(())
}

fn check_positive(name: &'static str, value: f64) -> Result<(), SimError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(SimError::Grid {
            name,
            value,
            requirement: "must be a finite number > 0",
        })
    }
}
