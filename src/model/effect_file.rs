//! Effects described in a TOML file: a user's force component, with memory
//! where the physics has it, without writing Rust. Loaded with
//! `--effects FILE` or [`Registry::load_effect_file`](super::Registry::load_effect_file),
//! it is parsed, fitted, offered as a candidate and added by the ladder like
//! a built-in component. The format is in `docs/components.md`; the
//! expressions are compiled once by [`super::expr`].
//!
//! ```
//! use hbis::model::effect_file::FileEffect;
//! use hbis::model::ForceComponent;
//!
//! let text = r#"
//! [effect]
//! name = "spring-extra"
//! meaning = "a linear spring beside the bearing"
//!
//! [[param]]
//! name = "r_s"
//! unit = "-"
//! bounds = [0.0, 1.0]
//! neutral = 0.0
//! meaning = "its stiffness relative to k0"
//!
//! [force]
//! extra = "r_s * k0 * u"
//! "#;
//! let e = FileEffect::from_toml(text, "spring.toml")?;
//! assert_eq!(e.name(), "spring-extra");
//! assert_eq!(e.params()[0].name, "r_s");
//! let bad = text.replace("r_s * k0 * u", "r_s * k0 * w");
//! let err = FileEffect::from_toml(&bad, "spring.toml").unwrap_err().to_string();
//! assert!(err.contains("spring.toml:14") && err.contains("`w`"), "{err}");
//! # Ok::<(), hbis::model::effect_file::EffectFileError>(())
//! ```

use std::path::Path;

use serde::Deserialize;
use thiserror::Error;
use toml::Spanned;

use super::component::{
    FeatureKind, ForceComponent, Forces, Kinematics, Memory, ParamSpec, Quantities, Slot, StateSpec,
};
use super::error::ParamError;
use super::expr::{is_function, Expr, ExprError};
use super::numeric::MAX_STATES;

/// Most parameters one effect file may declare.
pub const MAX_PARAMS: usize = 16;

/// The variables every force and rate expression may read, before the
/// effect's parameters and states (in slot order).
pub const MOTION_VARIABLES: [&str; 7] = ["u", "v", "dir", "travel", "t", "k0", "u0"];

/// The variables a release expression may read, before the parameters.
pub const RELEASE_VARIABLES: [&str; 2] = ["u0", "k0"];

/// Names an effect's parameters and states may not take: the paper's
/// parameters (every model has some of them) and `sigma`, `rho`.
const RESERVED: [&str; 11] = [
    "u0", "uy", "uF0", "rF0", "zeta0", "f0", "f1", "f2", "u3", "sigma", "rho",
];

