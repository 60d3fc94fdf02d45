//! Model criticism: where a fitted model fails, which physical effect is
//! missing, and the ladder that adds effects until none is supported.

pub mod effects;
pub mod ranking;
pub mod residuals;

pub use effects::{candidates, Candidate, Composite, Effect, Offset};
pub use ranking::{
    diagnosis_of, fit_model, ladder, ladder_observed, place_release, priors_for, rank_candidates,
    CriticismError, ModelFit, RankedCandidate, Step,
};
pub use residuals::{diagnose, Diagnostics};
