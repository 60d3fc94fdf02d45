//! The numerical engine: the same equation of motion integrated by the
//! adaptive Dormand-Prince 5(4) solver with event location, for force
//! components whose phases are not linear (friction that depends on
//! velocity or on the distance travelled, a stiffness that degrades, a
//! user's gap spring...).
//!
//! The state is `(u, u')`; the distance travelled `s = int |u'| dt` grows
//! by `dir (u - u_start)` within a stretch of one direction. The
//! forces are the closed-form system's (spring on its hysteretic branch,
//! friction amplitude `F_F0 + k_F |u|` in the direction of sliding, damper),
//! then each component's [`modify`](ForceComponent::modify) in order. The
//! hysteretic spring's branches and the stop rule are the closed-form
//! model's ([`Spring`]; eq. 5.6 with the forces of
//! the components at `u' = 0`). Each stretch between events is integrated
//! with the events located on the dense output: the reversal (`u' = 0`),
//! the spring's next branch change, `u = 0` (the friction's kink) and the
//! kinks the components declare. Without components this engine solves the
//! closed-form model, against which it is checked.
//!
//! ```
//! use hbis::model::{ForwardModel, Params, Registry};
//!
//! let registry = Registry::builtin();
//! let closed = registry.parse("trilinear+lcfm+viscous")?;
//! let slow = registry.parse("trilinear+lcfm+viscous+velocity-friction")?;
//! let p = Params::table_8_1(5).unwrap();
//! let mut a = vec![0.0; 401];
//! closed.accel_into(&closed.theta_from_params(&p, &[])?, 0.005, &mut a)?;
//! // r_mu = 1: no velocity dependence, the same motion numerically.
//! let mut b = vec![0.0; 401];
//! slow.accel_into(&slow.theta_from_params(&p, &[("r_mu", 1.0)])?, 0.005, &mut b)?;
//! assert!((a[300] - b[300]).abs() < 1e-6);
//! // Slower friction near reversals: the record changes.
//! slow.accel_into(&slow.theta_from_params(&p, &[("r_mu", 0.5), ("v_t", 0.02)])?, 0.005, &mut b)?;
//! let largest = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
//! assert!(largest > 1e-2, "{largest}");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::component::{ForceComponent, Forces, Kinematics, Memory, Quantities};
use super::error::SimError;
use super::forced::{Excitation, ForcedSink, Peaks};
use super::simulate::{PhaseKind, System};
use super::spring::{Spring, SpringBranch};
use crate::numeric::affine::{exponential, solve_on_grid, AffineFlow, Grid, StepMap};
use crate::numeric::ode::{Dopri5, Stop};

/// `Phi(dt)` and `Psi(dt)` of one matrix ([`exponential`]).
type StepMaps<const N: usize> = ([[f64; N]; N], [[f64; N]; N]);

/// Whether two matrices of affine flows are the same to rounding (each
/// read off a right-hand side, [`AffineFlow::from_rhs`]).
fn close<const N: usize>(a: &[[f64; N]; N], b: &[[f64; N]; N]) -> bool {
    let size = a.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .all(|(x, y)| (x - y).abs() <= 1e-13 * size)
}

/// The forces within one phase, its spring line resolved once: the
/// integrator evaluates them a few thousand times per record, and the
/// branch lookup would otherwise be repeated at each.
struct PhaseForces<'s, 'a> {
    sys: &'s NumericSystem<'a>,
    k: f64,
    c: f64,
    dir: f64,
}

impl PhaseForces<'_, '_> {
    #[inline]
    fn at(&self, k: &Kinematics, t: f64, x: &[f64]) -> Forces {
        let s = self.sys;
        let fr = s.system.friction();
        let mut f = Forces {
            spring: self.c + self.k * k.u,
            friction: if s.floored {
                self.dir * fr.capacity(k.u, self.dir).max(0.0)
            } else {
                fr.force(k.u, self.dir)
            },
            damper: s.system.damper_rate() * k.v,
            extra: 0.0,
        };
        s.modify(k, t, x, &mut f);
        f
    }
}

/// The adaptive integrator's relative tolerance on a release.
pub const RTOL: f64 = 5e-9;

/// Most kinks one model may declare (the solver locates 16 events).
const MAX_KINKS: usize = 13;

/// Most state variables one model's components may carry together (the
/// engine's state is `(u, u', states)`, a fixed-size vector per count).
pub const MAX_STATES: usize = 4;

/// The resolved system plus the components solved numerically.
#[derive(Clone)]
pub struct NumericSystem<'a> {
    system: System,
    terms: &'a [(&'a dyn ForceComponent, &'a [f64])],
    /// Where each term's states start in the state vector (after `u, u'`);
    /// the last entry is the number of states.
    offsets: Vec<usize>,
    q: Quantities,
    /// Friction amplitude floored at zero (as under shaking).
    floored: bool,
    /// The adaptive integrator on every phase, affine ones too (the
    /// independent check of [`crate::numeric::affine`]).
    adaptive: bool,
    /// The adaptive integrator's relative tolerance.
    rtol: f64,
}

