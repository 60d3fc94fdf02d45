//! The full response of one release test: phase log, samples at any time,
//! forces, residual displacement and the work done by each device.

use serde::Serialize;

use super::error::SimError;
use super::params::Params;
use super::simulate::{check_grid, GridSampler, Phase, PhaseKind, SimOptions, System};
use super::spec::ModelSpec;
use crate::numeric::quadrature::GaussLegendre;

/// The state and forces at one instant. Forces are per unit mass (N/kg),
/// signed as in eq. 5.1, so `a = -(f_spring + f_friction + f_damper)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sample {
    /// Time since release (s).
    pub t: f64,
    /// Displacement (m).
    pub u: f64,
    /// Velocity (m/s).
    pub v: f64,
    /// Acceleration (m/s^2).
    pub a: f64,
    /// Rubber-bearing spring force per unit mass `F_S/m`.
    pub f_spring: f64,
    /// Slider force per unit mass `F_F/m` (at rest: the static force that
    /// holds the spring).
    pub f_friction: f64,
    /// Damper force per unit mass `c u'/m`.
    pub f_damper: f64,
    /// What the spring is doing.
    pub phase: PhaseKind,
}

/// Work done on the mass by each device over the record, per unit mass
/// (J/kg). Their sum equals the change of kinetic energy.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Work {
    pub spring: f64,
    pub friction: f64,
    pub damper: f64,
    /// `v(T)^2/2 - v(0)^2/2`.
    pub kinetic_change: f64,
    /// Energy exchanged: the sum over phases of each device's `|work|` plus
    /// the peak kinetic energy (a phase from rest to rest exchanges energy
    /// that its net work does not show); the scale the balance is judged on.
    pub gross: f64,
}

impl Work {
    /// `|sum of works - kinetic change|` over the energy exchanged.
    pub fn relative_imbalance(&self) -> f64 {
        (self.spring + self.friction + self.damper - self.kinetic_change).abs()
            / self.gross.max(f64::MIN_POSITIVE)
    }
}

/// The simulated release test from `t = 0` to `duration`.
///
/// ```
/// use hbis::model::{ModelSpec, Params, Response};
/// let r = Response::simulate(&ModelSpec::FULL, &Params::table_8_1(5).unwrap(), 10.0).unwrap();
/// let u_r = r.residual_displacement().unwrap();
/// assert!((0.002..0.004).contains(&u_r));
/// ```
#[derive(Debug, Clone)]
pub struct Response {
    system: System,
    phases: Vec<Phase>,
    duration: f64,
}

impl Response {
    /// Simulate validated parameters of a model for `duration` seconds.
    pub fn simulate(spec: &ModelSpec, params: &Params, duration: f64) -> Result<Self, SimError> {
        Self::simulate_with(spec, params, duration, &SimOptions::default())
    }

    /// As [`Response::simulate`], with explicit limits.
    pub fn simulate_with(
        spec: &ModelSpec,
        params: &Params,
        duration: f64,
        opts: &SimOptions,
    ) -> Result<Self, SimError> {
        spec.validate(params)?;
        if !(duration.is_finite() && duration > 0.0) {
            return Err(SimError::Grid {
                name: "duration",
                value: duration,
                requirement: "must be a finite number > 0",
            });
        }
        Self::of_system(System::new(spec, params), duration, opts)
    }

