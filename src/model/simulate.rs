//! Phase-by-phase closed-form simulation of the release test.
//!
//! The engine walks from one event to the next: reversal (`u' = 0`, where
//! the stop rule of eq. 5.6 is applied), `u = 0` (the friction stiffness
//! changes sign), an envelope breakpoint, or the end of an elastic stretch.
//! Each stretch in between is a [`LinearPhase`] solved exactly; the phases
//! are handed to a sink, so sampling the acceleration allocates nothing.

use std::fmt;

use serde::Serialize;

use super::error::SimError;
use super::friction::Friction;
use super::params::Params;
use super::phase::{LinearPhase, Reach};
use super::spec::{DamperKind, FrictionKind, ModelSpec, SpringKind};
use super::spring::{Spring, SpringBranch};

/// What the spring does during a phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PhaseKind {
    /// Elastic unloading or reloading with slope `k0`.
    Elastic,
    /// On the envelope, branch 1 (slope `k2`, before the first breakpoint).
    Plastic1,
    /// On the envelope, branch 2 (slope `k1`).
    Plastic2,
    /// On the envelope, branch 3 (slope `k2`, beyond `u3`).
    Plastic3,
    /// At rest for good: the slider holds the spring force (eq. 5.6).
    Rest,
}

impl PhaseKind {
    /// Lower-case name as written in CSV and JSON (`elastic`, `plastic1`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            PhaseKind::Elastic => "elastic",
            PhaseKind::Plastic1 => "plastic1",
            PhaseKind::Plastic2 => "plastic2",
            PhaseKind::Plastic3 => "plastic3",
            PhaseKind::Rest => "rest",
        }
    }
}

impl fmt::Display for PhaseKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One phase of motion: a stretch with constant coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phase {
    pub kind: PhaseKind,
    pub t_start: f64,
    pub t_end: f64,
    pub u_start: f64,
    pub v_start: f64,
    pub u_end: f64,
    pub v_end: f64,
    /// Direction of motion, `+1` or `-1` (`0` at rest).
    pub dir: f64,
    /// Sign of `u` during the phase.
    pub sign_u: f64,
    /// The phase's equation of motion.
    pub lin: LinearPhase,
    /// Spring line `F_S = spring_c + spring_k u` during the phase.
    pub spring_k: f64,
    pub spring_c: f64,
}

impl Phase {
    /// Displacement and velocity at absolute time `t` within the phase.
    pub fn state_at(&self, t: f64) -> (f64, f64) {
        self.lin
            .state_at(self.u_start, self.v_start, t - self.t_start)
    }

    /// Spring force per unit mass at `u`.
    pub fn spring_force(&self, u: f64) -> f64 {
        self.spring_c + self.spring_k * u
    }
}

/// Limits on one simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimOptions {
    /// At most this many phases (guards against runaway responses).
    pub phase_cap: usize,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self { phase_cap: 200_000 }
    }
}

/// Receives the phases in time order.
pub trait PhaseSink {
    /// One phase; `last` is true for the phase that reaches the end time.
    fn push(&mut self, phase: &Phase, last: bool);
}

impl PhaseSink for Vec<Phase> {
    fn push(&mut self, phase: &Phase, _last: bool) {
        Vec::push(self, *phase);
    }
}

/// The model resolved per unit mass: what the engine integrates.
#[derive(Debug, Clone, PartialEq)]
pub struct System {
    spring: Spring,
    friction: Friction,
    alpha: f64,
    u0: f64,
}

impl System {
    /// Resolve validated parameters of a model.
    pub fn new(spec: &ModelSpec, p: &Params) -> Self {
        let w = |f: f64| (2.0 * std::f64::consts::PI * f).powi(2);
        let k0 = w(p.f0);
        let spring = match spec.spring {
            SpringKind::Linear => Spring::linear(k0),
            SpringKind::Bilinear => Spring::bilinear(k0, w(p.f1), p.uy),
            SpringKind::Trilinear => Spring::trilinear(k0, w(p.f1), w(p.f2), p.uy, p.u3),
        };
        let friction = match spec.friction {
            FrictionKind::None => Friction::new(0.0, 0.0),
            FrictionKind::Coulomb => Friction::new(p.uf0 * k0, 0.0),
            FrictionKind::Lcfm => Friction::new(p.uf0 * k0, p.rf0 * k0),
        };
        let alpha = match spec.damper {
            DamperKind::None => 0.0,
            DamperKind::Viscous => p.zeta0 * k0.sqrt(),
        };
        Self {
            spring,
            friction,
            alpha,
            u0: p.u0,
        }
    }

