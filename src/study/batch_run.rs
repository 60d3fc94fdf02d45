//! A study's run: each item planned (its folder, its `hbis fit` arguments,
//! the stamp that says what it was run with), finished items skipped,
//! the rest fitted by the caller's `fit`, and the tidy summary written.
//!
//! The front end supplies only what turns an item's arguments into a fit
//! (`hbis batch` parses them as `hbis fit` does and runs it) and what to
//! print; the skipping, stamping and summary are here, the same for every
//! caller.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::model::{ForwardModel, Registry};
use crate::report::outdir::{
    remove_orphan_temporaries, write_file_atomic, InputEntry, Manifest, OutError, MANIFEST,
};
use crate::study::batch::{summary_header, summary_rows, BatchError, Item, Shard, Study};

/// The file beside an item's results that says what it was run with.
pub const STAMP: &str = "batch-item.json";

/// Why a study's run failed.
#[derive(Debug, Error)]
pub enum BatchRunError {
    /// The manifest or the shard.
    #[error(transparent)]
    Batch(#[from] BatchError),
    /// An item could not be planned (its record, effect files or model).
    #[error("{item}")]
    Plan {
        /// The item, described.
        item: String,
        /// Why.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// An output file.
    #[error(transparent)]
    Out(#[from] OutError),
    /// An item's `fit.json` could not be read for the summary.
    #[error("{path}")]
    Result {
        /// The file.
        path: String,
        /// Why.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// Serialising a stamp.
    #[error("serialising an item's stamp")]
    Json(#[from] serde_json::Error),
    /// Items failed; the others are complete and in the summary.
    #[error("{failed} of {of} items failed (their errors are above; rerun to retry them, finished items are skipped): {names}")]
    Failed {
        /// How many.
        failed: usize,
        /// Of how many run.
        of: usize,
        /// Which, described.
        names: String,
    },
    /// `collect` found items without a complete result.
    #[error("{missing} of {of} items have no complete result in {out} (run their shards; finished items are skipped): {names}")]
    Missing {
        /// How many.
        missing: usize,
        /// Of how many.
        of: usize,
        /// The study's folder.
        out: String,
        /// The first ten, described.
        names: String,
    },
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
    /// SHA-256 of each file option's file (`prior`), by option: an edited
    /// prior file reruns the item.
    #[serde(default)]
    option_files_sha256: BTreeMap<String, String>,
}

/// One item, ready to run.
#[derive(Debug)]
pub struct Plan {
    /// The item.
    pub item: Item,
    /// Its output folder.
    pub folder: PathBuf,
    /// Its record file.
    pub record: PathBuf,
    /// Its `hbis fit` arguments (the output folder included).
    pub args: Vec<String>,
    /// Its model's name, as the registry writes it.
    pub model: String,
    stamp: ItemStamp,
}

/// An item in words: `item 3 (record test3, model ..., seed 2)`.
pub fn describe(study: &Study, item: &Item) -> String {
    format!(
        "item {} (record {}, model {}, seed {})",
        item.index + 1,
        study.records[item.record].name,
        item.model,
        item.seed
    )
}

/// Plans every item of `study` into `out`, over `registry` with the
/// study's effect files loaded. Every item is planned before any runs: a
/// typo costs nothing.
pub fn plan(study: &Study, registry: &Registry, out: &Path) -> Result<Vec<Plan>, BatchRunError> {
    let mut registry = registry.clone();
    for (i, e) in study.effects.iter().enumerate() {
        registry
            .load_effect_file(e)
            .map_err(|x| BatchRunError::Plan {
                item: format!("`effects[{}]` {}", i + 1, e.display()),
                source: x.into(),
            })?;
    }
    refuse_same_models(study, &registry)?;
    let mut hashes = HashMap::new();
    study
        .items()
        .into_iter()
        .map(|item| plan_item(study, &registry, out, item, &mut hashes))
        .collect()
}

/// Refuses two specs of one model (`bilinear+coulomb`, `coulomb+bilinear`):
/// their items would be the same fit twice. Specs that do not parse are
/// left to their items' errors.
fn refuse_same_models(study: &Study, registry: &Registry) -> Result<(), BatchError> {
    let mut first: HashMap<String, usize> = HashMap::new();
    for (j, spec) in study.models.iter().enumerate() {
        let Ok(model) = registry.parse(spec) else {
            continue;
        };
        if let Some(i) = first.insert(model.name(), j) {
            return Err(BatchError::Key {
                key: format!("models[{}]", j + 1),
                problem: format!(
                    "`{spec}` is the model of models[{}] (`{}`): list each model once",
                    i + 1,
                    study.models[i]
                ),
            });
        }
    }
    Ok(())
}

/// One item's plan; `hashes` keeps each input file's SHA-256 (by path),
/// so a file shared by items is read once.
fn plan_item(
    study: &Study,
    registry: &Registry,
    out: &Path,
    item: Item,
    hashes: &mut HashMap<PathBuf, String>,
) -> Result<Plan, BatchRunError> {
    let what = describe(study, &item);
    let mut hash = |key: String, path: &Path| -> Result<String, BatchRunError> {
        if let Some(h) = hashes.get(path) {
            return Ok(h.clone());
        }
        let sha = InputEntry::of(path)
            .map_err(|x| BatchRunError::Plan {
                item: format!("{what}: `{key}`"),
                source: x.into(),
            })?
            .sha256;
        hashes.insert(path.to_path_buf(), sha.clone());
        Ok(sha)
    };
    let record = study.records[item.record].path.clone();
    let record_sha256 = hash(format!("record[{}].path", item.record + 1), &record)?;
    let effects_sha256 = study
        .effects
        .iter()
        .enumerate()
        .map(|(i, e)| hash(format!("effects[{}]", i + 1), e))
        .collect::<Result<Vec<_>, _>>()?;
    let mut option_files_sha256 = BTreeMap::new();
    for (option, key, path) in study.option_files(&item) {
        option_files_sha256.insert(option, hash(key, &path)?);
    }
    let model = registry
        .parse(&item.model)
        .map_err(|x| BatchRunError::Plan {
            item: what.clone(),
            source: x.into(),
        })?
        .name();
    let folder = out.join(item.folder(study));
    let args = study.fit_args(&item, &folder);
    // The output folder is where the results go, not what they are.
    let mut kept = args.clone();
    if let Some(i) = kept.iter().position(|x| x == "--out") {
        kept.drain(i..i + 2);
    }
    Ok(Plan {
        folder,
        record,
        args,
        model,
        stamp: ItemStamp {
            args: kept,
            record_sha256,
            effects_sha256,
            option_files_sha256,
        },
        item,
    })
}

impl Plan {
    /// Whether a complete result of this very item is in its folder.
    pub fn is_done(&self) -> bool {
        let Ok(text) = std::fs::read_to_string(self.folder.join(MANIFEST)) else {
            return false;
        };
        let Ok(m) = serde_json::from_str::<Manifest>(&text) else {
            return false;
        };
        let same_run =
            m.complete && m.command == "fit" && m.seed == self.item.seed && m.model == self.model;
        let stamp = std::fs::read_to_string(self.folder.join(STAMP))
            .ok()
            .and_then(|t| serde_json::from_str::<ItemStamp>(&t).ok());
        same_run
            && stamp.as_ref() == Some(&self.stamp)
            && m.record.as_ref().map(|r| &r.sha256) == Some(&self.stamp.record_sha256)
    }

    /// Records what the finished item was run with.
    pub fn stamp(&self) -> Result<(), BatchRunError> {
        let text = serde_json::to_string_pretty(&self.stamp)? + "\n";
        write_file_atomic(&self.folder.join(STAMP), &[&self.record], text.as_bytes())?;
        Ok(())
    }
}

/// What a study's run tells its caller as it goes.
#[derive(Debug)]
pub enum Event<'a> {
    /// Item `n` of `of` of this shard is complete and skipped.
    Skipped {
        /// 1-based position in the shard.
        n: usize,
        /// Items in the shard.
        of: usize,
        /// The item.
        plan: &'a Plan,
    },
    /// Item `n` is being fitted.
    Fitting {
        /// 1-based position in the shard.
        n: usize,
        /// Items in the shard.
        of: usize,
        /// The item.
        plan: &'a Plan,
    },
    /// Item `n` is done, in `seconds`.
    Done {
        /// 1-based position in the shard.
        n: usize,
        /// Items in the shard.
        of: usize,
        /// The item.
        plan: &'a Plan,
        /// Wall time of its fit (s).
        seconds: f64,
    },
    /// Item `n` failed, with its error's whole chain.
    Failed {
        /// 1-based position in the shard.
        n: usize,
        /// Items in the shard.
        of: usize,
        /// The item.
        plan: &'a Plan,
        /// The error and its causes.
        chain: Vec<String>,
    },
    /// The summary was written.
    Summary {
        /// Its path.
        path: PathBuf,
        /// Items in it.
        items: usize,
    },
}

/// Runs the items of `shard`: finished ones skipped, the others fitted by
/// `fit` (an error fails the item, not the run) and stamped; then the
/// shard's summary. Fails, naming them, if items failed.
#[allow(clippy::too_many_arguments)]
pub fn run(
    study: &Study,
    plans: &[Plan],
    shard: Shard,
    out: &Path,
    manifest: &Path,
    fit: &mut dyn FnMut(&Plan) -> Result<(), Vec<String>>,
    on_event: &mut dyn FnMut(Event<'_>),
) -> Result<(), BatchRunError> {
    let mine: Vec<&Plan> = plans.iter().filter(|p| shard.holds(&p.item)).collect();
    let of = mine.len();
    let name = if shard == Shard::ALL {
        "summary.csv".to_string()
    } else {
        format!("summary-shard-{}-of-{}.csv", shard.index, shard.count)
    };
    // Other shards may share `out`: of its files, only this summary's.
    remove_orphan_temporaries(out, false, &|f| f == name)?;
    let mut failed = Vec::new();
    for (k, plan) in mine.iter().enumerate() {
        let n = k + 1;
        // The item's folder is this shard's alone.
        remove_orphan_temporaries(&plan.folder, true, &|_| true)?;
        if plan.is_done() {
            on_event(Event::Skipped { n, of, plan });
            continue;
        }
        on_event(Event::Fitting { n, of, plan });
        let started = std::time::Instant::now();
        let result = fit(plan).and_then(|()| plan.stamp().map_err(|e| error_chain(&e)));
        match result {
            Ok(()) => on_event(Event::Done {
                n,
                of,
                plan,
                seconds: started.elapsed().as_secs_f64(),
            }),
            Err(chain) => {
                on_event(Event::Failed { n, of, plan, chain });
                failed.push(describe(study, &plan.item));
            }
        }
    }
    let done: Vec<&Plan> = mine.into_iter().filter(|p| p.is_done()).collect();
    let path = write_summary(study, &done, out, manifest, &name)?;
    on_event(Event::Summary {
        path,
        items: done.len(),
    });
    if !failed.is_empty() {
        return Err(BatchRunError::Failed {
            failed: failed.len(),
            of,
            names: failed.join("; "),
        });
    }
    Ok(())
}

/// An error and its causes, each in words.
pub fn error_chain(e: &(dyn std::error::Error + 'static)) -> Vec<String> {
    std::iter::successors(Some(e), |e| e.source())
        .map(|e| e.to_string())
        .collect()
}

/// Gathers every item's result (all shards) into `summary.csv`; fails,
/// naming them, if items have no complete result.
pub fn collect(
    study: &Study,
    plans: &[Plan],
    out: &Path,
    manifest: &Path,
) -> Result<PathBuf, BatchRunError> {
    let missing: Vec<String> = plans
        .iter()
        .filter(|p| !p.is_done())
        .map(|p| describe(study, &p.item))
        .collect();
    if !missing.is_empty() {
        let shown: Vec<&str> = missing.iter().take(10).map(String::as_str).collect();
        return Err(BatchRunError::Missing {
            missing: missing.len(),
            of: plans.len(),
            out: out.display().to_string(),
            names: format!(
                "{}{}",
                shown.join("; "),
                if missing.len() > 10 { "; ..." } else { "" }
            ),
        });
    }
    let all: Vec<&Plan> = plans.iter().collect();
    remove_orphan_temporaries(out, false, &|f| f == "summary.csv")?;
    write_summary(study, &all, out, manifest, "summary.csv")
}

/// Writes the tidy summary of `plans` (in the study's order) as `name` in
/// `out`; returns its path.
fn write_summary(
    study: &Study,
    plans: &[&Plan],
    out: &Path,
    manifest: &Path,
    name: &str,
) -> Result<PathBuf, BatchRunError> {
    let mut text = summary_header();
    for p in plans {
        let path = p.folder.join("fit.json");
        let wrap = |source: Box<dyn std::error::Error + Send + Sync>| BatchRunError::Result {
            path: path.display().to_string(),
            source,
        };
        let raw = std::fs::read_to_string(&path).map_err(|e| wrap(e.into()))?;
        let fit: serde_json::Value = serde_json::from_str(&raw).map_err(|e| wrap(e.into()))?;
        let item = &p.item;
        text.push_str(&summary_rows(
            &study.records[item.record].name,
            &item.model,
            item.seed,
            &fit,
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| BatchRunError::Result {
        path: out.display().to_string(),
        source: e.into(),
    })?;
    let path = out.join(name);
    let inputs: Vec<&Path> = std::iter::once(manifest)
        .chain(study.records.iter().map(|r| r.path.as_path()))
        .collect();
    write_file_atomic(&path, &inputs, text.as_bytes())?;
    Ok(path)
}
