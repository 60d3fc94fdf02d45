//! Rubber stiffness that falls with the distance travelled (scragging,
//! Mullins-like softening of the rubber bearings during the test).
//!
//! # Formula
//! ```text
//! F_S(u, s) = F_S,hysteretic(u) / (1 + kappa_k s),   s = int |u'| dt
//! ```
//! Every spring stiffness is scaled by the same factor, so the period of a
//! half-cycle lengthens as the test goes on. `kappa_k = 0` is the paper's
//! spring. Not piecewise linear (the factor changes within a phase):
//! solved numerically.
//!
//! ```
//! use hbis::model::catalog::Degradation;
//! // After 0.5 m of travel at kappa_k = 0.5 1/m, 80 % of the stiffness is left.
//! assert!((Degradation::factor(0.5, 0.5) - 0.8).abs() < 1e-15);
//! ```

use super::velocity_friction::invalid;
use crate::model::component::{FeatureKind, ForceComponent, Forces, Kinematics, ParamSpec};
use crate::model::error::ParamError;

/// Stiffness degradation with travel.
#[derive(Debug, Clone, Copy, Default)]
pub struct Degradation;

impl Degradation {
    /// `1 / (1 + kappa_k s)`.
    pub fn factor(kappa_k: f64, travel: f64) -> f64 {
        1.0 / (1.0 + kappa_k * travel)
    }
}

impl ForceComponent for Degradation {
    fn name(&self) -> &str {
        "degradation"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("kappa_k", "1/m", (0.0, 3.0), 0.0)
            .symbol("kappa_k")
            .meaning("stiffness loss per metre travelled: F_S / (1 + kappa_k s)")
            .scale(0.02)]
    }
    fn meaning(&self) -> &str {
        "rubber stiffness that falls with the distance travelled (scragging): F_S / (1 + kappa_k s)"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        vec![FeatureKind::PeriodDrift, FeatureKind::DecayRate]
    }

    fn signature(&self) -> &str {
        "a stiffness that softens during the test: the half-cycle periods lengthen from swing to swing beyond what the amplitude explains"
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        if theta[0].is_nan() || theta[0] < 0.0 {
            return Err(invalid("kappa_k", theta[0], "must be >= 0"));
        }
        Ok(())
    }
    fn modify(&self, theta: &[f64], s: &Kinematics, f: &mut Forces) {
        f.spring *= Self::factor(theta[0], s.travel);
    }
}
