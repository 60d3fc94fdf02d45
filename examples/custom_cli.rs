//! The whole `hbis` command line over a registry of your own: a binary of
//! yours that registers a component (here the gap spring of
//! `custom_force_effect.rs`) and hands the registry to `hbis::cli::run`.
//! Every command then knows it: `fit --model trilinear+lcfm+viscous+gap-spring`,
//! `diagnose` and `ladder` offer it, `predict` simulates it.
//!
//! ```sh
//! cargo run --release --features examples --example custom_cli -- \
//!     predict --model trilinear+lcfm+viscous+gap-spring --params p.json --synthetic
//! ```

use std::sync::Arc;

use hbis::model::Registry;

#[allow(dead_code)]
#[path = "custom_force_effect.rs"]
mod gap;

fn main() -> std::process::ExitCode {
    let mut registry = Registry::builtin();
    if let Err(e) = registry.register_force(Arc::new(gap::GapSpring)) {
        eprintln!("hbis: error: {e}");
        return std::process::ExitCode::from(2);
    }
    hbis::cli::run(registry)
}
