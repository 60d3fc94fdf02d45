//! Studies of many records: a manifest of records x models x seeds, its
//! items in a fixed order, shards of them for a job array, and the tidy
//! summary across the study.
//!
//! A study is a TOML file (`docs/cli.md`, "hbis batch"):
//!
//! ```toml
//! models = ["trilinear+lcfm+viscous"]
//! seeds = [1, 2]
//!
//! [fit]                      # hbis fit's flags without the dashes
//! ensembles = 2
//! map-only = false
//! prior = "priors/a.json"    # relative to the manifest's folder
//!
//! [[record]]
//! path = "records/test3.csv" # relative to the manifest's folder
//! name = "test3"             # default: the file's stem
//! released-force = 1050      # any fit flag, for this record only
//! static-friction = 100
//! ```
//!
//! Item `k` (records, then models, then seeds, in the manifest's order)
//! belongs to shard `k mod n + 1` of `n`: round robin, so that records of
//! different lengths spread over the shards. Every item's result depends
//! only on its record, model, seed and options, so a study split into
//! shards and collected equals the unsplit run.
//!
//! ```
//! use hbis::batch::{Shard, Study};
//!
//! let study = Study::parse(
//!     "models = [\"bilinear+coulomb\"]\nseeds = [1, 2]\n[[record]]\npath = \"a.csv\"\n[[record]]\npath = \"b.csv\"\n",
//!     "/data".as_ref(),
//! )?;
//! let items = study.items();
//! assert_eq!(items.len(), 4);
//! assert_eq!(items[1].folder(&study), std::path::Path::new("a/bilinear+coulomb/seed-2"));
//! let shard: Shard = "2/2".parse()?;
//! assert_eq!(study.items().into_iter().filter(|i| shard.holds(i)).count(), 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;
use std::hash::Hash;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use thiserror::Error;

/// What is wrong with a study manifest or a shard.
#[derive(Debug, Error)]
pub enum BatchError {
    /// Not TOML.
    #[error("not a TOML study manifest: {0}")]
    Syntax(String),
    /// A key is missing, of the wrong type, or unknown.
    #[error("`{key}`: {problem}")]
    Key {
        /// The key, with its table (`record[2].path`).
        key: String,
        /// What was expected.
        problem: String,
    },
    /// A shard that is not `i/n` with `1 <= i <= n`.
    #[error("shard `{0}`: expected i/n with 1 <= i <= n, e.g. 1/4")]
    Shard(String),
}

/// Most items (records x models x seeds) a study may hold: each is a fit
/// of seconds to minutes, so 100,000 is weeks of work; a manifest of a few
/// lines listing more is a mistake, refused before anything is planned.
pub const MAX_ITEMS: usize = 100_000;

fn key_err(key: impl Into<String>, problem: impl Into<String>) -> BatchError {
    BatchError::Key {
        key: key.into(),
        problem: problem.into(),
    }
}

/// `hbis fit` flags a manifest may set (without their dashes), with
/// whether they take a value. `data`, `model`, `seed` and `out` come from
/// the item.
pub const FIT_OPTIONS: &[(&str, bool)] = &[
    ("noise", true),
    ("prior", true),
    ("max-evals", true),
    ("map-only", false),
    ("ensembles", true),
    ("walkers", true),
    ("tau-multiple", true),
    ("max-steps", true),
    ("ess", true),
    ("moves", true),
    ("evidence", false),
    ("released-force", true),
    ("static-friction", true),
    ("design-target", true),
    ("no-design", false),
    ("t0", true),
    ("accel-units", true),
    ("drop-outliers", false),
    ("thin", true),
    ("no-chains", false),
    ("keep-checkpoint", false),
];

/// `hbis fit` options whose value is a file: resolved against the
/// manifest's folder, as record paths are, and their content is in each
/// item's stamp.
pub const FILE_OPTIONS: &[&str] = &["prior"];

