//! Smooth hysteretic rubber: the Bouc-Wen law in the spring slot (Wen,
//! *J. Eng. Mech.* 102 (1976) 249-263; the form of OpenSees `BoucWen` and of
//! Constantinou & Adnane's isolator models), beside the paper's piecewise
//! linear `bilinear`/`trilinear` laws.
//!
//! # Formula
//! ```text
//! F_S = k2 u + (k0 - k2) z,   dz/dt = u' [1 - (beta sgn(u' z) + gamma) |z/uy|^n],   gamma = 1 - beta
//! k0 = (2 pi f0)^2,  k2 = (2 pi f2)^2
//! ```
//! `z` (m) is the hysteretic displacement: it follows `u` while small and
//! saturates at `uy`, so the spring yields smoothly, the sharper the larger
//! `n`. At the release `z` is where loading along the virgin curve from rest
//! to `u0` leaves it (`dz/du = 1 - |z/uy|^n`). The model's spring slot holds
//! the linear law, whose `f0` is the initial stiffness; `bouc-wen` sets the
//! spring force. In a spec it stands in the spring's place:
//! `bouc-wen+lcfm+viscous`.
//!
//! ```
//! use hbis::model::{ForwardModel, Params, Registry};
//!
//! let registry = Registry::builtin();
//! let model = registry.parse("bouc-wen+lcfm+viscous")?;
//! assert_eq!(model.name(), "bouc-wen+lcfm+viscous");
//! assert_eq!(model.param_names(), ["u0", "uF0", "rF0", "zeta0", "f0", "f2", "uy", "n", "beta"]);
//! let p = Params::table_8_1(5).unwrap();
//! let theta = model.theta_from_params(&p, &[("f2", p.f2), ("uy", p.uy), ("n", 2.0), ("beta", 0.5)])?;
//! let mut a = vec![0.0; 2001];
//! model.accel_into(&theta, 0.005, &mut a)?;
//! assert!(a.iter().all(|x| x.is_finite()) && a[0] < 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::velocity_friction::invalid;
use crate::model::component::{
    FeatureKind, ForceComponent, Forces, Kinematics, Memory, ParamSpec, Quantities, StateSpec,
};
use crate::model::error::ParamError;

/// The Bouc-Wen spring law.
#[derive(Debug, Clone, Copy, Default)]
pub struct BoucWen;

/// Steps of the virgin-curve integration that sets `z` at the release.
const VIRGIN_STEPS: usize = 400;

