//! Friction that depends on velocity (Constantinou et al., MCEER-99-0012;
//! OpenSees `VelDependent`).
//!
//! # Formula
//! ```text
//! F_F(u, u') = phi(u') (F_F0 + k_F |u|) sign(u'),   phi(v) = 1 - (1 - r_mu) exp(-|v| / v_t)
//! ```
//! The paper's amplitude is the fast (sliding) value; near a reversal, where
//! the mass is slow, friction falls towards `r_mu` times it. `r_mu = 1` is
//! the paper's model.
//!
//! ```
//! use hbis::model::catalog::VelocityFriction;
//! assert!((VelocityFriction::factor(0.5, 0.02, 0.0) - 0.5).abs() < 1e-15);
//! assert!((VelocityFriction::factor(0.5, 0.02, 1.0) - 1.0).abs() < 1e-12);
//! ```

use crate::model::component::{FeatureKind, ForceComponent, Forces, Kinematics, ParamSpec, Slot};
use crate::model::error::ParamError;

/// Constantinou's velocity dependence of the friction coefficient.
#[derive(Debug, Clone, Copy, Default)]
pub struct VelocityFriction;

impl VelocityFriction {
    /// `phi(v) = 1 - (1 - r_mu) exp(-|v|/v_t)`.
    pub fn factor(r_mu: f64, v_t: f64, v: f64) -> f64 {
        1.0 - (1.0 - r_mu) * (-v.abs() / v_t).exp()
    }
}

impl ForceComponent for VelocityFriction {
    fn name(&self) -> &str {
        "velocity-friction"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("r_mu", "-", (0.05, 1.0), 1.0)
                .symbol("mu_slow/mu_fast")
                .meaning("friction at rest relative to the sliding friction")
                .scale(0.05),
            ParamSpec::new("v_t", "m/s", (0.005, 0.3), 0.05)
                .symbol("v_t")
                .meaning("velocity over which friction rises from its slow to its fast value")
                .scale(0.01),
        ]
    }
    fn meaning(&self) -> &str {
        "friction that drops at low velocity (Constantinou): phi(v) = 1 - (1 - r_mu) exp(-|v|/v_t)"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        vec![FeatureKind::JumpSize, FeatureKind::DecayRate]
    }

    fn signature(&self) -> &str {
        "friction that drops at low velocity (Constantinou): the acceleration right after each reversal, where the mass is slow, differs from the sliding value"
    }
    fn requires(&self) -> Option<Slot> {
        Some(Slot::Friction)
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        let (r, v_t) = (theta[0], theta[1]);
        if !(r > 0.0 && r <= 1.0) {
            return Err(invalid("r_mu", r, "must be in (0, 1]"));
        }
        if v_t.is_nan() || v_t <= 0.0 {
            return Err(invalid("v_t", v_t, "must be > 0"));
        }
        Ok(())
    }
    fn modify(&self, theta: &[f64], s: &Kinematics, f: &mut Forces) {
        f.friction *= Self::factor(theta[0], theta[1], s.v);
    }
}

/// A component parameter outside its range.
pub(crate) fn invalid(name: &str, value: f64, requirement: &str) -> ParamError {
    ParamError::Component {
        name: name.to_string(),
        value,
        requirement: requirement.to_string(),
    }
}
