//! `hbis diagnose` and `hbis ladder`: where the model fails and which
//! physical effect is missing.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use hbis::criticism::{
    choose_noise, diagnose_model, ladder_observed, place_release, Diagnostics, ModelFit,
    NoiseChoice, RankedCandidate, Step,
};
use hbis::data::{Aligned, ReleaseSource, Warning};
use hbis::inference::{MapSettings, Noise};
use hbis::model::{ForwardModel, Model, Registry};
use hbis::report::html::CriticismInfo;
use hbis::report::json::DataInfo;
use hbis::report::outdir::{InputEntry, OutDir};
use serde::Serialize;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Record: CSV with columns `t` (s) and `a` (m/s^2), or whitespace-separated text.
    #[arg(long)]
    data: PathBuf,
    /// Starting model, e.g. `bilinear+coulomb` (catalog output effects such as `+offset` allowed).
    #[arg(long)]
    model: String,
    /// Seed of every random number.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output folder.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also print the JSON report to standard output.
    #[arg(long)]
    json: bool,
    /// Release time in the record's clock (s); default: detected.
    #[arg(long, allow_negative_numbers = true)]
    t0: Option<f64>,
    #[command(flatten)]
    record: super::inputs::RecordArgs,
    /// Measurement-error model of every fit: `white`, `ar1`, or `auto`
    /// (the lower BIC of the two at the start model).
    #[arg(long, default_value = "white")]
    noise: String,
    /// Offer only these components as candidates (comma-separated names;
    /// `maxwell`, offered on request, may be named here).
    #[arg(long, value_delimiter = ',')]
    candidates: Option<Vec<String>>,
    /// Never offer these components as candidates (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    exclude: Vec<String>,
    #[command(flatten)]
    effects: super::inputs::EffectArgs,
}

/// `hbis ladder`'s arguments: those of `hbis diagnose` and a step limit.
#[derive(Debug, clap::Args)]
pub struct LadderArgs {
    #[command(flatten)]
    common: Args,
    /// Most effects the ladder adds (0: only the start model's diagnosis,
    /// as `hbis diagnose` computes it).
    #[arg(long, default_value_t = MAX_LADDER_STEPS)]
    max_steps: usize,
}

impl Args {
    /// The built-in registry with `--candidates` and `--exclude` applied.
    fn registry(&self) -> Result<Registry> {
        let names = |v: &[String]| v.iter().map(|s| s.trim().to_string()).collect::<Vec<_>>();
        let mut registry = self.effects.registry()?;
        if let Some(list) = &self.candidates {
            let list = names(list);
            let refs: Vec<&str> = list.iter().map(String::as_str).collect();
            registry = registry
                .with_candidates(&refs)
                .with_context(|| format!("--candidates `{}`", list.join(",")))?;
        }
        let list = names(&self.exclude);
        let refs: Vec<&str> = list.iter().map(String::as_str).collect();
        registry
            .excluding(&refs)
            .with_context(|| format!("--exclude `{}`", list.join(",")))
    }

    /// The noise model asked for; `None` for `auto`.
    fn noise(&self) -> Result<Option<Noise>> {
        if self.noise == "auto" {
            return Ok(None);
        }
        Noise::parse(&self.noise).map(Some).with_context(|| {
            format!(
                "--noise `{}`: expected `white`, `ar1` or `auto`",
                self.noise
            )
        })
    }
}

/// The start model, the record (release placed) and the noise model, with
/// how `auto` chose it.
type Loaded = (Model, Aligned, Noise, Option<NoiseChoice>, Vec<Warning>);

fn load(a: &Args, registry: &Registry) -> Result<Loaded> {
    let model = super::inputs::model(registry, &a.model)?;
    // Refused before any computation.
    let asked = a.noise()?;
    let (data, warnings) = super::inputs::record(&a.data, &a.record, a.t0)?;
    let mut err = std::io::stderr().lock();
    writeln!(err, "{}", super::fit::release_line(&data))?;
    let data = place_release(&model, data, &MapSettings::default(), a.seed ^ 0x7E1E_A5E0)
        .context("placing the release")?;
    if data.lag > 0.0 && data.source == ReleaseSource::Detected {
        writeln!(
            err,
            "release placed by a fit of {} at t0 = {} s, {:.2} ms before the first sample",
            model.name(),
            data.t0,
            1e3 * data.lag
        )?;
    }
    let (noise, choice) = match asked {
        Some(n) => (n, None),
        None => {
            let c = choose_noise(&model, &data, &MapSettings::default(), a.seed ^ 0x0A17_0015)
                .context("choosing the noise model")?;
            writeln!(err, "{}", c.sentence())?;
            (c.chosen, Some(c))
        }
    };
    Ok((model, data, noise, choice, warnings))
}