    /// The spring.
    pub fn spring(&self) -> &Spring {
        &self.spring
    }

    /// The slider.
    pub fn friction(&self) -> &Friction {
        &self.friction
    }

    /// The slider, to be changed by a piecewise-linear component.
    pub fn friction_mut(&mut self) -> &mut Friction {
        &mut self.friction
    }

    /// Displacement at release (m).
    pub fn u0(&self) -> f64 {
        self.u0
    }

    /// Damper rate `c/m = 2 alpha` (1/s).
    pub fn damper_rate(&self) -> f64 {
        2.0 * self.alpha
    }

    /// Run from release at `t = 0` to `t_end`, handing each phase to `sink`.
    pub fn run<S: PhaseSink>(
        &self,
        t_end: f64,
        opts: &SimOptions,
        sink: &mut S,
    ) -> Result<(), SimError> {
        let (sp, fr) = (&self.spring, &self.friction);
        let bound = 1e6 * self.u0.abs().max(1e-3);
        let mut t = 0.0;
        let mut u = self.u0;
        let mut v = 0.0;
        let mut branch = SpringBranch::Elastic {
            u_i: u,
            f_i: sp.virgin(u),
        };
        // Direction after a stop at u on branch b, or None if it stays (eq. 5.6).
        let start = |b: SpringBranch, u: f64| {
            let fs = sp.force(b, u);
            (fs.abs() > fr.capacity(u, -fs.signum())).then(|| -fs.signum())
        };
        let mut dir = start(branch, u);
        let mut count = 0usize;
        while t < t_end {
            count += 1;
            if count > opts.phase_cap {
                return Err(SimError::PhaseCap {
                    cap: opts.phase_cap,
                    t,
                });
            }
            let Some(d) = dir else {
                let fs = sp.force(branch, u);
                let rest = Phase {
                    kind: PhaseKind::Rest,
                    t_start: t,
                    t_end,
                    u_start: u,
                    v_start: 0.0,
                    u_end: u,
                    v_end: 0.0,
                    dir: 0.0,
                    sign_u: u.signum(),
                    lin: LinearPhase::new(0.0, 0.0, 0.0),
                    spring_k: 0.0,
                    spring_c: fs,
                };
                sink.push(&rest, true);
                return Ok(());
            };
            // Round-off must not leave a velocity against the direction.
            if d * v < 0.0 {
                v = 0.0;
            }
            let sign_u = if u > 0.0 {
                1.0
            } else if u < 0.0 {
                -1.0
            } else {
                d
            };
            let (ks, cs, plastic) = sp.line(branch);
            let (kf, cf) = fr.phase_terms(d, sign_u);
            let lin = LinearPhase::new(self.alpha, ks + kf, cs + cf);

            // The nearest displacement event ahead: the spring's, or u = 0.
            let mut target = sp.next_event(branch, d).map(|(x, b)| (x, Some(b)));
            if fr.has_slope() && sign_u != d {
                let nearer = target.is_none_or(|(x, _)| d * x > 0.0);
                if nearer {
                    target = Some((0.0, None));
                }
            }
            let horizon = t_end - t;
            let rev = lin.reversal(u, v, d).filter(|r| r.0.is_finite());
            let t_rev = rev.map(|r| r.0);
            let t_hi = t_rev.map_or(horizon, |r| r.min(horizon));
            // At a reversal inside the record the end state is already known.
            let at_hi = rev.filter(|r| r.0 <= horizon).map(|r| (r.1, 0.0));
            let hit = target.map(|(x, b)| (x, b, lin.time_to_reach(u, v, d, x, t_hi, at_hi)));

            let (tau, u1, v1, event) = match (hit, rev) {
                (Some((x, b, Reach::At { t: tau, v: v1 })), r) if r.is_none_or(|r| tau < r.0) => {
                    (tau, x, v1, Event::Threshold(b))
                }
                (_, Some((r, u_r))) if r <= horizon => (r, u_r, 0.0, Event::Reversal),
                // The search already evaluated the state at the horizon.
                (Some((_, _, Reach::Beyond { u: u1, v: v1 })), _) => (horizon, u1, v1, Event::End),
                _ => {
                    let (u1, v1) = lin.state_at(u, v, horizon);
                    (horizon, u1, v1, Event::End)
                }
            };
            if !(u1.is_finite() && v1.is_finite() && tau.is_finite()) || u1.abs() > bound {
                return Err(SimError::Diverged { t: t + tau, u: u1 });
            }
            let t1 = if matches!(event, Event::End) {
                t_end
            } else {
                t + tau
            };
            if tau > 0.0 {
                let phase = Phase {
                    kind: match plastic {
                        0 => PhaseKind::Elastic,
                        1 => PhaseKind::Plastic1,
                        2 => PhaseKind::Plastic2,
                        _ => PhaseKind::Plastic3,
                    },
                    t_start: t,
                    t_end: t1,
                    u_start: u,
                    v_start: v,
                    u_end: u1,
                    v_end: v1,
                    dir: d,
                    sign_u,
                    lin,
                    spring_k: ks,
                    spring_c: cs,
                };
                sink.push(&phase, matches!(event, Event::End));
            }
            t = t1;
            u = u1;
            v = v1;
            match event {
                Event::Threshold(Some(b)) => branch = b,
                // u = 0: only the sign of u changes, picked up next round.
                Event::Threshold(None) | Event::End => {}
                Event::Reversal => {
                    branch = sp.unload(branch, u);
                    dir = start(branch, u);
                }
            }
        }
        Ok(())
    }