    /// The response of a resolved system (a [`Model`](super::Model)'s
    /// piecewise-linear components configured: [`Model::system`](super::Model::system)).
    pub fn of_system(system: System, duration: f64, opts: &SimOptions) -> Result<Self, SimError> {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(SimError::Grid {
                name: "duration",
                value: duration,
                requirement: "must be a finite number > 0",
            });
        }
        let mut phases = Vec::new();
        system.run(duration, opts, &mut phases)?;
        Ok(Self {
            system,
            phases,
            duration,
        })
    }

    /// The phase log in time order.
    pub fn phases(&self) -> &[Phase] {
        &self.phases
    }

    /// The resolved system.
    pub fn system(&self) -> &System {
        &self.system
    }

    /// Simulated duration (s).
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// Displacement at which the mass came to rest, if it did.
    pub fn residual_displacement(&self) -> Option<f64> {
        self.rest().map(|p| p.u_start)
    }

    /// Time at which the mass came to rest, if it did.
    pub fn rest_time(&self) -> Option<f64> {
        self.rest().map(|p| p.t_start)
    }

    fn rest(&self) -> Option<&Phase> {
        self.phases.last().filter(|p| p.kind == PhaseKind::Rest)
    }

    /// Number of reversals (velocity zeros) before the end or rest.
    pub fn reversals(&self) -> usize {
        self.phases
            .iter()
            .filter(|p| p.kind != PhaseKind::Rest && p.v_end == 0.0)
            .count()
    }

    /// Largest `|u'|` reached (at phase ends or interior extrema).
    pub fn peak_velocity(&self) -> f64 {
        // |v| peaks where a = 0: search each phase on a fine grid.
        let mut peak: f64 = 0.0;
        for p in &self.phases {
            let n = 64;
            for k in 0..=n {
                let t = p.t_start + (p.t_end - p.t_start) * k as f64 / n as f64;
                peak = peak.max(p.state_at(t).1.abs());
            }
        }
        peak
    }

    fn phase_index(&self, t: f64) -> usize {
        self.phases
            .partition_point(|p| p.t_end <= t)
            .min(self.phases.len() - 1)
    }

    /// State and forces at time `t` (clamped to `[0, duration]`). At an
    /// event time the phase that starts there is used.
    pub fn at(&self, t: f64) -> Sample {
        let t = t.clamp(0.0, self.duration);
        let p = &self.phases[self.phase_index(t)];
        let (u, v) = p.state_at(t);
        self.sample(t, u, v, p)
    }

    fn sample(&self, t: f64, u: f64, v: f64, p: &Phase) -> Sample {
        let f_spring = p.spring_force(u);
        let (f_friction, f_damper) = if p.kind == PhaseKind::Rest {
            (-f_spring, 0.0)
        } else {
            (
                self.system.friction().force(u, p.dir),
                self.system.damper_rate() * v,
            )
        };
        Sample {
            t,
            u,
            v,
            a: p.lin.accel(u, v),
            f_spring,
            f_friction,
            f_damper,
            phase: p.kind,
        }
    }

    /// Samples at `t_i = i dt` for `t_i <= duration` (plus round-off).
    pub fn sample_grid(&self, dt: f64) -> Result<Vec<Sample>, SimError> {
        let n = grid_len(dt, self.duration);
        check_grid(dt, n)?;
        // Refused before the allocation, for callers who skipped
        // `data::limits::grid`.
        if n as f64 > crate::data::limits::MAX_GRID_SAMPLES {
            return Err(SimError::Grid {
                name: "samples",
                value: n as f64,
                requirement: "at most 1e7 (hbis::data::limits::MAX_GRID_SAMPLES): use a larger dt",
            });
        }
        let mut out = Vec::with_capacity(n);
        let mut sampler = GridSampler::new(dt, n, |i, u, v, p: &Phase| {
            out.push(self.sample(i as f64 * dt, u, v, p))
        });
        for (k, p) in self.phases.iter().enumerate() {
            crate::model::simulate::PhaseSink::push(&mut sampler, p, k + 1 == self.phases.len());
        }
        Ok(out)
    }

    /// Work done by each device from release to the end.
    pub fn work(&self) -> Work {
        let gl = GaussLegendre::new(16);
        let fr = self.system.friction();
        let c = self.system.damper_rate();
        let (mut ws, mut wf, mut wd, mut gross) = (0.0, 0.0, 0.0, 0.0);
        for p in self.phases.iter().filter(|p| p.kind != PhaseKind::Rest) {
            let (u0, u1) = (p.u_start, p.u_end);
            // Factored as (u1-u0)(u1+u0) against cancellation.
            let (du, half_sum) = (u1 - u0, 0.5 * (u1 + u0));
            let w_s = -(p.spring_c + p.spring_k * half_sum) * du;
            let (kf, cf) = fr.phase_terms(p.dir, p.sign_u);
            let w_f = -(cf + kf * half_sum) * du;
            ws += w_s;
            wf += w_f;
            gross += w_s.abs() + w_f.abs();
            if c > 0.0 {
                // Independent quadrature of c v^2 over pieces short against
                // the phase's own time scales.
                let rate = p.lin.stiffness().abs().sqrt() + p.lin.alpha() + 1.0;
                let len = p.t_end - p.t_start;
                // Bounded: an absurd stiffness must not make the loop endless.
                let pieces = ((len * rate / 0.5).ceil() as usize).clamp(1, 1 << 20);
                let h = len / pieces as f64;
                let mut w_d = 0.0;
                for j in 0..pieces {
                    let a = p.t_start + j as f64 * h;
                    w_d -= c * gl.integrate(a, a + h, |t| p.state_at(t).1.powi(2));
                }
                wd += w_d;
                gross += w_d.abs();
            }
        }
        let v_end = self.phases.last().map_or(0.0, |p| p.v_end);
        Work {
            spring: ws,
            friction: wf,
            damper: wd,
            kinetic_change: 0.5 * v_end * v_end,
            gross: gross + 0.5 * self.peak_velocity().powi(2),
        }
    }
}

/// Number of grid samples `i dt <= duration` (tolerating round-off);
/// `usize::MAX` for a grid too long to count (the float-to-integer cast
/// saturates, and so does the `+ 1`, so nothing wraps to a short grid).
pub fn grid_len(dt: f64, duration: f64) -> usize {
    if !(dt > 0.0 && duration >= 0.0 && dt.is_finite() && duration.is_finite()) {
        return 0;
    }
    ((duration / dt * (1.0 + 1e-12)).floor() as usize).saturating_add(1)
}
