//! The numerical engine: the same equation of motion integrated by the
//! adaptive Dormand-Prince 5(4) solver with event location, for effects
//! whose phases are not linear.
//!
//! Velocity-dependent friction (Constantinou et al., MCEER-99-0012;
//! OpenSees `VelDependent`) scales the slider force by
//! `phi(v) = 1 - (1 - r) exp(-|v|/v_t)`, `r = mu_slow/mu_fast`: the friction
//! amplitude `F_F0 + k_F |u|` of the paper is the fast (sliding) value, and
//! near a reversal, where the mass is slow, the friction falls towards `r`
//! times it. With `r = 1` this engine solves the closed-form model, against
//! which it is checked.
//!
//! The hysteretic spring, its branches and the stop rule are the closed-form
//! model's ([`Spring`](super::spring::Spring), eq. 5.6 with the friction at rest, `r` times the
//! amplitude); each stretch between reversals and spring events is
//! integrated, with the events located on the dense output: the reversal
//! (`v = 0`), the spring's next branch change, and `u = 0` (where the
//! friction force has a kink).
//!
//! ```
//! use hbis::model::numeric::{NumericSystem, VelocityLaw};
//! use hbis::model::{ModelSpec, Params, SimOptions, System};
//!
//! let (spec, p) = (ModelSpec::FULL, Params::table_8_1(5).unwrap());
//! let mut closed = vec![0.0; 401];
//! System::new(&spec, &p).accel_into(0.005, &mut closed, &SimOptions::default())?;
//! let mut numeric = vec![0.0; 401];
//! NumericSystem::new(&spec, &p, None).accel_into(0.005, &mut numeric)?;
//! assert!((closed[300] - numeric[300]).abs() < 1e-6);
//! // Slower friction near reversals: the record changes.
//! let law = VelocityLaw { ratio: 0.5, v_t: 0.02 };
//! NumericSystem::new(&spec, &p, Some(law)).accel_into(0.005, &mut numeric)?;
//! let largest = closed.iter().zip(&numeric).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
//! assert!(largest > 1e-2, "{largest}");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::error::SimError;
use super::params::Params;
use super::simulate::System;
use super::spec::ModelSpec;
use super::spring::SpringBranch;
use crate::numeric::ode::{Dopri5, Stop};

/// Constantinou's velocity dependence of the friction coefficient.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityLaw {
    /// `mu_slow / mu_fast`, in `(0, 1]`.
    pub ratio: f64,
    /// Transition velocity `v_t` (m/s), > 0.
    pub v_t: f64,
}

impl VelocityLaw {
    /// `phi(v) = 1 - (1 - r) exp(-|v|/v_t)`.
    pub fn factor(&self, v: f64) -> f64 {
        1.0 - (1.0 - self.ratio) * (-v.abs() / self.v_t).exp()
    }
}

/// The model with (optionally) velocity-dependent friction, solved
/// numerically.
#[derive(Debug, Clone)]
pub struct NumericSystem {
    /// Spring, friction amplitude and damper, resolved as for the closed form.
    system: System,
    u0: f64,
    law: Option<VelocityLaw>,
}

impl NumericSystem {
    /// The system of validated parameters `p` of `spec`, with `law` if given.
    pub fn new(spec: &ModelSpec, p: &Params, law: Option<VelocityLaw>) -> Self {
        Self {
            system: System::new(spec, p),
            u0: p.u0,
            law,
        }
    }

    fn phi(&self, v: f64) -> f64 {
        self.law.map_or(1.0, |l| l.factor(v))
    }

    fn accel(&self, b: SpringBranch, u: f64, v: f64, d: f64) -> f64 {
        let s = &self.system;
        -(s.spring().force(b, u)
            + s.friction().amplitude(u) * d * self.phi(v)
            + s.damper_rate() * v)
    }