/// The record's warnings and those of a fit of `model` (printed).
fn with_fit_warnings(mut warnings: Vec<Warning>, model: &Model, fit: &ModelFit) -> Vec<Warning> {
    let priors = hbis::inference::Posterior::default_priors(model, fit.noise);
    let more = hbis::report::sanity::fit_warnings(&fit.names, &fit.theta, fit.e2, &priors);
    super::inputs::print_warnings(&more);
    warnings.extend(more);
    warnings
}

/// `diagnosis.json`.
#[derive(Debug, Serialize)]
struct DiagnosisReport<'a> {
    hbis_version: &'a str,
    model: String,
    seed: u64,
    noise: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    noise_choice: Option<NoiseChoice>,
    data: DataInfo,
    e2: f64,
    bic: f64,
    log_evidence: f64,
    map: std::collections::BTreeMap<String, f64>,
    candidates: &'a [RankedCandidate],
    caution: Option<String>,
    conclusion: String,
    residual: &'a Diagnostics,
    verdict: &'a str,
    warnings: Vec<Warning>,
}

pub fn diagnose(a: Args) -> Result<()> {
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("hbis-diagnose"));
    let registry = a.registry()?;
    super::inputs::model(&registry, &a.model)?;
    a.noise()?;
    let mut dir = OutDir::open(&out, &[&a.data], "diagnose")?;
    let (model, data, noise, choice, warnings) = load(&a, &registry)?;
    let _ = writeln!(
        std::io::stderr(),
        "fitting {}, then refitting it with each catalog candidate (multi-start)...",
        model.name()
    );
    let settings = MapSettings::default();
    let (fit, diagnosis, ranked) =
        diagnose_model(&registry, &model, &data, noise, &settings, a.seed).context("diagnosis")?;
    let report = DiagnosisReport {
        hbis_version: env!("CARGO_PKG_VERSION"),
        model: model.name(),
        seed: a.seed,
        noise: noise.as_str(),
        noise_choice: choice,
        data: DataInfo::new(&a.data.display().to_string(), &data),
        e2: fit.e2,
        bic: fit.bic,
        log_evidence: fit.log_evidence,
        map: fit
            .names
            .iter()
            .cloned()
            .zip(fit.theta.iter().copied())
            .collect(),
        candidates: &ranked,
        caution: hbis::criticism::caution(&ranked),
        conclusion: hbis::criticism::conclusion(&diagnosis, &ranked),
        residual: &diagnosis,
        verdict: &diagnosis.verdict,
        warnings: with_fit_warnings(warnings, &model, &fit),
    };
    let text = serde_json::to_string_pretty(&report)? + "\n";
    dir.write("diagnosis.json", text.as_bytes())?;
    let mut svgs = Vec::new();
    if let Some(svg) = residual_figure(
        &mut dir,
        "residual.png",
        &model,
        &fit,
        &data,
        None,
        &model.name(),
    )? {
        svgs.push((
            svg,
            "Measured and model acceleration; the residual below.".to_string(),
        ));
    }
    #[cfg(feature = "figures")]
    {
        let map = |tmp: &std::path::Path| {
            hbis::report::figures::residual_map_figure(
                tmp,
                &diagnosis.map_u_edges,
                &diagnosis.map_v_edges,
                &diagnosis.map_force,
                &format!("{}: restoring-force residual", model.name()),
            )
        };
        dir.write_with("residual-map.png", map)?;
        svgs.push((
            hbis::report::figures::svg_text(map)?,
            "Mean residual force per unit mass over displacement and velocity (blue negative, red positive, grey: no sample)."
                .to_string(),
        ));
    }
    let noise_choice = report.noise_choice.as_ref().map(|c| c.sentence());
    let info = CriticismInfo {
        source: &report.data.source,
        model: &report.model,
        seed: a.seed,
        noise: report.noise,
        noise_choice: noise_choice.as_deref(),
    };
    let html = hbis::report::html::diagnosis_page(
        &info,
        &fit,
        &diagnosis,
        &ranked,
        &report.warnings,
        &svgs,
    );
    dir.write("report.html", html.as_bytes())?;
    let path = dir.path("diagnosis.json");
    dir.finish(
        "diagnose",
        a.seed,
        &model.name(),
        Some(InputEntry::of(&a.data)?),
    )?;
    let mut err = std::io::stderr().lock();
    print_diagnosis(&mut err, &model.name(), &fit, &diagnosis, &ranked)?;
    writeln!(err, "wrote {}", path.display())?;
    if a.json {
        super::print_stdout(&text)?;
    }
    Ok(())
}

