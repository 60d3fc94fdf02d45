//! Physical effects as components.
//!
//! A model under criticism is a closed-form base ([`ModelSpec`]: spring,
//! friction, damper) plus any number of [`Effect`]s. The catalog:
//!
//! | effect | what it adds | parameters | how |
//! |---|---|---|---|
//! | `trilinear` | a third stiffness branch (upgrades `bilinear`) | `f2`, `u3` | closed form |
//! | `lcfm` | friction growing with amplitude (upgrades `coulomb`) | `rF0` | closed form |
//! | `viscous` | a viscous damper | `zeta0` | closed form |
//! | `velocity-friction` | friction falling to `r_mu` times its sliding value at low velocity (Constantinou) | `r_mu`, `v_t` (m/s) | numerical engine |
//! | `offset` | a constant accelerometer offset | `a_off` (m/s^2) | output component |
//!
//! An [`Effect`] is an output component: it sees the base model's sampled
//! acceleration and the record's step and changes the acceleration the
//! accelerometer reports (an offset, a superstructure mode filtering the
//! base motion, a sensor's response...). A user adds one by implementing the
//! trait; neither the solver nor the inference code changes
//! (`examples/custom_effect.rs` adds a flexible superstructure mode).
//!
//! Velocity-dependent friction changes the equation of motion itself, so a
//! model with it runs on the numerical engine ([`crate::model::numeric`])
//! behind the same [`ForwardModel`] trait.
//!
//! ```
//! use hbis::criticism::effects::{Composite, Offset};
//! use hbis::model::{ForwardModel, ModelSpec, Params};
//! use std::sync::Arc;
//!
//! let spec = ModelSpec::FULL;
//! let model = Composite::new(spec, vec![Arc::new(Offset)]);
//! assert_eq!(model.param_names().last().unwrap(), "a_off");
//! let mut theta = Params::table_8_1(5).unwrap().to_theta(&spec);
//! theta.push(0.01);
//! let mut a = vec![0.0; 3];
//! model.accel_into(&theta, 0.005, &mut a).unwrap();
//! let mut base = vec![0.0; 3];
//! spec.accel_into(&theta[..9], 0.005, &mut base).unwrap();
//! assert!((a[0] - base[0] - 0.01).abs() < 1e-15);
//! ```

use std::fmt;
use std::sync::Arc;

use crate::model::numeric::{NumericSystem, VelocityLaw};
use crate::model::{DamperKind, ParamName};
use crate::model::{ForwardModel, FrictionKind, ModelSpec, SimError, SpringKind};

/// An output component: changes the acceleration the record reports.
pub trait Effect: Send + Sync {
    /// Short name (`offset`, `superstructure`, ...).
    fn name(&self) -> &str;
    /// Its parameters, in order.
    fn param_names(&self) -> Vec<String>;
    /// Prior bounds of each parameter (uniform default prior).
    fn bounds(&self) -> Vec<(f64, f64)>;
    /// The value that switches the effect off (its warm start when added).
    fn neutral(&self) -> Vec<f64>;
    /// One line: what it models and how it shows in a record.
    fn meaning(&self) -> &str;
    /// Applies the effect with parameters `theta` to `accel` sampled every `dt`.
    fn apply(&self, theta: &[f64], dt: f64, accel: &mut [f64]);
}

/// A constant accelerometer offset `a_off` (m/s^2) added to every sample.
#[derive(Debug, Clone, Copy)]
pub struct Offset;

impl Effect for Offset {
    fn name(&self) -> &str {
        "offset"
    }
    fn param_names(&self) -> Vec<String> {
        vec!["a_off".into()]
    }
    fn bounds(&self) -> Vec<(f64, f64)> {
        vec![(-0.2, 0.2)]
    }
    fn neutral(&self) -> Vec<f64> {
        vec![0.0]
    }
    fn meaning(&self) -> &str {
        "a constant accelerometer offset: the residual has a non-zero mean, also at rest"
    }
    fn apply(&self, theta: &[f64], _dt: f64, accel: &mut [f64]) {
        for a in accel.iter_mut() {
            *a += theta[0];
        }
    }
}

/// A base model (closed form, or the numerical engine when friction depends
/// on velocity) with output effects.
#[derive(Clone)]
pub struct Composite {
    spec: ModelSpec,
    velocity: bool,
    effects: Vec<Arc<dyn Effect>>,
    n_base: usize,
}

