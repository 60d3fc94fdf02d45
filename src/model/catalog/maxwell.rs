//! Viscoelastic rubber: a Maxwell element (a spring and a dashpot in
//! series) in parallel with the rubber bearing, the simplest force with
//! memory (Kelly, *Earthquake-Resistant Design with Rubber*, ch. 3; the
//! generalised Maxwell model of elastomers with one branch).
//!
//! # Formula
//! ```text
//! F_m = k_m (u - q),   dq/dt = (u - q) / tau_m,   k_m = r_m k0
//! q = u0 at the release (the element relaxed while the mass was held)
//! ```
//! `q` is the dashpot's displacement. Under fast motion (`omega tau_m >> 1`)
//! the element adds the stiffness `k_m`; under slow motion it relaxes and
//! adds nothing; in between it dissipates, most at `omega tau_m = 1`.
//! At rest it keeps relaxing, so its force can fall until the rubber alone
//! beats the friction and the mass slides again. `r_m = 0` is the paper's
//! model.
//!
//! ```
//! use hbis::model::{ForwardModel, Params, Registry};
//!
//! let registry = Registry::builtin();
//! let base = registry.parse("trilinear+lcfm+viscous")?;
//! let model = registry.parse("trilinear+lcfm+viscous+maxwell")?;
//! let p = Params::table_8_1(5).unwrap();
//! let (mut a, mut b) = (vec![0.0; 801], vec![0.0; 801]);
//! base.accel_into(&base.theta_from_params(&p, &[])?, 0.005, &mut a)?;
//! // r_m = 0: the closed form's motion, by the engine that carries q.
//! model.accel_into(&model.theta_from_params(&p, &[("r_m", 0.0)])?, 0.005, &mut b)?;
//! assert!((a[500] - b[500]).abs() < 1e-6);
//! // A stiff, slow element changes the record.
//! model.accel_into(&model.theta_from_params(&p, &[("r_m", 0.3), ("tau_m", 0.5)])?, 0.005, &mut b)?;
//! assert!((a[500] - b[500]).abs() > 1e-2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::velocity_friction::invalid;
use crate::model::component::{
    FeatureKind, ForceComponent, Forces, Kinematics, Memory, ParamSpec, Quantities, StateSpec,
};
use crate::model::error::ParamError;

/// A Maxwell element in parallel with the rubber bearing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Maxwell;

impl ForceComponent for Maxwell {
    fn name(&self) -> &str {
        "maxwell"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("r_m", "-", (0.0, 1.0), 0.0)
                .symbol("k_m/k0")
                .meaning(
                    "stiffness of the Maxwell element relative to the rubber's initial stiffness",
                )
                .scale(0.02)
                .shows("the period and decay of the swings (stiffer and more damped when fast)"),
            ParamSpec::new("tau_m", "s", (0.02, 5.0), 0.5)
                .symbol("tau_m")
                .meaning("relaxation time of the Maxwell element (its dashpot over its spring)")
                .scale(0.1)
                .shows("how the added stiffness and damping change as the swings slow down"),
        ]
    }
    fn meaning(&self) -> &str {
        "viscoelastic rubber: a Maxwell element k_m (u - q), dq/dt = (u - q)/tau_m, beside the rubber"
    }
    fn signature(&self) -> &str {
        "viscoelastic rubber (a Maxwell element): damping and stiffness that change with the swings' rate, and a force that keeps relaxing at rest"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        vec![FeatureKind::DecayRate, FeatureKind::PeriodAmplitude]
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn affine(&self) -> bool {
        true
    }
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        let (r, tau) = (theta[0], theta[1]);
        if !(r >= 0.0 && r.is_finite()) {
            return Err(invalid("r_m", r, "must be finite and >= 0"));
        }
        if !(tau > 0.0 && tau.is_finite()) {
            return Err(invalid("tau_m", tau, "must be finite and > 0"));
        }
        Ok(())
    }
    fn states(&self) -> Vec<StateSpec> {
        vec![StateSpec::new(
            "q_m",
            "m",
            "displacement of the Maxwell element's dashpot",
        )]
    }
    fn release_states(&self, _: &[f64], q: &Quantities, out: &mut [f64]) {
        out[0] = q.u0;
    }
    fn rates(&self, theta: &[f64], k: &Kinematics, mem: &Memory, out: &mut [f64]) {
        out[0] = (k.u - mem.x[0]) / theta[1];
    }
    fn modify_with(&self, theta: &[f64], k: &Kinematics, mem: &Memory, f: &mut Forces) {
        f.extra += theta[0] * mem.q.k0 * (k.u - mem.x[0]);
    }
}
