//! The registry: the catalog of components as data. Parsing a model spec
//! (`"trilinear+lcfm+viscous+offset"`), listing the candidates that could
//! extend a fitted model, `diagnose` and the ladder all walk it. A library
//! user registers a component and it is parsed, fitted, offered and added
//! like a built-in one.
//!
//! ```
//! use std::sync::Arc;
//! use hbis::model::{Registry, ForwardModel};
//! use hbis::model::catalog::Offset;
//!
//! let registry = Registry::builtin();
//! let model = registry.parse("bilinear+coulomb")?;
//! let theta = vec![0.1, 0.01, 0.002, 0.55, 0.42];
//! let names: Vec<String> = registry.candidates(&model, &theta).into_iter().map(|c| c.effect).collect();
//! assert!(names.contains(&"trilinear".to_string()) && names.contains(&"offset".to_string()));
//! // A component that is there already is no candidate; one that is not known is an error.
//! assert!(registry.parse("bilinear+offset+offset").is_err());
//! assert!(registry.parse("bilinear+magic").unwrap_err().to_string().contains("offset"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::sync::Arc;

use super::catalog::{
    AsymmetricFriction, Averaging, BoucWen, CoreLaw, Degradation, FrictionDecay, Maxwell, Offset,
    VelocityFriction,
};
use super::component::{Core, FeatureKind, ForceComponent, OutputComponent, Slot};
use super::composed::Model;
use super::error::SpecError;
use super::numeric::MAX_STATES;
use super::spec::{DamperKind, FrictionKind, ModelSpec, SpringKind};

/// Built-in components parsed and fitted when named but offered as
/// candidates only on request ([`Registry::offering`]).
pub const OFFERED_ON_REQUEST: [&str; 3] = ["maxwell", "bouc-wen", "averaging"];

/// A registered component.
#[derive(Clone)]
pub enum Component {
    /// A term of the equation of motion.
    Force(Arc<dyn ForceComponent>),
    /// What stands between the motion and the accelerometer.
    Output(Arc<dyn OutputComponent>),
}

impl Component {
    /// Its name in model specs.
    pub fn name(&self) -> &str {
        match self {
            Component::Force(c) => c.name(),
            Component::Output(c) => c.name(),
        }
    }

    /// Its meaning.
    pub fn meaning(&self) -> &str {
        match self {
            Component::Force(c) => c.meaning(),
            Component::Output(c) => c.meaning(),
        }
    }
}

/// The components a model may be made of.
#[derive(Clone)]
pub struct Registry {
    entries: Vec<Component>,
    /// Names never offered as candidates (still parsed).
    withheld: Vec<String>,
}

/// One way to extend a fitted model by a registered component.
#[derive(Clone)]
pub struct Candidate {
    /// The component's name.
    pub effect: String,
    /// The extended model.
    pub model: Model,
    /// Warm start: the current MAP carried into the extended model by
    /// name, the new component switched off (same acceleration).
    pub start: Vec<f64>,
    /// What the component is, and which residual pattern it explains.
    pub signature: String,
    /// The residual structure it explains (empty: serial correlation).
    pub targets: Vec<FeatureKind>,
}

impl Default for Registry {
    fn default() -> Self {
        Self::builtin()
    }
}