    /// Sample the acceleration on the grid `t_i = i dt`, `i < out.len()`,
    /// into `out`. Allocates nothing.
    pub fn accel_into(&self, dt: f64, out: &mut [f64], opts: &SimOptions) -> Result<(), SimError> {
        self.accel_grid_into(0.0, dt, out, opts)
    }

    /// Sample the acceleration on the grid `t_i = start + i dt` (`start >= 0`
    /// s after release), `i < out.len()`, into `out`. Allocates nothing.
    pub fn accel_grid_into(
        &self,
        start: f64,
        dt: f64,
        out: &mut [f64],
        opts: &SimOptions,
    ) -> Result<(), SimError> {
        self.grid_into(start, dt, out, opts, false)
    }

    /// Sample the velocity on the grid `t_i = start + i dt` into `out`, by
    /// the acceleration's recurrence: within a phase the velocity obeys the
    /// same homogeneous equation (the derivative of the equation of motion
    /// removes its constant force). Allocates nothing.
    ///
    /// ```
    /// use hbis::model::{ModelSpec, Params, Response, SimOptions, System};
    /// let (spec, p) = (ModelSpec::FULL, Params::table_8_1(5).unwrap());
    /// let mut v = vec![0.0; 2001];
    /// System::new(&spec, &p).velocity_grid_into(0.0, 0.005, &mut v, &SimOptions::default()).unwrap();
    /// let full = Response::simulate(&spec, &p, 10.0).unwrap().sample_grid(0.005).unwrap();
    /// assert!(full.iter().zip(&v).all(|(s, v)| (s.v - v).abs() < 1e-12));
    /// ```
    pub fn velocity_grid_into(
        &self,
        start: f64,
        dt: f64,
        out: &mut [f64],
        opts: &SimOptions,
    ) -> Result<(), SimError> {
        self.grid_into(start, dt, out, opts, true)
    }

    /// The acceleration, or the `velocity`, on the grid into `out`.
    fn grid_into(
        &self,
        start: f64,
        dt: f64,
        out: &mut [f64],
        opts: &SimOptions,
        velocity: bool,
    ) -> Result<(), SimError> {
        check_grid(dt, out.len())?;
        check_start(start)?;
        let t_end = start + dt * (out.len() - 1) as f64;
        let mut sink = AccelSampler::new(start, dt, self.alpha, Write(out));
        sink.velocity = velocity;
        self.run(t_end, opts, &mut sink)
    }