/// Names of the velocity-dependent friction parameters.
pub const VELOCITY_PARAMS: [&str; 2] = ["r_mu", "v_t"];
/// Their prior bounds: `mu_slow/mu_fast` and the transition velocity (m/s).
pub const VELOCITY_BOUNDS: [(f64, f64); 2] = [(0.05, 1.0), (0.005, 0.3)];

impl fmt::Debug for Composite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Composite({})", self.name())
    }
}

impl Composite {
    /// `spec` with `effects` applied in order.
    pub fn new(spec: ModelSpec, effects: Vec<Arc<dyn Effect>>) -> Self {
        let n_base = spec.param_names().len();
        Self {
            spec,
            velocity: false,
            effects,
            n_base,
        }
    }

    /// The same model with velocity-dependent friction (parameters `r_mu`,
    /// `v_t` follow the spec's parameters), solved by the numerical engine.
    pub fn with_velocity_friction(mut self) -> Self {
        if !self.velocity {
            self.velocity = true;
            self.n_base += 2;
        }
        self
    }

    /// Whether friction depends on velocity.
    pub fn velocity_friction(&self) -> bool {
        self.velocity
    }

    /// Number of closed-form spec parameters (they come first).
    pub fn n_spec(&self) -> usize {
        self.spec.param_names().len()
    }

    /// Parses a spec with catalog output effects, e.g.
    /// `trilinear+lcfm+viscous+offset`.
    pub fn parse(s: &str) -> Result<Self, crate::model::SpecError> {
        let mut effects: Vec<Arc<dyn Effect>> = Vec::new();
        let mut base: Vec<&str> = Vec::new();
        let mut velocity = false;
        for part in s.split('+') {
            match part.trim() {
                "offset" => effects.push(Arc::new(Offset)),
                "velocity-friction" => velocity = true,
                other => base.push(other),
            }
        }
        let spec: ModelSpec = base.join("+").parse()?;
        let m = Self::new(spec, effects);
        Ok(if velocity {
            m.with_velocity_friction()
        } else {
            m
        })
    }

    /// The same model with another closed-form spec (other parts kept).
    pub fn with_spec(&self, spec: ModelSpec) -> Self {
        let m = Self::new(spec, self.effects.clone());
        if self.velocity {
            m.with_velocity_friction()
        } else {
            m
        }
    }

    /// The closed-form base.
    pub fn spec(&self) -> ModelSpec {
        self.spec
    }

    /// The output effects.
    pub fn effects(&self) -> &[Arc<dyn Effect>] {
        &self.effects
    }

    /// Number of base-model parameters (they come first in `theta`).
    pub fn n_base(&self) -> usize {
        self.n_base
    }

    /// Default prior bounds of every parameter.
    pub fn bounds(&self) -> Vec<(f64, f64)> {
        let mut b: Vec<(f64, f64)> = self
            .spec
            .param_names()
            .iter()
            .map(|p| {
                crate::inference::default_bounds(p.as_str())
                    .expect("every paper parameter has bounds")
            })
            .collect();
        if self.velocity {
            b.extend(VELOCITY_BOUNDS);
        }
        for e in &self.effects {
            b.extend(e.bounds());
        }
        b
    }
}

impl ForwardModel for Composite {
    fn name(&self) -> String {
        let mut s = self.spec.to_string();
        if self.velocity {
            s.push_str("+velocity-friction");
        }
        for e in &self.effects {
            s.push('+');
            s.push_str(e.name());
        }
        s
    }

    fn param_names(&self) -> Vec<String> {
        let mut n = ForwardModel::param_names(&self.spec);
        if self.velocity {
            n.extend(VELOCITY_PARAMS.iter().map(|s| s.to_string()));
        }
        for e in &self.effects {
            n.extend(e.param_names());
        }
        n
    }

    fn accel_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        if self.velocity {
            let ns = self.n_spec();
            let p = self.spec.params_from_slice(&theta[..ns])?;
            let (ratio, v_t) = (theta[ns], theta[ns + 1]);
            if !(ratio > 0.0 && ratio <= 1.0 && v_t > 0.0) {
                return Err(SimError::Param(crate::model::ParamError::Invalid {
                    name: "r_mu/v_t",
                    value: ratio,
                    requirement: "need 0 < r_mu <= 1 and v_t > 0",
                }));
            }
            NumericSystem::new(&self.spec, &p, Some(VelocityLaw { ratio, v_t }))
                .accel_grid_into(start, dt, out)?;
        } else {
            self.spec
                .accel_grid_into(&theta[..self.n_base], start, dt, out)?;
        }
        let mut i = self.n_base;
        for e in &self.effects {
            let k = e.param_names().len();
            e.apply(&theta[i..i + k], dt, out);
            i += k;
        }
        Ok(())
    }

    fn in_support(&self, theta: &[f64]) -> bool {
        self.spec.in_support(&theta[..self.n_spec()])
    }
}

