//! Components of a model: the terms of the equation of motion (force
//! components) and what stands between the motion and the accelerometer
//! (output components). Each declares its parameters; the [`Model`] lays
//! them out and picks the engine.
//!
//! A force component either fills one of the three slots of the paper's
//! model (spring law, friction law, damper: [`Core`]) or changes the forces
//! of the equation of motion at a state ([`ForceComponent::modify`]). The
//! model runs the closed form when every force component is piecewise
//! linear ([`ForceComponent::piecewise_linear`]: it changes only the
//! resolved linear system, [`ForceComponent::configure`]) and the numerical
//! Dormand-Prince engine otherwise.
//!
//! [`Model`]: super::Model

use super::error::ParamError;
pub use super::layout::ParamSpec;
use super::simulate::System;
use super::spec::{DamperKind, FrictionKind, SpringKind};

/// The slot of the paper's model a core component fills.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Core {
    /// The rubber-bearing spring law.
    Spring(SpringKind),
    /// The slider's friction law.
    Friction(FrictionKind),
    /// The damper.
    Damper(DamperKind),
}

/// Which slot: spring, friction or damper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Slot {
    /// The rubber-bearing spring.
    Spring,
    /// The slider.
    Friction,
    /// The damper.
    Damper,
}

impl Core {
    /// The slot it fills.
    pub fn slot(self) -> Slot {
        match self {
            Core::Spring(_) => Slot::Spring,
            Core::Friction(_) => Slot::Friction,
            Core::Damper(_) => Slot::Damper,
        }
    }
}

/// The state the forces are evaluated at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics {
    /// Displacement (m).
    pub u: f64,
    /// Velocity (m/s).
    pub v: f64,
    /// Direction of sliding, `+1` or `-1` (the direction the mass is about
    /// to move when `v = 0`).
    pub dir: f64,
    /// Distance travelled since the release, `int |u'| dt` (m).
    pub travel: f64,
}

/// Quantities of the model a component may read besides its own
/// parameters (per unit mass, as every force here).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantities {
    /// `k0/m = (2 pi f0)^2`: the rubber bearing's initial stiffness per
    /// unit mass (1/s^2).
    pub k0: f64,
    /// `u0`: the displacement the mass is held at before the release (m);
    /// `0` for a response from rest (an earthquake).
    pub u0: f64,
}

/// A state variable of a component with memory (a relaxing element's
/// internal displacement, a hysteretic variable, a temperature).
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpec {
    /// Name in outputs (e.g. `q_m`).
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// One line: the physical meaning.
    pub meaning: String,
}

impl StateSpec {
    /// A state with its name, unit and meaning.
    pub fn new(name: &str, unit: &str, meaning: &str) -> Self {
        Self {
            name: name.to_string(),
            unit: unit.to_string(),
            meaning: meaning.to_string(),
        }
    }
}

/// What a component sees besides the kinematics: the time since the
/// release, its own state variables (empty for a component without memory)
/// and the model's [`Quantities`].
#[derive(Debug, Clone, Copy)]
pub struct Memory<'a> {
    /// Time since the release (s).
    pub t: f64,
    /// The component's own state variables, in the order of
    /// [`ForceComponent::states`].
    pub x: &'a [f64],
    /// The model's quantities.
    pub q: &'a Quantities,
}

/// The force terms per unit mass (m/s^2) at a state, signed as in the
/// equation of motion `u'' = -(spring + friction + damper + extra)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Forces {
    /// Rubber-bearing spring.
    pub spring: f64,
    /// Slider (its sign is the direction of sliding).
    pub friction: f64,
    /// Viscous damper.
    pub damper: f64,
    /// Any other force a component adds.
    pub extra: f64,
}

impl Forces {
    /// The acceleration they give.
    pub fn accel(&self) -> f64 {
        -(self.spring + self.friction + self.damper + self.extra)
    }
}

