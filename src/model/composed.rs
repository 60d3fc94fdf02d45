//! One model made of components: the paper's spring law, friction law and
//! damper (the closed-form core), any other force components, and output
//! components, with the typed layout of their parameters.
//!
//! The model runs the closed form when every force component is piecewise
//! linear and the numerical Dormand-Prince engine otherwise; inference code
//! sees one [`ForwardModel`] either way.
//!
//! ```
//! use hbis::model::{ForwardModel, Params, Registry};
//!
//! let registry = Registry::builtin();
//! let model = registry.parse("trilinear+lcfm+viscous+offset")?;
//! assert!(model.closed_form());
//! assert_eq!(model.param_names().last().unwrap(), "a_off");
//! let theta = model.theta_from_params(&Params::table_8_1(5).unwrap(), &[("a_off", 0.01)])?;
//! let mut a = vec![0.0; 3];
//! model.accel_into(&theta, 0.005, &mut a)?;
//! let base = registry.parse("trilinear+lcfm+viscous")?;
//! let mut b = vec![0.0; 3];
//! base.accel_into(&base.theta_from_params(&Params::table_8_1(5).unwrap(), &[])?, 0.005, &mut b)?;
//! assert!((a[0] - b[0] - 0.01).abs() < 1e-15);
//! // Velocity-dependent friction is not piecewise linear: numerical engine.
//! assert!(!registry.parse("trilinear+lcfm+viscous+velocity-friction")?.closed_form());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fmt;
use std::sync::Arc;

use super::catalog::averaging::interval_mean_into;
use super::component::{ForceComponent, OutputComponent, ParamSpec, Slot};
use super::error::{ParamError, SimError};
use super::forced::{Excitation, ForcedSink, Peaks};
use super::layout::Layout;
use super::numeric::{Motion, NumericSystem, RTOL};
use super::params::Params;
use super::simulate::{SimOptions, System};
use super::spec::{DamperKind, FrictionKind, ModelSpec};
use super::ForwardModel;

/// A model: the closed-form core, force components and output components.
#[derive(Clone)]
pub struct Model {
    spec: ModelSpec,
    forces: Vec<Arc<dyn ForceComponent>>,
    outputs: Vec<Arc<dyn OutputComponent>>,
    layout: Layout,
    closed_form: bool,
    /// Per force component: solved by the numerical engine.
    numeric: Vec<bool>,
    /// The sensor reports interval means ([`OutputComponent::interval_mean`]).
    interval_mean: bool,
}

/// Relative tolerance of the numerical engine under shaking (the
/// closed-form cross-check agrees to about 1e-11 m at 1e-12).
pub const FORCED_RTOL: f64 = 1e-9;

/// Index of the core block in the layout.
const CORE: usize = 0;

impl fmt::Debug for Model {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Model({})", self.name())
    }
}

impl From<ModelSpec> for Model {
    fn from(spec: ModelSpec) -> Self {
        Self::new(spec, Vec::new(), Vec::new())
    }
}

impl Model {
    /// The core `spec` with force components and output components, in
    /// the order given (outputs apply in order).
    pub fn new(
        spec: ModelSpec,
        forces: Vec<Arc<dyn ForceComponent>>,
        outputs: Vec<Arc<dyn OutputComponent>>,
    ) -> Self {
        let mut layout = Layout::default();
        layout.push(
            spec.to_string(),
            spec.param_names().into_iter().map(|p| p.spec()).collect(),
        );
        for c in &forces {
            layout.push(c.name().to_string(), c.params());
        }
        for c in &outputs {
            layout.push(c.name().to_string(), c.params());
        }
        // A component with memory needs the engine that integrates its
        // states, whatever it says of its phases.
        let numeric: Vec<bool> = forces
            .iter()
            .map(|c| !c.piecewise_linear() || !c.states().is_empty())
            .collect();
        let closed_form = !numeric.contains(&true);
        let interval_mean = outputs.iter().any(|o| o.interval_mean());
        Self {
            spec,
            forces,
            outputs,
            layout,
            closed_form,
            numeric,
            interval_mean,
        }
    }

