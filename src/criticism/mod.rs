//! Model criticism: where a fitted model fails, which physical effect is
//! missing, and the ladder: a stepwise search that adds, removes and swaps
//! effects until no move lowers BIC.
//!
//! The effects are the components of a [`Registry`](crate::model::Registry)
//! (the built-in catalog, [`crate::model::catalog`], plus any a user
//! registers).

pub mod calibration;
pub mod features;
pub mod missing_form;
pub mod off_jumps;
pub mod ranking;
pub mod residuals;
pub mod sanity;
pub mod search;

pub use missing_form::{missing_form, FormSeries, MissingForm, Term};
pub use ranking::{
    adopt, caution, choose_noise, conclusion, diagnose_model, diagnose_ranking, diagnosis_of,
    fit_model, place_release, priors_for, rank_candidates, rank_described, short_lag_limit,
    CriticismError, ModelFit, NoiseChoice, RankedCandidate, Ranking, Screened,
};
pub use residuals::{diagnose, Diagnostics};
pub use search::{ladder, ladder_observed, Move, PathEnd, Search, Step};