    /// `sum_i (data_i - a(start + i dt))^2`, the acceleration compared
    /// with `data` as it is sampled, never stored: the white-noise
    /// likelihood needs only this sum.
    ///
    /// ```
    /// use hbis::model::{ModelSpec, Params, SimOptions, System};
    /// let sys = System::new(&ModelSpec::FULL, &Params::table_8_1(5).unwrap());
    /// let mut a = vec![0.0; 2001];
    /// sys.accel_into(0.005, &mut a, &SimOptions::default()).unwrap();
    /// let data: Vec<f64> = a.iter().enumerate().map(|(i, v)| v + 0.01 * (i % 3) as f64).collect();
    /// let direct: f64 = data.iter().zip(&a).map(|(d, m)| (d - m) * (d - m)).sum();
    /// let fused = sys.sse_grid(0.0, 0.005, &data, &SimOptions::default()).unwrap();
    /// assert!((fused - direct).abs() < 1e-12 * direct);
    /// ```
    pub fn sse_grid(
        &self,
        start: f64,
        dt: f64,
        data: &[f64],
        opts: &SimOptions,
    ) -> Result<f64, SimError> {
        check_grid(dt, data.len())?;
        check_start(start)?;
        let t_end = start + dt * (data.len() - 1) as f64;
        let mut sink = AccelSampler::new(start, dt, self.alpha, Sse::new(data));
        self.run(t_end, opts, &mut sink)?;
        Ok(sink.emit.total())
    }
}
/// Why a phase ended.
enum Event {
    /// A displacement threshold; `Some` carries the new spring branch.
    Threshold(Option<SpringBranch>),
    Reversal,
    End,
}

/// Reject a grid that cannot be sampled.
pub(crate) fn check_grid(dt: f64, n: usize) -> Result<(), SimError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SimError::Grid {
            name: "dt",
            value: dt,
            requirement: "must be a finite number > 0",
        });
    }
    if n < 2 {
        return Err(SimError::Grid {
            name: "samples",
            value: n as f64,
            requirement: "need at least 2 samples (duration >= dt)",
        });
    }
    Ok(())
}

/// Reject a grid start before the release.
pub(crate) fn check_start(start: f64) -> Result<(), SimError> {
    if !(start.is_finite() && start >= 0.0) {
        return Err(SimError::Grid {
            name: "start",
            value: start,
            requirement: "must be a finite time >= 0 s after release",
        });
    }
    Ok(())
}

/// Visits the grid samples `t_i = i dt` phase by phase: the first sample of a
/// phase exactly, the rest by the exact propagator (a few multiply-adds per
/// sample instead of an `exp`, `sin` and `cos`). Four interleaved lanes
/// advanced by the four-step propagator keep the dependency chains short.
pub struct GridSampler<F> {
    dt: f64,
    n: usize,
    next: usize,
    visit: F,
}

/// Re-anchor the lanes on the closed form this often, to bound round-off
/// growth in very long phases.
const REANCHOR: usize = 4096;

impl<F: FnMut(usize, f64, f64, &Phase)> GridSampler<F> {
    /// Sampler for `n` samples at spacing `dt`, calling `visit(i, u, v, phase)`.
    pub fn new(dt: f64, n: usize, visit: F) -> Self {
        Self {
            dt,
            n,
            next: 0,
            visit,
        }
    }

    /// One past the last sample index inside the phase `[t_start, t_end)`.
    fn end_index(&self, ph: &Phase, last: bool) -> usize {
        if last {
            self.n
        } else {
            first_index_at_or_after(ph.t_end, 0.0, self.dt, self.next, self.n)
        }
    }
}