/// One record of the study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyRecord {
    /// Its name in folders and the summary (unique in the study).
    pub name: String,
    /// The file, resolved against the manifest's folder.
    pub path: PathBuf,
    /// Its own fit flags, after the study's.
    pub flags: Vec<String>,
}

/// A parsed study manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    /// The records, in the manifest's order.
    pub records: Vec<StudyRecord>,
    /// The models (specs), in the manifest's order.
    pub models: Vec<String>,
    /// The seeds, in the manifest's order.
    pub seeds: Vec<u64>,
    /// Fit flags of every item.
    pub flags: Vec<String>,
    /// Effect files (key `effects`), resolved against the manifest's
    /// folder: every item is fitted with them loaded (`--effects`).
    pub effects: Vec<PathBuf>,
}

/// One fit of the study: a record, a model, a seed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Item {
    /// Position in the study's order (0-based).
    pub index: usize,
    /// Index of its record in [`Study::records`].
    pub record: usize,
    /// Model spec.
    pub model: String,
    /// Seed.
    pub seed: u64,
}

impl Item {
    /// Its folder inside the study's output folder:
    /// `<record>/<model>/seed-<seed>`.
    pub fn folder(&self, study: &Study) -> PathBuf {
        Path::new(&study.records[self.record].name)
            .join(&self.model)
            .join(format!("seed-{}", self.seed))
    }
}

/// Shard `index` of `count` (1-based), as `i/n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, 1..=count.
    pub index: usize,
    /// How many shards.
    pub count: usize,
}

impl Shard {
    /// The whole study as one shard.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// Whether `item` belongs to this shard (round robin).
    pub fn holds(&self, item: &Item) -> bool {
        item.index % self.count + 1 == self.index
    }
}

