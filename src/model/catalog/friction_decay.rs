//! Friction that falls with the distance travelled (heating of the sliding
//! surface).
//!
//! # Formula
//! ```text
//! F_F(u, s) = (F_F0 + k_F |u|) sign(u') / (1 + kappa_F s),   s = int |u'| dt
//! ```
//! `kappa_F = 0` is the paper's slider. In a free-vibration test the
//! amplitude falls as the travel grows, so a friction that decays with
//! travel looks much like one that grows with amplitude (`lcfm`, `rF0 > 0`):
//! `docs/components.md` measures how far one record tells them apart.
//!
//! ```
//! use hbis::model::catalog::FrictionDecay;
//! assert!((FrictionDecay::factor(0.25, 2.0) - 1.0 / 1.5).abs() < 1e-15);
//! ```

use super::velocity_friction::invalid;
use crate::model::component::{FeatureKind, ForceComponent, Forces, Kinematics, ParamSpec, Slot};
use crate::model::error::ParamError;

/// Friction decay with travel.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrictionDecay;

impl FrictionDecay {
    /// `1 / (1 + kappa_F s)`.
    pub fn factor(kappa_f: f64, travel: f64) -> f64 {
        1.0 / (1.0 + kappa_f * travel)
    }
}

impl ForceComponent for FrictionDecay {
    fn name(&self) -> &str {
        "friction-decay"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("kappa_F", "1/m", (0.0, 5.0), 0.0)
            .symbol("kappa_F")
            .meaning("friction loss per metre travelled: F_F / (1 + kappa_F s)")
            .scale(0.05)]
    }
    fn meaning(&self) -> &str {
        "friction that falls with the distance travelled (the sliding surface heats up): F_F / (1 + kappa_F s)"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        vec![FeatureKind::JumpSize, FeatureKind::DecayRate]
    }

    fn signature(&self) -> &str {
        "friction that weakens during the test: the acceleration jumps at reversals shrink from cycle to cycle faster than the amplitude explains"
    }
    fn requires(&self) -> Option<Slot> {
        Some(Slot::Friction)
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        if theta[0].is_nan() || theta[0] < 0.0 {
            return Err(invalid("kappa_F", theta[0], "must be >= 0"));
        }
        Ok(())
    }
    fn modify(&self, theta: &[f64], s: &Kinematics, f: &mut Forces) {
        f.friction *= Self::factor(theta[0], s.travel);
    }
}
