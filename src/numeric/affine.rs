//! The exact flow of an affine system `y' = A y + b`, stepped on a sample
//! grid, with its events located on the flow's Taylor series: the
//! numerical engine's phases where every force is affine in the state (the
//! paper's spring branch, slider and damper, a Maxwell element, an effect
//! file's linear memory term) are solved without an adaptive integrator's
//! stages ([`crate::model::numeric`]).
//!
//! A phase holds `A` fixed, so one step map over the sample interval
//! serves every sample of it (and of every later phase with the same `A`):
//! a sample costs one matrix-vector product. The step map is the
//! exponential's Taylor series with scaling and squaring (Moler and Van
//! Loan, *Nineteen dubious ways to compute the exponential of a matrix,
//! twenty-five years later*, SIAM Review 45, 2003, methods 1 and 3), on
//! matrices of at most six rows whose norm times the step is below one
//! here. Why our own: nalgebra's `exp` (Padé with scaling and squaring)
//! works on the same matrices, but not on the affine system's pair
//! `(Phi, Psi)` without an augmented matrix one row larger than a
//! const-generic size can name, and `argmin` and the ODE crates on
//! crates.io have no event location on a given grid.
//!
//! # Formula
//! ```text
//! y(t0 + h) = Phi(h) y(t0) + Psi(h) b
//! Phi(h) = sum_k (A h)^k / k!,   Psi(h) = h sum_k (A h)^k / (k + 1)!
//! Phi(2h) = Phi(h)^2,            Psi(2h) = Phi(h) Psi(h) + Psi(h)
//! within a step: y(t0 + s) = sum_k c_k s^k,
//!   c_0 = y(t0), c_1 = A c_0 + b, c_(k+1) = A c_k / (k + 1)
//! ```
//!
//! ```
//! use hbis::numeric::affine::AffineFlow;
//!
//! // The harmonic oscillator u'' = -u: a quarter period turns (1, 0)
//! // into (0, -1).
//! let flow = AffineFlow::new([[0.0, 1.0], [-1.0, 0.0]], [0.0, 0.0]);
//! let y = flow.step_map(std::f64::consts::FRAC_PI_2).apply(&[1.0, 0.0]);
//! assert!(y[0].abs() < 1e-15 && (y[1] + 1.0).abs() < 1e-15);
//! // A constant force: u'' = 2 from rest moves u = t^2.
//! let fall = AffineFlow::new([[0.0, 1.0], [0.0, 0.0]], [0.0, 2.0]);
//! let y = fall.step_map(3.0).apply(&[0.0, 0.0]);
//! assert!((y[0] - 9.0).abs() < 1e-13 && (y[1] - 6.0).abs() < 1e-13);
//! ```

use super::ode::{OdeError, Outcome, Stop};

/// Most event functions one solve locates (as [`super::ode::Dopri5`]).
pub const MAX_EVENTS: usize = 16;

/// Most Taylor terms of a series; the step keeps `|A| h` below one, where
/// 30 terms reach the rounding error many times over.
const MAX_TERMS: usize = 30;

/// `y' = A y + b` with `A` and `b` constant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AffineFlow<const N: usize> {
    a: [[f64; N]; N],
    b: [f64; N],
}

/// The flow over one step `h` of an [`AffineFlow`]: `y -> Phi y + gamma`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepMap<const N: usize> {
    phi: [[f64; N]; N],
    gamma: [f64; N],
}

impl<const N: usize> StepMap<N> {
    /// The state one step after `y`.
    #[inline]
    pub fn apply(&self, y: &[f64; N]) -> [f64; N] {
        std::array::from_fn(|i| self.gamma[i] + dot(&self.phi[i], y))
    }
}

/// Whether a watched function (times its sign) keeps its sign: `false`
/// at zero and at NaN too.
#[inline]
fn keeps(g: f64) -> bool {
    g > 0.0
}

/// The event functions that can fire, each times its sign (positive
/// while it keeps that sign), in fixed arrays: checked at every sample.
struct Watch<const N: usize> {
    g0: [f64; MAX_EVENTS],
    w: [[f64; N]; MAX_EVENTS],
    len: usize,
}