    /// The closed-form core (spring, friction, damper).
    pub fn spec(&self) -> ModelSpec {
        self.spec
    }

    /// Whether it is the closed-form core alone (spring, friction, damper;
    /// no other component): its response has phases with exact events.
    pub fn is_core(&self) -> bool {
        self.forces.is_empty() && self.outputs.is_empty()
    }

    /// The force components beyond the core.
    pub fn forces(&self) -> &[Arc<dyn ForceComponent>] {
        &self.forces
    }

    /// The output components.
    pub fn outputs(&self) -> &[Arc<dyn OutputComponent>] {
        &self.outputs
    }

    /// The parameter layout: the core block, then one block per component.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Whether the closed form solves it (every force component piecewise
    /// linear); otherwise the numerical engine runs.
    pub fn closed_form(&self) -> bool {
        self.closed_form
    }

    /// The same model solved by the numerical engine even where the closed
    /// form applies: the baseline against which components that need the
    /// engine are compared (the two engines place an event to within about
    /// 1e-9 s, and a MAP can sit where a reversal falls on a sample
    /// instant, so a sample there lands on either side of the jump).
    pub fn numerically(mut self) -> Self {
        self.closed_form = false;
        self
    }

    /// Whether its sensor reports the mean acceleration over each sample
    /// interval (an `averaging` output component): the likelihood is then
    /// continuous in the event times.
    pub fn interval_mean(&self) -> bool {
        self.interval_mean
    }

    /// How many state variables its force components carry.
    pub fn n_states(&self) -> usize {
        self.forces.iter().map(|c| c.states().len()).sum()
    }

    /// Whether a component of that name is part of the model (a core law
    /// included).
    pub fn has(&self, name: &str) -> bool {
        self.name().split('+').any(|p| p == name)
            || self.forces.iter().any(|c| c.name() == name)
            || self.outputs.iter().any(|c| c.name() == name)
    }

    /// Whether a slot of the core is filled (the spring always is).
    pub fn fills(&self, slot: Slot) -> bool {
        match slot {
            Slot::Spring => true,
            Slot::Friction => self.spec.friction != FrictionKind::None,
            Slot::Damper => self.spec.damper != DamperKind::None,
        }
    }

    /// The same model with another core (components kept).
    pub fn with_spec(&self, spec: ModelSpec) -> Self {
        Self::new(spec, self.forces.clone(), self.outputs.clone())
    }

    /// The same model with one more force component.
    pub fn with_force(&self, c: Arc<dyn ForceComponent>) -> Self {
        let mut forces = self.forces.clone();
        forces.push(c);
        Self::new(self.spec, forces, self.outputs.clone())
    }

    /// The same model with one more output component.
    pub fn with_output(&self, c: Arc<dyn OutputComponent>) -> Self {
        let mut outputs = self.outputs.clone();
        outputs.push(c);
        Self::new(self.spec, self.forces.clone(), outputs)
    }

    /// The paper's parameters from `theta` (validated).
    pub fn core_params(&self, theta: &[f64]) -> Result<Params, ParamError> {
        self.check_len(theta)?;
        self.spec.params_from_slice(self.layout.values(theta, CORE))
    }

    /// `theta` from the paper's parameters and named values of the other
    /// components' parameters (missing ones at their neutral value).
    pub fn theta_from_params(
        &self,
        p: &Params,
        others: &[(&str, f64)],
    ) -> Result<Vec<f64>, ParamError> {
        let core = p.to_theta(&self.spec);
        let mut theta = core;
        for block in &self.layout.blocks()[1..] {
            for q in &block.params {
                let v = others
                    .iter()
                    .find(|(n, _)| *n == q.name)
                    .map_or(q.neutral, |(_, v)| *v);
                theta.push(v);
            }
        }
        self.check(&theta)?;
        Ok(theta)
    }

    fn check_len(&self, theta: &[f64]) -> Result<(), ParamError> {
        if theta.len() != self.layout.len() {
            return Err(ParamError::Length {
                model: self.name(),
                expected: self.layout.len(),
                found: theta.len(),
            });
        }
        Ok(())
    }

