//! `hbis predict`: the identified posterior's response to an earthquake.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use hbis::data::ground_motion::{GroundMotion, KanaiTajimi};
use hbis::data::validation::AccelUnits;
use hbis::model::{ForwardModel, Model};
use hbis::predict::{Draw, FitDraws, PredictOptions, Stats, G};
use hbis::report::outdir::{InputEntry, OutDir};
use hbis::study::prediction::{write_prediction, PredictJob, PredictOutcome};

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
        conflicts_with_all = ["synthetic", "motions"],
        required_unless_present_any = ["synthetic", "motions"]
    )]
    motion: Option<PathBuf>,
    /// A suite of ground motions: `N` seeded synthetic Kanai-Tajimi motions
    /// (as --synthetic, seeds derived from --seed), or a folder of `.AT2`
    /// files (a folder named by digits: write `./20`). The draws are paired
    /// with the motions, so the summary carries the record-to-record
    /// variability.
    #[arg(long, value_name = "N|DIR", conflicts_with = "synthetic")]
    motions: Option<String>,
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
    /// Peak ground acceleration (m/s^2, or in g with a `g` suffix: `0.3g`)
    /// of the synthetic motions (default 0.3g), or that a folder's motions
    /// are scaled to. A list (`0.1g,0.2g,0.3g,0.4g`) scales the motions to
    /// each level for a fragility curve of --capacity; the summary and
    /// figures are at the first level.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "LIST",
        allow_hyphen_values = true
    )]
    pga: Vec<String>,
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
    let levels = pga_levels(&a)?;
    let motions = motions(&a, levels.first().copied())?;
    let (model, draws, fit_seed) = draws(&a)?;
    let job = PredictJob {
        model,
        draws,
        fit: a.fit.clone(),
        fit_seed,
        params: a.params.clone(),
        motions,
        scale: a.scale,
        fragility_pgas: if levels.len() > 1 { levels } else { Vec::new() },
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
    for w in &p.prediction.warnings {
        say!("warning: {w}");
    }
    if a.json {
        return super::print_stdout(&json);
    }
    let mut out = std::io::stdout().lock();
    print_summary(&mut out, &p, &job)?;
    let fragility = if p.fragility.is_some() {
        ", fragility.png"
    } else {
        ""
    };
    writeln!(
        out,
        "wrote {} and draws.csv, band.csv, response.png, peak-displacement.png{fragility} beside it",
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
    if a.draws == 0 {
        bail!("--draws 0: expected at least one draw");
    }
    if !a.scale.is_finite() || a.scale == 0.0 {
        bail!("--scale {}: expected a finite, nonzero factor", a.scale);
    }
    if !a.pga.is_empty() && a.motion.is_some() {
        bail!("--pga scales --synthetic or --motions; scale a --motion file with --scale");
    }
    if a.pga.len() > 1 && a.capacity.is_none() {
        bail!(
            "--pga {}: several levels draw a fragility curve of the capacity: give --capacity (m)",
            a.pga.join(",")
        );
    }
    Ok(())
}

/// Most motions of a synthetic suite.
const MAX_SUITE: usize = 10_000;

/// The --pga levels in m/s^2, each checked.
fn pga_levels(a: &Args) -> Result<Vec<f64>> {
    a.pga.iter().map(|s| parse_pga(s)).collect()
}

/// A PGA in m/s^2 from `2.94` or `0.3g`.
fn parse_pga(s: &str) -> Result<f64> {
    let t = s.trim();
    let (num, factor) = match t.strip_suffix(['g', 'G']) {
        Some(n) => (n, hbis::predict::G),
        None => (t, 1.0),
    };
    let v = num
        .trim()
        .parse::<f64>()
        .ok()
        .map(|v| v * factor)
        .filter(|v| v.is_finite() && *v > 0.0);
    match v {
        Some(v) => Ok(v),
        None => {
            bail!("--pga `{s}`: expected an acceleration > 0 in m/s^2 (`2.94`) or in g (`0.3g`)")
        }
    }
}

/// What --motions names.
enum Suite<'a> {
    Synthetic(usize),
    Folder(&'a Path),
}

fn suite(spec: &str) -> Result<Suite<'_>> {
    if !spec.is_empty() && spec.bytes().all(|b| b.is_ascii_digit()) {
        let n: usize = spec.parse().unwrap_or(usize::MAX);
        if n == 0 || n > MAX_SUITE {
            bail!("--motions {spec}: expected 1 to {MAX_SUITE} synthetic motions, or a folder of .AT2 files");
        }
        return Ok(Suite::Synthetic(n));
    }
    let dir = Path::new(spec);
    if !dir.is_dir() {
        bail!("--motions {spec}: not a number of motions, nor a folder of .AT2 files");
    }
    Ok(Suite::Folder(dir))
}

