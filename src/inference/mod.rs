//! The Bayesian layer: priors, likelihood, posterior, the MAP by CMA-ES and
//! an `argmin` polish, the ensemble sampler and its diagnostics.

pub mod autocorr;
pub mod basins;
pub mod bounds;
pub mod cmaes;
pub mod design;
pub mod diagnostics;
pub mod ensemble;
pub mod identifiability;
pub mod laplace;
pub mod likelihood;
pub mod map;
pub mod pipeline;
pub mod pointwise;
pub mod polish;
pub mod posterior;
pub mod priors;
pub mod proportion;
pub mod release;
pub mod sample;
pub mod stop_check;
pub mod summary;
pub mod tmcmc;

pub use bounds::{BoundsError, BoxTransform};
pub use cmaes::{Cmaes, CmaesError, CmaesResult, RunSummary, Start, StopReason};
pub use likelihood::Noise;
pub use map::{find_map, MapError, MapEstimate, MapSettings, PolishReport};
pub use pipeline::{compare, fit_map, laplace_evidence, Comparison, MapFit, PipelineError};
pub use polish::{Polish, PolishError, PolishOutcome};
pub use posterior::{Evaluation, Posterior, PosteriorError};
pub use priors::{default_bounds, Prior, PriorError, Priors};
pub use sample::{
    conditional_scales, sample_posterior, CheckpointStatus, PosteriorSample, Progress, SampleError,
    SampleSettings,
};
pub use summary::ParamSummary;