    /// Checks every component's values.
    pub fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        self.core_params(theta)?;
        for (i, c) in self.forces.iter().enumerate() {
            let values = self.layout.values(theta, 1 + i);
            finite(&self.layout.blocks()[1 + i].params, values)?;
            c.check(values)?;
        }
        let first = 1 + self.forces.len();
        for i in 0..self.outputs.len() {
            let b = &self.layout.blocks()[first + i];
            finite(&b.params, self.layout.values(theta, first + i))?;
        }
        Ok(())
    }

    /// The resolved linear system at `theta`, with every piecewise-linear
    /// component configured.
    pub fn system(&self, theta: &[f64]) -> Result<System, ParamError> {
        let p = self.core_params(theta)?;
        let mut system = System::new(&self.spec, &p);
        for (i, c) in self.forces.iter().enumerate() {
            let values = self.layout.values(theta, 1 + i);
            c.check(values)?;
            c.configure(values, &mut system);
        }
        Ok(system)
    }

    /// The motion's acceleration (before output components) on the grid:
    /// its value at each instant, or its mean over each sample interval
    /// for an averaging sensor ([`catalog::averaging`](super::catalog::averaging)).
    pub fn motion_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        if self.interval_mean {
            return interval_mean_into(start, dt, out, |s, v| {
                self.velocity_grid_into(theta, s, dt, v)
            });
        }
        if self.closed_form {
            let system = self.system(theta)?;
            return system.accel_grid_into(start, dt, out, &SimOptions::default());
        }
        self.numeric_grid_into(theta, start, dt, out)
            .map_err(|e| self.naming(e, theta))
    }

    /// The velocity on the grid `t_i = start + i dt`, on the model's engine.
    pub fn velocity_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let system = self.system(theta)?;
        if self.closed_form {
            return system.velocity_grid_into(start, dt, out, &SimOptions::default());
        }
        let terms = self.numeric_terms(theta);
        NumericSystem::with_terms(system, &terms)
            .velocity_grid_into(start, dt, out)
            .map_err(|e| self.naming(e, theta))
    }

    /// A non-finite acceleration named with the parameter set that gave it.
    fn naming(&self, e: SimError, theta: &[f64]) -> SimError {
        match e {
            SimError::NotFinite { t } => SimError::NotFiniteAt {
                t,
                model: self.name(),
                params: self
                    .layout
                    .params()
                    .zip(theta)
                    .map(|(p, v)| format!("{} = {v}", p.name))
                    .collect::<Vec<_>>()
                    .join(", "),
            },
            e => e,
        }
    }

    /// The motion (displacement, velocity, acceleration before output
    /// components, spring phase) at `t_i = start + i dt`, `n` samples, by
    /// the numerical engine whatever the model: one path for every model,
    /// its own forces included (criticism places the reversals on it; the
    /// closed-form core alone would misplace them once another force
    /// component acts).
    pub fn motion_grid(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        n: usize,
    ) -> Result<Vec<Motion>, SimError> {
        let system = self.system(theta)?;
        let terms = self.numeric_terms(theta);
        // Dormand-Prince on every phase, as before the exact flow: a MAP
        // sits where the likelihood's staircase steps, with reversals on
        // sample instants to 1e-13 s, and which side of its reversal such a
        // sample falls on moves criticism's jump features (docs/criticism.md,
        // "The exact flow and the reversals on sample instants").
        NumericSystem::with_terms(system, &terms)
            .adaptive(RTOL)
            .motion_grid(start, dt, n)
    }

    /// The response to the ground acceleration `ex` from rest (see
    /// [`forced`](super::forced)): closed form when every force component
    /// is piecewise linear, else the numerical engine at tolerance
    /// [`FORCED_RTOL`]. Output components (sensor terms) do not act.
    pub fn forced<S: ForcedSink>(
        &self,
        theta: &[f64],
        ex: &Excitation,
        sink: &mut S,
    ) -> Result<Peaks, SimError> {
        let system = self.system(theta)?;
        if self.closed_form {
            return system.forced(ex, &SimOptions::default(), sink);
        }
        let terms = self.numeric_terms(theta);
        NumericSystem::with_terms(system, &terms).forced(ex, FORCED_RTOL, sink)
    }

    /// [`Model::forced`] by the numerical engine whatever the model, at
    /// tolerance `rtol`: the cross-check.
    pub fn forced_numerically<S: ForcedSink>(
        &self,
        theta: &[f64],
        ex: &Excitation,
        rtol: f64,
        sink: &mut S,
    ) -> Result<Peaks, SimError> {
        let system = self.system(theta)?;
        let terms = self.numeric_terms(theta);
        NumericSystem::with_terms(system, &terms).forced(ex, rtol, sink)
    }

    /// The components solved numerically, with their parameter values.
    fn numeric_terms<'a>(&'a self, theta: &'a [f64]) -> Vec<(&'a dyn ForceComponent, &'a [f64])> {
        self.forces
            .iter()
            .enumerate()
            .filter(|(i, _)| self.numeric[*i])
            .map(|(i, c)| (c.as_ref(), self.layout.values(theta, 1 + i)))
            .collect()
    }

    /// The motion's acceleration computed by the numerical engine's
    /// adaptive integrator at relative tolerance `rtol` on every phase,
    /// also where the engine solves a phase by its exact flow
    /// ([`crate::numeric::affine`]): the independent integration the
    /// engine is checked against (the engine's own tolerance is
    /// [`super::numeric::RTOL`]).
    pub fn adaptive_grid_into(
        &self,
        theta: &[f64],
        (start, dt): (f64, f64),
        rtol: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let system = self.system(theta)?;
        let terms = self.numeric_terms(theta);
        NumericSystem::with_terms(system, &terms)
            .adaptive(rtol)
            .accel_grid_into(start, dt, out)
    }

    /// The motion's acceleration computed by the numerical engine even when
    /// the closed form applies: the cross-check of the two engines.
    pub fn numeric_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let system = self.system(theta)?;
        let terms = self.numeric_terms(theta);
        NumericSystem::with_terms(system, &terms).accel_grid_into(start, dt, out)
    }
}

