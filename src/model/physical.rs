//! Physical quantities from the identification parameters (Table 8.2).
//!
//! Acceleration fixes every force only per unit mass. The mass follows from
//! the force released at `t = 0` (eq. 8.1): the spring held `F0^n - F_fS` on
//! the virgin curve at `u0`.
//!
//! # Formula
//!
//! ```text
//! m = (F0^n - F_fS) / (w0^2 uy + w1^2 (u3 - uy) + w2^2 (u0 - u3))
//! k_i = m w_i^2,   k_F = rF0 k0,   c = 2 zeta0 w0 m
//! ```
//!
//! The denominator is the virgin spring force per unit mass at `u0`, which
//! is how it is evaluated here, so the formula also holds for `u0 < u3` and
//! for the nested models.
//!
//! ```
//! use hbis::model::{physical::Physical, ModelSpec, Params};
//! let p = Params::table_8_1(5).unwrap();
//! let q = Physical::from_params(&ModelSpec::FULL, &p, 1180.0, 100.0).unwrap();
//! assert_eq!(q.m.round(), 1333.0);
//! ```

use serde::Serialize;
use thiserror::Error;

use super::params::Params;
use super::simulate::System;
use super::spec::{FrictionKind, ModelSpec};

/// Masses in t, stiffnesses in kN/m, damping in kNs/m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Physical {
    /// Mass above the isolation interface (t).
    pub m: f64,
    /// Elastic stiffness (kN/m).
    pub k0: f64,
    /// First post-yield stiffness (kN/m).
    pub k1: f64,
    /// Second post-yield stiffness (kN/m).
    pub k2: f64,
    /// Friction slope (kN/m).
    #[serde(rename = "kF")]
    pub kf: f64,
    /// Viscous damping coefficient (kNs/m).
    pub c: f64,
}

/// Inputs of eq. 8.1 that give no positive mass.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PhysicalError {
    #[error(transparent)]
    Param(#[from] super::error::ParamError),
    #[error("released force {released} kN must exceed the static friction {friction} kN (both finite, friction >= 0)")]
    Forces { released: f64, friction: f64 },
    #[error(
        "the virgin spring force at u0 is {0} per unit mass; it must be > 0 for a mass to follow"
    )]
    SpringForce(f64),
    /// A component replaces the spring law eq. 8.1 reads.
    #[error("model `{model}`: eq. 8.1 converts the bilinear and trilinear springs; `{law}` replaces the spring law")]
    SpringLaw { model: String, law: String },
}

/// Refuses a model whose spring law a component replaces: eq. 8.1 reads
/// the core's bilinear or trilinear spring, which such a model does not use.
pub fn check_convertible(model: &super::Model) -> Result<(), PhysicalError> {
    match model.forces().iter().find(|c| c.spring_law()) {
        Some(law) => Err(PhysicalError::SpringLaw {
            model: crate::model::ForwardModel::name(model),
            law: law.name().to_string(),
        }),
        None => Ok(()),
    }
}

impl Physical {
    /// Eq. 8.1 with released force `released_kn` (`F0^n`) and static friction
    /// `static_friction_kn` (`F_fS`), both in kN.
    pub fn from_params(
        spec: &ModelSpec,
        p: &Params,
        released_kn: f64,
        static_friction_kn: f64,
    ) -> Result<Self, PhysicalError> {
        spec.validate(p)?;
        if !(released_kn.is_finite() && static_friction_kn.is_finite())
            || static_friction_kn < 0.0
            || released_kn <= static_friction_kn
        {
            return Err(PhysicalError::Forces {
                released: released_kn,
                friction: static_friction_kn,
            });
        }
        let sys = System::new(spec, p);
        let per_mass = sys.spring().virgin(p.u0);
        if per_mass.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(PhysicalError::SpringForce(per_mass));
        }
        let m = (released_kn - static_friction_kn) / per_mass;
        let w = |f: f64| 2.0 * std::f64::consts::PI * f;
        let k0 = m * w(p.f0).powi(2);
        Ok(Self {
            m,
            k0,
            k1: m * w(p.f1).powi(2),
            k2: m * w(p.f2).powi(2),
            kf: if spec.friction == FrictionKind::Lcfm {
                p.rf0 * k0
            } else {
                0.0
            },
            c: 2.0 * p.zeta0 * w(p.f0) * m,
        })
    }
}