/// An effect file that cannot be used.
#[derive(Debug, Error)]
pub enum EffectFileError {
    #[error("cannot read effect file {path}: {error}")]
    Read { path: String, error: std::io::Error },
    #[error("{path}: {message}")]
    Toml { path: String, message: String },
    #[error("{path}:{line}: `{field}`: {error}")]
    Expr {
        path: String,
        line: usize,
        field: String,
        error: ExprError,
    },
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    effect: Header,
    #[serde(default)]
    param: Vec<ParamEntry>,
    #[serde(default)]
    state: Vec<StateEntry>,
    force: ForceEntry,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    name: String,
    meaning: String,
    #[serde(default)]
    signature: Option<String>,
    #[serde(default)]
    targets: Vec<String>,
    #[serde(default)]
    requires: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParamEntry {
    name: String,
    unit: String,
    bounds: [f64; 2],
    neutral: f64,
    meaning: String,
    #[serde(default)]
    symbol: Option<String>,
    #[serde(default)]
    scale: Option<f64>,
    #[serde(default)]
    prior: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StateEntry {
    name: String,
    unit: String,
    meaning: String,
    release: Spanned<String>,
    rate: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ForceEntry {
    #[serde(default)]
    extra: Option<Spanned<String>>,
    #[serde(default)]
    friction_factor: Option<Spanned<String>>,
    #[serde(default)]
    spring_factor: Option<Spanned<String>>,
}

/// A force component read from an effect file.
#[derive(Debug, Clone)]
pub struct FileEffect {
    name: String,
    meaning: String,
    signature: String,
    targets: Vec<FeatureKind>,
    requires: Option<Slot>,
    params: Vec<ParamSpec>,
    states: Vec<StateSpec>,
    release: Vec<Expr>,
    rates: Vec<Expr>,
    extra: Option<Expr>,
    friction_factor: Option<Expr>,
    spring_factor: Option<Expr>,
    source: String,
    /// [`FileEffect::affine_in_phase`], read off the expressions.
    affine: bool,
}

/// Whether the rates and the extra force are affine in the coordinates
/// (`u`, `v`, `travel` and the states) and the factors constant, with
/// `t` read nowhere. The slots are [`MOTION_VARIABLES`], then the
/// `n_params` parameters (constant), then the states.
fn affine_in_phase(
    n_params: usize,
    rates: &[Expr],
    extra: Option<&Expr>,
    factors: [&Option<Expr>; 2],
) -> bool {
    use super::expr::Degree;
    let motion = MOTION_VARIABLES.len();
    let of_var = |i: usize| match MOTION_VARIABLES.get(i) {
        Some(&"u" | &"v" | &"travel") => Degree::Affine,
        Some(&"t") => Degree::Other,
        Some(_) => Degree::Constant,
        None if i < motion + n_params => Degree::Constant,
        None => Degree::Affine,
    };
    let affine = |e: &Expr| e.degree(&of_var) <= Degree::Affine;
    rates.iter().all(affine)
        && extra.is_none_or(affine)
        && factors.iter().all(|f| {
            f.as_ref()
                .is_none_or(|e| e.degree(&of_var) == Degree::Constant)
        })
}

fn feature(name: &str) -> Option<FeatureKind> {
    Some(match name {
        "colour" => FeatureKind::Colour,
        "offset" => FeatureKind::Offset,
        "period-amplitude" => FeatureKind::PeriodAmplitude,
        "period-drift" => FeatureKind::PeriodDrift,
        "decay-rate" => FeatureKind::DecayRate,
        "jump-size" => FeatureKind::JumpSize,
        "jump-direction" => FeatureKind::JumpDirection,
        "spectral-peak" => FeatureKind::SpectralPeak,
        _ => return None,
    })
}

/// The TOML parser's message on one line: where, then what (its source
/// excerpt dropped).
fn one_line(message: &str) -> String {
    let lines: Vec<&str> = message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    match (lines.first(), lines.last()) {
        (Some(a), Some(b)) if lines.len() > 1 => format!("{a}: {b}"),
        (Some(a), _) => a.to_string(),
        _ => String::new(),
    }
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

impl FileEffect {
    /// Reads and checks the effect file at `path`.
    pub fn load(path: &Path) -> Result<Self, EffectFileError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|error| EffectFileError::Read {
            path: shown.clone(),
            error,
        })?;
        Self::from_toml(&text, &shown)
    }

    /// Parses and checks an effect file's text; `path` names it in errors.
    pub fn from_toml(text: &str, path: &str) -> Result<Self, EffectFileError> {
        let invalid = |message: String| EffectFileError::Invalid {
            path: path.to_string(),
            message,
        };
        let spec: FileSpec = toml::from_str(text).map_err(|e| EffectFileError::Toml {
            path: path.to_string(),
            message: one_line(&e.to_string()),
        })?;
        let h = &spec.effect;
        if h.name.is_empty() || h.name.contains('+') || h.name.trim() != h.name {
            return Err(invalid(format!(
                "effect name `{}`: non-empty, no `+`, no surrounding spaces",
                h.name
            )));
        }
        if spec.param.len() > MAX_PARAMS {
            return Err(invalid(format!(
                "{} parameters; at most {MAX_PARAMS}",
                spec.param.len()
            )));
        }
        if spec.state.len() > MAX_STATES {
            return Err(invalid(format!(
                "{} states; at most {MAX_STATES}",
                spec.state.len()
            )));
        }
        let mut names: Vec<&str> = Vec::new();
        let param_names = spec.param.iter().map(|p| p.name.as_str());
        let state_names = spec.state.iter().map(|s| s.name.as_str());
        for n in param_names.clone().chain(state_names.clone()) {
            let ident = !n.is_empty()
                && n.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_')
                && !n.as_bytes()[0].is_ascii_digit();
            if !ident {
                return Err(invalid(format!(
                    "name `{n}`: letters, digits and `_`, not starting with a digit"
                )));
            }
            if RESERVED.contains(&n) || MOTION_VARIABLES.contains(&n) || is_function(n) {
                return Err(invalid(format!(
                    "name `{n}` clashes with a built-in name (a model parameter, a motion variable or a function)"
                )));
            }
            if names.contains(&n) {
                return Err(invalid(format!("name `{n}` is declared twice")));
            }
            names.push(n);
        }
        let mut params = Vec::new();
        for p in &spec.param {
            let [lo, hi] = p.bounds;
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(invalid(format!(
                    "parameter `{}`: bounds [{lo}, {hi}] must be finite with low < high",
                    p.name
                )));
            }
            if !(p.neutral.is_finite() && lo <= p.neutral && p.neutral <= hi) {
                return Err(invalid(format!(
                    "parameter `{}`: neutral {} must lie within its bounds [{lo}, {hi}]",
                    p.name, p.neutral
                )));
            }
            if let Some(prior) = p.prior.as_deref().filter(|p| *p != "uniform") {
                return Err(invalid(format!(
                    "parameter `{}`: prior `{prior}`: only `uniform` (on its bounds) is supported",
                    p.name
                )));
            }
            let mut spec =
                ParamSpec::new(&p.name, &p.unit, (lo, hi), p.neutral).meaning(&p.meaning);
            if let Some(s) = &p.symbol {
                spec = spec.symbol(s);
            }
            if let Some(s) = p.scale {
                if !(s.is_finite() && s > 0.0) {
                    return Err(invalid(format!(
                        "parameter `{}`: scale {s} must be finite and > 0",
                        p.name
                    )));
                }
                spec = spec.scale(s);
            }
            params.push(spec);
        }
        let motion: Vec<&str> = MOTION_VARIABLES
            .iter()
            .copied()
            .chain(param_names.clone())
            .chain(state_names)
            .collect();
        let release_vars: Vec<&str> = RELEASE_VARIABLES
            .iter()
            .copied()
            .chain(param_names)
            .collect();
        let compile = |field: String, e: &Spanned<String>, vars: &[&str]| {
            Expr::compile(e.get_ref(), vars).map_err(|error| EffectFileError::Expr {
                path: path.to_string(),
                line: line_of(text, e.span().start),
                field,
                error,
            })
        };
        let mut release = Vec::new();
        let mut rates = Vec::new();
        for s in &spec.state {
            release.push(compile(
                format!("state {}.release", s.name),
                &s.release,
                &release_vars,
            )?);
            rates.push(compile(format!("state {}.rate", s.name), &s.rate, &motion)?);
        }
        let f = &spec.force;
        let extra = f
            .extra
            .as_ref()
            .map(|e| compile("force.extra".into(), e, &motion))
            .transpose()?;
        let friction_factor = f
            .friction_factor
            .as_ref()
            .map(|e| compile("force.friction_factor".into(), e, &motion))
            .transpose()?;
        let spring_factor = f
            .spring_factor
            .as_ref()
            .map(|e| compile("force.spring_factor".into(), e, &motion))
            .transpose()?;
        if extra.is_none() && friction_factor.is_none() && spring_factor.is_none() {
            return Err(invalid(
                "[force] needs at least one of `extra`, `friction_factor`, `spring_factor`".into(),
            ));
        }
        let mut targets = Vec::new();
        for t in &h.targets {
            targets.push(feature(t).ok_or_else(|| {
                invalid(format!(
                    "target `{t}`: expected one of colour, offset, period-amplitude, period-drift, decay-rate, jump-size, jump-direction, spectral-peak"
                ))
            })?);
        }
        let requires = match h.requires.as_deref() {
            None => None,
            Some("friction") => Some(Slot::Friction),
            Some("damper") => Some(Slot::Damper),
            Some(other) => {
                return Err(invalid(format!(
                    "requires `{other}`: expected `friction` or `damper`"
                )))
            }
        };
        let affine = affine_in_phase(
            params.len(),
            &rates,
            extra.as_ref(),
            [&friction_factor, &spring_factor],
        );
        Ok(Self {
            affine,
            name: h.name.clone(),
            meaning: h.meaning.clone(),
            signature: h.signature.clone().unwrap_or_else(|| h.meaning.clone()),
            targets,
            requires,
            params,
            states: spec
                .state
                .iter()
                .map(|s| StateSpec::new(&s.name, &s.unit, &s.meaning))
                .collect(),
            release,
            rates,
            extra,
            friction_factor,
            spring_factor,
            source: path.to_string(),
        })
    }

    /// Whether its rates and extra force are affine in `u`, `v`, the travel
    /// and its states, its factors constant and `t` unread: what
    /// [`ForceComponent::affine`] asks, and what the file's component
    /// answers it with (since 2026-12-04; docs/components.md).
    pub fn affine_in_phase(&self) -> bool {
        self.affine
    }

    /// The file it was read from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// The motion slots: `u, v, dir, travel, t, k0, u0`, the parameters,
    /// the states; fills `slots` and returns how many are used.
    fn motion_slots(
        &self,
        theta: &[f64],
        k: &Kinematics,
        mem: &Memory,
        slots: &mut [f64; SLOTS],
    ) -> usize {
        let head = [k.u, k.v, k.dir, k.travel, mem.t, mem.q.k0, mem.q.u0];
        slots[..head.len()].copy_from_slice(&head);
        let mut n = head.len();
        slots[n..n + theta.len()].copy_from_slice(theta);
        n += theta.len();
        slots[n..n + mem.x.len()].copy_from_slice(mem.x);
        n + mem.x.len()
    }
}

/// Slots an evaluation needs at most.
const SLOTS: usize = MOTION_VARIABLES.len() + MAX_PARAMS + MAX_STATES;

impl ForceComponent for FileEffect {
    fn name(&self) -> &str {
        &self.name
    }
    fn params(&self) -> Vec<ParamSpec> {
        self.params.clone()
    }
    fn meaning(&self) -> &str {
        &self.meaning
    }
    fn signature(&self) -> &str {
        &self.signature
    }
    fn targets(&self) -> Vec<FeatureKind> {
        self.targets.clone()
    }
    fn requires(&self) -> Option<Slot> {
        self.requires
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn affine(&self) -> bool {
        self.affine
    }

    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        for (p, v) in self.params.iter().zip(theta) {
            if !v.is_finite() {
                return Err(ParamError::Component {
                    name: p.name.clone(),
                    value: *v,
                    requirement: "must be a finite number".into(),
                });
            }
        }
        Ok(())
    }
    fn states(&self) -> Vec<StateSpec> {
        self.states.clone()
    }
    fn release_states(&self, theta: &[f64], q: &Quantities, out: &mut [f64]) {
        let mut slots = [0.0; SLOTS];
        slots[0] = q.u0;
        slots[1] = q.k0;
        slots[2..2 + theta.len()].copy_from_slice(theta);
        for (o, e) in out.iter_mut().zip(&self.release) {
            *o = e.eval(&slots);
        }
    }
    fn rates(&self, theta: &[f64], k: &Kinematics, mem: &Memory, out: &mut [f64]) {
        let mut slots = [0.0; SLOTS];
        self.motion_slots(theta, k, mem, &mut slots);
        for (o, e) in out.iter_mut().zip(&self.rates) {
            *o = e.eval(&slots);
        }
    }
    fn modify_with(&self, theta: &[f64], k: &Kinematics, mem: &Memory, f: &mut Forces) {
        let mut slots = [0.0; SLOTS];
        self.motion_slots(theta, k, mem, &mut slots);
        if let Some(e) = &self.spring_factor {
            f.spring *= e.eval(&slots);
        }
        if let Some(e) = &self.friction_factor {
            f.friction *= e.eval(&slots);
        }
        if let Some(e) = &self.extra {
            f.extra += e.eval(&slots);
        }
    }
}

impl super::Registry {
    /// Reads the effect file at `path` and registers its component: its
    /// name must be new, and its parameter names must differ from every
    /// registered component's. It is offered as a candidate like a built-in
    /// one.
    pub fn load_effect_file(&mut self, path: &Path) -> Result<(), EffectFileError> {
        let effect = FileEffect::load(path)?;
        self.register_file_effect(effect)
    }

