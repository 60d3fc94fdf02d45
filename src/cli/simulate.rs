//! `hbis simulate`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use hbis::model::response::grid_len;
use hbis::model::{Response, SimError};
use hbis::report;

use super::inputs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Model spec, e.g. `trilinear+lcfm+viscous` or `bilinear+coulomb`.
    #[arg(long)]
    model: String,
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
    let spec = inputs::spec(&a.model)?;
    let params = inputs::params(&a.params, &spec)?;
    check_positive("dt", a.dt)?;
    check_positive("duration", a.duration)?;
    if grid_len(a.dt, a.duration) < 2 {
        anyhow::bail!(
            "--duration {} is shorter than --dt {}: no samples after release",
            a.duration,
            a.dt
        );
    }
    let response = Response::simulate(&spec, &params, a.duration)?;
    let samples = response.sample_grid(a.dt)?;
    match &a.out {
        Some(path) => {
            inputs::ensure_parent(path)?;
            let f = std::fs::File::create(path)
                .with_context(|| format!("cannot create {}", path.display()))?;
            report::csv::write_samples(std::io::BufWriter::new(f), &samples)
                .with_context(|| format!("writing {}", path.display()))?;
        }
        None => report::csv::write_samples(std::io::stdout().lock(), &samples)
            .context("writing samples to standard output")?,
    }
    if let Some(path) = &a.phases {
        inputs::ensure_parent(path)?;
        let f = std::fs::File::create(path)
            .with_context(|| format!("cannot create {}", path.display()))?;
        report::csv::write_phases(f, response.phases())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &a.figure {
        super::demo::figure(
            path,
            &response,
            a.dt,
            &format!("{spec}: simulated release test"),
        )?;
    }
    // The summary goes to stderr so that stdout can carry the CSV.
    let mut err = std::io::stderr().lock();
    super::demo::summary(&mut err, &response)?;
    err.flush()?;
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