impl<'a> NumericSystem<'a> {
    /// `system` (piecewise-linear components already configured) with the
    /// components `terms` and their parameter values.
    pub fn with_terms(system: System, terms: &'a [(&'a dyn ForceComponent, &'a [f64])]) -> Self {
        let mut offsets = Vec::with_capacity(terms.len() + 1);
        let mut total = 0;
        offsets.push(total);
        for (c, _) in terms {
            total += c.states().len();
            offsets.push(total);
        }
        let q = Quantities {
            k0: system.spring().k0(),
            u0: system.u0(),
        };
        Self {
            system,
            terms,
            offsets,
            q,
            floored: false,
            adaptive: false,
            rtol: RTOL,
        }
    }

    /// The same system solved by the adaptive integrator on every phase
    /// at relative tolerance `rtol`, also where each phase is affine and
    /// solved exactly by default: the independent check of the exact flow.
    pub fn adaptive(mut self, rtol: f64) -> Self {
        self.adaptive = true;
        self.rtol = rtol;
        self
    }

    /// Whether each phase of a release is affine in the state, and solved
    /// by its exact flow ([`ForceComponent::affine`]): the spring's branch,
    /// the slider (on one side of `u = 0`) and the damper are, and so is
    /// every component that says so and declares no kinks, with states
    /// (a Maxwell element) or without.
    fn exact_phases(&self) -> bool {
        let mut kinks = Vec::new();
        !self.adaptive
            && !self.floored
            && self.terms.iter().all(|(c, theta)| {
                c.kinks(theta, &mut kinks);
                c.affine() && kinks.is_empty()
            })
    }

    /// How many state variables the components carry.
    pub fn n_states(&self) -> usize {
        *self.offsets.last().unwrap_or(&0)
    }

    /// The forces on spring branch `b` at state `k` (components without
    /// memory only: no time, no states).
    pub fn forces(&self, b: SpringBranch, k: &Kinematics) -> Forces {
        self.forces_at(b, k, 0.0, &[])
    }

    /// The forces on spring branch `b` at state `k`, time `t` since the
    /// release and component states `x` (all of them, in term order).
    pub fn forces_at(&self, b: SpringBranch, k: &Kinematics, t: f64, x: &[f64]) -> Forces {
        self.phase(b, k.dir).at(k, t, x)
    }

    /// Each component's change to the forces `f`, in order.
    fn modify(&self, k: &Kinematics, t: f64, x: &[f64], f: &mut Forces) {
        for (i, (c, theta)) in self.terms.iter().enumerate() {
            let x = x.get(self.offsets[i]..self.offsets[i + 1]).unwrap_or(&[]);
            let mem = Memory { t, x, q: &self.q };
            c.modify_with(theta, k, &mem, f);
        }
    }

    /// The force law of one phase: spring branch `b`, sliding direction
    /// `dir`.
    fn phase(&self, b: SpringBranch, dir: f64) -> PhaseForces<'_, 'a> {
        let (k, c, _) = self.system.spring().line(b);
        PhaseForces {
            sys: self,
            k,
            c,
            dir,
        }
    }

    /// The states' rates at state `k`, time `t` and states `x`, into `out`.
    fn rates_into(&self, k: &Kinematics, t: f64, x: &[f64], out: &mut [f64]) {
        for (i, (c, theta)) in self.terms.iter().enumerate() {
            let (a, b) = (self.offsets[i], self.offsets[i + 1]);
            if b > a {
                let mem = Memory {
                    t,
                    x: &x[a..b],
                    q: &self.q,
                };
                c.rates(theta, k, &mem, &mut out[a..b]);
            }
        }
    }

    /// The states at the release (or, for a response from rest, `q.u0 = 0`).
    fn release_states(&self, q: &Quantities, out: &mut [f64]) {
        for (i, (c, theta)) in self.terms.iter().enumerate() {
            let (a, b) = (self.offsets[i], self.offsets[i + 1]);
            if b > a {
                c.release_states(theta, q, &mut out[a..b]);
            }
        }
    }

    /// Direction of motion after a stop at `u` on branch `b`, or `None` if
    /// the slider holds the mass (eq. 5.6 with every component's force).
    fn start_dir(&self, b: SpringBranch, u: f64, travel: f64, t: f64, x: &[f64]) -> Option<f64> {
        let at = |dir| {
            self.forces_at(
                b,
                &Kinematics {
                    u,
                    v: 0.0,
                    dir,
                    travel,
                },
                t,
                x,
            )
        };
        let f = at(1.0);
        let drive = f.spring + f.extra;
        if drive == 0.0 {
            return None;
        }
        let dir = -drive.signum();
        let f = at(dir);
        (drive.abs() > f.friction.abs()).then_some(dir)
    }

    /// Samples the acceleration at `t_i = i dt` into `out`.
    pub fn accel_into(&self, dt: f64, out: &mut [f64]) -> Result<(), SimError> {
        self.accel_grid_into(0.0, dt, out)
    }