impl BoucWen {
    /// `z` after loading along the virgin curve from rest to `u0`
    /// (`dz/du = 1 - |z/uy|^n`, classic RK4 in `u`).
    ///
    /// ```
    /// use hbis::model::catalog::BoucWen;
    /// // For n = 2 the virgin curve is z = uy tanh(u/uy).
    /// let exact = 0.01 * (0.015f64 / 0.01).tanh();
    /// assert!((BoucWen::virgin_z(0.015, 0.01, 2.0) - exact).abs() < 1e-12);
    /// // Far beyond yield z saturates at uy.
    /// assert!((BoucWen::virgin_z(0.2, 0.01, 4.0) - 0.01).abs() < 1e-6);
    /// assert_eq!(BoucWen::virgin_z(-0.2, 0.01, 4.0), -BoucWen::virgin_z(0.2, 0.01, 4.0));
    /// ```
    pub fn virgin_z(u0: f64, uy: f64, n: f64) -> f64 {
        let slope = |z: f64| 1.0 - (z.abs() / uy).powf(n);
        let h = u0.abs() / VIRGIN_STEPS as f64;
        let mut z = 0.0;
        for _ in 0..VIRGIN_STEPS {
            let k1 = slope(z);
            let k2 = slope(z + 0.5 * h * k1);
            let k3 = slope(z + 0.5 * h * k2);
            let k4 = slope(z + h * k3);
            z += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        z.copysign(u0)
    }

    fn stiffness(f: f64) -> f64 {
        (2.0 * std::f64::consts::PI * f).powi(2)
    }
}

impl ForceComponent for BoucWen {
    fn name(&self) -> &str {
        "bouc-wen"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("f2", "Hz", (0.02, 2.0), 0.3)
                .symbol("f2")
                .meaning(
                    "post-yield frequency: sqrt(k2/m)/(2 pi), the stiffness once z has saturated",
                )
                .scale(0.01),
            ParamSpec::new("uy", "m", (0.0005, 0.05), 0.01)
                .symbol("u_y")
                .meaning("yield displacement: the level at which z saturates")
                .scale(1e-3),
            ParamSpec::new("n", "-", (1.0, 10.0), 2.0)
                .symbol("n")
                .meaning("sharpness of yielding (large n: close to bilinear)")
                .scale(0.5),
            ParamSpec::new("beta", "-", (0.0, 1.0), 0.5)
                .symbol("beta")
                .meaning("shape of the loops: unloading stiffness (gamma = 1 - beta)")
                .scale(0.05),
        ]
    }
    fn meaning(&self) -> &str {
        "smooth hysteretic rubber (Bouc-Wen): F = k2 u + (k0 - k2) z, dz/dt = v [1 - (beta sgn(v z) + gamma) |z/uy|^n]"
    }
    fn signature(&self) -> &str {
        "smooth hysteretic rubber (Bouc-Wen): yielding that rounds the corners of the piecewise-linear spring, so the period and the acceleration change gradually with amplitude"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        vec![FeatureKind::PeriodAmplitude, FeatureKind::DecayRate]
    }
    fn spring_law(&self) -> bool {
        true
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn check(&self, theta: &[f64]) -> Result<(), ParamError> {
        let (f2, uy, n, beta) = (theta[0], theta[1], theta[2], theta[3]);
        if !(f2 > 0.0 && f2.is_finite()) {
            return Err(invalid("f2", f2, "must be finite and > 0"));
        }
        if !(uy > 0.0 && uy.is_finite()) {
            return Err(invalid("uy", uy, "must be finite and > 0"));
        }
        if !(0.5..=50.0).contains(&n) {
            return Err(invalid("n", n, "must be in [0.5, 50]"));
        }
        if !(0.0..=1.0).contains(&beta) {
            return Err(invalid("beta", beta, "must be in [0, 1]"));
        }
        Ok(())
    }
    fn states(&self) -> Vec<StateSpec> {
        vec![StateSpec::new(
            "z_bw",
            "m",
            "hysteretic displacement of the Bouc-Wen spring",
        )]
    }
    fn release_states(&self, theta: &[f64], q: &Quantities, out: &mut [f64]) {
        out[0] = Self::virgin_z(q.u0, theta[1], theta[2]);
    }
    fn rates(&self, theta: &[f64], k: &Kinematics, mem: &Memory, out: &mut [f64]) {
        let (uy, n, beta) = (theta[1], theta[2], theta[3]);
        let z = mem.x[0];
        let gamma = 1.0 - beta;
        let sign = if k.v * z > 0.0 {
            1.0
        } else if k.v * z < 0.0 {
            -1.0
        } else {
            0.0
        };
        out[0] = k.v * (1.0 - (beta * sign + gamma) * (z.abs() / uy).powf(n));
    }
    fn modify_with(&self, theta: &[f64], k: &Kinematics, mem: &Memory, f: &mut Forces) {
        let k2 = Self::stiffness(theta[0]);
        f.spring = k2 * k.u + (mem.q.k0 - k2) * mem.x[0];
    }
    fn warm_start(&self, current: &dyn Fn(&str) -> Option<f64>) -> Vec<f64> {
        let p = self.params();
        vec![
            current("f2")
                .or_else(|| current("f1"))
                .unwrap_or(p[0].neutral),
            current("uy").unwrap_or(p[1].neutral),
            p[2].neutral,
            p[3].neutral,
        ]
    }
}
