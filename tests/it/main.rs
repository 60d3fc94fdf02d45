//! The integration tests as one binary: one build and link instead of one
//! per file, and one pool of test threads across files (a file with one
//! long test no longer leaves a core idle).

#[path = "common/bin.rs"]
#[allow(dead_code)]
mod bin;
mod common;

mod basins;
mod calibration;
mod cli;
mod cli_batch;
mod cli_checkpoint;
mod cli_criticism;
mod cli_fit;
mod cli_fit_components;
mod cli_predict;
mod cli_registry;
mod cli_reliability;
mod closed_form_vs_rk;
mod components;
mod criticism;
mod criticism_calibration;
mod design;
mod energy;
mod evidence;
mod evidence_analytic;
mod forced;
mod identifiability;
mod map_second_search;
mod map_synthetic;
mod memory;
mod memory_fit;
mod missing_form;
mod model_props;
mod numeric_engine;
mod paper_checks;
mod record_props;
mod release;
mod sampler_stop;
mod search;
mod sensor;
mod verdicts;