/// A term of the equation of motion.
///
/// A user writes one by giving its name, parameters and either
/// [`configure`](Self::configure) (piecewise linear: closed form) or
/// [`modify`](Self::modify) (anything else: numerical engine).
pub trait ForceComponent: Send + Sync {
    /// Name in model specs (`velocity-friction`, `degradation`, ...).
    fn name(&self) -> &str;
    /// Its parameters, in order.
    fn params(&self) -> Vec<ParamSpec>;
    /// One line: what it models.
    fn meaning(&self) -> &str;
    /// How a record shows that it is missing (offered with candidates).
    fn signature(&self) -> &str {
        self.meaning()
    }
    /// The residual structure it explains when missing; empty: the
    /// residual's serial correlation as a whole.
    fn targets(&self) -> Vec<FeatureKind> {
        Vec::new()
    }
    /// The slot it fills, for the paper's spring laws, friction laws and
    /// damper; `None` for a component that modifies the forces.
    fn core(&self) -> Option<Core> {
        None
    }
    /// Whether it is the rubber's spring law in place of the paper's
    /// piecewise-linear ones: the model's spring slot then holds the linear
    /// law (its `f0` is the initial stiffness, `k0` in [`Quantities`]) and
    /// this component sets the spring force. It stands in the spring's
    /// place in a spec (`bouc-wen+lcfm+viscous`).
    fn spring_law(&self) -> bool {
        false
    }
    /// The core component this one replaces in a fitted model when added
    /// (`trilinear` upgrades `bilinear`).
    fn upgrades(&self) -> Option<&str> {
        None
    }
    /// A slot that must be filled for it to make sense (a friction law
    /// needs a slider).
    fn requires(&self) -> Option<Slot> {
        None
    }
    /// Whether every phase stays linear with it, so the closed form (after
    /// [`configure`](Self::configure)) solves it exactly.
    fn piecewise_linear(&self) -> bool;
    /// Checks its parameter values (the model refuses others).
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        let _ = theta;
        Ok(())
    }
    /// Changes the resolved linear system (piecewise-linear components).
    fn configure(&self, theta: &[f64], system: &mut System) {
        let _ = (theta, system);
    }
    /// Changes the forces at a state (components solved numerically).
    fn modify(&self, theta: &[f64], state: &Kinematics, forces: &mut Forces) {
        let _ = (theta, state, forces);
    }
    /// Its state variables (a component with memory); none by default.
    /// A component with states is never piecewise linear: the numerical
    /// engine integrates them with the motion (docs/components.md).
    fn states(&self) -> Vec<StateSpec> {
        Vec::new()
    }
    /// The states at the release, after the test protocol: the mass pushed
    /// quasi-statically from rest at `u = 0` to `q.u0` and held there (for a
    /// response from rest, `q.u0 = 0`). By default zero.
    fn release_states(&self, theta: &[f64], q: &Quantities, out: &mut [f64]) {
        let _ = (theta, q);
        out.fill(0.0);
    }
    /// The states' rates `dx/dt` at a state of the motion (at rest too,
    /// with `v = 0`). By default zero.
    fn rates(&self, theta: &[f64], state: &Kinematics, mem: &Memory, out: &mut [f64]) {
        let _ = (theta, state, mem);
        out.fill(0.0);
    }
    /// Changes the forces at a state of the motion and of the component's
    /// memory. By default [`modify`](Self::modify): a component without
    /// memory implements that one.
    fn modify_with(&self, theta: &[f64], state: &Kinematics, mem: &Memory, forces: &mut Forces) {
        let _ = mem;
        self.modify(theta, state, forces);
    }
    /// Whether, within a phase of one sliding direction, its change to
    /// the forces and its states' rates are affine in `u`, `v` and its
    /// states (the travel is affine in `u` there), constant in time, and
    /// its factors on the spring and friction forces constant: the
    /// numerical engine then solves each phase exactly
    /// ([`crate::numeric::affine`]) where every component is. By default
    /// no.
    fn affine(&self) -> bool {
        false
    }
    /// Displacements where its force has a kink: the numerical engine
    /// stops a step there instead of smoothing over it.
    fn kinks(&self, theta: &[f64], out: &mut Vec<f64>) {
        let _ = (theta, out);
    }
    /// Warm start of its parameters when added to a fitted model whose
    /// values `current` gives by name: by default the neutral values.
    fn warm_start(&self, current: &dyn Fn(&str) -> Option<f64>) -> Vec<f64> {
        let _ = current;
        self.params().iter().map(|p| p.neutral).collect()
    }
}

/// What the accelerometer reports instead of the motion's acceleration: an
/// offset, a superstructure mode, a sensor's filter.
pub trait OutputComponent: Send + Sync {
    /// Name in model specs (`offset`, ...).
    fn name(&self) -> &str;
    /// Its parameters, in order.
    fn params(&self) -> Vec<ParamSpec>;
    /// One line: what it models and how it shows in a record.
    fn meaning(&self) -> &str;
    /// Applies it with parameters `theta` to `accel` sampled every `dt`.
    fn apply(&self, theta: &[f64], dt: f64, accel: &mut [f64]);
    /// Whether the sensor reports the mean acceleration over each sample
    /// interval (centred on the sample instant) instead of the value at the
    /// instant: the model then forms every sample from the velocity at the
    /// interval's ends, before any output component applies (default no).
    fn interval_mean(&self) -> bool {
        false
    }
    /// The residual structure it explains when missing; empty: the
    /// residual's serial correlation as a whole.
    fn targets(&self) -> Vec<FeatureKind> {
        Vec::new()
    }
}

/// A kind of residual structure (measured by
/// [`crate::criticism::features`]): what a component explains when it is
/// missing, so that criticism adds it only if that structure shrinks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FeatureKind {
    /// Serial correlation left in the (whitened) residual: Ljung-Box `Q`.
    Colour,
    /// A mean residual: the accelerometer's offset.
    Offset,
    /// Half-cycle periods off by amplitude (an amplitude-dependent
    /// stiffness the spring law lacks).
    PeriodAmplitude,
    /// Half-cycle period error that drifts across the test (a stiffness
    /// that changes during it).
    PeriodDrift,
    /// Swings that decay faster or slower than the model's (dissipation).
    DecayRate,
    /// Acceleration jumps at reversals larger or smaller (friction there).
    JumpSize,
    /// Jumps that differ by direction of sliding (a friction law whose
    /// jump depends on the direction; `asymmetric-friction`'s does not).
    JumpDirection,
    /// A residual oscillation at a frequency the model cannot produce.
    SpectralPeak,
}
