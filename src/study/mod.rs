//! The runners: one job each, end to end, over a [`Registry`](crate::model::Registry).
//!
//! Every front end (the `hbis` binary, the Python package, a user's own
//! binary through [`crate::cli::run`]) is arguments and printing over these;
//! the files a runner writes and the values it returns are the same whoever
//! calls it.
//!
//! - [`fit`]: one record, the MAP, the posterior, summaries, identifiability
//!   ([`fit_record`]); its outputs (`fit.json`, `fit.csv`, chains, figures,
//!   `report.html`) in [`outputs`];
//! - [`criticize`]: `diagnose` and `ladder`, their reports
//!   (`diagnosis.json`, `ladder.json`) and figures;
//! - [`predict`]: the posterior predictive response to an earthquake and the
//!   reader of a fit's draws; its job and files in [`prediction`];
//! - [`batch`]: studies of many records (manifest, items, shards, summary),
//!   run by [`batch_run`] (skipping, stamps, the summary).

pub mod batch;
pub mod batch_run;
pub mod criticize;
pub mod fit;
pub mod outputs;
pub mod predict;
pub mod prediction;

pub use fit::*;