fn finite(specs: &[ParamSpec], values: &[f64]) -> Result<(), ParamError> {
    for (s, v) in specs.iter().zip(values) {
        if !v.is_finite() {
            return Err(ParamError::Component {
                name: s.name.clone(),
                value: *v,
                requirement: "must be a finite number".into(),
            });
        }
    }
    Ok(())
}

impl ForwardModel for Model {
    fn name(&self) -> String {
        let mut s = self.spec.to_string();
        // A spring law with memory stands in the linear law's place.
        let law = self.forces.iter().find(|c| c.spring_law());
        if let Some(law) = law {
            s = s.replacen("linear", law.name(), 1);
        }
        for c in self.forces.iter().filter(|c| !c.spring_law()) {
            s.push('+');
            s.push_str(c.name());
        }
        for c in &self.outputs {
            s.push('+');
            s.push_str(c.name());
        }
        s
    }

    fn params(&self) -> Vec<ParamSpec> {
        self.layout.params().cloned().collect()
    }

    fn accel_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        self.motion_grid_into(theta, start, dt, out)?;
        let first = 1 + self.forces.len();
        for (i, c) in self.outputs.iter().enumerate() {
            c.apply(self.layout.values(theta, first + i), dt, out);
        }
        Ok(())
    }

    /// Fused where the closed form samples the motion and no output
    /// component changes it.
    fn sse_grid(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        data: &[f64],
    ) -> Option<Result<f64, SimError>> {
        if !(self.closed_form && self.outputs.is_empty()) {
            return None;
        }
        let sse = self
            .system(theta)
            .map_err(SimError::from)
            .and_then(|s| s.sse_grid(start, dt, data, &SimOptions::default()));
        Some(sse)
    }

    fn in_support(&self, theta: &[f64]) -> bool {
        theta.len() == self.layout.len() && self.spec.in_support(self.layout.values(theta, CORE))
    }
}
