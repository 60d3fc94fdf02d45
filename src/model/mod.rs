//! The forward model: a rigid mass on a hysteretic spring, a friction slider
//! and a viscous damper, released from an imposed displacement and solved in
//! closed form phase by phase.
//!
//! - [`spring`]: the tri-linear / bi-linear / linear rubber-bearing spring;
//! - [`friction`]: the linear Coulomb slider;
//! - [`phase`]: one linear phase, solved exactly in every regime;
//! - [`simulate`]: the event-driven walk from phase to phase;
//! - [`response`]: samples, forces, residual displacement, work;
//! - [`physical`]: Table 8.2 quantities from the parameters;
//! - [`component`], [`catalog`], [`registry`], [`composed`], [`layout`]: a
//!   model made of components (force terms and output terms) with a typed
//!   parameter layout, the built-in catalog, and the registry that parses
//!   specs and lists candidates;
//! - [`numeric`]: the Dormand-Prince engine for components that are not
//!   piecewise linear.

pub mod catalog;
pub mod component;
pub mod composed;
pub mod effect_file;
pub mod error;
pub mod expr;
pub mod forced;
pub mod friction;
pub mod layout;
pub mod numeric;
pub mod params;
pub mod phase;
pub mod physical;
pub mod registry;
pub mod response;
pub mod simulate;
pub mod spec;
pub mod spring;

pub use component::{
    Core, FeatureKind, ForceComponent, Forces, Kinematics, Memory, OutputComponent, ParamSpec,
    Quantities, Slot, StateSpec,
};
pub use composed::Model;
pub use error::{ParamError, SimError, SpecError};
pub use layout::{Block, Layout};
pub use params::{ParamName, Params};
pub use registry::{Candidate, Component, Registry};
pub use response::{Response, Sample, Work};
pub use simulate::{Phase, PhaseKind, SimOptions, System};
pub use spec::{DamperKind, FrictionKind, ModelSpec, SpringKind};

/// What the inference layer sees of a model: named parameters in, sampled
/// acceleration out. It knows nothing else about the physics.
pub trait ForwardModel: Send + Sync {
    /// The model's name (its spec string).
    fn name(&self) -> String;

    /// The parameters, in the order of `theta`, as their components
    /// declare them.
    fn params(&self) -> Vec<ParamSpec>;

    /// Parameter names, in the order of `theta`.
    fn param_names(&self) -> Vec<String> {
        self.params().into_iter().map(|p| p.name).collect()
    }

    /// Default prior bounds, in the order of `theta`.
    fn bounds(&self) -> Vec<(f64, f64)> {
        self.params().into_iter().map(|p| p.bounds).collect()
    }

    /// Acceleration at `t_i = start + i dt` (`start >= 0` s after release:
    /// a record's first sample may come a little after the release) for
    /// `i < out.len()`, written into `out`.
    fn accel_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError>;

    /// Acceleration at `t_i = i dt` for `i < out.len()`, written into `out`.
    fn accel_into(&self, theta: &[f64], dt: f64, out: &mut [f64]) -> Result<(), SimError> {
        self.accel_grid_into(theta, 0.0, dt, out)
    }

    /// `sum_i (data_i - a_i)^2` over the grid `t_i = start + i dt`, where
    /// the model forms it without storing the acceleration (the white-noise
    /// likelihood needs only this sum); `None` where it cannot, and the
    /// caller samples and sums. Default: `None`.
    fn sse_grid(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        data: &[f64],
    ) -> Option<Result<f64, SimError>> {
        let _ = (theta, start, dt, data);
        None
    }

    /// Whether `theta` lies where the model is identifiable at all; the
    /// posterior puts zero prior mass elsewhere. Default: everywhere.
    fn in_support(&self, theta: &[f64]) -> bool {
        let _ = theta;
        true
    }
}

impl ModelSpec {
    /// A tri-linear spring needs `u3 < u0`: released short of its third
    /// branch, it is the bi-linear model with `f2` and `u3` free and
    /// unidentified (a flat ridge of the posterior that traps searches;
    /// model-notes.md). Fit `bilinear` for such a test.
    pub fn in_support(&self, theta: &[f64]) -> bool {
        if self.spring != SpringKind::Trilinear {
            return true;
        }
        let at = |p: ParamName| self.used().position(|q| q == p).map(|i| theta[i]);
        match (at(ParamName::U3), at(ParamName::U0)) {
            (Some(u3), Some(u0)) => u3 < u0,
            _ => true,
        }
    }
}