/// One way to extend a model by a catalog effect.
#[derive(Clone)]
pub struct Candidate {
    /// Catalog name of the effect.
    pub effect: String,
    /// The extended model.
    pub model: Composite,
    /// Warm start: the current MAP mapped into the extended model, with the
    /// new effect switched off (same acceleration).
    pub start: Vec<f64>,
    /// What the effect is, and which residual pattern it explains.
    pub signature: String,
}

/// Catalog effects absent from `model`, each with its extended model and a
/// warm start from `theta` (a point of `model`).
pub fn candidates(model: &Composite, theta: &[f64]) -> Vec<Candidate> {
    let spec = model.spec();
    let base = &theta[..model.n_spec()];
    // Velocity-friction parameters and output effects' parameters.
    let extras = &theta[model.n_spec()..];
    let value = |p: ParamName| -> Option<f64> {
        spec.param_names()
            .iter()
            .position(|&q| q == p)
            .map(|i| base[i])
    };
    let mut out = Vec::new();
    // Rebuilds the base parameters for a new spec, `fill` giving new ones.
    let upgrade = |new: ModelSpec, fill: &dyn Fn(ParamName) -> f64| -> Vec<f64> {
        let mut t: Vec<f64> = new
            .param_names()
            .iter()
            .map(|&p| value(p).unwrap_or_else(|| fill(p)))
            .collect();
        t.extend_from_slice(extras);
        t
    };
    if spec.spring == SpringKind::Bilinear {
        let new = ModelSpec {
            spring: SpringKind::Trilinear,
            ..spec
        };
        let (uy, u0, f1) = (
            value(ParamName::Uy).unwrap_or(0.0),
            value(ParamName::U0).unwrap_or(0.0),
            value(ParamName::F1).unwrap_or(0.0),
        );
        let start = upgrade(new, &|p| match p {
            ParamName::F2 => f1,
            ParamName::U3 => 0.5 * (uy + u0),
            _ => 0.0,
        });
        out.push(Candidate {
            effect: "trilinear".into(),
            model: model.with_spec(new),
            start,
            signature: "a third stiffness branch beyond u3: the period of the largest swings differs from the smaller ones'".into(),
        });
    }
    if spec.friction == FrictionKind::Coulomb {
        let new = ModelSpec {
            friction: FrictionKind::Lcfm,
            ..spec
        };
        out.push(Candidate {
            effect: "lcfm".into(),
            model: model.with_spec(new),
            start: upgrade(new, &|_| 0.0),
            signature: "friction growing with amplitude: the acceleration jumps at reversals scale with the amplitude".into(),
        });
    }
    if spec.damper == DamperKind::None {
        let new = ModelSpec {
            damper: DamperKind::Viscous,
            ..spec
        };
        out.push(Candidate {
            effect: "viscous".into(),
            model: model.with_spec(new),
            start: upgrade(new, &|_| 0.0),
            signature: "viscous damping: residual in phase with velocity, largest mid-swing, amplitude decays faster than friction alone allows".into(),
        });
    }
    if spec.friction != FrictionKind::None && !model.velocity_friction() {
        // Insert r_mu = 1 (no velocity dependence) and a middling v_t after
        // the spec parameters.
        let mut start = base.to_vec();
        start.extend([1.0, 0.05]);
        start.extend_from_slice(extras);
        out.push(Candidate {
            effect: "velocity-friction".into(),
            model: model.clone().with_velocity_friction(),
            start,
            signature: "friction that drops at low velocity (Constantinou): the acceleration right after each reversal, where the mass is slow, differs from the sliding value".into(),
        });
    }
    if !model.effects().iter().any(|e| e.name() == "offset") {
        let mut effects = model.effects().to_vec();
        effects.push(Arc::new(Offset));
        let mut start = theta.to_vec();
        start.push(0.0);
        out.push(Candidate {
            effect: "offset".into(),
            model: Composite {
                effects,
                ..model.clone()
            },
            start,
            signature: Offset.meaning().to_string(),
        });
    }
    out
}