impl<F: FnMut(usize, f64, f64, &Phase)> PhaseSink for GridSampler<F> {
    fn push(&mut self, ph: &Phase, last: bool) {
        let (start, end) = (self.next, self.end_index(ph, last));
        self.next = end.max(start);
        if start >= end {
            return;
        }
        if ph.kind == PhaseKind::Rest {
            for i in start..end {
                (self.visit)(i, ph.u_start, 0.0, ph);
            }
            return;
        }
        let dt = self.dt;
        let s1 = ph.lin.step(dt);
        let s4 = s1.doubled().doubled();
        let mut i = start;
        while i < end {
            // Anchor four lanes: one exact sample, three single steps.
            let mut lane = [(0.0, 0.0); 4];
            lane[0] = ph.state_at(i as f64 * dt);
            for k in 1..4 {
                lane[k] = s1.apply(lane[k - 1].0, lane[k - 1].1);
            }
            let stop = end.min(i + REANCHOR);
            while i + 4 <= stop {
                for (k, &(u, v)) in lane.iter().enumerate() {
                    (self.visit)(i + k, u, v, ph);
                }
                for l in lane.iter_mut() {
                    *l = s4.apply(l.0, l.1);
                }
                i += 4;
            }
            for (k, &(u, v)) in lane.iter().enumerate().take(stop - i) {
                (self.visit)(i + k, u, v, ph);
            }
            i = stop;
        }
    }
}

/// First sample index at or after `t` (the grid is `start + i dt`), not
/// before `from`.
fn first_index_at_or_after(t: f64, start: f64, dt: f64, from: usize, n: usize) -> usize {
    // A ceiling by hand: `f64::ceil` is a libm call on baseline x86-64.
    let x = ((t - start) / dt).max(0.0);
    let c = x as usize;
    let mut e = if (c as f64) < x {
        c.saturating_add(1)
    } else {
        c
    }
    .clamp(from, n);
    // The division may be off by an ulp: settle on the exact comparison.
    while e > from && start + (e - 1) as f64 * dt >= t {
        e -= 1;
    }
    while e < n && start + (e as f64) * dt < t {
        e += 1;
    }
    e
}

/// Interleaved lanes of the acceleration recurrence: enough independent
/// chains to hide the multiply-add latency.
const LANES: usize = 4;

/// The scalar recurrence amplifies round-off by about `1/sin(w LANES dt)`;
/// re-anchoring it this often keeps the error near 1e-12 m/s^2 even at
/// fine sampling, for one closed-form evaluation per 256 samples.
const ACCEL_REANCHOR: usize = 256;

/// Where the sampled acceleration goes.
trait Emit {
    /// Number of samples on the grid.
    fn len(&self) -> usize;
    /// Samples `i .. i + vals.len()`.
    fn put(&mut self, i: usize, vals: &[f64]);
    /// Samples `i .. end`, from the recurrence.
    fn recur(&mut self, i: usize, end: usize, rec: Recurrence);
    /// Samples `i .. end` at rest: zero acceleration.
    fn rest(&mut self, i: usize, end: usize);
}

/// The lanes' recurrence `a[n+2L] = p a[n+L] + q a[n]`, from the two
/// rows of samples before.
struct Recurrence {
    p: f64,
    q: f64,
    prev: [f64; LANES],
    cur: [f64; LANES],
}

impl Recurrence {
    /// The next `LANES` samples.
    #[inline(always)]
    fn next(&mut self) -> [f64; LANES] {
        let a: [f64; LANES] = std::array::from_fn(|k| self.p * self.cur[k] + self.q * self.prev[k]);
        self.prev = self.cur;
        self.cur = a;
        a
    }
}

/// Writes the samples out.
struct Write<'a>(&'a mut [f64]);

impl Emit for Write<'_> {
    fn len(&self) -> usize {
        self.0.len()
    }

    fn put(&mut self, i: usize, vals: &[f64]) {
        // A copy of known length is a few moves, not a call to memcpy.
        match <&[f64; 2 * LANES]>::try_from(vals) {
            Ok(all) => self.0[i..i + 2 * LANES].copy_from_slice(all),
            Err(_) => self.0[i..i + vals.len()].copy_from_slice(vals),
        }
    }

    #[inline(always)]
    fn recur(&mut self, i: usize, end: usize, mut rec: Recurrence) {
        let mut chunks = self.0[i..end].chunks_exact_mut(LANES);
        for chunk in &mut chunks {
            chunk.copy_from_slice(&rec.next());
        }
        let rest = chunks.into_remainder();
        rest.copy_from_slice(&rec.next()[..rest.len()]);
    }

    fn rest(&mut self, i: usize, end: usize) {
        self.0[i..end].fill(0.0);
    }
}