    /// Samples the acceleration at `t_i = start + i dt` (`start >= 0` s after
    /// release) into `out`.
    pub fn accel_grid_into(&self, start: f64, dt: f64, out: &mut [f64]) -> Result<(), SimError> {
        let n = out.len();
        self.grid(start, dt, n, true, |i, s| out[i] = s.a)
    }

    /// Samples the velocity at `t_i = start + i dt` into `out`.
    pub fn velocity_grid_into(&self, start: f64, dt: f64, out: &mut [f64]) -> Result<(), SimError> {
        let n = out.len();
        self.grid(start, dt, n, false, |i, s| out[i] = s.v)
    }

    /// The motion at `t_i = start + i dt`, `n` samples: displacement,
    /// velocity, acceleration and the spring's phase (what criticism needs
    /// to place the reversals of a model solved numerically).
    pub fn motion_grid(&self, start: f64, dt: f64, n: usize) -> Result<Vec<Motion>, SimError> {
        let mut out = vec![
            Motion {
                u: 0.0,
                v: 0.0,
                a: 0.0,
                phase: PhaseKind::Rest,
            };
            n
        ];
        self.grid(start, dt, n, true, |i, s| out[i] = s)?;
        Ok(out)
    }

    /// Integrates and hands each grid sample to `emit`: the state vector
    /// has `2 + n_states` entries, a size fixed at compile time per count.
    /// Without `accel` the samples' acceleration is not formed (NaN): a
    /// velocity grid saves a force evaluation per sample.
    fn grid(
        &self,
        start: f64,
        dt: f64,
        n: usize,
        accel: bool,
        emit: impl FnMut(usize, Motion),
    ) -> Result<(), SimError> {
        match self.n_states() {
            0 => self.grid_n::<2>(start, dt, n, accel, emit),
            1 => self.grid_n::<3>(start, dt, n, accel, emit),
            2 => self.grid_n::<4>(start, dt, n, accel, emit),
            3 => self.grid_n::<5>(start, dt, n, accel, emit),
            4 => self.grid_n::<6>(start, dt, n, accel, emit),
            found => Err(SimError::States {
                found,
                max: MAX_STATES,
            }),
        }
    }

