//! Reading the user's input files, with the file named in every error.

use std::path::Path;

use anyhow::{bail, Context, Result};
use hbis::data::{record_warnings, AccelUnits, Aligned, Record, Warning};
use hbis::model::{ForwardModel, Model, Registry};

/// `--effects FILE` (repeatable): a user's effect files, added to the
/// built-in catalog.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct EffectArgs {
    /// An effect file (TOML) whose component joins the catalog: parsed in
    /// --model, offered as a candidate (docs/components.md). Repeatable.
    #[arg(long = "effects", value_name = "FILE")]
    pub effects: Vec<std::path::PathBuf>,
}

impl EffectArgs {
    /// The built-in registry with every effect file loaded.
    pub fn registry(&self) -> Result<Registry> {
        let mut registry = super::base_registry();
        for path in &self.effects {
            registry
                .load_effect_file(path)
                .with_context(|| format!("--effects {}", path.display()))?;
        }
        Ok(registry)
    }
}

/// Parse a model argument with `registry` (core laws, catalog components
/// and the user's effects).
pub fn model(registry: &Registry, s: &str) -> Result<Model> {
    registry
        .parse(s)
        .with_context(|| format!("--model `{s}` (an effect file's component needs --effects FILE)"))
}

/// Create the parent folder of an output file if needed.
pub fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create folder {}", dir.display()))?;
    }
    Ok(())
}

/// How a record file is read: its acceleration unit and whether detected
/// single-sample outliers are replaced before the fit.
#[derive(Debug, Clone, clap::Args)]
pub struct RecordArgs {
    /// Unit of the record's acceleration column: `m/s2`, `g` or `mm/s2`
    /// (converted to m/s^2 on reading).
    #[arg(long, default_value = "m/s2")]
    pub accel_units: String,
    /// Replace detected single-sample outliers (glitches) by the mean of
    /// their neighbours before the fit (they are always reported, and
    /// always ignored by the release detection).
    #[arg(long)]
    pub drop_outliers: bool,
}

impl RecordArgs {
    /// The unit asked for, refused before any work if unknown.
    pub fn units(&self) -> Result<AccelUnits> {
        self.accel_units
            .parse::<AccelUnits>()
            .with_context(|| format!("--accel-units `{}`", self.accel_units))
    }
}

/// Reads, converts and aligns a record; returns it with the warnings it
/// raises (printed on standard error as well).
pub fn record(path: &Path, how: &RecordArgs, t0: Option<f64>) -> Result<(Aligned, Vec<Warning>)> {
    let units = how.units()?;
    let within = || format!("in record {}", path.display());
    let raw = Record::read(path)
        .and_then(|r| r.in_units(units))
        .with_context(within)?;
    let (record, dropped) = if how.drop_outliers {
        raw.without_outliers()
    } else {
        (raw.clone(), Vec::new())
    };
    let data = record.aligned(t0).with_context(within)?;
    let mut warnings = record_warnings(&raw, &data);
    if !dropped.is_empty() {
        let rows: Vec<String> = dropped.iter().map(|o| o.row.to_string()).collect();
        warnings.push(Warning {
            code: "outliers-dropped".into(),
            message: format!(
                "{} single-sample outliers replaced by the mean of their neighbours before the fit (rows {})",
                dropped.len(),
                rows.join(", ")
            ),
        });
    }
    print_warnings(&warnings);
    Ok((data, warnings))
}

/// Prints warnings on standard error (ignoring a closed stderr).
pub fn print_warnings(warnings: &[Warning]) {
    use std::io::Write;
    let mut err = std::io::stderr().lock();
    for w in warnings {
        let _ = writeln!(err, "{w}");
    }
}

/// Every parameter of `model` from a JSON object, by name.
pub fn model_params(model: &Model, path: &Path) -> Result<Vec<f64>> {
    let within = || format!("parameters {}", path.display());
    let text = std::fs::read_to_string(path).with_context(within)?;
    let value = hbis::data::strict_json::parse(&text).with_context(within)?;
    let Some(obj) = value.as_object() else {
        bail!("{}: expected a JSON object of parameters", within());
    };
    let names = model.param_names();
    if let Some(k) = obj.keys().find(|k| !names.contains(k)) {
        bail!(
            "{}: parameter `{k}` is not used by model `{}` (its parameters: {})",
            within(),
            model.name(),
            names.join(", ")
        );
    }
    let theta = names
        .iter()
        .map(|n| match obj.get(n) {
            Some(v) => v.as_f64().filter(|x| x.is_finite()).with_context(|| {
                format!(
                    "{}: parameter `{n}` = {v}: expected a finite number",
                    within()
                )
            }),
            None => bail!(
                "{}: missing parameter `{n}` of model `{}`",
                within(),
                model.name()
            ),
        })
        .collect::<Result<Vec<_>>>()?;
    model.check(&theta).with_context(within)?;
    Ok(theta)
}