/// The motions at the summary's level `pga` (m/s^2; `None`: as given).
fn motions(a: &Args, pga: Option<f64>) -> Result<Vec<GroundMotion>> {
    let units = a
        .motion_units
        .as_deref()
        .map(|u| {
            u.parse::<AccelUnits>()
                .with_context(|| format!("--motion-units `{u}`"))
        })
        .transpose()?;
    let kt = KanaiTajimi {
        pga: pga.unwrap_or(0.3 * hbis::predict::G),
        ..KanaiTajimi::default()
    };
    let ms = match (&a.motion, &a.motions) {
        (Some(path), _) => vec![motion_file(path, units)?],
        (None, Some(spec)) => match suite(spec)? {
            Suite::Synthetic(n) => kt.suite(n, a.seed)?,
            Suite::Folder(dir) => {
                let ms = GroundMotion::read_at2_dir(dir, units)
                    .with_context(|| format!("--motions {spec}"))?;
                match pga {
                    Some(g) => ms
                        .into_iter()
                        .map(|m| m.scaled_to_pga(g))
                        .collect::<Result<_, _>>()?,
                    None => ms,
                }
            }
        },
        (None, None) => vec![kt.generate(a.seed)?],
    };
    ms.into_iter().map(|m| Ok(m.scaled(a.scale)?)).collect()
}

fn motion_file(path: &Path, units: Option<AccelUnits>) -> Result<GroundMotion> {
    let at2 = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("at2"));
    if at2 {
        return Ok(GroundMotion::read_at2(path, units)?);
    }
    let Some(units) = units else {
        bail!(
            "--motion {}: state the unit of a two-column motion with --motion-units g, m/s2 or mm/s2",
            path.display()
        );
    };
    Ok(GroundMotion::read_columns(path, units)?)
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
    outcome: &PredictOutcome,
    job: &PredictJob,
) -> Result<()> {
    let p = &outcome.prediction;
    let n = job.draws.len();
    let sets = format!("{n} parameter set{}", if n == 1 { "" } else { "s" });
    match job.motions.as_slice() {
        [m] => writeln!(
            out,
            "Response to {} (PGA {:.3} g), {sets}, each from rest:",
            m.source,
            m.pga() / G
        )?,
        ms => {
            let pgas = ms.iter().map(|m| m.pga() / G);
            let lo = pgas.clone().fold(f64::INFINITY, f64::min);
            let hi = pgas.fold(0.0, f64::max);
            let level = if (hi - lo) <= 1e-9 * hi {
                format!("PGA {hi:.3} g")
            } else {
                format!("PGA {lo:.3}-{hi:.3} g")
            };
            writeln!(
                out,
                "Response to {} ground motions ({level}), {sets}, {} pairs, each from rest:",
                ms.len(),
                p.pairs.len()
            )?
        }
    }
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
    if let Some(c) = &p.exceedance {
        writeln!(
            out,
            "  P(peak displacement > capacity) = {:.4} (95 % interval {:.4}-{:.4})",
            c.p, c.low, c.high
        )?;
    }
    if let (Some(f), Some(cap)) = (&outcome.fragility, job.opts.capacity) {
        writeln!(
            out,
            "Fragility of the {:.0} mm capacity ({} motions scaled to each PGA):",
            1e3 * cap,
            job.motions.len()
        )?;
        writeln!(
            out,
            "  {:>8} {:>10} {:>17} {:>20}",
            "PGA (g)", "P(exceed)", "95 % interval", "peak u q50 (mm)"
        )?;
        for x in f {
            writeln!(
                out,
                "  {:>8.3} {:>10.4} {:>8.4}-{:<8.4} {:>20.1}",
                x.pga_g,
                x.p_exceed,
                x.ci_low,
                x.ci_high,
                1e3 * x.peak_displacement.q50
            )?;
        }
    }
    Ok(())
}