/// `ladder.json`.
#[derive(Debug, Serialize)]
struct LadderReport<'a> {
    hbis_version: &'a str,
    model: String,
    seed: u64,
    noise: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    noise_choice: Option<NoiseChoice>,
    data: DataInfo,
    final_model: String,
    steps: Vec<LadderStep<'a>>,
    warnings: Vec<Warning>,
}

#[derive(Debug, Serialize)]
struct LadderStep<'a> {
    model: &'a str,
    added: Option<&'a str>,
    e2: f64,
    bic: f64,
    log_evidence: f64,
    lag: f64,
    verdict: &'a str,
    candidates: &'a [RankedCandidate],
    caution: Option<&'a str>,
    conclusion: &'a str,
}

pub fn run_ladder(l: LadderArgs) -> Result<()> {
    let a = l.common;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("hbis-ladder"));
    let registry = a.registry()?;
    super::inputs::model(&registry, &a.model)?;
    a.noise()?;
    let mut dir = OutDir::open(&out, &[&a.data], "ladder")?;
    let (model, data, noise, choice, warnings) = load(&a, &registry)?;
    let start = model.name();
    let steps = ladder_steps(&registry, model, &data, noise, a.seed, l.max_steps)?;
    let mut err = std::io::stderr().lock();
    print_ladder(&mut err, &steps)?;
    let warnings = match steps.last() {
        Some(s) => with_fit_warnings(warnings, &registry.parse(&s.model)?, &s.fit),
        None => warnings,
    };
    let text = write_ladder(
        &registry,
        &mut dir,
        &start,
        a.seed,
        &a.data.display().to_string(),
        &steps,
        &data,
        choice,
        warnings,
    )?;
    dir.finish("ladder", a.seed, &start, Some(InputEntry::of(&a.data)?))?;
    writeln!(err, "wrote {}", out.join("ladder.json").display())?;
    if a.json {
        super::print_stdout(&text)?;
    }
    Ok(())
}

/// Most effects the ladder adds by default.
pub const MAX_LADDER_STEPS: usize = 6;

/// Runs the ladder (at most `max_steps` effects are added), with a line per
/// step on standard error when it is a terminal.
pub fn ladder_steps(
    registry: &Registry,
    model: Model,
    data: &Aligned,
    noise: Noise,
    seed: u64,
    max_steps: usize,
) -> Result<Vec<Step>> {
    // A line per step on stderr (a ladder runs for minutes).
    let mut report = |s: &Step| {
        let next = match s.candidates.iter().find(|c| c.accepted) {
            Some(c) => format!("adding {}", c.effect),
            None => "no effect added".to_string(),
        };
        let _ = writeln!(
            std::io::stderr(),
            "  fitted {}: e2 = {:.5}; {next}",
            s.model,
            s.e2
        );
    };
    ladder_observed(
        registry,
        model,
        data,
        noise,
        &MapSettings::default(),
        seed,
        max_steps,
        &mut report,
    )
    .context("ladder")
}

