//! `hbis batch`: a study of many records (records x models x seeds from a
//! TOML manifest), each item an `hbis fit` into its own folder, resumable,
//! split into shards for a job array and collected into one summary.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Parser;
use hbis::batch::{summary_header, summary_rows, Item, Shard, Study};
use hbis::model::ForwardModel;
use hbis::report::outdir::{write_file_atomic, InputEntry, Manifest, MANIFEST};
use serde::{Deserialize, Serialize};

use super::fit;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The study: a TOML manifest of records, models and seeds (format in
    /// docs/cli.md); record paths are relative to its folder.
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

/// What an item was run with, beside its results: a finished item is
/// skipped only while these still hold.
#[derive(Debug, Serialize, Deserialize, PartialEq)]
struct ItemStamp {
    /// The `hbis fit` arguments (the output folder left out).
    args: Vec<String>,
    /// SHA-256 of the record file.
    record_sha256: String,
    /// SHA-256 of each effect file, in the manifest's order: an edited
    /// effect file reruns the item.
    #[serde(default)]
    effects_sha256: Vec<String>,
}

const STAMP: &str = "batch-item.json";

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
    let items = study.items();
    // Every item is checked before any is run: a typo costs nothing.
    let mut plans = Vec::with_capacity(items.len());
    for item in &items {
        plans.push(plan(&study, item, &a.out).with_context(|| describe(&study, item))?);
    }
    if a.collect {
        return collect(&a, &study, &items, &plans);
    }
    let mine: Vec<usize> = (0..items.len())
        .filter(|&k| shard.holds(&items[k]))
        .collect();
    eprintln!(
        "study {}: {} items ({} records x {} models x {} seeds); shard {shard}: {} items",
        a.manifest.display(),
        items.len(),
        study.records.len(),
        study.models.len(),
        study.seeds.len(),
        mine.len()
    );
    let mut failed = Vec::new();
    for (n, &k) in mine.iter().enumerate() {
        let (item, p) = (&items[k], &plans[k]);
        let what = describe(&study, item);
        if p.is_done()? {
            eprintln!("[{}/{}] {what}: complete, skipped", n + 1, mine.len());
            continue;
        }
        eprintln!(
            "[{}/{}] {what}: fitting into {}",
            n + 1,
            mine.len(),
            p.folder.display()
        );
        let started = std::time::Instant::now();
        match p.fit_args().and_then(fit::run).and_then(|()| p.stamp()) {
            Ok(()) => eprintln!(
                "[{}/{}] {what}: done in {:.1} s",
                n + 1,
                mine.len(),
                started.elapsed().as_secs_f64()
            ),
            Err(e) => {
                let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
                eprintln!(
                    "[{}/{}] {what}: error: {}",
                    n + 1,
                    mine.len(),
                    chain.join(": ")
                );
                failed.push(what);
            }
        }
    }
    let name = if shard == Shard::ALL {
        "summary.csv".to_string()
    } else {
        format!("summary-shard-{}-of-{}.csv", shard.index, shard.count)
    };
    let done: Vec<usize> = mine
        .iter()
        .copied()
        .filter(|&k| plans[k].is_done().unwrap_or(false))
        .collect();
    write_summary(&a, &study, &items, &plans, &done, &name)?;
    if !failed.is_empty() {
        anyhow::bail!(
            "{} of {} items failed (their errors are above; rerun to retry them, finished items are skipped): {}",
            failed.len(),
            mine.len(),
            failed.join("; ")
        );
    }
    Ok(())
}

/// One item, ready to run.
struct Plan {
    folder: PathBuf,
    record: PathBuf,
    args: Vec<String>,
    stamp: ItemStamp,
    model: String,
    seed: u64,
}

fn describe(study: &Study, item: &Item) -> String {
    format!(
        "item {} (record {}, model {}, seed {})",
        item.index + 1,
        study.records[item.record].name,
        item.model,
        item.seed
    )
}

