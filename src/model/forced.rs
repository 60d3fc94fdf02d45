//! The response to a ground acceleration, in closed form.
//!
//! With the ground moving, the equation of motion of the isolation level
//! (displacement `u` relative to the ground) per unit mass is
//!
//! ```text
//! u'' + ag(t) + 2 alpha u' + F_S(u) + F_F(u, u') = 0.
//! ```
//!
//! Between two samples of the ground acceleration, `ag` is linear in time
//! (`ag = a_k + s tau`), so a phase with fixed spring branch and sliding
//! direction solves `u'' + 2 alpha u' + K u + C + a_k + s tau = 0` exactly:
//! the free phase of [`LinearPhase`] with the constant `C + a_k`, plus the
//! ramp response `-s G(tau)` ([`LinearPhase::ramp`]).
//!
//! # Formula
//!
//! ```text
//! u(tau) = u0 + v0 es - (K u0 + C + a_k) E - s G
//! v(tau) = v0 ec - (alpha v0 + K u0 + C + a_k) es - s E
//! ```
//!
//! Differentiating the equation once, the velocity obeys a free phase with
//! constant `s`, `v'' + 2 alpha v' + K v + s = 0`; so the instants where
//! the acceleration vanishes (the velocity's extrema) are the closed-form
//! reversal times of that phase, between them the velocity is monotonic,
//! and a stop (`u' = 0`) is bracketed and located exactly. Samples are
//! split finely enough (`sqrt(K) h < 2`) that the acceleration, a free
//! oscillation, changes sign at most once per step.
//!
//! Friction now **sticks and breaks away**: with the slider stuck (`u' =
//! 0`, the isolation level moves with the ground) the drive `F_S(u) +
//! ag(t)` is linear in time, and the slider lets go when it exceeds the
//! friction capacity the way it pushes, at a time solved in closed form.
//! A linear-Coulomb friction whose amplitude `F_F0 + k_F |u|` would fall
//! below zero (`rF0 < 0` at large `|u|`) is floored at zero there (a slider
//! does not push), an event of its own, and the outcome says so.
//!
//! ```
//! use hbis::model::forced::Excitation;
//! use hbis::model::{ModelSpec, Params, System};
//!
//! let spec: ModelSpec = "trilinear+lcfm+viscous".parse()?;
//! let system = System::new(&spec, &Params::table_8_1(5).unwrap());
//! // Half a second of a 2 m/s^2 pulse, then 10 s at rest.
//! let ag: Vec<f64> = (0..=50).map(|i| if i < 50 { 2.0 } else { 0.0 }).collect();
//! let ex = Excitation::new(0.01, &ag, 10.0)?;
//! let peaks = system.forced(&ex, &Default::default(), &mut ())?;
//! assert!(peaks.peak_displacement > 0.01 && peaks.peak_displacement < 0.5);
//! // Base shear per unit mass and total acceleration are one quantity.
//! assert!((peaks.peak_base_shear - peaks.peak_total_acceleration).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use serde::Serialize;

use super::error::SimError;
use super::friction::Friction;
use super::phase::{LinearPhase, Reach};
use super::simulate::{SimOptions, System};
use super::spring::{Spring, SpringBranch};

/// A ground acceleration sampled every `dt` from `t = 0`, linear between
/// samples, followed by a tail of zeros so the system can come to rest.
#[derive(Debug, Clone, Copy)]
pub struct Excitation<'a> {
    dt: f64,
    ag: &'a [f64],
    n: usize,
}

/// Most integration steps per motion sample: a stiffness that needs more
/// is an error of units, not a system (f0 = 1 kHz at 100 Hz needs 32).
const MAX_SPLIT: f64 = 1e5;

/// Most samples of a forced response (motion and tail), as many as a
/// ground motion may have ([`crate::data::ground_motion::MAX_SAMPLES`]).
pub const MAX_FORCED_SAMPLES: usize = 2_000_000;