/// Sums the squared differences from a record, a partial sum per lane so
/// the adds overlap (the sum's order is fixed by the phases, so the same
/// on every run).
struct Sse<'a> {
    data: &'a [f64],
    acc: [f64; LANES],
    other: f64,
}

impl<'a> Sse<'a> {
    fn new(data: &'a [f64]) -> Self {
        Self {
            data,
            acc: [0.0; LANES],
            other: 0.0,
        }
    }

    fn total(&self) -> f64 {
        (self.acc[0] + self.acc[1]) + (self.acc[2] + self.acc[3]) + self.other
    }
}

impl Emit for Sse<'_> {
    fn len(&self) -> usize {
        self.data.len()
    }

    fn put(&mut self, i: usize, vals: &[f64]) {
        for (d, v) in self.data[i..i + vals.len()].iter().zip(vals) {
            self.other += (d - v) * (d - v);
        }
    }

    #[inline(always)]
    fn recur(&mut self, i: usize, end: usize, mut rec: Recurrence) {
        let mut chunks = self.data[i..end].chunks_exact(LANES);
        for d in &mut chunks {
            let a = rec.next();
            for k in 0..LANES {
                let r = d[k] - a[k];
                self.acc[k] += r * r;
            }
        }
        let rest = chunks.remainder();
        self.put(end - rest.len(), &rec.next()[..rest.len()]);
    }

    fn rest(&mut self, i: usize, end: usize) {
        let mut chunks = self.data[i..end].chunks_exact(LANES);
        for c in &mut chunks {
            for (acc, v) in self.acc.iter_mut().zip(c) {
                *acc += v * v;
            }
        }
        for d in chunks.remainder() {
            self.other += d * d;
        }
    }
}

/// The hot path: only the acceleration, which obeys the homogeneous two-term
/// recurrence `a[n+2] = p a[n+1] + q a[n]` within a phase. Interleaved lanes
/// (a stride-LANES recurrence) keep the dependency chains short; what the
/// recurrence needs depends on the effective stiffness alone, which recurs
/// from phase to phase, so it is cached. The samples go to an [`Emit`].
struct AccelSampler<E> {
    start: f64,
    dt: f64,
    next: usize,
    emit: E,
    cache: [(f64, Lanes); 8],
    cached: usize,
    alpha: f64,
    /// Samples the velocity instead of the acceleration.
    velocity: bool,
}

/// What the lanes need for one stiffness `K`, over the grid step `h`.
///
/// The pair `(a, a')` obeys the homogeneous equation, so `a(t + k h)` is the
/// first row of the homogeneous propagator's `k`-th power applied to
/// `(a(t), a'(t))`: the `2 LANES` seeds of the lanes are independent
/// products, not a chain of steps.
#[derive(Debug, Clone, Copy)]
struct Lanes {
    /// First row of `M^k`, `k = 0 .. 2 LANES`.
    row: [(f64, f64); 2 * LANES],
    /// The recurrence over `LANES` steps: `a[n+2L] = p a[n+L] + q a[n]`.
    p: f64,
    q: f64,
}

impl Lanes {
    fn new(alpha: f64, k: f64, h: f64) -> Self {
        let b = LinearPhase::new(alpha, k, 0.0).basis(h);
        let m = [
            [b.ec + alpha * b.es, b.es],
            [-k * b.es, b.ec - alpha * b.es],
        ];
        let mut row = [(1.0, 0.0); 2 * LANES];
        for n in 1..2 * LANES {
            let (r1, r2) = row[n - 1];
            row[n] = (r1 * m[0][0] + r2 * m[1][0], r1 * m[0][1] + r2 * m[1][1]);
        }
        // p, q over one step, doubled: r1^2 + r2^2 = p^2 + 2q, (r1 r2)^2 = q^2.
        let (mut p, mut q) = (2.0 * b.ec, -b.d * b.d);
        let mut span = 1;
        while span < LANES {
            (p, q) = (p * p + 2.0 * q, -(q * q));
            span *= 2;
        }
        Self { row, p, q }
    }
}

