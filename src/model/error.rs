//! Errors of the model layer.

use thiserror::Error;

/// A parameter set that cannot be used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ParamError {
    /// Unparseable JSON or not an object of numbers.
    #[error("parameters: {0}")]
    Json(String),
    /// A name outside the paper's set.
    #[error("unknown parameter `{0}` (expected one of u0, uy, uF0, rF0, zeta0, f0, f1, f2, u3)")]
    Unknown(String),
    /// A value that is not a number.
    #[error("parameter `{name}`: expected a number, found {found}")]
    NotANumber { name: String, found: String },
    /// A name the model needs but was not given.
    #[error("missing parameter `{name}` required by model `{model}`")]
    Missing { name: &'static str, model: String },
    /// A name the model does not use.
    #[error("parameter `{name}` is not used by model `{model}` (its parameters: {expected})")]
    Unused {
        name: &'static str,
        model: String,
        expected: String,
    },
    /// A value outside its valid range.
    #[error("parameter `{name}` = {value}: {requirement}")]
    Invalid {
        name: &'static str,
        value: f64,
        requirement: &'static str,
    },
    /// A component's parameter outside its valid range.
    #[error("parameter `{name}` = {value}: {requirement}")]
    Component {
        name: String,
        value: f64,
        requirement: String,
    },
    /// A parameter vector of the wrong length.
    #[error("model `{model}` takes {expected} parameters, got {found}")]
    Length {
        model: String,
        expected: usize,
        found: usize,
    },
}

/// A model spec string that cannot be parsed, or a component that cannot
/// be registered.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SpecError {
    #[error("unknown model component `{name}` (registered: {known})")]
    Unknown { name: String, known: String },
    #[error("model spec `{spec}` names {kind} twice")]
    Duplicate { spec: String, kind: String },
    #[error("model spec `{0}` names no spring (linear, bilinear or trilinear)")]
    NoSpring(String),
    #[error("component `{component}` needs a {slot} in the model")]
    Requires {
        component: String,
        slot: &'static str,
    },
    #[error("component name `{0}` is not usable in a spec (non-empty, no `+`, no surrounding spaces, not `none`)")]
    BadName(String),
    #[error("a component named `{0}` is registered already")]
    Registered(String),
    #[error("`{spec}`: its components carry {found} state variables; the numerical engine holds at most {max}")]
    States {
        spec: String,
        found: usize,
        max: usize,
    },
}

/// A simulation that cannot be completed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    #[error(transparent)]
    Param(#[from] ParamError),
    /// A sampling setting (time step, duration, grid start, noise level) is
    /// not usable.
    #[error("`{name}` = {value}: {requirement}")]
    Grid {
        name: &'static str,
        value: f64,
        requirement: &'static str,
    },
    /// More phases than the cap allows (a runaway or Zeno-like response).
    #[error("more than {cap} phases of motion before t = {t:.6} s: a runaway or chattering response (check the parameters, and a motion's unit and scale; library callers may raise `SimOptions::phase_cap`)")]
    PhaseCap { cap: usize, t: f64 },
    /// The response grows without bound (negative net stiffness).
    #[error("the response diverges (|u| = {u:e} m at t = {t:.6} s): the net restoring force becomes negative")]
    Diverged { t: f64, u: f64 },
    /// A model component produced a NaN or infinite acceleration: a bug in
    /// that component, reported instead of propagated.
    #[error("the model's acceleration is not finite at t = {t:.6} s (a bug in a model component)")]
    NotFinite { t: f64 },
    /// [`SimError::NotFinite`] with the model and the parameter set that
    /// gave it.
    #[error("`{model}`: the acceleration is not finite at t = {t:.6} s with {params} (a model component gives NaN or infinity there)")]
    NotFiniteAt {
        t: f64,
        model: String,
        params: String,
    },
    /// The components carry more state variables than the engine holds.
    #[error("the model's components carry {found} state variables; the numerical engine holds at most {max}")]
    States { found: usize, max: usize },
}