impl<'a> Excitation<'a> {
    /// Ground acceleration `ag` (m/s^2) at `t_i = i dt`, then `tail` seconds
    /// of stillness.
    pub fn new(dt: f64, ag: &'a [f64], tail: f64) -> Result<Self, SimError> {
        super::simulate::check_grid(dt, ag.len())?;
        if !(tail.is_finite() && tail >= 0.0) {
            return Err(SimError::Grid {
                name: "tail",
                value: tail,
                requirement: "must be a finite time >= 0 s",
            });
        }
        if let Some(i) = ag.iter().position(|a| !a.is_finite()) {
            return Err(SimError::Grid {
                name: "ground acceleration",
                value: i as f64,
                requirement: "sample at this index is not a finite number",
            });
        }
        // Checked in floating point: a cast would wrap `1e300 / dt`.
        let n = ag.len() as f64 + (tail / dt).round();
        if n > MAX_FORCED_SAMPLES as f64 {
            return Err(SimError::Grid {
                name: "tail",
                value: tail,
                requirement: "motion and tail together exceed 2,000,000 samples",
            });
        }
        let n = n as usize;
        Ok(Self { dt, ag, n })
    }

    /// Sampling step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Samples including the tail.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Never empty (at least two samples).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Ground acceleration at sample `i` (zero in the tail).
    #[inline]
    pub fn at(&self, i: usize) -> f64 {
        self.ag.get(i).copied().unwrap_or(0.0)
    }

    /// Ground acceleration at time `t` (linear between samples).
    pub fn at_time(&self, t: f64) -> f64 {
        let x = (t / self.dt).max(0.0);
        let i = x.floor() as usize;
        let f = x - i as f64;
        self.at(i) + f * (self.at(i + 1) - self.at(i))
    }
}

/// What a forced response reached, over continuous time (stops and other
/// events are located exactly; peaks are taken there and at every sample).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Peaks {
    /// Largest `|u|` (m): the isolators' peak displacement.
    pub peak_displacement: f64,
    /// `|u|` at the end of the tail (m): the residual displacement.
    pub residual_displacement: f64,
    /// Largest `|F_S + F_F + c u'| / m` (m/s^2): base shear per unit mass.
    pub peak_base_shear: f64,
    /// Largest `|u'' + ag|` (m/s^2): total acceleration of the isolated mass.
    pub peak_total_acceleration: f64,
    /// The deepest envelope branch entered (0 elastic, 1-3 plastic phase).
    pub deepest_branch: u8,
    /// Whether the friction amplitude was floored at zero somewhere.
    pub friction_floored: bool,
}

impl Peaks {
    fn new() -> Self {
        Self {
            peak_displacement: 0.0,
            residual_displacement: 0.0,
            peak_base_shear: 0.0,
            peak_total_acceleration: 0.0,
            deepest_branch: 0,
            friction_floored: false,
        }
    }

    #[inline]
    fn note(&mut self, u: f64, shear: f64, total: f64) {
        self.peak_displacement = self.peak_displacement.max(u.abs());
        self.peak_base_shear = self.peak_base_shear.max(shear.abs());
        self.peak_total_acceleration = self.peak_total_acceleration.max(total.abs());
    }
}

/// Receives the response at the excitation's samples.
pub trait ForcedSink {
    /// Sample `i`: displacement, velocity (relative to the ground) and total
    /// acceleration `u'' + ag`.
    fn sample(&mut self, i: usize, u: f64, v: f64, total: f64);
}

impl ForcedSink for () {
    #[inline]
    fn sample(&mut self, _: usize, _: f64, _: f64, _: f64) {}
}

/// Both sinks, in turn.
impl<A: ForcedSink, B: ForcedSink> ForcedSink for (A, B) {
    #[inline]
    fn sample(&mut self, i: usize, u: f64, v: f64, total: f64) {
        self.0.sample(i, u, v, total);
        self.1.sample(i, u, v, total);
    }
}

/// Displacement history: `u` at every sample.
impl ForcedSink for Vec<f64> {
    fn sample(&mut self, i: usize, u: f64, _: f64, _: f64) {
        if i >= self.len() {
            self.resize(i + 1, 0.0);
        }
        self[i] = u;
    }
}

/// The friction law floored at zero amplitude.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Floored {
    fr: Friction,
    /// `|u|` where the amplitude reaches zero (infinite if never).
    uz: f64,
}

impl Floored {
    pub(crate) fn new(fr: Friction) -> Self {
        Self {
            fr,
            uz: fr.zero_amplitude_at().unwrap_or(f64::INFINITY),
        }
    }

