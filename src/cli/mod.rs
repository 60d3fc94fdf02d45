//! The `hbis` command line: parsing and dispatch over the library's
//! runners. Every error is printed with its whole cause chain on one line;
//! bad input exits with code 2. This front end alone uses `anyhow`; the
//! library's own errors are `thiserror` types.
//!
//! A Rust user runs the whole command line over a registry of their own
//! (their components parsed in `--model`, offered by `diagnose` and the
//! ladder, simulated by `predict`) from a binary of theirs:
//!
//! ```no_run
//! use hbis::model::Registry;
//!
//! fn main() -> std::process::ExitCode {
//!     let registry = Registry::builtin(); // register your components here
//!     hbis::cli::run(registry)
//! }
//! ```
//! `examples/custom_cli.rs` does it with a gap spring.

/// `eprintln!` that never panics: a closed or full stderr loses the line,
/// not the run (`eprintln!` panics with "failed printing to stderr").
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod batch;
mod convert;
mod criticize;
mod demo;
mod fit;
mod inputs;
mod predict;
mod simulate;

use std::io::Write;
use std::process::ExitCode;

use anyhow::{Context, Result};

use clap::{Parser, Subcommand};

/// Bayesian identification of hybrid base isolation systems from
/// free-vibration release tests.
#[derive(Debug, Parser)]
#[command(name = "hbis", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a release test in closed form and write its samples as CSV.
    Simulate(simulate::Args),
    /// Convert identification parameters to physical quantities (Table 8.2).
    Convert(convert::Args),
    /// Find the MAP of a model for a measured acceleration record.
    Fit(fit::Args),
    /// Where a fitted model fails and which catalog effect is missing.
    Diagnose(criticize::Args),
    /// Add the best accepted effect, refit, repeat until none is accepted.
    Ladder(criticize::LadderArgs),
    /// Run the built-in demonstration on the Solarino Test 5 parameters.
    Demo(demo::Args),
    /// The identified system's response to an earthquake: each posterior
    /// draw of a fit (or one parameter set) under a ground motion.
    Predict(predict::Args),
    /// Fit a study of many records (records x models x seeds from a TOML
    /// manifest): resumable, split into shards, collected into one summary.
    Batch(batch::Args),
}

/// The registry every command starts from (`--effects` adds to it).
static BASE: std::sync::OnceLock<hbis::model::Registry> = std::sync::OnceLock::new();

/// The registry the command line runs over: the one given to [`run`], or
/// the built-in catalog.
pub(crate) fn base_registry() -> hbis::model::Registry {
    BASE.get()
        .cloned()
        .unwrap_or_else(hbis::model::Registry::builtin)
}

/// The whole command line over `registry` instead of the built-in
/// catalog: arguments from the process, an exit code back (2 on bad
/// input). Call it once per process.
pub fn run(registry: hbis::model::Registry) -> ExitCode {
    run_from(registry, std::env::args_os())
}

/// [`run`] with the arguments given (the first is the program's name).
pub fn run_from<I, T>(registry: hbis::model::Registry, args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    if BASE.set(registry).is_err() {
        let _ = writeln!(
            std::io::stderr(),
            "hbis: error: the command line's registry is set once per process"
        );
        return ExitCode::from(2);
    }
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    dispatch(cli)
}

/// Exit code of a fit whose posterior sample did not converge (every
/// output written); `--allow-unconverged` makes it 0.
pub const EXIT_UNCONVERGED: u8 = 3;

/// A fit whose posterior sample did not converge, after every output was
/// written: a result that is probably not yet a posterior is not a success.
#[derive(Debug, thiserror::Error)]
#[error("the posterior sample did not converge: {reason}; every output is written, and fit.json says `converged: false`")]
pub struct Unconverged {
    /// Why, as `fit.json`'s `sampling.not_converged` says.
    pub reason: String,
}

/// Parse the arguments, run, and turn the outcome into an exit code.
pub fn main() -> ExitCode {
    // clap prints its own usage errors and exits with code 2.
    dispatch(Cli::parse())
}

fn dispatch(cli: Cli) -> ExitCode {
    // On a worker of the pool (`hbis::parallel`), for `main` and a user's
    // own binary (`run`) alike.
    crate::parallel::init_pool();
    let result = crate::parallel::on_pool(|| match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Convert(a) => convert::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Diagnose(a) => criticize::diagnose(a),
        Command::Ladder(a) => criticize::run_ladder(a),
        Command::Demo(a) => demo::run(a),
        Command::Batch(a) => batch::run(a),
        Command::Predict(a) => predict::run(a),
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<Unconverged>() => {
            let _ = writeln!(
                std::io::stderr(),
                "hbis: {e} (exit {EXIT_UNCONVERGED}; --allow-unconverged exits 0)"
            );
            ExitCode::from(EXIT_UNCONVERGED)
        }
        Err(e) => {
            let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            // A closed or full stderr must not turn an error into a panic.
            let _ = writeln!(std::io::stderr(), "hbis: error: {}", chain.join(": "));
            ExitCode::from(2)
        }
    }
}

/// Writes `text` to standard output, flushed, as an error (not a panic)
/// when it cannot be written (`> /dev/full`, a closed pipe).
pub fn print_stdout(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|_| out.flush())
        .context("cannot write to standard output")
}
