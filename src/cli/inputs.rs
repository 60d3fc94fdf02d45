//! Reading the user's input files, with the file named in every error.

use std::path::Path;

use anyhow::{Context, Result};
use hbis::model::{Model, ModelSpec, Params, Registry};

/// Parse a model argument with the built-in registry (core laws and every
/// catalog component).
pub fn model(s: &str) -> Result<Model> {
    Registry::builtin()
        .parse(s)
        .with_context(|| format!("--model `{s}`"))
}

/// Parse a closed-form core spec argument (spring, friction, damper).
pub fn spec(s: &str) -> Result<ModelSpec> {
    s.parse::<ModelSpec>()
        .with_context(|| format!("--model `{s}`"))
}

/// Read a parameter file for a model.
pub fn params(path: &Path, spec: &ModelSpec) -> Result<Params> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read parameter file {}", path.display()))?;
    let map = Params::map_from_json(&text).with_context(|| format!("in {}", path.display()))?;
    spec.params_from_map(&map)
        .with_context(|| format!("in {}", path.display()))
}

/// Create the parent folder of an output file if needed.
pub fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create folder {}", dir.display()))?;
    }
    Ok(())
}