    /// Whether the amplitude is zero at `u` on a motion in direction `d`.
    #[inline]
    fn off(&self, u: f64, d: f64, sign_u: f64) -> bool {
        u.abs() > self.uz || (u.abs() == self.uz && sign_u == d)
    }

    /// Phase stiffness and constant of the slider.
    #[inline]
    fn terms(&self, d: f64, sign_u: f64, u: f64) -> (f64, f64) {
        if self.off(u, d, sign_u) {
            (0.0, 0.0)
        } else {
            self.fr.phase_terms(d, sign_u)
        }
    }

    /// Whether the amplitude depends on `u` (phases split at `u = 0`).
    fn has_slope(&self) -> bool {
        self.fr.has_slope()
    }

    /// What the slider can hold against a push in direction `dir`.
    #[inline]
    pub(crate) fn capacity(&self, u: f64, dir: f64) -> f64 {
        self.fr.capacity(u, dir).max(0.0)
    }

    /// The nearest `u = +-uz` strictly ahead of `u` in direction `d`.
    fn ahead(&self, u: f64, d: f64) -> Option<f64> {
        [self.uz, -self.uz]
            .into_iter()
            .filter(|x| x.is_finite() && d * (x - u) > 0.0)
            .min_by(|a, b| (d * (a - u)).total_cmp(&(d * (b - u))))
    }
}

/// The state carried from step to step.
#[derive(Debug, Clone, Copy)]
struct State {
    u: f64,
    v: f64,
    branch: SpringBranch,
    /// `Some(d)` sliding in direction `d`, `None` stuck.
    dir: Option<f64>,
}

/// What ended a stretch within a step.
enum Event {
    /// A displacement threshold; `Some` carries the new spring branch.
    Threshold(Option<SpringBranch>),
    /// The velocity reached zero.
    Stop,
}

impl System {
    /// The response to the ground acceleration `ex` from rest (virgin
    /// spring, `u = 0`), handing each sample to `sink`.
    pub fn forced<S: ForcedSink>(
        &self,
        ex: &Excitation,
        opts: &SimOptions,
        sink: &mut S,
    ) -> Result<Peaks, SimError> {
        Forced::new(self, ex.dt())?.run(ex, opts, sink)
    }
}

/// The engine over one excitation.
struct Forced<'a> {
    sp: &'a Spring,
    fr: Floored,
    alpha: f64,
    /// Steps per sample, so that `sqrt(K) h < 2` on every branch.
    split: usize,
    h: f64,
    events: usize,
    peaks: Peaks,
}

impl<'a> Forced<'a> {
    fn new(system: &'a System, dt: f64) -> Result<Self, SimError> {
        let sp = system.spring();
        let fr = *system.friction();
        let k_max = sp.k0() + fr.slope().abs() * (1.0 + fr.asymmetry());
        // In floating point first: a cast of an absurd stiffness would
        // saturate and the run never end.
        let split = (dt * k_max.max(0.0).sqrt() / 2.0).ceil().max(1.0);
        if split > MAX_SPLIT {
            return Err(SimError::Grid {
                name: "largest stiffness (2 pi f)^2, as f",
                value: k_max.sqrt() / std::f64::consts::TAU,
                requirement: "needs more than 100,000 steps per motion sample: check the parameters' units (f0 in Hz)",
            });
        }
        let split = split as usize;
        Ok(Self {
            sp,
            fr: Floored::new(fr),
            alpha: 0.5 * system.damper_rate(),
            split,
            h: dt / split as f64,
            events: 0,
            peaks: Peaks::new(),
        })
    }

    fn run<S: ForcedSink>(
        mut self,
        ex: &Excitation,
        opts: &SimOptions,
        sink: &mut S,
    ) -> Result<Peaks, SimError> {
        let mut st = State {
            u: 0.0,
            v: 0.0,
            branch: SpringBranch::Elastic { u_i: 0.0, f_i: 0.0 },
            dir: None,
        };
        let a0 = ex.at(0);
        self.peaks.note(0.0, a0, a0);
        sink.sample(0, 0.0, 0.0, a0);
        for k in 0..ex.len() - 1 {
            let (ak, ak1) = (ex.at(k), ex.at(k + 1));
            let s = (ak1 - ak) / ex.dt();
            for j in 0..self.split {
                let ag = ak + s * (j as f64 * self.h);
                self.step(&mut st, ag, s, self.h, opts, k as f64 * ex.dt())?;
            }
            let total = self.total(&st, ak1);
            self.peaks.note(st.u, total, total);
            sink.sample(k + 1, st.u, st.v, total);
        }
        self.peaks.residual_displacement = st.u.abs();
        Ok(self.peaks)
    }