/// Writes ladder.json, ladder.png and one residual figure per step.
#[allow(clippy::too_many_arguments)]
pub fn write_ladder(
    registry: &Registry,
    out: &mut OutDir,
    start: &str,
    seed: u64,
    source: &str,
    steps: &[Step],
    data: &Aligned,
    noise_choice: Option<NoiseChoice>,
    warnings: Vec<Warning>,
) -> Result<String> {
    let report = LadderReport {
        hbis_version: env!("CARGO_PKG_VERSION"),
        model: start.to_string(),
        seed,
        noise: steps.first().map_or("white", |s| s.fit.noise.as_str()),
        noise_choice,
        data: DataInfo::new(
            source,
            &data
                .clone()
                .with_lag(steps.last().map_or(data.lag, |s| s.lag)),
        ),
        final_model: steps.last().map_or(String::new(), |s| s.model.clone()),
        steps: steps
            .iter()
            .map(|s| LadderStep {
                model: &s.model,
                added: s.added.as_deref(),
                e2: s.e2,
                bic: s.bic,
                log_evidence: s.log_evidence,
                lag: s.lag,
                verdict: &s.diagnosis.verdict,
                candidates: &s.candidates,
                caution: s.caution.as_deref(),
                conclusion: &s.conclusion,
            })
            .collect(),
        warnings,
    };
    let text = serde_json::to_string_pretty(&report)? + "\n";
    out.write("ladder.json", text.as_bytes())?;
    // The record's own noise level, whatever the models: what the error
    // can fall to (white noise assumed; coloured noise lies above it).
    let times: Vec<f64> = (0..data.a.len()).map(|i| data.time(i)).collect();
    let sigma_floor =
        hbis::data::Record::new(times, data.a.clone()).map_or(f64::NAN, |r| r.noise_level());
    #[cfg(feature = "figures")]
    let e2_floor = data.a.len() as f64 * sigma_floor * sigma_floor / data.energy();
    let mut svgs = Vec::new();
    #[cfg(feature = "figures")]
    {
        // Each step named by the effect it added.
        let labels: Vec<String> = steps
            .iter()
            .map(|s| match &s.added {
                Some(effect) => format!("+{effect}"),
                None => s.model.clone(),
            })
            .collect();
        let e2: Vec<f64> = steps.iter().map(|s| s.e2).collect();
        let z: Vec<f64> = steps.iter().map(|s| s.log_evidence).collect();
        let draw = |tmp: &std::path::Path| {
            hbis::report::figures::ladder_figure(tmp, &labels, &e2, &z, Some(e2_floor))
        };
        out.write_with("ladder.png", draw)?;
        svgs.push((
            hbis::report::figures::svg_text(draw)?,
            "e2 and the log-evidence at each step.".to_string(),
        ));
    }
    // One residual scale for every step (the largest residual of any), and
    // the last step's residual RMS as the noise floor, so the error is seen
    // to fall towards it.
    let mut half = 0.0f64;
    let mut models = Vec::new();
    for s in steps {
        let model = registry.parse(&s.model)?;
        let at_lag = data.clone().with_lag(s.lag);
        let mut accel = vec![0.0; at_lag.a.len()];
        at_lag.model_accel_into(&model, s.fit.model_theta(&model), &mut accel)?;
        for (m, a) in at_lag.a.iter().zip(&accel) {
            half = half.max((m - a).abs());
        }
        models.push((model, at_lag));
    }
    let floor = sigma_floor;
    for (k, (s, (model, at_lag))) in steps.iter().zip(models).enumerate() {
        let title = match &s.added {
            Some(effect) => format!("step {k}: {} (added {effect})", s.model),
            None => format!("step {k}: {}", s.model),
        };
        let figure = residual_figure(
            out,
            &format!("step-{k}.png"),
            &model,
            &s.fit,
            &at_lag,
            Some((half, floor)),
            &title,
        )?;
        if let Some(svg) = figure {
            svgs.push((svg, title));
        }
    }
    let noise_choice = report.noise_choice.as_ref().map(|c| c.sentence());
    let info = CriticismInfo {
        source: &report.data.source,
        model: start,
        seed,
        noise: report.noise,
        noise_choice: noise_choice.as_deref(),
    };
    let html = hbis::report::html::ladder_page(&info, steps, &report.warnings, &svgs);
    out.write("report.html", html.as_bytes())?;
    Ok(text)
}

