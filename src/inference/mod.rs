//! The Bayesian layer: priors, likelihood, posterior, the MAP by CMA-ES and
//! an `argmin` polish.

pub mod bounds;
pub mod cmaes;
pub mod likelihood;
pub mod map;
pub mod polish;
pub mod posterior;
pub mod priors;

pub use bounds::{BoundsError, BoxTransform};
pub use cmaes::{Cmaes, CmaesError, CmaesResult, RunSummary, Start, StopReason};
pub use likelihood::Noise;
pub use map::{find_map, MapError, MapEstimate, MapSettings, PolishReport};
pub use polish::{Polish, PolishError, PolishOutcome};
pub use posterior::{Evaluation, Posterior, PosteriorError};
pub use priors::{default_bounds, Prior, PriorError, Priors};