    /// Samples the acceleration at `t_i = i dt` into `out`.
    pub fn accel_into(&self, dt: f64, out: &mut [f64]) -> Result<(), SimError> {
        self.accel_grid_into(0.0, dt, out)
    }

    /// Samples the acceleration at `t_i = start + i dt` (`start >= 0` s after
    /// release) into `out`.
    pub fn accel_grid_into(&self, start: f64, dt: f64, out: &mut [f64]) -> Result<(), SimError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(SimError::Grid {
                name: "dt",
                value: dt,
                requirement: "must be finite and > 0",
            });
        }
        crate::model::simulate::check_start(start)?;
        let n = out.len();
        if n == 0 {
            return Ok(());
        }
        let t_end = start + dt * (n - 1) as f64 + 0.5 * dt;
        let sp = self.system.spring();
        let fr = self.system.friction();
        let mut t = 0.0;
        let (mut u, mut v) = (self.u0, 0.0);
        let mut branch = SpringBranch::Elastic {
            u_i: u,
            f_i: sp.virgin(u),
        };
        // Direction after a stop, or None if it stays (eq. 5.6, friction at rest).
        let start_dir = |b: SpringBranch, u: f64| {
            let fs = sp.force(b, u);
            (fs.abs() > fr.amplitude(u) * self.phi(0.0)).then(|| -fs.signum())
        };
        let mut dir = start_dir(branch, u);
        let mut next = 0usize;
        let ode = Dopri5::new()
            .with_rtol(1e-8)
            .and_then(|o| o.with_atol(1e-11))
            .and_then(|o| o.with_h_max(0.05))
            .expect("valid tolerances");
        let mut phases = 0;
        while t < t_end && next < n {
            phases += 1;
            if phases > 100_000 {
                return Err(SimError::PhaseCap { cap: 100_000, t });
            }
            let Some(d) = dir else {
                // At rest: the forces balance.
                for a in out[next..].iter_mut() {
                    *a = 0.0;
                }
                return Ok(());
            };
            let target = sp.next_event(branch, d);
            let b = branch;
            let rhs = |_: f64, y: &[f64; 2]| [y[1], self.accel(b, y[0], y[1], d)];
            let events = |_: f64, y: &[f64; 2], g: &mut [f64]| {
                g[0] = d * y[1];
                g[1] = target.map_or(1.0, |(x, _)| d * (x - y[0]));
                g[2] = if fr.has_slope() { y[0] } else { 1.0 };
            };
            let observe = |step: &crate::numeric::ode::DenseStep<2>| {
                while next < n {
                    let ti = start + next as f64 * dt;
                    if ti > step.t_end() {
                        break;
                    }
                    let y = step.eval(ti.max(step.t_start()));
                    out[next] = self.accel(b, y[0], y[1], d);
                    next += 1;
                }
            };
            // A phase that starts exactly on its kink must not stop at once.
            let (u_start, v_start) = (u, if v * d < 0.0 { 0.0 } else { v });
            let outcome = ode
                .solve(rhs, t, [u_start, v_start], t_end, 3, events, observe)
                .map_err(|_| SimError::Diverged { t, u })?;
            t = outcome.t;
            u = outcome.y[0];
            v = outcome.y[1];
            if !(u.is_finite() && v.is_finite()) || u.abs() > 1e6 * self.u0.abs().max(1e-3) {
                return Err(SimError::Diverged { t, u });
            }
            match outcome.stop {
                Stop::End => break,
                Stop::Event { index: 0 } => {
                    v = 0.0;
                    branch = sp.unload(branch, u);
                    dir = start_dir(branch, u);
                }
                Stop::Event { index: 1 } => {
                    if let Some((x, nb)) = target {
                        u = x;
                        branch = nb;
                    }
                }
                Stop::Event { .. } => {}
            }
        }
        // Samples the last step did not reach (round-off at the very end).
        let last = self.accel(branch, u, v, dir.unwrap_or(1.0));
        for a in out[next..].iter_mut() {
            *a = last;
        }
        Ok(())
    }
}