/// Writes the measured-against-model figure `name` and returns it as SVG
/// for report.html (`None` without the `figures` feature).
/// `scale`: the residual axis and noise floor shared by a ladder's steps;
/// `None` for the figure's own (a diagnosis).
#[cfg_attr(not(feature = "figures"), allow(unused_variables))]
fn residual_figure(
    out: &mut OutDir,
    name: &str,
    model: &Model,
    fit: &ModelFit,
    data: &Aligned,
    scale: Option<(f64, f64)>,
    title: &str,
) -> Result<Option<String>> {
    #[cfg(feature = "figures")]
    {
        let mut accel = vec![0.0; data.a.len()];
        data.model_accel_into(model, fit.model_theta(model), &mut accel)?;
        let t: Vec<f64> = (0..accel.len()).map(|i| data.time(i)).collect();
        let (measured, accel) = (data.in_record_sign(&data.a), data.in_record_sign(&accel));
        let sigma = (fit.e2 * data.energy() / data.a.len().max(1) as f64).sqrt();
        let scale = match scale {
            Some((half, floor)) => hbis::report::figures::ResidualScale {
                half,
                sigma: floor,
                label: "±σ: noise floor (white noise, from second differences)",
            },
            None => hbis::report::figures::ResidualScale {
                half: 0.0,
                sigma,
                label: "±σ: residual RMS",
            },
        };
        let phases = hbis::study::segments(model, fit.model_theta(model), data)
            .ok()
            .map(|s| s.phase);
        let draw = |tmp: &std::path::Path| {
            hbis::report::figures::fit_figure(
                tmp,
                &t,
                &measured,
                &accel,
                &hbis::report::figures::Overlays {
                    band: None,
                    scale: Some(scale),
                    phases: phases.as_deref(),
                },
                &format!("{title}: e2 = {:.5}", fit.e2),
            )
        };
        out.write_with(name, draw)?;
        Ok(Some(hbis::report::figures::svg_text(draw)?))
    }
    #[cfg(not(feature = "figures"))]
    {
        let _ = (out, name, model, fit, data);
        Ok(None)
    }
}

pub fn print_diagnosis(
    out: &mut impl Write,
    model: &str,
    fit: &ModelFit,
    d: &Diagnostics,
    ranked: &[RankedCandidate],
) -> Result<()> {
    writeln!(out, "{model}: e2 = {:.5}, BIC = {:.1}", fit.e2, fit.bic)?;
    writeln!(out, "  residual by phase:")?;
    for g in &d.by_phase {
        writeln!(
            out,
            "    {:9} {:>5} samples  RMS {:.2e}  mean {:+.2e}",
            g.group, g.samples, g.rms, g.mean
        )?;
    }
    writeln!(
        out,
        "  dominant residual frequency {:.2} Hz (model can produce it: {})",
        d.dominant_frequency_hz, d.spectrum.model_can_produce
    )?;
    writeln!(out, "  verdict: {}", d.verdict)?;
    writeln!(out, "  candidates, best first:")?;
    for c in ranked {
        writeln!(
            out,
            "    {:10} e2 {:.5}  dBIC {:>9.1}  dlogL {:>8.1}  dlogZ {:>8.1}  score {:>8.1}  {}",
            c.effect,
            c.e2,
            c.delta_bic,
            c.delta_log_likelihood,
            c.delta_log_evidence,
            c.score,
            if c.accepted {
                "accepted"
            } else if c.supported {
                "supported, not accepted"
            } else {
                "unsupported"
            }
        )?;
    }
    if let Some(c) = hbis::criticism::caution(ranked) {
        writeln!(out, "  caution: {c}")?;
    }
    writeln!(
        out,
        "  conclusion: {}",
        hbis::criticism::conclusion(d, ranked)
    )?;
    Ok(())
}

pub fn print_ladder(out: &mut impl Write, steps: &[Step]) -> Result<()> {
    writeln!(
        out,
        "{:>4}  {:32} {:>10} {:>9} {:>12} {:>12}",
        "step", "model", "added", "e2", "BIC", "log-evidence"
    )?;
    for (k, s) in steps.iter().enumerate() {
        writeln!(
            out,
            "{k:>4}  {:32} {:>10} {:>9.5} {:>12.1} {:>12.1}",
            s.model,
            s.added.as_deref().unwrap_or("-"),
            s.e2,
            s.bic,
            s.log_evidence
        )?;
    }
    for (k, s) in steps.iter().enumerate() {
        if let Some(c) = &s.caution {
            writeln!(out, "caution at step {k}: {c}")?;
        }
    }
    if let Some(last) = steps.last() {
        writeln!(out, "final verdict: {}", last.diagnosis.verdict)?;
        writeln!(out, "conclusion: {}", last.conclusion)?;
    }
    Ok(())
}