impl FromStr for Shard {
    type Err = BatchError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || BatchError::Shard(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || count == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A table's fit options as flags, refusing unknown keys and values of the
/// wrong type. `skip` names keys handled elsewhere; file options resolve
/// against `base`.
fn flags_of(
    table: &toml::Table,
    at: &str,
    skip: &[&str],
    base: &Path,
) -> Result<Vec<String>, BatchError> {
    let mut flags = Vec::new();
    for (k, v) in table {
        if skip.contains(&k.as_str()) {
            continue;
        }
        let key = format!("{at}{k}");
        let Some(&(_, takes_value)) = FIT_OPTIONS.iter().find(|(name, _)| name == k) else {
            let known: Vec<&str> = FIT_OPTIONS.iter().map(|(n, _)| *n).collect();
            return Err(key_err(
                key,
                format!(
                    "not an option of hbis fit here (known: {})",
                    known.join(", ")
                ),
            ));
        };
        match (takes_value, v) {
            (false, toml::Value::Boolean(true)) => flags.push(format!("--{k}")),
            (false, toml::Value::Boolean(false)) => {}
            (false, _) => return Err(key_err(key, "expected true or false")),
            (true, v) => flags.extend(value_flag(k, v, base).map_err(|p| key_err(key, p))?),
        }
    }
    Ok(flags)
}

/// `--k value` for an option that takes one; a file option's path joined
/// to `base`.
fn value_flag(k: &str, v: &toml::Value, base: &Path) -> Result<Vec<String>, &'static str> {
    let value = match v {
        toml::Value::String(s) if FILE_OPTIONS.contains(&k) => base.join(s).display().to_string(),
        _ if FILE_OPTIONS.contains(&k) => return Err("expected a file path (a string)"),
        toml::Value::String(s) => s.clone(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(x) => x.to_string(),
        _ => return Err("expected a number or a string"),
    };
    // Apart, a value starting with a dash (`-3`) would be read by `hbis fit`
    // as a flag of its own, and its error would not name the option.
    Ok(if value.starts_with('-') {
        vec![format!("--{k}={value}")]
    } else {
        vec![format!("--{k}"), value]
    })
}

/// Flags as groups, each a flag with its value if it has one. Values never
/// start with a dash (see [`value_flag`]).
fn flag_groups(flags: &[String]) -> Vec<&[String]> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=flags.len() {
        if i == flags.len() || flags[i].starts_with("--") {
            out.push(&flags[start..i]);
            start = i;
        }
    }
    out
}

/// The option a group sets, without dashes: `walkers` for `--walkers=-3`.
fn flag_name(group: &[String]) -> &str {
    let flag = group[0].trim_start_matches("--");
    flag.split_once('=').map_or(flag, |(n, _)| n)
}

/// The value a group gives, attached (`--k=v`) or apart (`--k v`).
fn flag_value(group: &[String]) -> Option<&str> {
    match group.get(1) {
        Some(v) => Some(v),
        None => group[0].split_once('=').map(|(_, v)| v),
    }
}

/// Refuses an entry listed twice under `key`: its item would run once and
/// its rows be written once per copy.
fn refuse_duplicates<T: Hash + Eq>(
    list: &[T],
    key: &str,
    shown: impl Fn(&T) -> String,
) -> Result<(), BatchError> {
    let mut first = HashMap::new();
    for (j, x) in list.iter().enumerate() {
        if let Some(i) = first.insert(x, j) {
            return Err(key_err(
                format!("{key}[{}]", j + 1),
                format!(
                    "{} is listed twice (also {key}[{}]): list each once",
                    shown(x),
                    i + 1
                ),
            ));
        }
    }
    Ok(())
}

/// A TOML error on one line: where it is, the key being read there (the
/// last one at or before that line), and the message's lines joined.
fn syntax_error(text: &str, e: &toml::de::Error) -> BatchError {
    let message: Vec<&str> = e
        .message()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    let message = message.join("; ");
    let Some(at) = e.span().map(|s| s.start.min(text.len())) else {
        return BatchError::Syntax(message);
    };
    let before = text.get(..at).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    let key = match key_before(text, line) {
        Some((k, l)) if l == line => format!(", at `{k}`"),
        Some((k, _)) => format!(", after `{k}`"),
        None => String::new(),
    };
    BatchError::Syntax(format!("line {line}, column {column}{key}: {message}"))
}

/// The last `key = ...` at or before line `line` (1-based), with its table
/// (`fit.walkers`, `record[2].path`), and its line.
fn key_before(text: &str, line: usize) -> Option<(String, usize)> {
    let mut table = String::new();
    let mut arrays: BTreeMap<String, usize> = BTreeMap::new();
    let mut key = None;
    for (n, l) in text.lines().take(line).enumerate() {
        let l = l.trim();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let count = arrays.entry(name.trim().to_string()).or_default();
            *count += 1;
            table = format!("{}[{count}].", name.trim());
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.split(']').next()) {
            table = format!("{}.", name.trim());
        } else if let Some((k, _)) = l.split_once('=') {
            let k = k.trim();
            let bare = !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
            if bare {
                key = Some((format!("{table}{k}"), n + 1));
            }
        }
    }
    key
}

