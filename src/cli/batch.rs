//! `hbis batch`: a study of many records (records x models x seeds from a
//! TOML manifest), each item an `hbis fit` into its own folder, resumable,
//! split into shards for a job array and collected into one summary.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::error::{ContextKind, ContextValue};
use clap::Parser;
use hbis::batch::{Item, Shard, Study};
use hbis::study::batch_run::{self, describe, Event, Plan};

use super::fit;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The study: a TOML manifest of records, models and seeds (format in
    /// docs/cli.md); its paths are relative to its folder.
    #[arg(long)]
    manifest: PathBuf,
    /// The study's output folder: one folder per item
    /// (`<record>/<model>/seed-<seed>`) and the summary.
    #[arg(long, default_value = "hbis-study")]
    out: PathBuf,
    /// Run only shard i of n (round robin over the items), e.g. `--shard
    /// $((SLURM_ARRAY_TASK_ID + 1))/8`; its summary is
    /// `summary-shard-<i>-of-<n>.csv`.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Fit nothing: gather every item's result (all shards) into
    /// `summary.csv`; fails, naming them, if items have no result.
    #[arg(long)]
    collect: bool,
}

/// `hbis fit`'s arguments, parsed as the binary parses them.
#[derive(Debug, Parser)]
#[command(name = "hbis fit", no_binary_name = true)]
struct FitCommand {
    #[command(flatten)]
    args: fit::Args,
}

pub fn run(a: Args) -> Result<()> {
    let shard = match &a.shard {
        Some(s) => s.parse::<Shard>()?,
        None => Shard::ALL,
    };
    if a.collect && a.shard.is_some() {
        anyhow::bail!("--collect gathers every shard: leave out --shard");
    }
    let text = std::fs::read_to_string(&a.manifest)
        .with_context(|| format!("cannot read the study manifest {}", a.manifest.display()))?;
    let base = a.manifest.parent().unwrap_or(Path::new(""));
    let study =
        Study::parse(&text, base).with_context(|| format!("in {}", a.manifest.display()))?;
    let plans = batch_run::plan(&study, &super::base_registry(), &a.out)?;
    // Every item's options are checked as `hbis fit` checks them (flags,
    // then values such as `max-evals = 0`, priors and effect files) before
    // any is run: a typo costs nothing.
    for p in &plans {
        let args = parse_fit(&study, &p.item, &p.args)?;
        fit::check(&args).map_err(|e| {
            let chain = with_key(&study, &p.item, e.chain().map(|c| c.to_string()).collect());
            anyhow::anyhow!("{}: {}", describe(&study, &p.item), chain.join(": "))
        })?;
    }
    if a.collect {
        let path = batch_run::collect(&study, &plans, &a.out, &a.manifest)?;
        say!("wrote {} ({} items)", path.display(), plans.len());
        return Ok(());
    }
    say!(
        "study {}: {} items ({} records x {} models x {} seeds); shard {shard}: {} items",
        a.manifest.display(),
        plans.len(),
        study.records.len(),
        study.models.len(),
        study.seeds.len(),
        plans.iter().filter(|p| shard.holds(&p.item)).count()
    );
    let mut fit = |p: &Plan| -> Result<(), Vec<String>> {
        parse_fit(&study, &p.item, &p.args)
            .and_then(fit::run)
            .or_else(|e| match e.downcast_ref::<super::Unconverged>() {
                // Its outputs are written and fit.json says so: the item is
                // done, and the study says it did not converge.
                Some(u) => {
                    say!("{}: {u}", describe(&study, &p.item));
                    Ok(())
                }
                None => Err(e),
            })
            .map_err(|e| with_key(&study, &p.item, e.chain().map(|c| c.to_string()).collect()))
    };
    let mut on_event = |e: Event<'_>| match e {
        Event::Skipped { n, of, plan } => {
            say!(
                "[{n}/{of}] {}: complete, skipped",
                describe(&study, &plan.item)
            )
        }
        Event::Fitting { n, of, plan } => say!(
            "[{n}/{of}] {}: fitting into {}",
            describe(&study, &plan.item),
            plan.folder.display()
        ),
        Event::Done {
            n,
            of,
            plan,
            seconds,
        } => say!(
            "[{n}/{of}] {}: done in {seconds:.1} s",
            describe(&study, &plan.item)
        ),
        Event::Failed { n, of, plan, chain } => say!(
            "[{n}/{of}] {}: error: {}",
            describe(&study, &plan.item),
            chain.join(": ")
        ),
        Event::Summary { path, items } => {
            say!("wrote {} ({items} items)", path.display())
        }
    };
    batch_run::run(
        &study,
        &plans,
        shard,
        &a.out,
        &a.manifest,
        &mut fit,
        &mut on_event,
    )?;
    Ok(())
}

/// Parses `item`'s `hbis fit` arguments as the binary does; a clap error
/// becomes its first line, after the item and the manifest key that set
/// the flag it is about.
fn parse_fit(study: &Study, item: &Item, args: &[String]) -> Result<fit::Args> {
    FitCommand::try_parse_from(args)
        .map(|c| c.args)
        .map_err(|e| {
            let msg = e.to_string();
            let first = msg.lines().next().unwrap_or("");
            let first = first.trim_start_matches("error: ");
            let key = match e.get(ContextKind::InvalidArg) {
                Some(ContextValue::String(flag)) => study.key_of(item, flag_name(flag)),
                _ => None,
            };
            let item = describe(study, item);
            match key {
                Some(k) => anyhow::anyhow!("{item}: `{k}`: {first}"),
                None => anyhow::anyhow!("{item}: {first}"),
            }
        })
}

/// An item's error chain, led by the manifest key that set the flag it
/// starts with (`hbis fit` names the flag: `--max-evals: ...`).
fn with_key(study: &Study, item: &Item, mut chain: Vec<String>) -> Vec<String> {
    let first = chain.first().map_or("", String::as_str);
    if first.starts_with("--") {
        if let Some(key) = study.key_of(item, flag_name(first)) {
            chain.insert(0, format!("`{key}`"));
        }
    }
    chain
}

/// The option a message or a clap argument starts with: `walkers` for
/// `--walkers <WALKERS>`, `max-evals` for `--max-evals: ...`.
fn flag_name(arg: &str) -> &str {
    let flag = arg.trim_start_matches('-');
    let end = flag
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .unwrap_or(flag.len());
    &flag[..end]
}