impl Registry {
    /// The built-in catalog ([`super::catalog`]).
    pub fn builtin() -> Self {
        let mut entries: Vec<Component> = CoreLaw::ALL
            .iter()
            .map(|c| Component::Force(Arc::new(*c)))
            .collect();
        entries.push(Component::Force(Arc::new(AsymmetricFriction)));
        entries.push(Component::Force(Arc::new(VelocityFriction)));
        entries.push(Component::Force(Arc::new(FrictionDecay)));
        entries.push(Component::Force(Arc::new(Degradation)));
        entries.push(Component::Force(Arc::new(Maxwell)));
        entries.push(Component::Force(Arc::new(BoucWen)));
        entries.push(Component::Output(Arc::new(Offset)));
        entries.push(Component::Output(Arc::new(Averaging)));
        Self {
            entries,
            // A component with memory is parsed and fitted when named, and
            // offered as a candidate only on request (`offering`,
            // `--candidates`): the false-addition rate of criticism has not
            // been measured with it in the catalog (docs/components.md).
            // The averaging sensor is a choice about the data, not physics
            // to discover.
            withheld: OFFERED_ON_REQUEST.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// The same registry with `name` offered as a candidate again (a
    /// built-in one withheld by default, or one `withholding` removed).
    pub fn offering(mut self, name: &str) -> Result<Self, SpecError> {
        self.known_name(name)?;
        self.withheld.retain(|w| w != name);
        Ok(self)
    }

    /// The same registry offering exactly `names` as candidates (each must
    /// be registered; the rest still parse).
    pub fn with_candidates(mut self, names: &[&str]) -> Result<Self, SpecError> {
        for n in names {
            self.known_name(n)?;
        }
        self.withheld = self
            .entries
            .iter()
            .map(|c| c.name().to_string())
            .filter(|c| !names.contains(&c.as_str()))
            .collect();
        Ok(self)
    }

    /// The same registry never offering `names` (each must be registered).
    pub fn excluding(mut self, names: &[&str]) -> Result<Self, SpecError> {
        for n in names {
            self.known_name(n)?;
            self.withheld.push(n.to_string());
        }
        Ok(self)
    }

    /// The names offered as candidates (before a model rules some out).
    pub fn offered(&self) -> Vec<&str> {
        self.entries
            .iter()
            .map(|c| c.name())
            .filter(|n| !self.withheld.iter().any(|w| w == n))
            .collect()
    }

    fn known_name(&self, name: &str) -> Result<(), SpecError> {
        match self.get(name) {
            Some(_) => Ok(()),
            None => Err(SpecError::Unknown {
                name: name.to_string(),
                known: self.known(),
            }),
        }
    }

    /// Registers a component; its name must be new and usable in a spec.
    pub fn register(&mut self, c: Component) -> Result<(), SpecError> {
        let name = c.name().to_string();
        if name.is_empty() || name.contains('+') || name.trim() != name || name == "none" {
            return Err(SpecError::BadName(name));
        }
        if self.get(&name).is_some() {
            return Err(SpecError::Registered(name));
        }
        self.entries.push(c);
        Ok(())
    }

    /// Registers a force component.
    pub fn register_force(&mut self, c: Arc<dyn ForceComponent>) -> Result<(), SpecError> {
        self.register(Component::Force(c))
    }

    /// Registers an output component.
    pub fn register_output(&mut self, c: Arc<dyn OutputComponent>) -> Result<(), SpecError> {
        self.register(Component::Output(c))
    }

    /// The same registry with `name` never offered as a candidate (it
    /// still parses): to check what criticism says when the catalog lacks
    /// an effect.
    pub fn withholding(mut self, name: &str) -> Self {
        self.withheld.push(name.to_string());
        self
    }

    /// Every registered component.
    pub fn components(&self) -> &[Component] {
        &self.entries
    }

    /// A component by name.
    pub fn get(&self, name: &str) -> Option<&Component> {
        self.entries.iter().find(|c| c.name() == name)
    }

    fn known(&self) -> String {
        self.entries
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Parses a spec: one spring law, at most one friction law and one
    /// damper, then any other registered components, joined by `+`
    /// (`none` may stand for a missing slot).
    pub fn parse(&self, s: &str) -> Result<Model, SpecError> {
        let mut spring: Option<SpringKind> = None;
        let mut friction: Option<FrictionKind> = None;
        let mut damper: Option<DamperKind> = None;
        let mut forces: Vec<Arc<dyn ForceComponent>> = Vec::new();
        let mut outputs: Vec<Arc<dyn OutputComponent>> = Vec::new();
        let mut spring_law = false;
        let dup = |kind: &str| SpecError::Duplicate {
            spec: s.to_string(),
            kind: kind.to_string(),
        };
        for part in s.split('+').map(str::trim) {
            if part == "none" {
                continue;
            }
            let c = self.get(part).ok_or_else(|| SpecError::Unknown {
                name: part.to_string(),
                known: self.known(),
            })?;
            match c {
                Component::Force(f) => match f.core() {
                    Some(Core::Spring(k)) => {
                        if spring.replace(k).is_some() {
                            return Err(dup("a spring"));
                        }
                    }
                    Some(Core::Friction(k)) => {
                        if friction.replace(k).is_some() {
                            return Err(dup("a friction law"));
                        }
                    }
                    Some(Core::Damper(k)) => {
                        if damper.replace(k).is_some() {
                            return Err(dup("a damper"));
                        }
                    }
                    None => {
                        if forces.iter().any(|g| g.name() == part) {
                            return Err(dup(&format!("`{part}`")));
                        }
                        if f.spring_law() {
                            if spring_law {
                                return Err(dup("a spring"));
                            }
                            spring_law = true;
                        }
                        forces.push(f.clone());
                    }
                },
                Component::Output(o) => {
                    if outputs.iter().any(|g| g.name() == part) {
                        return Err(dup(&format!("`{part}`")));
                    }
                    outputs.push(o.clone());
                }
            }
        }
        // A spring law with memory fills the slot with the linear law.
        let spring = match (spring, spring_law) {
            (Some(_), true) => return Err(dup("a spring")),
            (None, true) => Some(SpringKind::Linear),
            (k, false) => k,
        };
        let spec = ModelSpec {
            spring: spring.ok_or_else(|| SpecError::NoSpring(s.to_string()))?,
            friction: friction.unwrap_or(FrictionKind::None),
            damper: damper.unwrap_or(DamperKind::None),
        };
        let model = Model::new(spec, forces, outputs);
        let states = model.n_states();
        if states > MAX_STATES {
            return Err(SpecError::States {
                spec: s.to_string(),
                found: states,
                max: MAX_STATES,
            });
        }
        for f in model.forces() {
            if let Some(slot) = f.requires() {
                if !model.fills(slot) {
                    return Err(SpecError::Requires {
                        component: f.name().to_string(),
                        slot: slot_name(slot),
                    });
                }
            }
        }
        Ok(model)
    }

    /// Registered components absent from `model` that could extend it,
    /// each with the extended model and a warm start from `theta` (a point
    /// of `model`) at which the new component is switched off.
    pub fn candidates(&self, model: &Model, theta: &[f64]) -> Vec<Candidate> {
        let mut out = Vec::new();
        for c in &self.entries {
            if self.withheld.iter().any(|w| w == c.name()) || model.has(c.name()) {
                continue;
            }
            let extended = match c {
                Component::Force(f) => match f.core() {
                    Some(core) => match upgraded(model, core, f.upgrades()) {
                        Some(spec) => model.with_spec(spec),
                        None => continue,
                    },
                    None if f.spring_law() => {
                        // A swap of the spring law: the slot's linear law
                        // carries f0, the component the rest.
                        if model.forces().iter().any(|g| g.spring_law()) {
                            continue;
                        }
                        let spec = ModelSpec {
                            spring: SpringKind::Linear,
                            ..model.spec()
                        };
                        model.with_spec(spec).with_force(f.clone())
                    }
                    None => {
                        if f.requires().is_some_and(|s| !model.fills(s)) {
                            continue;
                        }
                        model.with_force(f.clone())
                    }
                },
                Component::Output(o) => model.with_output(o.clone()),
            };
            let start = warm_start(model, theta, &extended, c);
            let (signature, targets) = match c {
                Component::Force(f) => (f.signature().to_string(), f.targets()),
                Component::Output(o) => (o.meaning().to_string(), o.targets()),
            };
            out.push(Candidate {
                effect: c.name().to_string(),
                model: extended,
                start,
                signature,
                targets,
            });
        }
        out
    }
}

fn slot_name(slot: Slot) -> &'static str {
    match slot {
        Slot::Spring => "spring",
        Slot::Friction => "friction law (coulomb or lcfm)",
        Slot::Damper => "damper",
    }
}

/// The core with `core` in its slot, if that extends `model`: it upgrades
/// the law there, or fills an empty slot (laws that upgrade another are
/// offered only as upgrades).
fn upgraded(model: &Model, core: Core, upgrades: Option<&str>) -> Option<ModelSpec> {
    let spec = model.spec();
    let fills_empty = upgrades.is_none() && !model.fills(core.slot());
    let upgrades_present = upgrades.is_some_and(|u| model.has(u));
    if !(fills_empty || upgrades_present) {
        return None;
    }
    Some(match core {
        Core::Spring(k) => ModelSpec { spring: k, ..spec },
        Core::Friction(k) => ModelSpec {
            friction: k,
            ..spec
        },
        Core::Damper(k) => ModelSpec { damper: k, ..spec },
    })
}

/// `theta` carried into `extended` by name; the new component's
/// parameters at its warm start.
fn warm_start(model: &Model, theta: &[f64], extended: &Model, c: &Component) -> Vec<f64> {
    let layout = model.layout();
    let current = |name: &str| layout.get(theta, name);
    let (names, values): (Vec<String>, Vec<f64>) = match c {
        Component::Force(f) => (
            f.params().into_iter().map(|p| p.name).collect(),
            f.warm_start(&current),
        ),
        Component::Output(o) => o.params().into_iter().map(|p| (p.name, p.neutral)).unzip(),
    };
    extended.layout().theta_from(&|p| {
        current(&p.name)
            .or_else(|| names.iter().position(|n| *n == p.name).map(|i| values[i]))
            .unwrap_or(p.neutral)
    })
}

impl Model {
    /// Parses a spec with the built-in registry.
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        Registry::builtin().parse(s)
    }
}

impl std::str::FromStr for Model {
    type Err = SpecError;
    fn from_str(s: &str) -> Result<Self, SpecError> {
        Self::parse(s)
    }
}