impl<E: Emit> AccelSampler<E> {
    fn new(start: f64, dt: f64, alpha: f64, emit: E) -> Self {
        let empty = Lanes {
            row: [(0.0, 0.0); 2 * LANES],
            p: 0.0,
            q: 0.0,
        };
        Self {
            start,
            dt,
            next: 0,
            emit,
            cache: [(f64::NAN, empty); 8],
            cached: 0,
            alpha,
            velocity: false,
        }
    }

    fn lanes(&mut self, k: f64) -> Lanes {
        if let Some((_, l)) = self.cache[..self.cached].iter().find(|(kc, _)| *kc == k) {
            return *l;
        }
        let l = Lanes::new(self.alpha, k, self.dt);
        let slot = self.cached % self.cache.len();
        self.cache[slot] = (k, l);
        self.cached = (self.cached + 1).min(self.cache.len());
        l
    }
}

impl<E: Emit> PhaseSink for AccelSampler<E> {
    fn push(&mut self, ph: &Phase, last: bool) {
        let n = self.emit.len();
        let start = self.next;
        let end = if last {
            n
        } else {
            first_index_at_or_after(ph.t_end, self.start, self.dt, start, n)
        };
        self.next = end.max(start);
        if start >= end {
            return;
        }
        if ph.kind == PhaseKind::Rest {
            self.emit.rest(start, end);
            return;
        }
        let k = ph.lin.stiffness();
        let lanes = self.lanes(k);
        let mut i = start;
        while i < end {
            let stop = end.min(i + ACCEL_REANCHOR);
            let (u, v) = ph.state_at(self.start + i as f64 * self.dt);
            let a = ph.lin.accel(u, v);
            // The quantity sampled and its rate: both obey the homogeneous
            // equation, so one recurrence serves.
            let (x, dx) = if self.velocity {
                (v, a)
            } else {
                (a, -(2.0 * self.alpha * a + k * v))
            };
            let mut seeds = [0.0; 2 * LANES];
            for (slot, &(r1, r2)) in seeds.iter_mut().zip(&lanes.row) {
                *slot = r1 * x + r2 * dx;
            }
            self.emit.put(i, &seeds[..(stop - i).min(2 * LANES)]);
            if stop > i + 2 * LANES {
                let mut rec = Recurrence {
                    p: lanes.p,
                    q: lanes.q,
                    prev: [0.0; LANES],
                    cur: [0.0; LANES],
                };
                rec.prev.copy_from_slice(&seeds[..LANES]);
                rec.cur.copy_from_slice(&seeds[LANES..]);
                self.emit.recur(i + 2 * LANES, stop, rec);
            }
            i = stop;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Response;

    /// Every spring, friction and damper kind, each with a Table 8.1
    /// column.
    const SPECS: [(&str, u32); 4] = [
        ("trilinear+lcfm+viscous", 5),
        ("bilinear+coulomb", 3),
        ("trilinear", 8),
        ("linear+viscous", 6),
    ];

    /// The hot path (acceleration recurrence) and the full response (state
    /// propagator) sample the same record.
    #[test]
    fn accel_into_matches_the_full_response() {
        for (spec, test) in SPECS {
            let spec: ModelSpec = spec.parse().unwrap();
            let p = spec.restrict(&Params::table_8_1(test).unwrap()).unwrap();
            for &(dt, n) in &[(0.005, 2001usize), (0.0007, 30_000), (0.05, 7)] {
                let duration = dt * (n - 1) as f64;
                let r = Response::simulate(&spec, &p, duration).unwrap();
                let full = r.sample_grid(dt).unwrap();
                assert_eq!(full.len(), n);
                let mut a = vec![f64::NAN; n];
                System::new(&spec, &p)
                    .accel_into(dt, &mut a, &SimOptions::default())
                    .unwrap();
                for (i, (s, &ai)) in full.iter().zip(&a).enumerate() {
                    assert!(
                        (s.a - ai).abs() < 1e-11,
                        "{spec} dt={dt} i={i}: {} vs {ai}",
                        s.a
                    );
                }
            }
        }
    }

    /// The fused sum of squared differences is the sum over the written
    /// samples, for every spring and friction, grids with rest phases,
    /// re-anchored stretches and lane remainders, and a shifted start.
    #[test]
    fn sse_grid_is_the_sum_over_the_sampled_acceleration() {
        for (spec, test) in SPECS {
            let spec: ModelSpec = spec.parse().unwrap();
            let p = spec.restrict(&Params::table_8_1(test).unwrap()).unwrap();
            let sys = System::new(&spec, &p);
            for &(start, dt, n) in &[
                (0.0, 0.005, 2001usize),
                (0.0, 0.0007, 30_001),
                (0.013, 0.05, 7),
            ] {
                let mut a = vec![0.0; n];
                sys.accel_grid_into(start, dt, &mut a, &SimOptions::default())
                    .unwrap();
                let data: Vec<f64> = (0..n).map(|i| 0.3 * ((i * 7) % 11) as f64 - 1.0).collect();
                let direct: f64 = data.iter().zip(&a).map(|(d, m)| (d - m) * (d - m)).sum();
                let fused = sys
                    .sse_grid(start, dt, &data, &SimOptions::default())
                    .unwrap();
                // Two orders of summing n positive terms: each is within
                // (n - 1) eps/2 of the exact sum (Higham, Accuracy and
                // Stability, 4.2).
                assert!(
                    (fused - direct).abs() <= n as f64 * f64::EPSILON * direct,
                    "{spec} dt={dt}: {fused} vs {direct}"
                );
            }
        }
    }

    /// A grid that starts after the release samples the same curve: every
    /// fifth sample of a fine grid, from the third on.
    #[test]
    fn a_shifted_grid_samples_the_same_response() {
        for spec in ["trilinear+lcfm+viscous", "bilinear+coulomb", "linear"] {
            let spec: ModelSpec = spec.parse().unwrap();
            let p = spec.restrict(&Params::table_8_1(5).unwrap()).unwrap();
            let sys = System::new(&spec, &p);
            let mut fine = vec![0.0; 10_001];
            sys.accel_into(0.001, &mut fine, &SimOptions::default())
                .unwrap();
            let mut coarse = vec![f64::NAN; 1_999];
            sys.accel_grid_into(0.003, 0.005, &mut coarse, &SimOptions::default())
                .unwrap();
            for (i, &a) in coarse.iter().enumerate() {
                let f = fine[3 + 5 * i];
                assert!((a - f).abs() < 1e-10, "{spec} i={i}: {a} vs {f}");
            }
        }
    }

    #[test]
    fn bad_grids_are_rejected() {
        let sys = System::new(&ModelSpec::FULL, &Params::table_8_1(5).unwrap());
        let mut out = vec![0.0; 10];
        for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                sys.accel_into(dt, &mut out, &SimOptions::default()),
                Err(SimError::Grid { name: "dt", .. })
            ));
        }
        assert!(sys
            .accel_into(0.01, &mut out[..1], &SimOptions::default())
            .is_err());
        for start in [-0.001, f64::NAN] {
            assert!(matches!(
                sys.accel_grid_into(start, 0.01, &mut out, &SimOptions::default()),
                Err(SimError::Grid { name: "start", .. })
            ));
        }
    }

    #[test]
    fn the_phase_cap_stops_a_long_run_with_an_error() {
        let spec: ModelSpec = "linear".parse().unwrap();
        let p = spec.restrict(&Params::table_8_1(5).unwrap()).unwrap();
        let opts = SimOptions { phase_cap: 10 };
        let mut out = vec![0.0; 20_001];
        let err = System::new(&spec, &p)
            .accel_into(0.005, &mut out, &opts)
            .unwrap_err();
        assert!(matches!(err, SimError::PhaseCap { cap: 10, .. }), "{err}");
        // Issue 37: the message names the library option, not a flag the
        // command line does not have.
        let msg = err.to_string();
        assert!(msg.contains("may raise `SimOptions::phase_cap`"), "{msg}");
    }
}