    fn grid_n<const N: usize>(
        &self,
        start: f64,
        dt: f64,
        n: usize,
        accel: bool,
        mut emit: impl FnMut(usize, Motion),
    ) -> Result<(), SimError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(SimError::Grid {
                name: "dt",
                value: dt,
                requirement: "must be finite and > 0",
            });
        }
        crate::model::simulate::check_start(start)?;
        if n == 0 {
            return Ok(());
        }
        let mut kinks = Vec::new();
        for (c, theta) in self.terms {
            c.kinks(theta, &mut kinks);
        }
        kinks.retain(|x| x.is_finite());
        kinks.truncate(MAX_KINKS);
        let t_end = start + dt * (n - 1) as f64 + 0.5 * dt;
        let sp = self.system.spring();
        let has_slope = self.system.friction().has_slope();
        let u0 = self.system.u0();
        let mut t = 0.0;
        let (mut u, mut v, mut s) = (u0, 0.0, 0.0);
        // The component states ride in x[2..] (x[0], x[1] unused).
        let mut x = [0.0; N];
        self.release_states(&self.q, &mut x[2..]);
        check_states(&x[2..], 0.0)?;
        let mut branch = SpringBranch::Elastic {
            u_i: u,
            f_i: sp.virgin(u),
        };
        let mut dir = self.start_dir(branch, u, s, t, &x[2..]);
        let mut last_dir = 1.0;
        let mut next = 0usize;
        let ode = Dopri5::new()
            .with_rtol(self.rtol)
            .and_then(|o| o.with_atol(1e-11))
            .and_then(|o| o.with_h_max(0.05))
            .expect("valid tolerances");
        let mut phases = 0;
        let mut h_carry: Option<f64> = None;
        let exact = self.exact_phases();
        // The step maps over `dt` met so far, by matrix: a record's phases
        // take a few matrices in turn (one per spring branch and side).
        let mut maps: Vec<([[f64; N]; N], StepMaps<N>)> = Vec::new();
        let scale = u0.abs().max(1e-3);
        // Travel within a stretch of direction d that started at (u_s, s_s).
        let state = |y: &[f64; N], d: f64, u_s: f64, s_s: f64| Kinematics {
            u: y[0],
            v: y[1],
            dir: d,
            travel: s_s + d * (y[0] - u_s),
        };
        while t < t_end && next < n {
            phases += 1;
            if phases > 100_000 {
                return Err(SimError::PhaseCap { cap: 100_000, t });
            }
            let Some(d) = dir else {
                let rest = Motion {
                    u,
                    v: 0.0,
                    a: 0.0,
                    phase: PhaseKind::Rest,
                };
                if N == 2 {
                    // At rest with nothing that evolves: for good.
                    for i in next..n {
                        emit(i, rest);
                    }
                    return Ok(());
                }
                let grid = Grid { start, dt, next, n };
                let reached = |ti_end| {
                    while next < n && start + next as f64 * dt < ti_end {
                        emit(next, rest);
                        next += 1;
                    }
                };
                let held = (branch, u, s, last_dir);
                let (restart, t_r) = if exact {
                    self.held_exact::<N>(held, (t, t_end), grid, &mut x, &mut maps, reached)?
                } else {
                    self.held::<N>(held, (t, t_end), &|_| 0.0, &mut x, ode, reached)?
                };
                t = t_r;
                dir = restart;
                h_carry = None;
                continue;
            };
            last_dir = d;
            let target = sp.next_event(branch, d);
            if let Some((x, nb)) = target.filter(|(x, _)| d * (x - u) <= 1e-12 * scale) {
                // Already there (sliding on after a rest on the envelope,
                // which the stop unloaded): an event function that starts
                // on or behind its zero would not fire, and whether it
                // starts a rounding error ahead of it or behind depends on
                // the engine (the forced response's rule, with a margin for
                // the exact flow's event functions, read off at the origin).
                u = x;
                branch = nb;
                continue;
            }
            let b = branch;
            let (u_s, s_s) = (u, s);
            let nan = NanWatch::default();
            let law = self.phase(b, d);
            let rhs = |tt: f64, y: &[f64; N]| {
                let k = state(y, d, u_s, s_s);
                let mut r = [0.0; N];
                r[0] = y[1];
                r[1] = law.at(&k, tt, &y[2..]).accel();
                if N > 2 {
                    self.rates_into(&k, tt, &y[2..], &mut r[2..]);
                }
                nan.check(tt, &r)
            };
            let events = |_: f64, y: &[f64; N], g: &mut [f64]| {
                g[0] = d * y[1];
                g[1] = target.map_or(1.0, |(x, _)| d * (x - y[0]));
                g[2] = if has_slope { y[0] } else { 1.0 };
                for (gk, x) in g[3..].iter_mut().zip(&kinks) {
                    *gk = y[0] - x;
                }
            };
            let mut bad = None;
            // A phase that starts exactly on its kink must not stop at once.
            let v_start = if v * d < 0.0 { 0.0 } else { v };
            let mut y0 = x;
            [y0[0], y0[1]] = [u, v_start];
            let outcome = if exact {
                // The flow of this phase, read off its right-hand side on
                // the side of `u = 0` the phase moves on (the slider's law
                // has a kink there).
                let side = if u.abs() > 1e-12 * scale {
                    u.signum()
                } else {
                    d
                };
                let mut y_ref = [0.0; N];
                y_ref[0] = side * scale;
                let flow = AffineFlow::from_rhs(|y| rhs(0.0, y), y_ref, [side * scale; N]);
                let full = step_map(&mut maps, &flow, dt);
                let grid = Grid { start, dt, next, n };
                let sample = |i: usize, y: &[f64; N]| {
                    let a = if accel { flow.rate(y)[1] } else { f64::NAN };
                    if accel && !a.is_finite() {
                        bad.get_or_insert(start + i as f64 * dt);
                    }
                    emit(
                        i,
                        Motion {
                            u: y[0],
                            v: y[1],
                            a,
                            phase: phase_of(sp, b),
                        },
                    );
                };
                let (outcome, reached) = solve_on_grid(
                    &flow,
                    &full,
                    t,
                    y0,
                    t_end,
                    grid,
                    3 + kinks.len(),
                    |y, g| events(0.0, y, g),
                    sample,
                )
                .map_err(|_| nan.error(t, u))?;
                next = reached;
                outcome
            } else {
                let observe = |step: &crate::numeric::ode::DenseStep<N>| {
                    while next < n {
                        let ti = start + next as f64 * dt;
                        // A sample exactly at an event belongs to the phase
                        // after it, as in the closed form (the last step ends
                        // half a step past the last sample).
                        if ti >= step.t_end() {
                            break;
                        }
                        let tc = ti.max(step.t_start());
                        let y = step.eval(tc);
                        let a = if accel {
                            law.at(&state(&y, d, u_s, s_s), tc, &y[2..]).accel()
                        } else {
                            f64::NAN
                        };
                        if accel && !a.is_finite() {
                            bad.get_or_insert(ti);
                        }
                        emit(
                            next,
                            Motion {
                                u: y[0],
                                v: y[1],
                                a,
                                phase: phase_of(sp, b),
                            },
                        );
                        next += 1;
                    }
                };
                // The step the last phase ended with suits the next one (the
                // motion's time scale does not change at an event), and saves
                // the start-up steps.
                let ode = h_carry.map_or(ode, |h| ode.with_h_init(h).unwrap_or(ode));
                ode.solve(rhs, t, y0, t_end, 3 + kinks.len(), events, observe)
                    .map_err(|_| nan.error(t, u))?
            };
            if let Some(t) = bad {
                return Err(SimError::NotFinite { t });
            }
            t = outcome.t;
            x = outcome.y;
            [u, v] = [x[0], x[1]];
            h_carry = Some(outcome.h_next);
            s = s_s + d * (u - u_s);
            if !(u.is_finite() && v.is_finite()) || u.abs() > 1e6 * u0.abs().max(1e-3) {
                return Err(SimError::Diverged { t, u });
            }
            check_states(&x[2..], t)?;
            match outcome.stop {
                Stop::End => break,
                Stop::Event { index: 0 } => {
                    v = 0.0;
                    branch = sp.unload(branch, u);
                    dir = self.start_dir(branch, u, s, t, &x[2..]);
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
        let last = self
            .forces_at(
                branch,
                &Kinematics {
                    u,
                    v,
                    dir: dir.unwrap_or(1.0),
                    travel: s,
                },
                t,
                &x[2..],
            )
            .accel();
        let last = if dir.is_some() { last } else { 0.0 };
        for i in next..n {
            emit(
                i,
                Motion {
                    u,
                    v,
                    a: last,
                    phase: if dir.is_some() {
                        phase_of(sp, branch)
                    } else {
                        PhaseKind::Rest
                    },
                },
            );
        }
        Ok(())
    }

    /// The mass held by the slider at `u` on `branch` (travel `s`, last
    /// sliding direction `d`) from `t` to at most `t_end`, under the ground
    /// acceleration `ag` (zero in a release test), while its components'
    /// states evolve (`x[2..]`, updated): the direction in which it starts
    /// to slide again and when, located as an event where the drive (the
    /// spring's and the states' forces and `ag`) leaves the friction band
    /// (eq. 5.6); `None` and `t_end` if it holds. `reached(t)` is told how
    /// far the rest goes (infinity once it holds to the end).
    #[allow(clippy::too_many_arguments)]
    fn held<const N: usize>(
        &self,
        (branch, u, s, d): (SpringBranch, f64, f64, f64),
        (t, t_end): (f64, f64),
        ag: &dyn Fn(f64) -> f64,
        x: &mut [f64; N],
        ode: Dopri5,
        mut reached: impl FnMut(f64),
    ) -> Result<(Option<f64>, f64), SimError> {
        let at = |dir: f64| Kinematics {
            u,
            v: 0.0,
            dir,
            travel: s,
        };
        let nan = NanWatch::default();
        let rhs = |tt: f64, y: &[f64; N]| {
            let mut r = [0.0; N];
            self.rates_into(&at(d), tt, &y[2..], &mut r[2..]);
            nan.check(tt, &r)
        };
        // Positive once the drive beats the friction that resists a start
        // in that direction.
        let events = |tt: f64, y: &[f64; N], g: &mut [f64]| {
            let up = self.forces_at(branch, &at(1.0), tt, &y[2..]);
            let down = self.forces_at(branch, &at(-1.0), tt, &y[2..]);
            let drive = up.spring + up.extra + ag(tt);
            g[0] = -drive - up.friction.abs();
            g[1] = drive - down.friction.abs();
        };
        let mut g = [0.0; 2];
        events(t, x, &mut g);
        // Already beyond the band (the ground moved on while stuck).
        if let Some(k) = g.iter().position(|&gk| gk > 0.0) {
            return Ok((Some(if k == 0 { 1.0 } else { -1.0 }), t));
        }
        let mut y0 = *x;
        [y0[0], y0[1]] = [u, 0.0];
        let out = ode
            .solve(rhs, t, y0, t_end, 2, events, |step| reached(step.t_end()))
            .map_err(|_| nan.error(t, u))?;
        *x = out.y;
        check_states(&x[2..], out.t)?;
        let restart = match out.stop {
            Stop::End => None,
            Stop::Event { index: 0 } => Some(1.0),
            Stop::Event { .. } => Some(-1.0),
        };
        if restart.is_none() {
            // The last step ends at t_end, after the last sample.
            reached(f64::INFINITY);
        }
        Ok((restart, if restart.is_none() { t_end } else { out.t }))
    }

    /// [`held`](Self::held) of a release whose phases are affine
    /// ([`exact_phases`](Self::exact_phases)), by the states' exact flow on
    /// the sample grid `grid`: at rest the states' rates and the drive
    /// are affine in the states, and the friction at `u` is constant.
    fn held_exact<const N: usize>(
        &self,
        (branch, u, s, d): (SpringBranch, f64, f64, f64),
        (t, t_end): (f64, f64),
        grid: Grid,
        x: &mut [f64; N],
        maps: &mut Vec<([[f64; N]; N], StepMaps<N>)>,
        mut reached: impl FnMut(f64),
    ) -> Result<(Option<f64>, f64), SimError> {
        let at = |dir: f64| Kinematics {
            u,
            v: 0.0,
            dir,
            travel: s,
        };
        let rhs = |y: &[f64; N]| {
            let mut r = [0.0; N];
            self.rates_into(&at(d), t, &y[2..], &mut r[2..]);
            r
        };
        let events = |y: &[f64; N], g: &mut [f64]| {
            let up = self.forces_at(branch, &at(1.0), t, &y[2..]);
            let down = self.forces_at(branch, &at(-1.0), t, &y[2..]);
            let drive = up.spring + up.extra;
            g[0] = -drive - up.friction.abs();
            g[1] = drive - down.friction.abs();
        };
        let mut g = [0.0; 2];
        events(x, &mut g);
        if let Some(k) = g.iter().position(|&gk| gk > 0.0) {
            return Ok((Some(if k == 0 { 1.0 } else { -1.0 }), t));
        }
        let mut y0 = *x;
        [y0[0], y0[1]] = [u, 0.0];
        let scale = self.q.u0.abs().max(1e-3);
        let flow = AffineFlow::from_rhs(rhs, y0, [scale; N]);
        let full = step_map(maps, &flow, grid.dt);
        let (out, _) = solve_on_grid(&flow, &full, t, y0, t_end, grid, 2, events, |_, _| {})
            .map_err(|_| SimError::Diverged { t, u })?;
        *x = out.y;
        check_states(&x[2..], out.t)?;
        let restart = match out.stop {
            Stop::End => None,
            Stop::Event { index: 0 } => Some(1.0),
            Stop::Event { .. } => Some(-1.0),
        };
        reached(if restart.is_none() {
            f64::INFINITY
        } else {
            out.t
        });
        Ok((restart, if restart.is_none() { t_end } else { out.t }))
    }
}

/// The step map of `flow` over `dt`, from `maps` where its matrix is
/// there (else computed and kept).
fn step_map<const N: usize>(
    maps: &mut Vec<([[f64; N]; N], StepMaps<N>)>,
    flow: &AffineFlow<N>,
    dt: f64,
) -> StepMap<N> {
    match maps.iter().find(|(a, _)| close(a, flow.matrix())) {
        Some((_, m)) => flow.step_map_from(m),
        None => {
            let m = exponential(flow.matrix(), dt);
            let full = flow.step_map_from(&m);
            maps.push((*flow.matrix(), m));
            full
        }
    }
}

/// Watches the right-hand side for NaN: a component's NaN is reported as
/// such, not as the divergence the solver would otherwise be taken for.
#[derive(Default)]
struct NanWatch(std::cell::Cell<Option<f64>>);

impl NanWatch {
    fn check<const N: usize>(&self, t: f64, r: &[f64; N]) -> [f64; N] {
        if r.iter().any(|x| x.is_nan()) && self.0.get().is_none() {
            self.0.set(Some(t));
        }
        *r
    }

    /// The solver's failure from `(t, u)`: NaN where one was seen.
    fn error(&self, t: f64, u: f64) -> SimError {
        match self.0.get() {
            Some(t) => SimError::NotFinite { t },
            None => SimError::Diverged { t, u },
        }
    }
}

/// Component states must stay finite: a NaN is a bug in a component.
fn check_states(x: &[f64], t: f64) -> Result<(), SimError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SimError::NotFinite { t })
    }
}

