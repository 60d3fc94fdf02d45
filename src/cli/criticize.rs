//! `hbis diagnose` and `hbis ladder`: where the model fails and which
//! physical effect is missing.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use hbis::criticism::{Diagnostics, ModelFit, Move, PathEnd, RankedCandidate, Screened, Step};
use hbis::inference::{MapSettings, Noise};
use hbis::model::{ForwardModel, Registry};
use hbis::report::outdir::{InputEntry, OutDir};
use hbis::study::criticize::{self, setup, Ladder, Setup, MAX_LADDER_STEPS};
use hbis::study::outputs::release_line;

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
        criticize::parse_noise(&self.noise).with_context(|| {
            format!(
                "--noise `{}`: expected `white`, `ar1` or `auto`",
                self.noise
            )
        })
    }
}

/// Loads the record and sets it up (release placed, noise chosen), with
/// what was done on standard error.
fn load(a: &Args, registry: &Registry) -> Result<Setup> {
    let model = super::inputs::model(registry, &a.model)?;
    // Refused before any computation.
    let asked = a.noise()?;
    let (data, warnings) = super::inputs::record(&a.data, &a.record, a.t0)?;
    let mut err = std::io::stderr().lock();
    writeln!(err, "{}", release_line(&data))?;
    let s = setup(
        model,
        data,
        asked,
        a.seed,
        &a.data.display().to_string(),
        warnings,
        &MapSettings::default(),
    )
    .context("setting up the record")?;
    if s.release_placed() {
        writeln!(
            err,
            "release placed by a fit of {} at t0 = {} s, {:.2} ms before the first sample",
            s.model.name(),
            s.data.t0,
            1e3 * s.data.lag
        )?;
    }
    if let Some(c) = &s.noise_choice {
        writeln!(err, "{}", c.sentence())?;
    }
    Ok(s)
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
    let s = load(&a, &registry)?;
    let _ = writeln!(
        std::io::stderr(),
        "fitting {}, then refitting it with each catalog candidate (multi-start)...",
        s.model.name()
    );
    let d = criticize::diagnose(&registry, &s, &MapSettings::default()).context("diagnosis")?;
    super::inputs::print_warnings(&d.report.warnings[s.warnings.len()..]);
    let text = criticize::write_diagnosis(&d, &s, &mut dir)?;
    let path = dir.path("diagnosis.json");
    let name = s.model.name();
    dir.finish("diagnose", a.seed, &name, Some(InputEntry::of(&a.data)?))?;
    let mut err = std::io::stderr().lock();
    let r = &d.report;
    print_diagnosis(
        &mut err,
        &name,
        &d.fit,
        &r.residual,
        &r.candidates,
        &r.screened_out,
    )?;
    writeln!(err, "wrote {}", path.display())?;
    if a.json {
        super::print_stdout(&text)?;
    }
    Ok(())
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
    let s = load(&a, &registry)?;
    let ladder = ladder_steps(&registry, &s, l.max_steps)?;
    let mut err = std::io::stderr().lock();
    print_ladder(&mut err, &ladder.steps)?;
    print_paths(&mut err, &ladder.report.paths)?;
    super::inputs::print_warnings(&ladder.report.warnings[s.warnings.len()..]);
    let text = criticize::write_ladder(&registry, &ladder, &s, &mut dir)?;
    let start = s.model.name();
    dir.finish("ladder", a.seed, &start, Some(InputEntry::of(&a.data)?))?;
    writeln!(err, "wrote {}", out.join("ladder.json").display())?;
    if a.json {
        super::print_stdout(&text)?;
    }
    Ok(())
}

/// Runs the ladder (at most `max_steps` effects are added), with a line per
/// step on standard error.
pub fn ladder_steps(registry: &Registry, s: &Setup, max_steps: usize) -> Result<Ladder> {
    // A line per step on stderr (a ladder runs for minutes).
    let mut report = |s: &Step| {
        let next = match s.candidates.iter().find(|c| c.accepted) {
            Some(c) => format!("adding {}", c.effect),
            None => "no candidate accepted".to_string(),
        };
        let mut err = std::io::stderr();
        // An addition is the step's own line, unless a move of the search
        // (unmask) made it: then it says why.
        for m in s
            .moves
            .iter()
            .filter(|m| m.kind != "add" || m.why.is_some())
        {
            let _ = writeln!(err, "  {}", move_line(m));
        }
        let path = if s.path > 0 {
            format!(" (path {}, from the first step's runner-up)", s.path)
        } else {
            String::new()
        };
        let _ = writeln!(err, "  fitted {}{path}: e2 = {:.5}; {next}", s.model, s.e2);
    };
    criticize::ladder(registry, s, &MapSettings::default(), max_steps, &mut report)
        .context("ladder")
}

pub fn print_diagnosis(
    out: &mut impl Write,
    model: &str,
    fit: &ModelFit,
    d: &Diagnostics,
    ranked: &[RankedCandidate],
    screened: &[Screened],
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
    for c in screened {
        writeln!(out, "    {:10} {}", c.effect, c.reason)?;
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

/// A removal or swap in words, with its BIC.
fn move_line(m: &Move) -> String {
    let what = match &m.replaces {
        Some(out) => format!("swapped `{out}` for `{}`", m.effect),
        None => format!(
            "{} `{}`",
            if m.kind == "add" { "added" } else { "removed" },
            m.effect
        ),
    };
    let why = m
        .why
        .as_deref()
        .map_or(String::new(), |w| format!(" ({w})"));
    format!(
        "{what} (BIC {:.1} to {:.1}): {}{why}",
        m.bic_before, m.bic_after, m.model
    )
}

/// Where each path of the search ended.
pub fn print_paths(out: &mut impl Write, paths: &[PathEnd]) -> Result<()> {
    if paths.len() < 2 {
        return Ok(());
    }
    for (i, p) in paths.iter().enumerate() {
        writeln!(
            out,
            "path {i} (first {}): ends at {} with BIC {:.1}, e2 {:.5}{}",
            p.first.as_deref().unwrap_or("-"),
            p.final_model,
            p.bic,
            p.e2,
            if p.chosen { " (chosen)" } else { "" }
        )?;
    }
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
        for m in s.moves.iter().filter(|m| m.kind != "add") {
            writeln!(out, "step {k}: {}", move_line(m))?;
        }
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
