//! A slider that rubs harder one way than the other (uneven sliding
//! surface, a tilted bearing, a test rig that pulls one way).
//!
//! # Formula
//! ```text
//! F_F(u, u') = (1 + a_F sign(u')) (F_F0 + k_F |u|) sign(u')
//! ```
//! Within a phase the direction is fixed, so the phase stays linear: the
//! closed form solves it exactly. `a_F = 0` is the paper's slider. It is
//! the paper's slider plus a constant force `a_F (F_F0 + k_F |u|)` while
//! sliding: the jump at a reversal stays `2 (F_F0 + k_F |u|)`, and a
//! shifted release displacement absorbs most of the constant force.
//!
//! ```
//! use hbis::model::friction::Friction;
//! let f = Friction::new(0.1, 0.0).with_asymmetry(0.2);
//! assert!((f.force(0.0, 1.0) - 0.12).abs() < 1e-15);
//! assert!((f.force(0.0, -1.0) + 0.08).abs() < 1e-15);
//! ```

use super::velocity_friction::invalid;
use crate::model::component::{FeatureKind, ForceComponent, ParamSpec, Slot};
use crate::model::error::ParamError;
use crate::model::simulate::System;

/// Direction-dependent friction.
#[derive(Debug, Clone, Copy, Default)]
pub struct AsymmetricFriction;

impl ForceComponent for AsymmetricFriction {
    fn name(&self) -> &str {
        "asymmetric-friction"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("a_F", "-", (-0.8, 0.8), 0.0)
            .symbol("a_F")
            .meaning("friction when sliding towards +u is (1 + a_F) times the mean, towards -u (1 - a_F) times")
            .scale(0.02)]
    }
    fn meaning(&self) -> &str {
        "friction that differs with the direction of sliding: (1 + a_F sign(u')) F_F"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        // (1 + a_F sign u') F_F sign u' = F_F sign u' + a_F F_F: a constant
        // force while sliding; the jump at a reversal stays 2 F_F.
        vec![FeatureKind::Offset]
    }

    fn signature(&self) -> &str {
        "friction different in the two directions: the paper's slider plus a constant force a_F F_F while sliding, so the swings are not centred and the residual's mean is not zero while the mass moves (the jumps at reversals, 2 F_F, do not change)"
    }
    fn requires(&self) -> Option<Slot> {
        Some(Slot::Friction)
    }
    fn piecewise_linear(&self) -> bool {
        true
    }
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        if theta[0].is_nan() || theta[0].abs() >= 1.0 {
            return Err(invalid("a_F", theta[0], "must be in (-1, 1)"));
        }
        Ok(())
    }
    fn configure(&self, theta: &[f64], system: &mut System) {
        let f = system.friction().with_asymmetry(theta[0]);
        *system.friction_mut() = f;
    }
}
