//! # hbis
//!
//! Bayesian identification of hybrid base isolation systems (rubber bearings
//! plus sliding bearings) from free-vibration release tests.
//!
//! The forward model is a rigid mass on a tri-linear hysteretic spring, a
//! linear Coulomb friction slider and a viscous damper, released from an
//! imposed displacement (Markou, Athanasiou & Oliveto). Every phase of motion
//! is linear, so the response is solved in closed form phase by phase, with
//! exact event times.
//!
//! Simulate the Solarino Test 5 of Table 8.1 and print its residual
//! displacement:
//!
//! ```
//! use hbis::model::{ModelSpec, Params, Response};
//!
//! let spec: ModelSpec = "trilinear+lcfm+viscous".parse()?;
//! let params = Params::table_8_1(5).expect("a Table 8.1 test");
//! let response = Response::simulate(&spec, &params, 10.0)?;
//! let u_r = response.residual_displacement().expect("comes to rest");
//! println!("residual displacement: {:.2} mm", 1e3 * u_r);
//! assert!((u_r - 0.003).abs() < 0.001);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Per-unit-mass parameters (SI units) are named as in the paper:
//! `u0, uy, uF0, rF0, zeta0, f0, f1, f2, u3` (see [`model::ParamName`]).
//!
//! The crate reads like the method:
//! - [`model`]: spring, friction, closed-form phases, event-driven
//!   simulation, and the numerical engine for effects that are not
//!   piecewise linear;
//! - [`data`]: measured records (validation, release instant, polarity) and
//!   synthetic ones;
//! - [`inference`]: priors, likelihood, posterior, CMA-ES, polish, the
//!   ensemble sampler, diagnostics, summaries, identifiability, TMCMC;
//! - [`study`]: the runners, one per job (fit, diagnose and ladder,
//!   predict, batch), that every front end calls;
//! - [`criticism`]: residual diagnostics, effects as components, ranking of
//!   missing effects, the ladder;
//! - [`report`]: CSV, `fit.json`, CmdStan chains, figures;
//! - [`cli`]: the `hbis` command line, arguments and printing over the
//!   runners;
//! - [`cancel`]: stopping a run another thread has given up on;
//! - [`parallel`]: running a job on rayon's workers.

// The CLI front end names the library as users do (`hbis::...`).
extern crate self as hbis;

pub mod cancel;
pub mod cli;
pub mod criticism;
pub mod data;
pub mod inference;
pub mod model;
pub mod numeric;
pub mod parallel;
pub mod report;
pub mod study;

// Their place before the runners moved under `study/`.
pub use study::{batch, predict};