/// One grid sample of a numerically solved motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Displacement (m).
    pub u: f64,
    /// Velocity (m/s).
    pub v: f64,
    /// Acceleration (m/s^2).
    pub a: f64,
    /// What the spring is doing (as the closed form names it).
    pub phase: PhaseKind,
}

/// The closed form's name of spring branch `b`.
fn phase_of(sp: &Spring, b: SpringBranch) -> PhaseKind {
    match sp.line(b).2 {
        0 => PhaseKind::Elastic,
        1 => PhaseKind::Plastic1,
        2 => PhaseKind::Plastic2,
        _ => PhaseKind::Plastic3,
    }
}

impl NumericSystem<'_> {
    /// The response to the ground acceleration `ex` from rest (virgin
    /// spring, `u = 0`), integrated numerically: each sliding stretch by
    /// Dormand-Prince at tolerance `rtol` (absolute `1e-3 rtol` m) between
    /// the samples of `ag` (where its slope changes), stops and branch
    /// changes located on the dense output; sticking and breakaway as in
    /// the closed form (the drive is linear in time while stuck). The
    /// friction amplitude is floored at zero.
    pub fn forced<S: ForcedSink>(
        &self,
        ex: &Excitation,
        rtol: f64,
        sink: &mut S,
    ) -> Result<Peaks, SimError> {
        let me = NumericSystem {
            floored: true,
            ..self.clone()
        };
        match self.n_states() {
            0 => me.forced_run::<S, 2>(ex, rtol, sink),
            1 => me.forced_run::<S, 3>(ex, rtol, sink),
            2 => me.forced_run::<S, 4>(ex, rtol, sink),
            3 => me.forced_run::<S, 5>(ex, rtol, sink),
            4 => me.forced_run::<S, 6>(ex, rtol, sink),
            found => Err(SimError::States {
                found,
                max: MAX_STATES,
            }),
        }
    }

    fn forced_run<S: ForcedSink, const N: usize>(
        &self,
        ex: &Excitation,
        rtol: f64,
        sink: &mut S,
    ) -> Result<Peaks, SimError> {
        let mut kinks = Vec::new();
        for (c, theta) in self.terms {
            c.kinks(theta, &mut kinks);
        }
        if let Some(uz) = self.system.friction().zero_amplitude_at() {
            kinks.extend([uz, -uz]);
        }
        kinks.retain(|x| x.is_finite());
        // Two events are kept for the extrema of the velocity and of the
        // total acceleration.
        kinks.truncate(MAX_KINKS - 2);
        let sp = self.system.spring();
        let has_slope = self.system.friction().has_slope();
        let ode = Dopri5::new()
            .with_rtol(rtol)
            .and_then(|o| o.with_atol(1e-3 * rtol))
            .map_err(|_| SimError::Grid {
                name: "rtol",
                value: rtol,
                requirement: "must be in (0, 0.1)",
            })?;
        let dt = ex.dt();
        let (mut u, mut v, mut s) = (0.0, 0.0, 0.0);
        // Component states in x[2..]: from rest, as after a push to u0 = 0.
        let mut x = [0.0; N];
        let from_rest = Quantities { u0: 0.0, ..self.q };
        self.release_states(&from_rest, &mut x[2..]);
        check_states(&x[2..], 0.0)?;
        let mut last_dir = 1.0;
        let mut branch = SpringBranch::Elastic { u_i: 0.0, f_i: 0.0 };
        let mut dir: Option<f64> = None;
        let mut peaks = ForcedPeaks::default();
        let kin = |u, v, dir, travel| Kinematics { u, v, dir, travel };
        // The total acceleration u'' + ag is the forces' (u'' = accel - ag).
        let note = |peaks: &mut ForcedPeaks, f: &Forces, u: f64| {
            let shear = f.spring + f.friction + f.damper + f.extra;
            peaks.note(u, shear, f.accel());
        };
        peaks.note(0.0, ex.at(0), ex.at(0));
        sink.sample(0, 0.0, 0.0, ex.at(0));
        let mut events = 0usize;
        let mut h_carry = None;
        for k in 0..ex.len() - 1 {
            let t_k = k as f64 * dt;
            let (ak, slope) = (ex.at(k), (ex.at(k + 1) - ex.at(k)) / dt);
            let ag = |t: f64| ak + slope * (t - t_k);
            let t_next = t_k + dt;
            let mut t = t_k;
            while t < t_next {
                events += 1;
                if events > 1_000_000 {
                    return Err(SimError::PhaseCap { cap: 1_000_000, t });
                }
                let Some(d) = dir else {
                    if N > 2 {
                        // Stuck while the states evolve: the breakaway is
                        // an event of their integration.
                        let (nd, t_b) = self.held(
                            (branch, u, s, last_dir),
                            (t, t_next),
                            &ag,
                            &mut x,
                            ode,
                            |_| {},
                        )?;
                        t = t_b;
                        match nd {
                            Some(nd) => dir = Some(nd),
                            None => break,
                        }
                        continue;
                    }
                    // Stuck: the drive F_S + extra + ag is linear in time.
                    let f = self.forces(branch, &kin(u, 0.0, 1.0, s));
                    let base = f.spring + f.extra;
                    let cap = |dd: f64| self.forces(branch, &kin(u, 0.0, dd, s)).friction.abs();
                    let (hi, lo) = (cap(-1.0), -cap(1.0));
                    let (d0, d1) = (base + ag(t), base + ag(t_next));
                    let (tau, nd) = if d0 > hi {
                        (0.0, -1.0)
                    } else if d0 < lo {
                        (0.0, 1.0)
                    } else if d1 > hi {
                        ((hi - d0) / slope, -1.0)
                    } else if d1 < lo {
                        ((lo - d0) / slope, 1.0)
                    } else {
                        break;
                    };
                    t = (t + tau.max(0.0)).min(t_next);
                    dir = Some(nd);
                    continue;
                };
                last_dir = d;
                let target = sp.next_event(branch, d);
                if let Some((x, nb)) = target.filter(|(x, _)| d * (x - u) <= 0.0) {
                    // Already there (sliding on after a pause on the
                    // envelope): an event function that starts behind its
                    // zero would never fire.
                    u = x;
                    branch = nb;
                    continue;
                }
                let b = branch;
                let (u_s, s_s) = (u, s);
                let state = |y: &[f64; N]| kin(y[0], y[1], d, s_s + d * (y[0] - u_s));
                let law = self.phase(b, d);
                let force = |tt: f64, y: &[f64; N]| law.at(&state(y), tt, &y[2..]);
                let nan = NanWatch::default();
                let rhs = |tt: f64, y: &[f64; N]| {
                    let mut r = [0.0; N];
                    r[0] = y[1];
                    r[1] = force(tt, y).accel() - ag(tt);
                    if N > 2 {
                        self.rates_into(&state(y), tt, &y[2..], &mut r[2..]);
                    }
                    nan.check(tt, &r)
                };
                let extremum = 3 + kinks.len();
                let events_fn = |tt: f64, y: &[f64; N], g: &mut [f64]| {
                    g[0] = d * y[1];
                    g[1] = target.map_or(1.0, |(x, _)| d * (x - y[0]));
                    g[2] = if has_slope { y[0] } else { 1.0 };
                    for (gk, x) in g[3..].iter_mut().zip(&kinks) {
                        *gk = y[0] - x;
                    }
                    // The velocity's extrema: a dip to zero inside one
                    // step changes no sign at the step's ends. (Not
                    // watched on the run up to such a minimum.)
                    if g.len() <= extremum {
                        return;
                    }
                    let total = |tt: f64, y: &[f64; N]| force(tt, y).accel();
                    let a = total(tt, y) - ag(tt);
                    g[extremum] = d * a;
                    // And the total acceleration's rate along the motion
                    // (a central difference of the forces; its zero is where
                    // the base shear peaks between samples).
                    let h = 1e-6;
                    let (mut yp, mut ym) = (*y, *y);
                    [yp[0], yp[1]] = [y[0] + h * y[1], y[1] + h * a];
                    [ym[0], ym[1]] = [y[0] - h * y[1], y[1] - h * a];
                    if N > 2 {
                        let mut r = [0.0; N];
                        self.rates_into(&state(y), tt, &y[2..], &mut r[2..]);
                        for i in 2..N {
                            yp[i] += h * r[i];
                            ym[i] -= h * r[i];
                        }
                    }
                    g[extremum + 1] = (total(tt + h, &yp) - total(tt - h, &ym)) / (2.0 * h);
                };
                let v_start = if v * d < 0.0 { 0.0 } else { v };
                let mut y0 = x;
                [y0[0], y0[1]] = [u, v_start];
                // The last stretch's step suits this one: no start-up steps.
                let ode = h_carry.map_or(ode, |h| ode.with_h_init(h).unwrap_or(ode));
                let mut out = ode
                    .solve(rhs, t, y0, t_next, extremum + 2, events_fn, |_| {})
                    .map_err(|_| nan.error(t, u))?;
                if out.stop == (Stop::Event { index: extremum }) && d * out.y[1] <= 0.0 {
                    // A minimum of the speed below zero: the stop came
                    // before it, inside a step. Again up to the minimum,
                    // where the velocity's sign has changed.
                    let t_min = out.t;
                    out = ode
                        .solve(rhs, t, y0, t_min, extremum, events_fn, |_| {})
                        .map_err(|_| nan.error(t, u))?;
                    if out.stop == Stop::End {
                        out.stop = Stop::Event { index: 0 };
                        out.y[1] = 0.0;
                    }
                }
                if out.stop != Stop::End {
                    // Peaks at the events, as the closed form takes them.
                    note(&mut peaks, &force(out.t, &out.y), out.y[0]);
                }
                t = out.t;
                x = out.y;
                [u, v] = [x[0], x[1]];
                check_states(&x[2..], t)?;
                h_carry = Some(out.h_next);
                s = s_s + d * (u - u_s);
                if !(u.is_finite() && v.is_finite()) || u.abs() > 1e3 {
                    return Err(SimError::Diverged { t, u });
                }
                match out.stop {
                    Stop::End => t = t_next,
                    Stop::Event { index: 0 } => {
                        v = 0.0;
                        let unloaded = sp.unload(branch, u);
                        let f = self.forces_at(unloaded, &kin(u, 0.0, d, s), t, &x[2..]);
                        note(&mut peaks, &f, u);
                        let drive = f.spring + f.extra + ag(t);
                        let nd = -drive.signum();
                        let cap = self
                            .forces_at(unloaded, &kin(u, 0.0, nd, s), t, &x[2..])
                            .friction
                            .abs();
                        if drive != 0.0 && drive.abs() > cap {
                            if nd != d {
                                branch = unloaded;
                            }
                            dir = Some(nd);
                        } else {
                            branch = unloaded;
                            dir = None;
                        }
                    }
                    Stop::Event { index: 1 } => {
                        if let Some((x, nb)) = target {
                            u = x;
                            branch = nb;
                            peaks.deepest = peaks.deepest.max(sp.line(nb).2);
                        }
                    }
                    Stop::Event { .. } => {}
                }
                if self.floored_at(u, d) {
                    peaks.floored = true;
                }
            }
            let ag1 = ex.at(k + 1);
            let (total, shear) = match dir {
                None => (ag1, -ag1),
                Some(d) => {
                    let f = self.forces_at(branch, &kin(u, v, d, s), t, &x[2..]);
                    (f.accel(), f.spring + f.friction + f.damper + f.extra)
                }
            };
            peaks.note(u, shear, total);
            sink.sample(k + 1, u, v, total);
        }
        Ok(Peaks {
            peak_displacement: peaks.u,
            residual_displacement: u.abs(),
            peak_base_shear: peaks.shear,
            peak_total_acceleration: peaks.total,
            deepest_branch: peaks.deepest,
            friction_floored: peaks.floored,
        })
    }

    fn floored_at(&self, u: f64, d: f64) -> bool {
        let fr = self.system.friction();
        fr.zero_amplitude_at().is_some() && fr.capacity(u, d) < 0.0
    }
}

/// Running peaks of the numerical forced response.
#[derive(Debug, Default)]
struct ForcedPeaks {
    u: f64,
    shear: f64,
    total: f64,
    deepest: u8,
    floored: bool,
}

impl ForcedPeaks {
    fn note(&mut self, u: f64, shear: f64, total: f64) {
        self.u = self.u.max(u.abs());
        self.shear = self.shear.max(shear.abs());
        self.total = self.total.max(total.abs());
    }
}