    /// Registers an effect read by [`FileEffect::from_toml`].
    pub fn register_file_effect(&mut self, effect: FileEffect) -> Result<(), EffectFileError> {
        let source = effect.source.clone();
        let invalid = |message: String| EffectFileError::Invalid {
            path: source.clone(),
            message,
        };
        for c in self.components() {
            let theirs = match c {
                super::Component::Force(f) => f.params(),
                super::Component::Output(o) => o.params(),
            };
            if let Some(p) = effect
                .params
                .iter()
                .find(|p| theirs.iter().any(|q| q.name == p.name))
            {
                return Err(invalid(format!(
                    "parameter `{}` clashes with a parameter of the registered component `{}`",
                    p.name,
                    c.name()
                )));
            }
        }
        let name = effect.name.clone();
        self.register_force(std::sync::Arc::new(effect))
            .map_err(|e| invalid(format!("effect `{name}`: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ForwardModel, Params, Registry};

    const MAXWELL: &str = include_str!("../../examples/effects/maxwell.toml");
    const HEATING: &str = include_str!("../../examples/effects/friction-heating.toml");

    #[test]
    fn a_linear_memory_term_is_affine_and_heating_is_not() {
        let maxwell = FileEffect::from_toml(MAXWELL, "maxwell.toml").unwrap();
        let heating = FileEffect::from_toml(HEATING, "heating.toml").unwrap();
        assert!(maxwell.affine_in_phase());
        // `abs(v)` in the rate, a state in the friction's factor.
        assert!(!heating.affine_in_phase());
        // Time, a product of coordinates, a factor that moves.
        for (field, text) in [
            ("extra", "r_mf * k0 * (u - q_mf) * t"),
            ("extra", "r_mf * k0 * u * q_mf"),
            ("spring_factor", "1 + r_mf * q_mf"),
        ] {
            let changed = MAXWELL.replace(
                "extra = \"r_mf * k0 * (u - q_mf)\"",
                &format!("{field} = \"{text}\""),
            );
            assert_ne!(changed, MAXWELL, "the file's force line changed");
            let e = FileEffect::from_toml(&changed, "changed.toml").unwrap();
            assert!(!e.affine_in_phase(), "{field} = {text}");
        }
        // A constant factor keeps it affine.
        let scaled = MAXWELL.replace(
            "extra = \"r_mf * k0 * (u - q_mf)\"",
            "extra = \"r_mf * k0 * (u - q_mf)\"\nspring_factor = \"1 + r_mf / 2\"",
        );
        assert!(FileEffect::from_toml(&scaled, "scaled.toml")
            .unwrap()
            .affine_in_phase());
        // The engine solves such a file by the exact flow (2026-12-04).
        assert!(ForceComponent::affine(&maxwell));
    }

    #[test]
    fn the_example_maxwell_file_is_the_built_in_maxwell() {
        let mut registry = Registry::builtin();
        registry
            .register_file_effect(FileEffect::from_toml(MAXWELL, "maxwell.toml").unwrap())
            .unwrap();
        let p = Params::table_8_1(5).unwrap();
        let run = |spec: &str, names: [&str; 2]| {
            let m = registry.parse(spec).unwrap();
            let theta = m
                .theta_from_params(&p, &[(names[0], 0.2), (names[1], 0.3)])
                .unwrap();
            let mut a = vec![0.0; 2401];
            m.accel_into(&theta, 0.005, &mut a).unwrap();
            a
        };
        let built_in = run("trilinear+lcfm+viscous+maxwell", ["r_m", "tau_m"]);
        let file = run("trilinear+lcfm+viscous+maxwell-file", ["r_mf", "tau_mf"]);
        let worst = built_in
            .iter()
            .zip(&file)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        // The same arithmetic in another order: round-off only.
        assert!(worst < 1e-9, "{worst}");
        assert!(built_in.iter().any(|a| a.abs() > 0.1));
    }

    #[test]
    fn the_heating_file_lowers_friction_with_sliding() {
        let mut registry = Registry::builtin();
        registry
            .register_file_effect(FileEffect::from_toml(HEATING, "heating.toml").unwrap())
            .unwrap();
        let m = registry
            .parse("trilinear+lcfm+viscous+friction-heating")
            .unwrap();
        let p = Params::table_8_1(5).unwrap();
        let base = m.theta_from_params(&p, &[]).unwrap();
        let hot = m.theta_from_params(&p, &[("h_T", 20.0)]).unwrap();
        let (mut a, mut b) = (vec![0.0; 2001], vec![0.0; 2001]);
        m.accel_into(&base, 0.005, &mut a).unwrap();
        m.accel_into(&hot, 0.005, &mut b).unwrap();
        // Less friction: the swings last longer, so late samples differ.
        let late = a[1500..].iter().zip(&b[1500..]).map(|(x, y)| (x - y).abs());
        assert!(late.fold(0.0, f64::max) > 1e-2);
    }

    #[test]
    fn bad_files_are_refused_with_file_line_and_name() {
        let mut registry = Registry::builtin();
        let clash = MAXWELL.replace("maxwell-file", "maxwell");
        let e = registry
            .register_file_effect(FileEffect::from_toml(&clash, "m.toml").unwrap())
            .unwrap_err();
        assert!(
            e.to_string().contains("m.toml") && e.to_string().contains("registered"),
            "{e}"
        );
        let param_clash = MAXWELL
            .replace("\"r_mf\"", "\"r_m\"")
            .replace("r_mf *", "r_m *");
        let e = registry
            .register_file_effect(FileEffect::from_toml(&param_clash, "m.toml").unwrap())
            .unwrap_err();
        assert!(e.to_string().contains("`r_m` clashes"), "{e}");
        for (bad, expect) in [
            (
                MAXWELL.replace("(u - q_mf) / tau_mf", "(u - qq) / tau_mf"),
                "`qq`",
            ),
            (
                MAXWELL.replace("name = \"r_mf\"", "name = \"f0\""),
                "`f0` clashes",
            ),
            (
                MAXWELL.replace("neutral = 0.0", "neutral = 5.0"),
                "neutral 5",
            ),
            (MAXWELL.replace("[force]", "[forces]"), "m.toml"),
            (
                MAXWELL.replace("unit = \"s\"", "unit = \"s\"\ncolour = 3"),
                "colour",
            ),
        ] {
            let e = FileEffect::from_toml(&bad, "m.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains(expect) && e.contains("m.toml"), "{expect}: {e}");
        }
        let e = FileEffect::from_toml(
            &MAXWELL.replace("(u - q_mf) / tau_mf", "(u - qq) / tau_mf"),
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        let line = MAXWELL
            .lines()
            .position(|l| l.contains("(u - q_mf) / tau_mf"))
            .unwrap()
            + 1;
        assert!(e.contains(&format!("m.toml:{line}:")), "{e}");
    }

    #[test]
    fn a_nan_force_is_an_error_naming_the_parameters() {
        let mut registry = Registry::builtin();
        let nan = MAXWELL.replace("r_mf * k0 * (u - q_mf)", "r_mf * k0 * ln(u - q_mf - 1)");
        registry
            .register_file_effect(FileEffect::from_toml(&nan, "m.toml").unwrap())
            .unwrap();
        let m = registry
            .parse("trilinear+lcfm+viscous+maxwell-file")
            .unwrap();
        let theta = m
            .theta_from_params(&Params::table_8_1(5).unwrap(), &[("r_mf", 0.2)])
            .unwrap();
        let mut a = vec![0.0; 401];
        let e = m.accel_into(&theta, 0.005, &mut a).unwrap_err().to_string();
        assert!(e.contains("not finite") && e.contains("r_mf = 0.2"), "{e}");
    }
}
