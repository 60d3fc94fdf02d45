//! `hbis fit`: the MAP of a model for a measured record.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use hbis::data::{Aligned, Record};
use hbis::inference::{find_map, MapEstimate, MapSettings, Noise, Posterior, Priors};
use hbis::model::ModelSpec;
use hbis::report::json::{DataInfo, FitReport};
use rand::{rngs::StdRng, SeedableRng};

use super::inputs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Record: CSV with columns `t` (s) and `a` (m/s^2), or whitespace-separated text.
    #[arg(long)]
    data: PathBuf,
    /// Model spec, e.g. `trilinear+lcfm+viscous` or `bilinear+coulomb`.
    #[arg(long, default_value = "trilinear+lcfm+viscous")]
    model: String,
    /// Prior file (JSON, or TOML if it ends in .toml); default: uniform within physical bounds.
    #[arg(long)]
    prior: Option<PathBuf>,
    /// Seed of every random number (results depend on nothing else).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output folder for fit.json, fit.csv and fit.png.
    #[arg(long, default_value = "hbis-fit")]
    out: PathBuf,
    /// Also print fit.json to standard output.
    #[arg(long)]
    json: bool,
    /// Release time in the record's clock (s); default: detected.
    #[arg(long, allow_negative_numbers = true)]
    t0: Option<f64>,
    /// Measurement-error model: `white` or `ar1`.
    #[arg(long, default_value = "white")]
    noise: String,
    /// CMA-ES evaluation budget.
    #[arg(long, default_value_t = 200_000)]
    max_evals: usize,
}

pub fn run(a: Args) -> Result<()> {
    let spec = inputs::spec(&a.model)?;
    let noise = Noise::parse(&a.noise)
        .with_context(|| format!("--noise `{}`: expected `white` or `ar1`", a.noise))?;
    let record =
        Record::read(&a.data).with_context(|| format!("in record {}", a.data.display()))?;
    let data = record
        .aligned(a.t0)
        .with_context(|| format!("in record {}", a.data.display()))?;
    let names = Posterior::names_for(&spec, noise);
    let priors = match &a.prior {
        Some(p) => {
            Priors::read(&names, p).with_context(|| format!("in prior file {}", p.display()))?
        }
        None => Priors::defaults(&names)?,
    };
    let settings = MapSettings::default().with_max_evals(a.max_evals)?;
    let source = a.data.display().to_string();
    let fitted = fit(spec, data, priors, noise, &settings, a.seed)?;
    let mut err = std::io::stderr().lock();
    writeln!(
        err,
        "release at t0 = {} s ({}), {} samples at dt = {} s",
        fitted.data.t0,
        fitted.data.source.as_str(),
        fitted.data.a.len(),
        fitted.data.dt
    )?;
    print_map(&mut err, &fitted.map)?;
    let report = fitted.write(&a.out, &source, &spec, a.seed, noise)?;
    writeln!(err, "wrote {}", a.out.join("fit.json").display())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    Ok(())
}

/// A fitted record: the posterior's pieces and its MAP.
pub struct Fitted {
    pub data: Aligned,
    pub posterior: Posterior<ModelSpec>,
    pub map: MapEstimate,
}

/// The MAP for a record, seeded.
pub fn fit(
    spec: ModelSpec,
    data: Aligned,
    priors: Priors,
    noise: Noise,
    settings: &MapSettings,
    seed: u64,
) -> Result<Fitted> {
    let posterior = Posterior::new(spec, data.clone(), priors, noise)?;
    let mut rng = StdRng::seed_from_u64(seed);
    let map = find_map(&posterior, settings, &mut rng).context("MAP search")?;
    Ok(Fitted {
        data,
        posterior,
        map,
    })
}

impl Fitted {
    /// Writes fit.json, fit.csv (t, measured, model, residual) and fit.png.
    pub fn write(
        &self,
        out: &Path,
        source: &str,
        spec: &ModelSpec,
        seed: u64,
        noise: Noise,
    ) -> Result<FitReport> {
        std::fs::create_dir_all(out)
            .with_context(|| format!("cannot create folder {}", out.display()))?;
        let report = FitReport::from_map(
            &spec.to_string(),
            seed,
            noise,
            DataInfo::new(source, &self.data),
            &self.map,
        );
        let path = out.join("fit.json");
        std::fs::write(&path, serde_json::to_string_pretty(&report)? + "\n")
            .with_context(|| format!("cannot write {}", path.display()))?;
        let model = self.posterior.model_accel(&self.map.theta)?;
        let t: Vec<f64> = (0..model.len())
            .map(|i| self.data.t0 + i as f64 * self.data.dt)
            .collect();
        let mut csv = String::from("t,a_measured,a_model,residual\n");
        for i in 0..model.len() {
            csv.push_str(&format!(
                "{},{},{},{}\n",
                t[i],
                self.data.a[i],
                model[i],
                self.data.a[i] - model[i]
            ));
        }
        let path = out.join("fit.csv");
        std::fs::write(&path, csv).with_context(|| format!("cannot write {}", path.display()))?;
        #[cfg(feature = "figures")]
        hbis::report::figures::fit_figure(
            &out.join("fit.png"),
            &t,
            &self.data.a,
            &model,
            None,
            &format!("{spec}: MAP fit, e2 = {:.5}", self.map.eval.e2),
        )?;
        Ok(report)
    }
}

/// The MAP as a table, with the search's numbers.
pub fn print_map(out: &mut impl Write, map: &MapEstimate) -> Result<()> {
    writeln!(
        out,
        "MAP after {} evaluations ({} CMA-ES runs) in {:.2} s: e2 = {:.6}, log-posterior = {:.3}",
        map.evaluations(),
        map.runs.len(),
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