impl<const N: usize> Watch<N> {
    /// Whether every watched function keeps its sign at `y`. Without a
    /// short circuit: the functions are few, and a branch per function
    /// and sample cost more than the products (the `numeric_maxwell`
    /// bench, 2026-12-04).
    #[inline]
    fn all_keep(&self, y: &[f64; N]) -> bool {
        let mut all = true;
        for e in 0..self.len {
            all &= keeps(self.g0[e] + dot(&self.w[e], y));
        }
        all
    }
}

#[inline]
fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn mat_mul<const N: usize>(a: &[[f64; N]; N], b: &[[f64; N]; N]) -> [[f64; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..N).map(|k| a[i][k] * b[k][j]).sum()))
}

fn mat_vec<const N: usize>(a: &[[f64; N]; N], x: &[f64; N]) -> [f64; N] {
    std::array::from_fn(|i| dot(&a[i], x))
}

/// Largest absolute row sum.
fn norm_inf<const N: usize>(a: &[[f64; N]; N]) -> f64 {
    a.iter()
        .map(|r| r.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

impl<const N: usize> AffineFlow<N> {
    /// The system `y' = a y + b`.
    pub fn new(a: [[f64; N]; N], b: [f64; N]) -> Self {
        Self { a, b }
    }

    /// The system whose right-hand side is `f`, which must be affine in
    /// `y`: read off its values at `y_ref` and at `y_ref + delta_j e_j`
    /// (each `delta_j` nonzero, of the size of `y_j`'s motion).
    pub fn from_rhs(f: impl Fn(&[f64; N]) -> [f64; N], y_ref: [f64; N], delta: [f64; N]) -> Self {
        let f0 = f(&y_ref);
        let mut a = [[0.0; N]; N];
        for j in 0..N {
            let mut y = y_ref;
            y[j] += delta[j];
            let h = y[j] - y_ref[j];
            let fj = f(&y);
            for i in 0..N {
                a[i][j] = (fj[i] - f0[i]) / h;
            }
        }
        let b = std::array::from_fn(|i| f0[i] - dot(&a[i], &y_ref));
        Self { a, b }
    }

    /// The matrix `A`.
    pub fn matrix(&self) -> &[[f64; N]; N] {
        &self.a
    }

    /// `A y + b`.
    #[inline]
    pub fn rate(&self, y: &[f64; N]) -> [f64; N] {
        std::array::from_fn(|i| self.b[i] + dot(&self.a[i], y))
    }

    /// The flow over `h > 0`, `Phi(h)` and `Psi(h) b` (see the module's
    /// formula).
    pub fn step_map(&self, h: f64) -> StepMap<N> {
        let (phi, psi) = exponential(&self.a, h);
        StepMap {
            phi,
            gamma: mat_vec(&psi, &self.b),
        }
    }

    /// The same step map for this flow's `b` from `Phi(h)` and `Psi(h)` of
    /// [`exponential`] (a flow with the same `A`).
    pub fn step_map_from(&self, (phi, psi): &([[f64; N]; N], [[f64; N]; N])) -> StepMap<N> {
        StepMap {
            phi: *phi,
            gamma: mat_vec(psi, &self.b),
        }
    }

    /// The Taylor coefficients `c_k` of `y(t0 + s)` from `y0`, enough for
    /// `s` up to `h`: until a term `|c_k| h^k` falls below the rounding
    /// error of the sum.
    fn series(&self, y0: &[f64; N], h: f64) -> ([[f64; N]; MAX_TERMS], usize) {
        let mut c = [[0.0; N]; MAX_TERMS];
        c[0] = *y0;
        c[1] = self.rate(y0);
        let size = |v: &[f64; N]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let scale = size(y0).max(size(&c[1]) * h);
        let mut hk = h;
        let mut k = 1;
        while k + 1 < MAX_TERMS {
            let next = mat_vec(&self.a, &c[k]);
            c[k + 1] = std::array::from_fn(|i| next[i] / (k + 1) as f64);
            hk *= h;
            k += 1;
            if size(&c[k]) * hk <= 1e-18 * scale {
                break;
            }
        }
        (c, k + 1)
    }
}

/// `Phi(h) = exp(A h)` and `Psi(h) = int_0^h exp(A s) ds` by their Taylor
/// series on `h / 2^j`, `|A| h / 2^j <= 1/2`, then `j` doublings.
pub fn exponential<const N: usize>(a: &[[f64; N]; N], h: f64) -> ([[f64; N]; N], [[f64; N]; N]) {
    let nu = norm_inf(a) * h;
    let j = if nu > 0.5 {
        (nu / 0.5).log2().ceil() as i32
    } else {
        0
    };
    let hs = h / 2f64.powi(j);
    let ah: [[f64; N]; N] = std::array::from_fn(|r| std::array::from_fn(|c| a[r][c] * hs));
    let eye: [[f64; N]; N] = std::array::from_fn(|r| std::array::from_fn(|c| f64::from(r == c)));
    let (mut phi, mut psi) = (eye, eye.map(|r| r.map(|x| x * hs)));
    let mut term = eye;
    for k in 1..MAX_TERMS {
        term = mat_mul(&term, &ah).map(|r| r.map(|x| x / k as f64));
        let small = norm_inf(&term) < 1e-18;
        for r in 0..N {
            for c in 0..N {
                phi[r][c] += term[r][c];
                psi[r][c] += term[r][c] * hs / (k + 1) as f64;
            }
        }
        if small {
            break;
        }
    }
    for _ in 0..j {
        let p = mat_mul(&phi, &psi);
        for r in 0..N {
            for c in 0..N {
                psi[r][c] += p[r][c];
            }
        }
        phi = mat_mul(&phi, &phi);
    }
    (phi, psi)
}

/// Horner's rule for the vector series `c[..n]` at `s`.
fn eval_series<const N: usize>(c: &[[f64; N]], s: f64) -> [f64; N] {
    let mut y = [0.0; N];
    for ck in c.iter().rev() {
        for i in 0..N {
            y[i] = y[i] * s + ck[i];
        }
    }
    y
}

/// The first `s` in `(0, h]` where the polynomial `p` (coefficients
/// lowest first; `p(0)` of sign `sign`) leaves that sign: the Illinois
/// method, on the side past the root (as [`super::ode::Dopri5`]'s event
/// location), to within the rounding of `t0 + s`.
fn first_root(p: &[f64], sign: f64, t0: f64, h: f64) -> f64 {
    let at = |s: f64| p.iter().rev().fold(0.0, |acc, c| acc * s + c);
    let unchanged = |x: f64| x != 0.0 && x.signum() == sign;
    let width = |s: f64| 2.0 * f64::EPSILON * (t0 + s).abs().max(t0.abs());
    let (mut lo, mut hi) = (0.0, h);
    let (mut g_lo, mut g_hi) = (at(lo), at(hi));
    let mut side = 0i8;
    for _ in 0..200 {
        if hi - lo <= width(hi) {
            break;
        }
        let guess = hi - g_hi * (hi - lo) / (g_hi - g_lo);
        let tol = 0.5 * width(hi);
        let mid = if guess.is_finite() && unchanged(g_lo) && !unchanged(g_hi) {
            guess.clamp(lo + tol, hi - tol)
        } else {
            0.5 * (lo + hi)
        };
        if mid <= lo || mid >= hi {
            break;
        }
        let g_mid = at(mid);
        if unchanged(g_mid) {
            (lo, g_lo) = (mid, g_mid);
            if side == -1 {
                g_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, g_hi) = (mid, g_mid);
            if side == 1 {
                g_lo *= 0.5;
            }
            side = 1;
        }
    }
    hi
}

/// The grid the solve steps on: samples at `start + i dt`, the first one
/// not yet handed out `next`, `n` in all.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    /// Time of sample 0.
    pub start: f64,
    /// Sample interval.
    pub dt: f64,
    /// First sample not yet handed out (at or after the solve's start).
    pub next: usize,
    /// Number of samples.
    pub n: usize,
}

impl Grid {
    fn time(&self, i: usize) -> f64 {
        self.start + i as f64 * self.dt
    }
}

/// Solves `y' = A y + b` from `(t0, y0)` towards `t_end`, stepping from
/// sample to sample of `grid` (`full` is the flow's step map over
/// `grid.dt`), and stops at `t_end` or at the first sign change of one of
/// the `n_events` functions `events(y, out)` writes, which must be affine
/// in `y`. As in [`super::ode::Dopri5::solve`], a function zero at `t0`
/// takes its sign from its first nonzero value, and a sample at an event
/// belongs to what follows it: `observe(i, y)` sees each sample `i` before
/// the stop, in order. Returns where it stopped and the first sample not
/// handed out.
#[allow(clippy::too_many_arguments)]
pub fn solve_on_grid<const N: usize, G, O>(
    flow: &AffineFlow<N>,
    full: &StepMap<N>,
    t0: f64,
    y0: [f64; N],
    t_end: f64,
    grid: Grid,
    n_events: usize,
    mut events: G,
    mut observe: O,
) -> Result<(Outcome<N>, usize), OdeError>
where
    G: FnMut(&[f64; N], &mut [f64]),
    O: FnMut(usize, &[f64; N]),
{
    if n_events > MAX_EVENTS || !(t0.is_finite() && t_end.is_finite() && t_end > t0) {
        return Err(OdeError::NonFinite { t: t0 });
    }
    let finite = |y: &[f64; N]| y.iter().all(|x| x.is_finite());
    // The functions are affine, `g_e(y) = g0_e + w_e . y`: read off once.
    let mut g0 = [0.0; MAX_EVENTS];
    events(&[0.0; N], &mut g0[..n_events]);
    let mut w = [[0.0; N]; MAX_EVENTS];
    for j in 0..N {
        let mut unit = [0.0; N];
        unit[j] = 1.0;
        let mut gj = [0.0; MAX_EVENTS];
        events(&unit, &mut gj[..n_events]);
        for e in 0..n_events {
            w[e][j] = gj[e] - g0[e];
        }
    }
    let g_at = |e: usize, y: &[f64; N]| g0[e] + dot(&w[e], y);
    let signum = |g: f64| if g == 0.0 { 0.0 } else { g.signum() };
    let mut sign = [0.0; MAX_EVENTS];
    for (e, s) in sign.iter_mut().enumerate().take(n_events) {
        *s = signum(g_at(e, &y0));
    }
    // The functions that can fire, each times its sign: positive while
    // it keeps that sign (a constant one never fires).
    let watched = |sign: &[f64; MAX_EVENTS]| {
        let mut out = Watch {
            g0: [0.0; MAX_EVENTS],
            w: [[0.0; N]; MAX_EVENTS],
            len: 0,
        };
        for e in 0..n_events {
            if sign[e] != 0.0 && w[e].iter().any(|&x| x != 0.0) {
                out.g0[out.len] = g0[e] * sign[e];
                out.w[out.len] = w[e].map(|x| x * sign[e]);
                out.len += 1;
            }
        }
        out
    };
    let mut watch = watched(&sign);
    let mut unsigned = sign[..n_events].contains(&0.0);
    let (mut t, mut y, mut next) = (t0, y0, grid.next);
    // A sample at the start belongs to this solve.
    while next < grid.n && grid.time(next) <= t0 {
        observe(next, &y);
        next += 1;
    }
    let mut steps = 0;
    // Whether `t` is a sample instant, where the full step map applies.
    let mut on_grid = false;
    loop {
        // Sample to sample while nothing fires: the map, the watch, the
        // sample (the steps below handle the rest).
        if on_grid && !unsigned {
            while next < grid.n && grid.time(next) < t_end {
                let y_new = full.apply(&y);
                if !watch.all_keep(&y_new) {
                    break;
                }
                (t, y) = (grid.time(next), y_new);
                observe(next, &y);
                next += 1;
                steps += 1;
            }
        }
        let target = if next < grid.n {
            grid.time(next).min(t_end)
        } else {
            t_end
        };
        let h = target - t;
        if h.is_nan() || h <= 0.0 {
            return Err(OdeError::StepTooSmall { t });
        }
        let full_step = on_grid && next < grid.n && target == grid.time(next);
        let y_new = if full_step {
            full.apply(&y)
        } else {
            let (c, k) = flow.series(&y, h);
            eval_series(&c[..k], h)
        };
        steps += 1;
        // Not finite propagates through the map: checked where it stops,
        // and where an event function cannot tell.
        let crossed = !watch.all_keep(&y_new);
        if crossed {
            if !finite(&y_new) {
                return Err(OdeError::NonFinite { t: target });
            }
            if let Some((s, e, ye)) = locate(flow, &y, h, t, &sign, n_events, &mut events) {
                let outcome = Outcome {
                    t: t + s,
                    y: ye,
                    stop: Stop::Event { index: e },
                    steps,
                    evaluations: 0,
                    h_next: grid.dt,
                };
                return Ok((outcome, next));
            }
        }
        if crossed || unsigned {
            for (e, s) in sign.iter_mut().enumerate().take(n_events) {
                let g = signum(g_at(e, &y_new));
                if g != 0.0 {
                    *s = g;
                }
            }
            watch = watched(&sign);
            unsigned = sign[..n_events].contains(&0.0);
        }
        t = target;
        y = y_new;
        if target == t_end {
            if !finite(&y) {
                return Err(OdeError::NonFinite { t });
            }
            let outcome = Outcome {
                t,
                y,
                stop: Stop::End,
                steps,
                evaluations: 0,
                h_next: grid.dt,
            };
            return Ok((outcome, next));
        }
        observe(next, &y);
        next += 1;
        on_grid = true;
    }
}

/// The earliest event in the step of length `h` from `(t, y)`: its offset
/// in the step, index and state; `None` where every crossing sits at the
/// step's start (a function that sat on zero there).
fn locate<const N: usize, G>(
    flow: &AffineFlow<N>,
    y: &[f64; N],
    h: f64,
    t: f64,
    sign: &[f64; MAX_EVENTS],
    n_events: usize,
    events: &mut G,
) -> Option<(f64, usize, [f64; N])>
where
    G: FnMut(&[f64; N], &mut [f64]),
{
    let (c, k) = flow.series(y, h);
    // Each event function along the step, as a polynomial in s: the
    // functions are affine, so their values at the coefficients (less the
    // constant part for k >= 1) are the polynomial's coefficients.
    let mut at_zero = [0.0; MAX_EVENTS];
    events(&[0.0; N], &mut at_zero[..n_events]);
    let mut poly = [[0.0; MAX_TERMS]; MAX_EVENTS];
    for (j, cj) in c[..k].iter().enumerate() {
        let mut gj = [0.0; MAX_EVENTS];
        events(cj, &mut gj[..n_events]);
        for e in 0..n_events {
            poly[e][j] = if j == 0 { gj[e] } else { gj[e] - at_zero[e] };
        }
    }
    let mut best: Option<(f64, usize)> = None;
    let at_start = |s: f64| s <= 4.0 * f64::EPSILON * t.abs().max((t + s).abs());
    for e in 0..n_events {
        if sign[e] == 0.0 {
            continue;
        }
        let p = &poly[e][..k];
        let value = |s: f64| p.iter().rev().fold(0.0, |acc, c| acc * s + c);
        // The step's end, or a crossing and crossing back before it that
        // the earliest event found so far reveals.
        let end = best.map_or(h, |b| b.0);
        let g_end = value(end);
        if g_end != 0.0 && g_end.signum() == sign[e] {
            continue;
        }
        let s = first_root(p, sign[e], t, end);
        if at_start(s) {
            continue;
        }
        if best.is_none_or(|(b, _)| s < b) {
            best = Some((s, e));
        }
    }
    // Functions that cross and cross back before the earliest event.
    if let Some((s_best, _)) = best {
        for e in 0..n_events {
            if sign[e] == 0.0 {
                continue;
            }
            let p = &poly[e][..k];
            let value = |s: f64| p.iter().rev().fold(0.0, |acc, c| acc * s + c);
            let g_e = value(s_best);
            if g_e != 0.0 && g_e.signum() != sign[e] {
                let s = first_root(p, sign[e], t, s_best);
                if !at_start(s) && s < best.map_or(f64::INFINITY, |b| b.0) {
                    best = Some((s, e));
                }
            }
        }
    }
    best.map(|(s, e)| (s, e, eval_series(&c[..k], s)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator `u'' + 2 z w u' + w^2 u = f`: its closed form.
    fn damped(w: f64, z: f64, f: f64, u0: f64, t: f64) -> (f64, f64) {
        let wd = w * (1.0 - z * z).sqrt();
        let ue = f / (w * w);
        let (a, b) = (u0 - ue, (u0 - ue) * z * w / wd);
        let e = (-z * w * t).exp();
        let u = ue + e * (a * (wd * t).cos() + b * (wd * t).sin());
        let v = e
            * ((-z * w) * (a * (wd * t).cos() + b * (wd * t).sin())
                + wd * (-a * (wd * t).sin() + b * (wd * t).cos()));
        (u, v)
    }

    fn oscillator(w: f64, z: f64, f: f64) -> AffineFlow<2> {
        AffineFlow::new([[0.0, 1.0], [-w * w, -2.0 * z * w]], [0.0, f])
    }

    #[test]
    fn the_step_map_is_the_damped_oscillators_closed_form() {
        let (w, z, f) = (2.0 * std::f64::consts::PI * 0.7, 0.05, 0.3);
        let flow = oscillator(w, z, f);
        // Long steps need doublings; short ones none.
        for h in [0.005, 0.37, 4.0] {
            let y = flow.step_map(h).apply(&[0.1, 0.0]);
            let (u, v) = damped(w, z, f, 0.1, h);
            assert!(
                (y[0] - u).abs() < 1e-13 && (y[1] - v).abs() < 1e-12,
                "{h}: {y:?} {u} {v}"
            );
        }
    }

    #[test]
    fn the_series_matches_the_step_map_within_a_step() {
        let flow = oscillator(3.0, 0.1, -0.5);
        let y0 = [0.2, -0.4];
        let (c, k) = flow.series(&y0, 0.01);
        for s in [0.001, 0.0047, 0.01] {
            let a = eval_series(&c[..k], s);
            let b = flow.step_map(s).apply(&y0);
            assert!((a[0] - b[0]).abs() < 1e-16 && (a[1] - b[1]).abs() < 1e-15);
        }
    }

    #[test]
    fn from_rhs_reads_the_matrix_back() {
        let flow = AffineFlow::new(
            [[0.0, 1.0, 0.0], [-4.0, -0.1, 0.3], [0.0, 2.0, -5.0]],
            [0.0, 0.2, 1.0],
        );
        let read = AffineFlow::from_rhs(|y| flow.rate(y), [0.1, 0.0, -0.2], [1e-2, 1e-2, 1e-2]);
        for i in 0..3 {
            for j in 0..3 {
                assert!((read.a[i][j] - flow.a[i][j]).abs() < 1e-12);
            }
            assert!((read.b[i] - flow.b[i]).abs() < 1e-13);
        }
    }

    #[test]
    fn the_first_reversal_is_at_half_the_damped_period() {
        // From rest at u0 > 0 the velocity first returns to zero at
        // pi / w_d.
        let (w, z) = (5.0, 0.08);
        let flow = oscillator(w, z, 0.0);
        let dt = 0.005;
        let full = flow.step_map(dt);
        let grid = Grid {
            start: 0.0,
            dt,
            next: 0,
            n: 1000,
        };
        let mut seen = Vec::new();
        let (out, next) = solve_on_grid(
            &flow,
            &full,
            1e-3,
            {
                let (u, v) = damped(w, z, 0.0, 0.05, 1e-3);
                [u, v]
            },
            10.0,
            Grid { next: 1, ..grid },
            1,
            |y, g| g[0] = -y[1],
            |i, y| seen.push((i, *y)),
        )
        .unwrap();
        let t_rev = std::f64::consts::PI / (w * (1.0 - z * z).sqrt());
        assert_eq!(out.stop, Stop::Event { index: 0 });
        assert!((out.t - t_rev).abs() < 1e-12, "{} {t_rev}", out.t);
        assert!(out.y[1].abs() < 1e-12);
        // Every sample before the reversal, each on the closed form.
        assert_eq!(next, (t_rev / dt).ceil() as usize);
        assert_eq!(seen.len(), next - 1);
        for (i, y) in seen {
            let (u, v) = damped(w, z, 0.0, 0.05, i as f64 * dt);
            assert!((y[0] - u).abs() < 1e-13 && (y[1] - v).abs() < 1e-12, "{i}");
        }
    }

    #[test]
    fn a_function_zero_at_the_start_does_not_fire_there() {
        let flow = oscillator(5.0, 0.0, 0.0);
        let full = flow.step_map(0.01);
        let grid = Grid {
            start: 0.0,
            dt: 0.01,
            next: 0,
            n: 400,
        };
        // v = 0 at the start: the event is the next zero of v, half a
        // period on.
        let (out, _) = solve_on_grid(
            &flow,
            &full,
            0.0,
            [1.0, 0.0],
            4.0,
            grid,
            1,
            |y, g| g[0] = y[1],
            |_, _| {},
        )
        .unwrap();
        assert!(
            (out.t - std::f64::consts::PI / 5.0).abs() < 1e-12,
            "{}",
            out.t
        );
    }
}