fn string_list(table: &toml::Table, key: &str) -> Result<Vec<String>, BatchError> {
    let v = table.get(key).ok_or_else(|| {
        key_err(
            key,
            "missing: expected a list, e.g. [\"trilinear+lcfm+viscous\"]",
        )
    })?;
    let list = v
        .as_array()
        .ok_or_else(|| key_err(key, "expected a list of strings"))?;
    let out = list
        .iter()
        .enumerate()
        .map(|(i, x)| {
            x.as_str()
                .map(str::to_string)
                .ok_or_else(|| key_err(format!("{key}[{}]", i + 1), "expected a string"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if out.is_empty() {
        return Err(key_err(key, "empty: expected at least one"));
    }
    Ok(out)
}

fn seeds(table: &toml::Table) -> Result<Vec<u64>, BatchError> {
    let Some(v) = table.get("seeds") else {
        return Ok(vec![1]);
    };
    let list = v
        .as_array()
        .ok_or_else(|| key_err("seeds", "expected a list of whole numbers, e.g. [1, 2, 3]"))?;
    let out = list
        .iter()
        .enumerate()
        .map(|(i, x)| match x.as_integer() {
            Some(s) if s >= 0 => Ok(s as u64),
            _ => Err(key_err(
                format!("seeds[{}]", i + 1),
                "expected a whole number >= 0",
            )),
        })
        .collect::<Result<Vec<_>, _>>()?;
    if out.is_empty() {
        return Err(key_err("seeds", "empty: expected at least one"));
    }
    Ok(out)
}

fn record(v: &toml::Value, i: usize, base: &Path) -> Result<StudyRecord, BatchError> {
    let at = format!("record[{}]", i + 1);
    let t = v
        .as_table()
        .ok_or_else(|| key_err(&at, "expected a table ([[record]])"))?;
    let path = t
        .get("path")
        .and_then(|p| p.as_str())
        .ok_or_else(|| key_err(format!("{at}.path"), "missing: expected the record file"))?;
    let path = base.join(path);
    let name = match t.get("name") {
        Some(n) => n
            .as_str()
            .ok_or_else(|| key_err(format!("{at}.name"), "expected a string"))?
            .to_string(),
        None => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    if name.is_empty() || name.starts_with('.') || name.contains(['/', '\\']) {
        return Err(key_err(
            format!("{at}.name"),
            format!("`{name}`: expected a folder name (no slashes, not starting with a dot)"),
        ));
    }
    let flags = flags_of(t, &format!("{at}."), &["path", "name"], base)?;
    Ok(StudyRecord { name, path, flags })
}

impl Study {
    /// Parses a manifest; relative paths (records, effect files, file
    /// options) are resolved against `base` (the manifest's folder).
    /// Duplicate models, seeds or records are refused.
    pub fn parse(text: &str, base: &Path) -> Result<Self, BatchError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
        for k in table.keys() {
            if !["models", "seeds", "effects", "fit", "record"].contains(&k.as_str()) {
                return Err(key_err(
                    k,
                    "unknown key (expected models, seeds, effects, [fit], [[record]])",
                ));
            }
        }
        let models = string_list(&table, "models")?;
        refuse_duplicates(&models, "models", |m| format!("model `{m}`"))?;
        let seeds = seeds(&table)?;
        refuse_duplicates(&seeds, "seeds", |s| format!("seed {s}"))?;
        let effects = match table.get("effects") {
            Some(_) => string_list(&table, "effects")?
                .iter()
                .map(|p| base.join(p))
                .collect(),
            None => Vec::new(),
        };
        let flags = match table.get("fit") {
            Some(toml::Value::Table(t)) => flags_of(t, "fit.", &[], base)?,
            Some(_) => return Err(key_err("fit", "expected a table ([fit])")),
            None => Vec::new(),
        };
        let list = match table.get("record") {
            Some(toml::Value::Array(a)) if !a.is_empty() => a,
            _ => {
                return Err(key_err(
                    "record",
                    "missing: expected at least one [[record]] with a path",
                ))
            }
        };
        let records = list
            .iter()
            .enumerate()
            .map(|(i, v)| record(v, i, base))
            .collect::<Result<Vec<_>, _>>()?;
        let same: Vec<(&Path, &[String])> = records
            .iter()
            .map(|r| (r.path.as_path(), r.flags.as_slice()))
            .collect();
        refuse_duplicates(&same, "record", |(p, _)| {
            format!("record file {} with the same options", p.display())
        })?;
        let mut names = BTreeSet::new();
        for (i, r) in records.iter().enumerate() {
            if !names.insert(r.name.clone()) {
                return Err(key_err(
                    format!("record[{}].name", i + 1),
                    format!("`{}` names two records: give each its own name", r.name),
                ));
            }
        }
        let items = records.len() as u128 * models.len() as u128 * seeds.len() as u128;
        if items > MAX_ITEMS as u128 {
            return Err(key_err(
                "seeds",
                format!(
                    "{} records x {} models x {} seeds make {items} items, more than the {MAX_ITEMS} a study may hold: split it into several manifests",
                    records.len(),
                    models.len(),
                    seeds.len()
                ),
            ));
        }
        Ok(Study {
            records,
            models,
            seeds,
            flags,
            effects,
        })
    }

    /// Every item, records x models x seeds, in the manifest's order.
    pub fn items(&self) -> Vec<Item> {
        let mut out = Vec::new();
        for r in 0..self.records.len() {
            for m in &self.models {
                for &s in &self.seeds {
                    out.push(Item {
                        index: out.len(),
                        record: r,
                        model: m.clone(),
                        seed: s,
                    });
                }
            }
        }
        out
    }

    /// The `hbis fit` arguments of `item`, writing into `out`.
    pub fn fit_args(&self, item: &Item, out: &Path) -> Vec<String> {
        let r = &self.records[item.record];
        let mut args = vec![
            "--data".to_string(),
            r.path.display().to_string(),
            "--model".into(),
            item.model.clone(),
            "--seed".into(),
            item.seed.to_string(),
            "--out".into(),
            out.display().to_string(),
        ];
        for e in &self.effects {
            args.extend(["--effects".to_string(), e.display().to_string()]);
        }
        args.extend(self.item_flags(item));
        args
    }

    /// The study's flags, then the record's; a record's option replaces
    /// the study's (`hbis fit` takes each once).
    fn item_flags(&self, item: &Item) -> Vec<String> {
        let own = &self.records[item.record].flags;
        let mine: BTreeSet<&str> = flag_groups(own).into_iter().map(flag_name).collect();
        let study = flag_groups(&self.flags)
            .into_iter()
            .filter(|g| !mine.contains(flag_name(g)));
        study.flatten().chain(own).cloned().collect()
    }

    /// The manifest key that sets fit option `name` (no dashes) for
    /// `item`: the record's own, else `[fit]`'s.
    pub fn key_of(&self, item: &Item, name: &str) -> Option<String> {
        let sets = |flags: &[String]| flag_groups(flags).iter().any(|g| flag_name(g) == name);
        if sets(&self.records[item.record].flags) {
            Some(format!("record[{}].{name}", item.record + 1))
        } else if sets(&self.flags) {
            Some(format!("fit.{name}"))
        } else {
            None
        }
    }

    /// The files of [`FILE_OPTIONS`] that `item` is fitted with: each
    /// option (`prior`), the manifest key that sets it, and the file.
    pub fn option_files(&self, item: &Item) -> Vec<(String, String, PathBuf)> {
        let flags = self.item_flags(item);
        let mut out = Vec::new();
        for g in flag_groups(&flags) {
            let name = flag_name(g);
            if let (true, Some(v)) = (FILE_OPTIONS.contains(&name), flag_value(g)) {
                let key = self.key_of(item, name).unwrap_or_else(|| name.to_string());
                out.push((name.to_string(), key, PathBuf::from(v)));
            }
        }
        out
    }
}

/// The columns of `summary.csv`, one row per item and parameter.
pub const SUMMARY_COLUMNS: &[&str] = &[
    "record",
    "model",
    "seed",
    "parameter",
    "map",
    "mean",
    "sd",
    "q05",
    "q50",
    "q95",
    "ess",
    "rhat",
    "converged",
    "bic",
    "sigma_hat",
];

/// The summary rows of one item from its `fit.json`: every parameter of
/// the MAP, with the posterior's numbers when the fit sampled (empty cells
/// otherwise). Nothing time-dependent is kept, so that a rerun gives the
/// same rows.
pub fn summary_rows(record: &str, model: &str, seed: u64, fit: &serde_json::Value) -> String {
    let num = |v: &serde_json::Value| v.as_f64().map(|x| x.to_string()).unwrap_or_default();
    let mut out = String::new();
    let Some(map) = fit["map"].as_object() else {
        return out;
    };
    let converged = match fit["sampling"]["converged"].as_bool() {
        Some(c) => c.to_string(),
        None => String::new(),
    };
    for (name, v) in map {
        let p = &fit["posterior"][name];
        let cells = [
            csv_cell(record),
            csv_cell(model),
            seed.to_string(),
            csv_cell(name),
            num(v),
            num(&p["mean"]),
            num(&p["sd"]),
            num(&p["q05"]),
            num(&p["q50"]),
            num(&p["q95"]),
            num(&fit["sampling"]["ess"][name]),
            num(&fit["sampling"]["rhat"][name]),
            converged.clone(),
            num(&fit["bic"]),
            num(&fit["sigma_hat"]),
        ];
        let _ = writeln!(out, "{}", cells.join(","));
    }
    out
}

/// A CSV cell, quoted when it holds a comma, a quote or a line break.
fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The header line of `summary.csv`.
pub fn summary_header() -> String {
    SUMMARY_COLUMNS.join(",") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study(text: &str) -> Result<Study, BatchError> {
        Study::parse(text, Path::new("/s"))
    }

    #[test]
    fn effect_files_resolve_against_the_manifest_and_reach_every_item() {
        let s = study(
            "models = [\"trilinear+lcfm+viscous+maxwell-file\"]\nseeds = [1]\neffects = [\"fx/m.toml\"]\n[[record]]\npath = \"x.csv\"\n",
        )
        .unwrap();
        assert_eq!(s.effects, [Path::new("/s/fx/m.toml")]);
        let args = s.fit_args(&s.items()[0], Path::new("out"));
        let at = args.iter().position(|a| a == "--effects").unwrap();
        assert_eq!(args[at + 1], "/s/fx/m.toml");
        let e = study(
            "models = [\"a\"]\nseeds = [1]\neffects = \"m.toml\"\n[[record]]\npath = \"x.csv\"\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("effects"), "{e}");
    }

    #[test]
    fn items_are_records_models_seeds_in_order_and_shards_partition_them() {
        let s = study(
            "models = [\"a\", \"b\"]\nseeds = [3, 4, 5]\n[[record]]\npath = \"x.csv\"\n[[record]]\npath = \"y/z.csv\"\nname = \"zz\"\n",
        )
        .unwrap();
        let items = s.items();
        assert_eq!(items.len(), 12);
        assert_eq!(
            (items[0].record, items[0].model.as_str(), items[0].seed),
            (0, "a", 3)
        );
        assert_eq!(
            (items[5].record, items[5].model.as_str(), items[5].seed),
            (0, "b", 5)
        );
        assert_eq!(items[6].folder(&s), Path::new("zz/a/seed-3"));
        assert_eq!(s.records[1].path, Path::new("/s/y/z.csv"));
        for n in 1..=5 {
            let mut seen = vec![0; items.len()];
            for i in 1..=n {
                let sh = Shard { index: i, count: n };
                for it in items.iter().filter(|it| sh.holds(it)) {
                    seen[it.index] += 1;
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{n} shards: {seen:?}");
        }
    }

    #[test]
    fn fit_options_become_flags_study_first_then_the_record_each_sorted_by_key() {
        let s = study(
            "models = [\"m\"]\n[fit]\nensembles = 2\nmap-only = true\nevidence = false\ntau-multiple = 20.5\n[[record]]\npath = \"x.csv\"\nreleased-force = 1050\naccel-units = \"g\"\n",
        )
        .unwrap();
        let args = s.fit_args(&s.items()[0], Path::new("out/x"));
        assert_eq!(
            args.join(" "),
            "--data /s/x.csv --model m --seed 1 --out out/x --ensembles 2 --map-only --tau-multiple 20.5 --accel-units g --released-force 1050"
        );
    }

    #[test]
    fn bad_manifests_name_the_key() {
        for (text, key) in [
            ("seeds = [1]\n[[record]]\npath = \"x\"\n", "`models`"),
            ("models = []\n[[record]]\npath = \"x\"\n", "`models`: empty"),
            ("models = [\"m\"]\n", "`record`"),
            (
                "models = [\"m\"]\n[[record]]\nname = \"x\"\n",
                "`record[1].path`",
            ),
            (
                "models = [\"m\"]\nseeds = [1, -2]\n[[record]]\npath = \"x\"\n",
                "`seeds[2]`",
            ),
            (
                "models = [\"m\"]\n[fit]\nwalkrs = 4\n[[record]]\npath = \"x\"\n",
                "`fit.walkrs`",
            ),
            (
                "models = [\"m\"]\n[fit]\nmap-only = 1\n[[record]]\npath = \"x\"\n",
                "`fit.map-only`: expected true or false",
            ),
            (
                "models = [\"m\"]\n[[record]]\npath = \"x\"\n[[record]]\npath = \"d/x\"\n",
                "`record[2].name`: `x` names two records",
            ),
            (
                "models = [\"m\"]\n[[record]]\npath = \"x\"\nname = \"../up\"\n",
                "`record[1].name`",
            ),
            ("modles = [\"m\"]\n", "`modles`: unknown key"),
            ("models = [\"m\"\n", "not a TOML"),
        ] {
            let e = study(text).unwrap_err().to_string();
            assert!(e.contains(key), "{text:?}: {e}");
        }
    }

    #[test]
    fn duplicate_models_seeds_and_records_are_refused_naming_both() {
        for (text, expect) in [
            (
                "models = [\"a\", \"b\", \"a\"]\n[[record]]\npath = \"x\"\n",
                "`models[3]`: model `a` is listed twice (also models[1])",
            ),
            (
                "models = [\"a\"]\nseeds = [1, 2, 2]\n[[record]]\npath = \"x\"\n",
                "`seeds[3]`: seed 2 is listed twice (also seeds[2])",
            ),
            (
                "models = [\"a\"]\n[[record]]\npath = \"x\"\n[[record]]\npath = \"./x\"\nname = \"y\"\n",
                "`record[2]`: record file /s/./x with the same options is listed twice (also record[1])",
            ),
        ] {
            let e = study(text).unwrap_err().to_string();
            assert!(e.contains(expect), "{text:?}: {e}");
        }
        // The same file with other options is another item.
        study("models = [\"a\"]\n[[record]]\npath = \"x\"\n[[record]]\npath = \"x\"\nname = \"y\"\nt0 = 0.5\n")
            .unwrap();
    }

    /// A few lines can list millions of items (found by the
    /// `batch_manifest` fuzz target): refused before any planning.
    #[test]
    fn a_study_of_more_than_max_items_is_refused() {
        let seeds: Vec<String> = (0..1001).map(|s| s.to_string()).collect();
        let models: Vec<String> = (0..100).map(|m| format!("\"m{m}\"")).collect();
        let text = format!(
            "models = [{}]\nseeds = [{}]\n[[record]]\npath = \"x\"\n",
            models.join(", "),
            seeds.join(", ")
        );
        let e = study(&text).unwrap_err().to_string();
        assert!(
            e.contains("1 records x 100 models x 1001 seeds make 100100 items"),
            "{e}"
        );
        let fewer = text.replace(", 1000]", "]");
        assert_eq!(study(&fewer).unwrap().items().len(), MAX_ITEMS);
    }

    #[test]
    fn file_options_resolve_against_the_manifest_and_are_listed_with_their_key() {
        let s = study(
            "models = [\"m\"]\n[fit]\nprior = \"p/a.json\"\n[[record]]\npath = \"x.csv\"\n[[record]]\npath = \"y.csv\"\nprior = \"/abs/b.toml\"\n",
        )
        .unwrap();
        let items = s.items();
        let args = s.fit_args(&items[0], Path::new("o")).join(" ");
        assert!(args.ends_with("--prior /s/p/a.json"), "{args}");
        assert_eq!(
            s.option_files(&items[0]),
            [(
                "prior".into(),
                "fit.prior".into(),
                PathBuf::from("/s/p/a.json")
            )]
        );
        assert_eq!(
            s.option_files(&items[1]),
            [(
                "prior".into(),
                "record[2].prior".into(),
                PathBuf::from("/abs/b.toml")
            )]
        );
        let e = study("models = [\"m\"]\n[fit]\nprior = 3\n[[record]]\npath = \"x\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`fit.prior`: expected a file path"), "{e}");
    }

    #[test]
    fn a_record_option_replaces_the_study_one_and_negative_values_stay_attached() {
        let s = study(
            "models = [\"m\"]\n[fit]\nwalkers = 40\nt0 = -0.5\n[[record]]\npath = \"x.csv\"\nwalkers = -3\n[[record]]\npath = \"y.csv\"\n",
        )
        .unwrap();
        let items = s.items();
        let own = s.fit_args(&items[0], Path::new("o")).join(" ");
        assert!(own.ends_with("--out o --t0=-0.5 --walkers=-3"), "{own}");
        assert_eq!(
            s.key_of(&items[0], "walkers").as_deref(),
            Some("record[1].walkers")
        );
        assert_eq!(
            s.key_of(&items[1], "walkers").as_deref(),
            Some("fit.walkers")
        );
        assert_eq!(s.key_of(&items[1], "t0").as_deref(), Some("fit.t0"));
        assert_eq!(s.key_of(&items[1], "ess"), None);
        let other = s.fit_args(&items[1], Path::new("o")).join(" ");
        assert!(other.ends_with("--out o --t0=-0.5 --walkers 40"), "{other}");
    }

    #[test]
    fn toml_errors_are_one_line_with_the_place_and_the_key() {
        for (text, expect) in [
            ("models = [\"m\"\n[fit]\n", "line 2, column 1, after `models`: "),
            (
                "models = [\"m\"]\n[fit]\nwalkers = \n",
                "line 3, column 11, at `fit.walkers`: ",
            ),
            (
                "models = [\"m\"]\n[[record]]\npath = \"a\"\n[[record]]\npath = \"b\"\npath = \"c\"\n",
                "line 6, column 1, at `record[2].path`: ",
            ),
        ] {
            let e = study(text).unwrap_err().to_string();
            assert!(e.starts_with("not a TOML study manifest: "), "{e}");
            assert!(e.contains(expect), "{text:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn shards_parse_as_i_of_n() {
        assert_eq!(
            "3/4".parse::<Shard>().unwrap(),
            Shard { index: 3, count: 4 }
        );
        for bad in ["0/2", "3/2", "1/0", "1", "a/b", "1/2/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn summary_rows_hold_the_map_and_the_posterior() {
        let fit: serde_json::Value = serde_json::from_str(
            r#"{"map": {"u0": 0.1, "f0": 0.5}, "bic": -10.5, "sigma_hat": 0.01,
                "posterior": {"u0": {"mean": 0.11, "sd": 0.001, "q05": 0.109, "q50": 0.11, "q95": 0.112},
                              "f0": {"mean": 0.51, "sd": 0.002, "q05": 0.5, "q50": 0.51, "q95": 0.52}},
                "sampling": {"converged": true, "ess": {"u0": 900.0, "f0": 800.0}, "rhat": {"u0": 1.001, "f0": 1.002}}}"#,
        )
        .unwrap();
        let rows = summary_rows("rec,1", "m", 7, &fit);
        assert_eq!(
            rows,
            "\"rec,1\",m,7,f0,0.5,0.51,0.002,0.5,0.51,0.52,800,1.002,true,-10.5,0.01\n\"rec,1\",m,7,u0,0.1,0.11,0.001,0.109,0.11,0.112,900,1.001,true,-10.5,0.01\n"
        );
        let map_only: serde_json::Value =
            serde_json::from_str(r#"{"map": {"u0": 0.1}, "bic": -1.0, "sigma_hat": 0.02}"#)
                .unwrap();
        assert_eq!(
            summary_rows("r", "m", 1, &map_only),
            "r,m,1,u0,0.1,,,,,,,,,-1,0.02\n"
        );
    }
}