    /// Total acceleration `u'' + ag` of a state (equal to minus the base
    /// shear per unit mass).
    fn total(&self, st: &State, ag: f64) -> f64 {
        match st.dir {
            None => ag,
            Some(d) => {
                let (k, c) = self.line(st, d);
                -(2.0 * self.alpha * st.v + k * st.u + c)
            }
        }
    }

    /// Stiffness and constant of the sliding phase in direction `d`.
    fn line(&self, st: &State, d: f64) -> (f64, f64) {
        let sign_u = sign_of(st.u, d);
        let (ks, cs, _) = self.sp.line(st.branch);
        let (kf, cf) = self.fr.terms(d, sign_u, st.u);
        (ks + kf, cs + cf)
    }

    /// Advance over one step of length `h` from ground acceleration `ag`
    /// rising at rate `s`.
    fn step(
        &mut self,
        st: &mut State,
        ag: f64,
        s: f64,
        h: f64,
        opts: &SimOptions,
        t: f64,
    ) -> Result<(), SimError> {
        let mut off = 0.0;
        loop {
            self.events += 1;
            if self.events > opts.phase_cap {
                return Err(SimError::PhaseCap {
                    cap: opts.phase_cap,
                    t: t + off,
                });
            }
            let rem = h - off;
            let g = ag + s * off;
            let tau = match st.dir {
                None => self.stuck(st, g, s, rem),
                Some(d) => self.slide(st, d, g, s, rem)?,
            };
            match tau {
                Some(tau) if tau < rem => off += tau,
                _ => return Ok(()),
            }
        }
    }

    /// Stuck: find the breakaway within `rem`; `None` if it holds.
    fn stuck(&mut self, st: &mut State, g: f64, s: f64, rem: f64) -> Option<f64> {
        let fs = self.sp.force(st.branch, st.u);
        let hi = self.fr.capacity(st.u, -1.0);
        let lo = -self.fr.capacity(st.u, 1.0);
        let (d0, d1) = (fs + g, fs + g + s * rem);
        let (tau, dir) = if d0 > hi {
            (0.0, -1.0)
        } else if d0 < lo {
            (0.0, 1.0)
        } else if d1 > hi {
            (((hi - d0) / s).clamp(0.0, rem), -1.0)
        } else if d1 < lo {
            (((lo - d0) / s).clamp(0.0, rem), 1.0)
        } else {
            return None;
        };
        st.dir = Some(dir);
        Some(tau)
    }