fn plan(study: &Study, item: &Item, out: &Path) -> Result<Plan> {
    let folder = out.join(item.folder(study));
    let args = study.fit_args(item, &folder);
    parse_fit(&args)?;
    let record = study.records[item.record].path.clone();
    let sha = InputEntry::of(&record)
        .with_context(|| format!("record {}", record.display()))?
        .sha256;
    let mut registry = super::base_registry();
    let mut effects_sha256 = Vec::new();
    for e in &study.effects {
        registry
            .load_effect_file(e)
            .with_context(|| format!("effects: {}", e.display()))?;
        effects_sha256.push(InputEntry::of(e)?.sha256);
    }
    let model = super::inputs::model(&registry, &item.model)?.name();
    // The output folder is where the results go, not what they are.
    let mut kept = args.clone();
    if let Some(i) = kept.iter().position(|x| x == "--out") {
        kept.drain(i..i + 2);
    }
    Ok(Plan {
        folder,
        record,
        args,
        stamp: ItemStamp {
            args: kept,
            record_sha256: sha,
            effects_sha256,
        },
        model,
        seed: item.seed,
    })
}

/// Parses `hbis fit` arguments as the binary does; a clap error becomes
/// its first line.
fn parse_fit(args: &[String]) -> Result<fit::Args> {
    FitCommand::try_parse_from(args)
        .map(|c| c.args)
        .map_err(|e| {
            let msg = e.to_string();
            anyhow::anyhow!(
                "{}",
                msg.lines()
                    .next()
                    .unwrap_or("")
                    .trim_start_matches("error: ")
            )
        })
}

impl Plan {
    fn fit_args(&self) -> Result<fit::Args> {
        parse_fit(&self.args)
    }

    /// Whether a complete result of this very item is in its folder.
    fn is_done(&self) -> Result<bool> {
        let Ok(text) = std::fs::read_to_string(self.folder.join(MANIFEST)) else {
            return Ok(false);
        };
        let Ok(m) = serde_json::from_str::<Manifest>(&text) else {
            return Ok(false);
        };
        let same_run =
            m.complete && m.command == "fit" && m.seed == self.seed && m.model == self.model;
        let stamp = std::fs::read_to_string(self.folder.join(STAMP))
            .ok()
            .and_then(|t| serde_json::from_str::<ItemStamp>(&t).ok());
        Ok(same_run
            && stamp.as_ref() == Some(&self.stamp)
            && m.record.as_ref().map(|r| &r.sha256) == Some(&self.stamp.record_sha256))
    }

    /// Records what the finished item was run with.
    fn stamp(&self) -> Result<()> {
        let text = serde_json::to_string_pretty(&self.stamp)? + "\n";
        write_file_atomic(&self.folder.join(STAMP), &[&self.record], text.as_bytes())?;
        Ok(())
    }
}

fn collect(a: &Args, study: &Study, items: &[Item], plans: &[Plan]) -> Result<()> {
    let mut missing = Vec::new();
    for (item, p) in items.iter().zip(plans) {
        if !p.is_done()? {
            missing.push(describe(study, item));
        }
    }
    if !missing.is_empty() {
        let shown: Vec<&String> = missing.iter().take(10).collect();
        anyhow::bail!(
            "{} of {} items have no complete result in {} (run their shards; finished items are skipped): {}{}",
            missing.len(),
            items.len(),
            a.out.display(),
            shown.iter().map(|s| s.as_str()).collect::<Vec<_>>().join("; "),
            if missing.len() > 10 { "; ..." } else { "" }
        );
    }
    let all: Vec<usize> = (0..items.len()).collect();
    write_summary(a, study, items, plans, &all, "summary.csv")
}

/// Writes the tidy summary of `which` items (in the study's order).
fn write_summary(
    a: &Args,
    study: &Study,
    items: &[Item],
    plans: &[Plan],
    which: &[usize],
    name: &str,
) -> Result<()> {
    let mut text = summary_header();
    for &k in which {
        let path = plans[k].folder.join("fit.json");
        let fit: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(&path)
                .with_context(|| format!("cannot read {}", path.display()))?,
        )
        .with_context(|| format!("in {}", path.display()))?;
        let item = &items[k];
        text.push_str(&summary_rows(
            &study.records[item.record].name,
            &item.model,
            item.seed,
            &fit,
        ));
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create folder {}", a.out.display()))?;
    let path = a.out.join(name);
    let inputs: Vec<&Path> = std::iter::once(a.manifest.as_path())
        .chain(study.records.iter().map(|r| r.path.as_path()))
        .collect();
    write_file_atomic(&path, &inputs, text.as_bytes())?;
    let mut err = std::io::stderr().lock();
    writeln!(err, "wrote {} ({} items)", path.display(), which.len())?;
    Ok(())
}
