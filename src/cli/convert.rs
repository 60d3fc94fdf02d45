//! `hbis convert`: Table 8.2 quantities by eq. 8.1.

use std::path::PathBuf;

use anyhow::{Context, Result};
use hbis::model::physical::Physical;

use super::inputs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON file of parameters (every parameter of --model, by name).
    #[arg(long)]
    params: PathBuf,
    /// Model the parameters belong to: any model of the registry (catalog
    /// components and --effects included); eq. 8.1 reads its spring,
    /// friction and damper.
    #[arg(long, default_value = "trilinear+lcfm+viscous")]
    model: String,
    #[command(flatten)]
    effects: inputs::EffectArgs,
    /// Released force F0^n (kN).
    #[arg(long, allow_negative_numbers = true)]
    released_force: f64,
    /// Static friction force F_fS (kN).
    #[arg(long, allow_negative_numbers = true)]
    static_friction: f64,
    /// Print a JSON object (keys m, k0, k1, k2, kF, c) instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<()> {
    let registry = a.effects.registry()?;
    let model = inputs::model(&registry, &a.model)?;
    hbis::model::physical::check_convertible(&model).context("--model")?;
    let theta = inputs::model_params(&model, &a.params)?;
    let p = model.core_params(&theta)?;
    let q = Physical::from_params(&model.spec(), &p, a.released_force, a.static_friction)?;
    if a.json {
        super::print_stdout(&(serde_json::to_string_pretty(&q)? + "\n"))?;
    } else {
        super::print_stdout(&table(&q))?;
    }
    Ok(())
}

/// The quantities as an aligned table with units.
pub fn table(q: &Physical) -> String {
    format!(
        "m  = {:10.1} t\nk0 = {:10.1} kN/m\nk1 = {:10.1} kN/m\nk2 = {:10.1} kN/m\nkF = {:10.1} kN/m\nc  = {:10.1} kNs/m\n",
        q.m, q.k0, q.k1, q.k2, q.kf, q.c
    )
}