    /// Sliding in direction `d`: advance to the first event within `rem`,
    /// or over all of it (`None`).
    fn slide(
        &mut self,
        st: &mut State,
        d: f64,
        g: f64,
        s: f64,
        rem: f64,
    ) -> Result<Option<f64>, SimError> {
        if d * st.v < 0.0 {
            st.v = 0.0;
        }
        let (u0, v0) = (st.u, st.v);
        let (k, c) = self.line(st, d);
        let alpha = self.alpha;
        let lin = LinearPhase::new(alpha, k, 0.0);
        let at = |tau: f64| {
            let b = lin.basis(tau);
            let gr = lin.ramp(tau, &b);
            let g0 = k * u0 + c + g;
            (
                u0 + v0 * b.es - g0 * b.e - s * gr,
                v0 * b.ec - (alpha * v0 + g0) * b.es - s * b.e,
            )
        };
        let accel = |u: f64, v: f64, tau: f64| -(2.0 * alpha * v + k * u + c + g + s * tau);
        let (u1, v1) = at(rem);
        let vphase = LinearPhase::new(alpha, k, s);
        let stop = first_stop(
            &vphase,
            d,
            v0,
            accel(u0, v0, 0.0),
            rem,
            v1,
            accel(u1, v1, rem),
        );
        let (t_lim, at_lim) = match stop {
            Some(ts) => (ts, at(ts)),
            None => (rem, (u1, v1)),
        };
        let u_lim = at_lim.0;
        // The nearest displacement event ahead.
        let sign_u = sign_of(u0, d);
        let mut target = self.sp.next_event(st.branch, d).map(|(x, b)| (x, Some(b)));
        let mut consider = |x: f64| {
            if target.is_none_or(|(y, _)| d * (x - y) < 0.0) {
                target = Some((x, None));
            }
        };
        if self.fr.has_slope() && sign_u != d {
            consider(0.0);
        }
        if let Some(x) = self.fr.ahead(u0, d) {
            consider(x);
        }
        let hit = target.filter(|(x, _)| d * (u_lim - x) >= 0.0);
        let (tau, event) = match (hit, stop) {
            (Some((x, b)), _) => {
                let tau = reach(&at, d, u0, x, t_lim);
                (tau, Some((Event::Threshold(b), x)))
            }
            (None, Some(ts)) => (ts, Some((Event::Stop, u_lim))),
            (None, None) => (rem, None),
        };
        let before = self.line(st, d);
        let (u, v) = if tau == t_lim { at_lim } else { at(tau) };
        if !(u.is_finite() && v.is_finite()) || u.abs() > 1e3 {
            return Err(SimError::Diverged { t: tau, u });
        }
        let g1 = g + s * tau;
        // The total acceleration's extremum inside the stretch, where its
        // rate -(2 alpha u'' + K u') changes sign.
        let w = |u: f64, v: f64, t: f64| 2.0 * alpha * accel(u, v, t) + k * v;
        let (w0, w1) = (w(u0, v0, 0.0), w(u, v, tau));
        if w0 * w1 < 0.0 {
            let te = root(
                |t| {
                    let (ut, vt) = at(t);
                    w(ut, vt, t)
                },
                tau,
                w0,
                w1,
            );
            let (ue, ve) = at(te);
            let total = accel(ue, ve, te) + g + s * te;
            self.peaks.note(ue, total, total);
        }
        let Some((event, x)) = event else {
            st.u = u;
            st.v = v;
            return Ok(None);
        };
        // The shear just before the event, at the exact event state.
        let (u, v) = match event {
            Event::Stop => (x, 0.0),
            Event::Threshold(_) => (x, v),
        };
        let shear = before.0 * u + before.1 + 2.0 * alpha * v;
        self.peaks.note(u, shear, -shear);
        st.u = u;
        st.v = v;
        match event {
            Event::Threshold(Some(b)) => {
                st.branch = b;
                self.peaks.deepest_branch = self.peaks.deepest_branch.max(self.sp.line(b).2);
            }
            Event::Threshold(None) => {}
            Event::Stop => self.after_stop(st, d, g1),
        }
        if self.fr.off(st.u, d, sign_of(st.u, d)) && st.dir.is_some() {
            self.peaks.friction_floored = true;
        }
        let total = self.total(st, g1);
        self.peaks.note(st.u, total, total);
        Ok(Some(tau))
    }

    /// At `u' = 0`: stick, or slide on (eq. 5.6 with the ground's push).
    fn after_stop(&mut self, st: &mut State, d: f64, g: f64) {
        let unloaded = self.sp.unload(st.branch, st.u);
        let drive = self.sp.force(unloaded, st.u) + g;
        let next = -drive.signum();
        if drive != 0.0 && drive.abs() > self.fr.capacity(st.u, next) {
            st.dir = Some(next);
            // Sliding on the same way, the spring never reversed.
            if next != d {
                st.branch = unloaded;
            }
        } else {
            st.dir = None;
            st.branch = unloaded;
        }
    }
}

/// Sign of `u`, or `d` at zero.
#[inline]
fn sign_of(u: f64, d: f64) -> f64 {
    if u > 0.0 {
        1.0
    } else if u < 0.0 {
        -1.0
    } else {
        d
    }
}

/// First time in `(0, h]` at which a velocity moving in direction `d`
/// returns to zero, given its phase `vphase` (state `(v, a)`) and the
/// states at both ends; `None` if it does not. The acceleration changes
/// sign at most once in the step.
fn first_stop(
    vphase: &LinearPhase,
    d: f64,
    v0: f64,
    a0: f64,
    h: f64,
    v1: f64,
    a1: f64,
) -> Option<f64> {
    // Just broken away: the acceleration starts at zero; round-off must
    // not make the velocity stop at once.
    let a0 = if v0 == 0.0 && d * a0 < 0.0 { 0.0 } else { a0 };
    let time = |r: Reach, t0: f64| match r {
        Reach::At { t, .. } => Some(t0 + t),
        Reach::Beyond { .. } => None,
    };
    if d * v1 > 0.0 {
        // Falls then rises: a stop only at a dip to zero.
        if d * a0 < 0.0 && d * a1 > 0.0 {
            let (tm, vm) = vphase.reversal(v0, a0, -d)?;
            if tm < h && d * vm <= 0.0 {
                return time(
                    vphase.time_to_reach(v0, a0, -d, 0.0, tm, Some((vm, 0.0))),
                    0.0,
                );
            }
        }
        return None;
    }
    if d * a0 <= 0.0 && v0 != 0.0 {
        // Falling from the start, until the acceleration's zero if any.
        let t_hi = if d * a1 > 0.0 {
            vphase.reversal_time(v0, a0, -d).map_or(h, |t| t.min(h))
        } else {
            h
        };
        let at_hi = (t_hi == h).then_some((v1, a1));
        return time(vphase.time_to_reach(v0, a0, -d, 0.0, t_hi, at_hi), 0.0);
    }
    // Rising first, then falling through zero after the extremum.
    let (tm, vm) = vphase.reversal(v0, a0, d).filter(|r| r.0 < h)?;
    time(
        vphase.time_to_reach(vm, 0.0, -d, 0.0, h - tm, Some((v1, a1))),
        tm,
    )
}

/// When `u` (moving in direction `d` from `u0`, monotonic on `[0, t_hi]`)
/// reaches `x`: safeguarded Newton on the closed form `at`.
fn reach(at: &impl Fn(f64) -> (f64, f64), d: f64, u0: f64, x: f64, t_hi: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, t_hi);
    if d * (u0 - x) >= 0.0 {
        return 0.0;
    }
    let tol = 4.0 * f64::EPSILON * x.abs().max(u0.abs());
    let mut t = 0.5 * t_hi;
    for _ in 0..100 {
        let (u, v) = at(t);
        let f = d * (u - x);
        if f.abs() <= tol {
            return t;
        }
        if f < 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        let newton = t - f / (d * v);
        t = if newton > lo && newton < hi && d * v > 0.0 {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 2.0 * f64::EPSILON * hi {
            break;
        }
    }
    hi
}

/// The root of `f` in `[0, t_hi]` where it changes sign from `f0` to `f1`:
/// the Illinois variant of regula falsi, to round-off in `t`.
fn root(f: impl Fn(f64) -> f64, t_hi: f64, f0: f64, f1: f64) -> f64 {
    // The bracket is [a, b] in either order, f(a) f(b) < 0.
    let (mut a, mut fa, mut b, mut fb) = (0.0, f0, t_hi, f1);
    for _ in 0..100 {
        let c = (a * fb - b * fa) / (fb - fa);
        if (b - a).abs() <= 4.0 * f64::EPSILON * t_hi || !c.is_finite() {
            return c.clamp(0.0, t_hi);
        }
        let fc = f(c);
        if fc == 0.0 {
            return c;
        }
        if fc * fb < 0.0 {
            (a, fa) = (b, fb);
        } else {
            fa *= 0.5;
        }
        (b, fb) = (c, fc);
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ModelSpec, Params};

    /// Issue 37: f0 = 1e100 (a unit error) asked for more steps per sample
    /// than a cast holds, and the run never ended.
    #[test]
    fn a_stiffness_needing_too_many_steps_per_sample_is_refused() {
        let spec: ModelSpec = "linear".parse().unwrap();
        let mut p = Params::table_8_1(5).unwrap();
        p.f0 = 1e100;
        let system = System::new(&spec, &spec.restrict(&p).unwrap());
        let Err(e) = Forced::new(&system, 0.01) else {
            panic!("f0 = 1e100 Hz accepted");
        };
        let e = e.to_string();
        assert!(
            e.contains("needs more than 100,000 steps per motion sample"),
            "{e}"
        );
    }
}
