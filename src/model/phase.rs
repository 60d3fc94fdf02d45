//! One linear phase of motion, solved in closed form.
//!
//! Within a phase the spring segment, the friction direction and the sign of
//! the displacement are fixed, so the equation of motion per unit mass is the
//! linear constant-coefficient equation
//!
//! ```text
//! u'' + 2 alpha u' + K u + C = 0,
//! ```
//!
//! with `alpha = zeta0 * w0` (the damper), `K` the effective stiffness
//! (segment slope plus `+-k_F`) and `C` the constant force (segment intercept
//! plus `+-F_F0`). The paper (eqs. 6.4-6.18) gives only the under-damped form
//! through a particular solution `u_P = -C/K`; that form breaks down at
//! critical damping, in over-damped phases and as `K -> 0`. Here the solution
//! is written without `u_P`, in functions that are entire in `K`:
//!
//! # Formula
//!
//! With `w2 = K - alpha^2`, `c(t) = cos(sqrt(w2) t)` and
//! `s(t) = sin(sqrt(w2) t) / sqrt(w2)` (continued analytically to `cosh`,
//! `sinh` for `w2 < 0` and to `1`, `t` at `w2 = 0`), `g0 = K u0 + C` and the
//! step response `E(t) = (1 - e^(-alpha t) (c + alpha s)) / K`:
//!
//! ```text
//! u(t) = u0 + v0 e^(-alpha t) s(t) - g0 E(t)
//! v(t) = v0 e^(-alpha t) c(t) - (alpha v0 + g0) e^(-alpha t) s(t)
//! a(t) = -(2 alpha v + K u + C)
//! ```
//!
//! `c`, `s` stay accurate through critical damping (`sin x / w` and
//! `expm1`), and `E` switches to a divided difference of `expm1` or to its Taylor series where
//! the direct quotient would cancel, so every regime is evaluated to a few
//! ulps. Reversal times are closed-form; displacement thresholds are found by
//! safeguarded Newton iteration on an interval where `u` is monotonic.
//!
//! ```
//! use hbis::model::phase::LinearPhase;
//! // Undamped unit oscillator released from u = 1: u(t) = cos t.
//! let p = LinearPhase::new(0.0, 1.0, 0.0);
//! let (u, v) = p.state_at(1.0, 0.0, std::f64::consts::FRAC_PI_2);
//! assert!(u.abs() < 1e-15 && (v + 1.0).abs() < 1e-15);
//! ```

/// Coefficients of one linear phase `u'' + 2 alpha u' + K u + C = 0`
/// (per unit mass, SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearPhase {
    /// `alpha = c / (2 m) = zeta0 * w0` (1/s): half the damping rate.
    alpha: f64,
    /// Effective stiffness per unit mass `K` (1/s^2); may be zero or negative.
    k: f64,
    /// Constant force per unit mass `C` (m/s^2).
    c: f64,
    /// `w2 = K - alpha^2`: positive under-damped, negative over-damped.
    w2: f64,
    /// `sqrt(|w2|)`, the damped (or hyperbolic) frequency.
    w: f64,
    /// `1/w` and `1/K` (infinite when zero), to multiply in the hot path.
    inv_w: f64,
    inv_k: f64,
}

/// Outcome of a search for a displacement threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reach {
    /// Reached after `t`, with velocity `v` there.
    At { t: f64, v: f64 },
    /// Not reached by the end of the interval, where the state is `(u, v)`.
    Beyond { u: f64, v: f64 },
}

/// The decayed basis at one time `t`: `ec = e^(-alpha t) c(t)`,
/// `es = e^(-alpha t) s(t)`, the step response `e = E(t)` and `d = e^(-alpha t)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Basis {
    pub ec: f64,
    pub es: f64,
    pub e: f64,
    pub d: f64,
}

/// The propagator over a fixed step `h`: `[u, v] <- M [u, v] + b`; and the
/// recurrence `a[n+2] = p a[n+1] + q a[n]` that the acceleration obeys
/// (it solves the homogeneous equation), with `p = 2 e^(-alpha h) c(h)`,
/// `q = -e^(-2 alpha h)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    pub m11: f64,
    pub m12: f64,
    pub m21: f64,
    pub m22: f64,
    pub b1: f64,
    pub b2: f64,
    pub p: f64,
    pub q: f64,
}

impl Step {
    /// The propagator over twice the step.
    pub fn doubled(&self) -> Step {
        let s = self;
        Step {
            m11: s.m11 * s.m11 + s.m12 * s.m21,
            m12: s.m11 * s.m12 + s.m12 * s.m22,
            m21: s.m21 * s.m11 + s.m22 * s.m21,
            m22: s.m21 * s.m12 + s.m22 * s.m22,
            b1: s.m11 * s.b1 + s.m12 * s.b2 + s.b1,
            b2: s.m21 * s.b1 + s.m22 * s.b2 + s.b2,
            // Power sums of the characteristic roots r1, r2:
            // r1^2 + r2^2 = p^2 + 2q and (r1 r2)^2 = q^2.
            p: s.p * s.p + 2.0 * s.q,
            q: -(s.q * s.q),
        }
    }

    /// Advance a state by one step.
    #[inline(always)]
    pub fn apply(&self, u: f64, v: f64) -> (f64, f64) {
        (
            self.m11 * u + self.m12 * v + self.b1,
            self.m21 * u + self.m22 * v + self.b2,
        )
    }
}

impl LinearPhase {
    /// A phase with damping `alpha`, effective stiffness `k` and constant
    /// force `c`, all per unit mass.
    pub fn new(alpha: f64, k: f64, c: f64) -> Self {
        Self {
            alpha,
            k,
            c,
            w2: k - alpha * alpha,
            w: (k - alpha * alpha).abs().sqrt(),
            inv_w: 1.0 / (k - alpha * alpha).abs().sqrt(),
            inv_k: 1.0 / k,
        }
    }

    /// Half the damping rate `alpha` (1/s).
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// Effective stiffness per unit mass `K` (1/s^2).
    pub fn stiffness(&self) -> f64 {
        self.k
    }

    /// Constant force per unit mass `C` (m/s^2).
    pub fn constant(&self) -> f64 {
        self.c
    }

    /// Acceleration of the state `(u, v)`.
    #[inline(always)]
    pub fn accel(&self, u: f64, v: f64) -> f64 {
        -(2.0 * self.alpha * v + self.k * u + self.c)
    }

    /// `c(t)` and `s(t)` of the module formula (without the decay factor).
    #[inline]
    fn cs(&self, t: f64) -> (f64, f64) {
        let x = self.w * t;
        if self.w2 > 0.0 {
            // sin(x)/w keeps full relative precision as w -> 0.
            let (sn, cs) = x.sin_cos();
            (cs, sn * self.inv_w)
        } else if self.w2 < 0.0 {
            // expm1 keeps sinh(x)/w accurate as w -> 0 (near critical).
            let em1 = x.exp_m1();
            let sinh = 0.5 * (em1 + em1 / (em1 + 1.0));
            (sinh + 1.0 / (em1 + 1.0), sinh * self.inv_w)
        } else {
            (1.0, t)
        }
    }

    /// Decayed basis at `t`.
    #[inline]
    pub fn basis(&self, t: f64) -> Basis {
        if self.w2 < 0.0 && self.w * t > 30.0 {
            // Strongly over-damped over a long time: cosh(w t) overflows
            // where e^(-alpha t) underflows (inf x 0), so the two real
            // exponentials are formed directly; w - alpha = -K/(alpha + w)
            // keeps the slow rate accurate.
            let ep = (-self.k / (self.alpha + self.w) * t).exp();
            let em = (-(self.alpha + self.w) * t).exp();
            let (ec, es) = (0.5 * (ep + em), 0.5 * (ep - em) * self.inv_w);
            return Basis {
                ec,
                es,
                e: self.step_response(t, ec, es),
                d: (-self.alpha * t).exp(),
            };
        }
        let (c, s) = self.cs(t);
        self.decayed(t, c, s)
    }

    #[inline]
    fn decayed(&self, t: f64, c: f64, s: f64) -> Basis {
        let d = (-self.alpha * t).exp();
        let (ec, es) = (d * c, d * s);
        Basis {
            ec,
            es,
            e: self.step_response(t, ec, es),
            d,
        }
    }

    /// `E(t) = integral_0^t e^(-alpha r) s(r) dr`, the response to a unit
    /// constant force from rest.
    fn step_response(&self, t: f64, ec: f64, es: f64) -> f64 {
        let (a, k) = (self.alpha, self.k);
        // The quotient's absolute error is about eps/|K|, which a
        // displacement (times g0 ~ 1 m/s^2) can carry while |K| >= 1e-3;
        // below that only if the relative cancellation is mild.
        if k.abs() >= 1e-3 || k.abs() * t * t >= 1e-2 {
            return (1.0 - (a * es + ec)) * self.inv_k;
        }
        if a * t >= 0.3 {
            // Real roots l1 = -K/(a+g) (slow), l2 = -(a+g) with g >= 0.94 a:
            // E is the divided difference of h(l) = (e^(l t) - 1)/l.
            let g = (a * a - k).sqrt();
            let l1 = -k / (a + g);
            let l2 = -(a + g);
            let h = |l: f64| {
                let x = l * t;
                if x == 0.0 {
                    t
                } else {
                    t * x.exp_m1() / x
                }
            };
            return (h(l1) - h(l2)) / (2.0 * g);
        }
        // Both rates are slow over t: Taylor series of E'' + 2aE' + KE = 1.
        let (mut e2, mut e1) = (0.5, 0.0); // e_n, e_(n-1) as coefficients
        let mut tn = t * t;
        let mut sum = 0.5 * tn;
        for n in 3..60 {
            let nf = n as f64;
            let en = -(2.0 * a * (nf - 1.0) * e2 + k * e1) / (nf * (nf - 1.0));
            tn *= t;
            let term = en * tn;
            sum += term;
            e1 = e2;
            e2 = en;
            if term.abs() <= 1e-18 * sum.abs() && n > 6 {
                break;
            }
        }
        sum
    }

    /// `G(t) = integral_0^t E(r) dr`, the displacement from rest under a unit
    /// force that grows linearly in time (`C = t`); `b` is the basis at `t`.
    /// A ground acceleration linear between its samples adds `-s G(t)` to
    /// the displacement of a phase (`s` its slope), `-s E(t)` to the
    /// velocity.
    ///
    /// # Formula
    ///
    /// From `E' + 2 alpha E + K G = t`: `G = (t - 2 alpha E - e^(-alpha t) s(t)) / K`,
    /// used where `|K| t^2 >= 1`; elsewhere the Taylor series of `E`
    /// integrated term by term, or (strongly damped) a divided difference
    /// of `(e^(l t) - 1 - l t) / l^2` over the two real rates.
    ///
    /// ```
    /// use hbis::model::phase::LinearPhase;
    /// // Free mass (alpha = K = 0): E = t^2/2, G = t^3/6.
    /// let p = LinearPhase::new(0.0, 0.0, 0.0);
    /// let t = 0.3;
    /// assert!((p.ramp(t, &p.basis(t)) - t * t * t / 6.0).abs() < 1e-16);
    /// ```
    pub fn ramp(&self, t: f64, b: &Basis) -> f64 {
        let (a, k) = (self.alpha, self.k);
        if k.abs() * t * t >= 1.0 {
            return (t - 2.0 * a * b.e - b.es) * self.inv_k;
        }
        if a * t > 2.0 {
            // |K| t^2 < 1 < (alpha t)^2: two real rates.
            let g = (a * a - k).sqrt();
            let l1 = -k / (a + g);
            let l2 = -(a + g);
            let h2 = |l: f64| t * t * phi2(l * t);
            return (h2(l1) - h2(l2)) / (2.0 * g);
        }
        // Series of E (e_2 = 1/2, e_n from E'' + 2aE' + KE = 1), integrated.
        let (mut e2, mut e1) = (0.5, 0.0);
        let mut tn = t * t * t;
        let mut sum = tn / 6.0;
        let mut last_small = false;
        for n in 3..80 {
            let nf = n as f64;
            let en = -(2.0 * a * (nf - 1.0) * e2 + k * e1) / (nf * (nf - 1.0));
            tn *= t;
            let term = en * tn / (nf + 1.0);
            sum += term;
            // Two small terms in a row: without damping every other one is 0.
            let small = term.abs() <= 1e-18 * sum.abs();
            if small && last_small && n > 6 {
                break;
            }
            last_small = small;
            e1 = e2;
            e2 = en;
        }
        sum
    }

    /// Displacement and velocity a time `t >= 0` after the state `(u0, v0)`.
    #[inline]
    pub fn state_at(&self, u0: f64, v0: f64, t: f64) -> (f64, f64) {
        self.propagate(&self.basis(t), u0, v0)
    }

    /// The state `(u0, v0)` carried over the time of basis `b`.
    #[inline]
    pub fn propagate(&self, b: &Basis, u0: f64, v0: f64) -> (f64, f64) {
        let g0 = self.k * u0 + self.c;
        let u = u0 + v0 * b.es - g0 * b.e;
        let v = v0 * b.ec - (self.alpha * v0 + g0) * b.es;
        (u, v)
    }

    /// The exact propagator over a step `h`.
    pub fn step(&self, h: f64) -> Step {
        self.step_from(&self.basis(h))
    }

    /// The propagator over the time of basis `b` (which depends on `alpha`
    /// and `K` only, so phases differing in `C` can share it).
    pub fn step_from(&self, b: &Basis) -> Step {
        Step {
            m11: 1.0 - self.k * b.e,
            m12: b.es,
            m21: -self.k * b.es,
            m22: b.ec - self.alpha * b.es,
            b1: -self.c * b.e,
            b2: -self.c * b.es,
            p: 2.0 * b.ec,
            q: -b.d * b.d,
        }
    }

    /// First time `t >= 0` at which the velocity returns to zero, for a phase
    /// moving in direction `dir` (`+1` or `-1`) from `(u0, v0)` with
    /// `dir * v0 >= 0`; `None` when it never does, `Some(0)` when the state
    /// is already at rest with the acceleration against `dir`.
    pub fn reversal_time(&self, u0: f64, v0: f64, dir: f64) -> Option<f64> {
        self.reversal(u0, v0, dir).map(|(t, _)| t)
    }

    /// [`LinearPhase::reversal_time`] and the displacement there. The basis
    /// at the reversal follows from the geometry of the root, so no
    /// `sin`/`cos` is needed.
    pub fn reversal(&self, u0: f64, v0: f64, dir: f64) -> Option<(f64, f64)> {
        // dir*v(t) = e^(-alpha t) [vp c(t) - bp s(t)].
        // +0.0, never -0.0: atan2(-0.0, x < 0) would be -pi.
        let vp = if dir * v0 > 0.0 { dir * v0 } else { 0.0 };
        let bp = dir * (self.alpha * v0 + (self.k * u0 + self.c));
        let (t, c, s) = if self.w2 > 0.0 {
            // atan2 keeps full relative precision as w -> 0 when bp > 0.
            let (y, x) = (self.w * vp, bp);
            // Plain sqrt: libm hypot is slow and these values cannot overflow.
            let r = (x * x + y * y).sqrt();
            if r == 0.0 {
                return Some((0.0, u0));
            }
            (y.atan2(x) / self.w, x / r, vp / r)
        } else {
            if bp <= 0.0 {
                return None;
            }
            let y = vp / bp;
            if self.w2 == 0.0 {
                (y, 1.0, y)
            } else {
                // tanh(w t) = w y.
                let x = self.w * y;
                if x >= 1.0 {
                    return None;
                }
                let ch = 1.0 / ((1.0 - x) * (1.0 + x)).sqrt();
                let t = if x == 0.0 { 0.0 } else { y * (x.atanh() / x) };
                (t, ch, y * ch)
            }
        };
        if !(t >= 0.0 && t.is_finite()) {
            return None;
        }
        let (u, _) = self.propagate(&self.decayed(t, c, s), u0, v0);
        Some((t, u))
    }

    /// When `u` reaches `target` in `(0, t_hi]`, moving in direction `dir`
    /// from `(u0, v0)`. The caller guarantees that `u` is monotonic on
    /// `[0, t_hi]` (no velocity zero inside), and may pass the state at
    /// `t_hi` when it already has it.
    pub fn time_to_reach(
        &self,
        u0: f64,
        v0: f64,
        dir: f64,
        target: f64,
        t_hi: f64,
        at_hi: Option<(f64, f64)>,
    ) -> Reach {
        // In the frame x = dir*(u - target): x increasing, x(0) < 0 wanted.
        let f0 = dir * (u0 - target);
        if f0 >= 0.0 {
            return Reach::At { t: 0.0, v: v0 };
        }
        let (uh, vh) = at_hi.unwrap_or_else(|| self.state_at(u0, v0, t_hi));
        let fh = dir * (uh - target);
        if fh < 0.0 {
            return Reach::Beyond { u: uh, v: vh };
        }
        // Start from the quintic Hermite interpolant of the two end states
        // (the accelerations are free), finish on the local series once
        // the root is near enough; until then Halley's method (the second
        // derivative is the acceleration) inside a shrinking bracket,
        // bisection as fallback; done once |u - target| is at round-off.
        let tol = 4.0 * f64::EPSILON * u0.abs().max(target.abs());
        let (mut lo, mut hi) = (0.0, t_hi);
        let h2 = t_hi * t_hi;
        let guess = hermite_root(
            [f0, dir * v0 * t_hi, dir * self.accel(u0, v0) * h2],
            [fh, dir * vh * t_hi, dir * self.accel(uh, vh) * h2],
        ) * t_hi;
        let (ug, vg) = self.state_at(u0, v0, guess);
        let (mut t, mut v, mut f) = (guess, vg, dir * (ug - target));
        for _ in 0..100 {
            if f.abs() <= tol {
                break;
            }
            if f < 0.0 {
                lo = t;
            } else {
                hi = t;
            }
            // Near the root the local series is exact to round-off and
            // needs no sin, cos or exp.
            if let Some((t1, v1)) = self.series_root(target + dir * f, v, target, t, lo, hi) {
                return Reach::At { t: t1, v: v1 };
            }
            let d1 = dir * v;
            let mut next = 0.5 * (lo + hi);
            if d1 > 0.0 {
                let d2 = dir * self.accel(target + dir * f, v);
                let r1 = 1.0 / d1;
                let newton = f * r1;
                let den = 1.0 - 0.5 * newton * d2 * r1;
                // Trust Halley's correction only near Newton's step.
                let step = if (0.5..=2.0).contains(&den) {
                    newton / den
                } else {
                    newton
                };
                if t - step > lo && t - step < hi {
                    next = t - step;
                }
            }
            let (u1, v1) = self.state_at(u0, v0, next);
            let done = hi - lo <= 2.0 * f64::EPSILON * hi;
            t = next;
            v = v1;
            f = dir * (u1 - target);
            if done {
                break;
            }
        }
        Reach::At { t, v }
    }
}

impl LinearPhase {
    /// Where the Taylor series of `u` about the state `(u, v)` at time `t`
    /// reaches `target` inside `(lo, hi)`, with the velocity there; `None`
    /// when the root lies too far for the series to be exact to round-off
    /// (or outside the bracket), so the caller evaluates the closed form.
    ///
    /// # Formula
    ///
    /// With `y_0 = u - target`, `y_1 = v`, `y_2 = a(u, v)` and, from the
    /// differentiated equation of motion, `y_(n+2) = -2 alpha y_(n+1) - K
    /// y_n`, the root `d` of `sum_n y_n d^n / n!` is found by Newton's
    /// method. Every rate of the phase is at most `rho = |alpha| + w` in
    /// modulus, so `y_n` grows like `rho^n` and the truncation error after
    /// the degree-`N` term is about `(rho d)^(N+1) / (N+1)!` of the
    /// amplitude in `u` and `(rho d)^N / N!` in `v / rho`: the degree is
    /// chosen from `rho d` to keep both below `1e-17`.
    ///
    /// ```
    /// use hbis::model::phase::LinearPhase;
    /// // u = cos t reaches 0.5 at t = pi/3; start 0.001 s before it.
    /// let p = LinearPhase::new(0.0, 1.0, 0.0);
    /// let t0 = std::f64::consts::FRAC_PI_3 - 1e-3;
    /// let (t, v) = p
    ///     .series_root(t0.cos(), -t0.sin(), 0.5, t0, 0.0, 2.0)
    ///     .unwrap();
    /// assert!((t - std::f64::consts::FRAC_PI_3).abs() < 1e-15);
    /// assert!((v + 0.75f64.sqrt()).abs() < 1e-15);
    /// ```
    pub fn series_root(
        &self,
        u: f64,
        v: f64,
        target: f64,
        t: f64,
        lo: f64,
        hi: f64,
    ) -> Option<(f64, f64)> {
        let y0 = u - target;
        if v == 0.0 {
            return None;
        }
        let d0 = -y0 / v;
        let rho = self.alpha.abs() + self.w;
        let z = rho * d0.abs();
        // The degree and the largest `rho d` it is exact for: the
        // velocity, one order lower, needs (rho d)^N / N! < 1e-17.
        let (degree, reach) = if z <= 1e-6 {
            (3, 1e-6)
        } else if z <= 1e-4 {
            (4, 1e-4)
        } else if z <= 7e-4 {
            (5, 7e-4)
        } else if z <= 2e-3 {
            (6, 2e-3)
        } else if z <= 1e-2 {
            (8, 1e-2)
        } else {
            return None;
        };
        // Taylor coefficients y_n / n!.
        let mut c = [0.0; 9];
        let (mut prev, mut cur) = (v, self.accel(u, v));
        c[0] = y0;
        c[1] = v;
        c[2] = 0.5 * cur;
        for n in 3..=degree {
            let next = -(2.0 * self.alpha * cur + self.k * prev);
            c[n] = next * INV_FACTORIAL[n];
            (prev, cur) = (cur, next);
        }
        let poly = |d: f64| {
            let (mut p, mut dp) = (c[degree], 0.0);
            for n in (0..degree).rev() {
                dp = dp * d + p;
                p = p * d + c[n];
            }
            (p, dp)
        };
        // Reversion of the series to third order, then Newton: the start
        // is off by about z^4 of the step.
        let (r2, r3) = (c[2] / v, c[3] / v);
        let mut d = d0 * (1.0 - d0 * (r2 - d0 * (2.0 * r2 * r2 - r3)));
        let mut converged = false;
        for _ in 0..4 {
            let (p, dp) = poly(d);
            let step = p / dp;
            d -= step;
            // Quadratic convergence: what is left is about rho step^2.
            if !(rho * step.abs() > 1e-9 && step.abs() > f64::EPSILON * (t + d).abs()) {
                converged = true;
                break;
            }
        }
        // Near a reversal the root can lie farther than `y0 / v` said.
        let t1 = t + d;
        if !(converged && rho * d.abs() <= reach && t1 > lo && t1 < hi) {
            return None;
        }
        Some((t1, poly(d).1))
    }
}

/// `1 / n!` for the local series.
const INV_FACTORIAL: [f64; 9] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5040.0,
    1.0 / 40320.0,
];

/// `(e^x - 1 - x) / x^2`, accurate for every `x` (series near 0).
fn phi2(x: f64) -> f64 {
    if x.abs() < 0.05 {
        let mut term = 0.5;
        let mut sum = 0.5;
        for n in 3..12 {
            term *= x / n as f64;
            sum += term;
        }
        sum
    } else {
        (x.exp_m1() - x) / (x * x)
    }
}

/// Root in `[0, 1]` of the quintic Hermite interpolant with values `f0 <
/// 0 <= f1`, slopes and second derivatives (scaled to the unit interval)
/// at both ends: `[f, f', f'']` at 0 and at 1. Its error is of order
/// `(rho h)^6 / 46080` of the amplitude, so that one evaluation of the
/// closed form there usually leaves the root close enough for the local
/// series.
fn hermite_root(a: [f64; 3], b: [f64; 3]) -> f64 {
    let ([f0, d0, e0], [f1, d1, e1]) = (a, b);
    // Monomial coefficients of the interpolant.
    let m3 = -10.0 * f0 - 6.0 * d0 - 1.5 * e0 + 0.5 * e1 - 4.0 * d1 + 10.0 * f1;
    let m4 = 15.0 * f0 + 8.0 * d0 + 1.5 * e0 - e1 + 7.0 * d1 - 15.0 * f1;
    let m5 = -6.0 * f0 - 3.0 * d0 - 0.5 * e0 + 0.5 * e1 - 3.0 * d1 + 6.0 * f1;
    let m2 = 0.5 * e0;
    let mut s = (-f0 / (f1 - f0)).clamp(0.0, 1.0);
    // A rough root is enough: the caller polishes it.
    for _ in 0..2 {
        let p = f0 + s * (d0 + s * (m2 + s * (m3 + s * (m4 + s * m5))));
        let dp = d0 + s * (2.0 * m2 + s * (3.0 * m3 + s * (4.0 * m4 + s * 5.0 * m5)));
        if dp <= 0.0 {
            break;
        }
        s = (s - p / dp).clamp(0.0, 1.0);
    }
    s
}

#[cfg(test)]
mod tests {
    /// A strongly over-damped phase over a long time (cosh overflows where
    /// the decay underflows): finite, and equal to the same time taken in
    /// 200 short steps of the ordinary formula.
    #[test]
    fn strongly_over_damped_long_times_stay_finite_and_consistent() {
        // zeta 30 at 0.5 Hz: alpha 94, K 9.9.
        let w0 = 2.0 * std::f64::consts::PI * 0.5;
        let p = super::LinearPhase::new(30.0 * w0, w0 * w0, 0.3);
        let t = 8.0;
        let (u, v) = p.state_at(0.1, -0.01, t);
        assert!(u.is_finite() && v.is_finite(), "{u} {v}");
        let (mut us, mut vs) = (0.1, -0.01);
        for _ in 0..200 {
            (us, vs) = p.state_at(us, vs, t / 200.0);
        }
        assert!(
            (u - us).abs() < 1e-12 && (v - vs).abs() < 1e-12,
            "{u} {us} {v} {vs}"
        );
    }

    use super::*;
    use approx::assert_relative_eq;

    /// Reference by direct Taylor integration of the ODE to high order over
    /// many tiny steps (independent of the closed form).
    fn taylor(alpha: f64, k: f64, c: f64, u0: f64, v0: f64, t: f64) -> (f64, f64) {
        let n = 100;
        let h = t / n as f64;
        let (mut u, mut v) = (u0, v0);
        for _ in 0..n {
            // Series of the solution over h: y^(j+2) = -2a y^(j+1) - K y^(j) (j >= 1).
            let mut d = [0.0f64; 24];
            d[0] = u;
            d[1] = v;
            d[2] = -(2.0 * alpha * v + k * u + c);
            for j in 3..24 {
                d[j] = -(2.0 * alpha * d[j - 1] + k * d[j - 2]);
            }
            let (mut un, mut vn, mut f) = (0.0, 0.0, 1.0);
            for j in 0..24 {
                un += d[j] * f;
                if j + 1 < 24 {
                    vn += d[j + 1] * f;
                }
                f *= h / (j + 1) as f64;
            }
            u = un;
            v = vn;
        }
        (u, v)
    }

    #[test]
    fn every_regime_matches_a_taylor_integration() {
        // (alpha, K, C): under, critical, over, K = 0, K < 0, undamped, tiny K.
        let cases = [
            (0.1, 10.0, 0.3),
            (0.5, 0.25, -0.1),
            (1.0, 0.2, 0.05),
            (0.3, 0.0, 0.2),
            (0.2, -0.5, 0.1),
            (0.0, 4.0, -1.0),
            (0.0, 0.0, 1.0),
            (0.4, 1e-9, 0.2),
            (0.4, 0.16 + 1e-9, 0.2),
            (1e-3, 1e-7, 0.0),
        ];
        for &(a, k, c) in &cases {
            let p = LinearPhase::new(a, k, c);
            for &t in &[1e-6, 0.01, 0.3, 1.0, 2.7] {
                let (u, v) = p.state_at(0.1, -0.2, t);
                let (ur, vr) = taylor(a, k, c, 0.1, -0.2, t);
                assert!((u - ur).abs() < 1e-13, "u {a} {k} {c} t={t}: {u} vs {ur}");
                assert!((v - vr).abs() < 1e-13, "v {a} {k} {c} t={t}: {v} vs {vr}");
            }
        }
    }

    /// `G` in every regime: against the Taylor integration of
    /// `u'' + 2 alpha u' + K u + r = 0` with `r = t` (by linearity, the ramp
    /// response is the difference of two integrations with `C` shifted).
    #[test]
    fn ramp_response_matches_a_taylor_integration() {
        let cases = [
            (0.1, 10.0),
            (0.5, 0.25),
            (1.0, 0.2),
            (0.3, 0.0),
            (0.2, -0.5),
            (0.0, 4.0),
            (0.0, 0.0),
            (3.0, 1e-4),
            (40.0, 0.5),
            (0.4, 0.16 + 1e-9),
        ];
        for &(a, k) in &cases {
            let p = LinearPhase::new(a, k, 0.0);
            for &t in &[1e-4, 0.01, 0.3, 1.0, 2.7] {
                let g = p.ramp(t, &p.basis(t));
                // G(t) = int_0^t E: trapezoid-free check via the ODE
                // E' + 2 alpha E + K G = t, with E and E' = e^(-alpha t) s(t)
                // from the Taylor integration of the unit-force response.
                let (e, es) = taylor(a, k, -1.0, 0.0, 0.0, t);
                let lhs = es + 2.0 * a * e + k * g;
                assert!(
                    (lhs - t).abs() < 1e-12 * t.max(1.0),
                    "{a} {k} t={t}: {lhs} vs {t}"
                );
                // And G itself, where K is too small for the identity to
                // fix it: the series G = t^3/6 - 2 alpha t^4/24 + ... to
                // first order in the rates.
                if a * t < 1e-3 && k * t * t < 1e-3 {
                    assert!((g - t * t * t / 6.0).abs() < 1e-3 * t * t * t);
                }
            }
        }
    }

    /// `G` is the integral of `E`: Simpson's rule on a fine grid.
    #[test]
    fn ramp_response_is_the_integral_of_the_step_response() {
        for &(a, k) in &[
            (0.1, 10.0),
            (3.0, 1e-4),
            (40.0, 0.5),
            (0.2, -0.5),
            (0.0, 1e-9),
        ] {
            let p = LinearPhase::new(a, k, 0.0);
            let t = 1.3;
            let n = 20000;
            let h = t / n as f64;
            let mut sum = 0.0;
            for i in 0..=n {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let r = i as f64 * h;
                sum += w * p.basis(r).e;
            }
            let simpson = sum * h / 3.0;
            let g = p.ramp(t, &p.basis(t));
            assert!(
                (g - simpson).abs() < 1e-12 * g.abs().max(1e-3),
                "{a} {k}: {g} vs {simpson}"
            );
        }
    }

    #[test]
    fn step_propagator_equals_direct_evaluation() {
        let p = LinearPhase::new(0.08, 7.0, 0.02);
        let s = p.step(0.005);
        let (mut u, mut v) = (0.1, 0.0);
        let mut a = vec![p.accel(u, v)];
        for _ in 0..400 {
            (u, v) = s.apply(u, v);
            a.push(p.accel(u, v));
        }
        let (ud, vd) = p.state_at(0.1, 0.0, 2.0);
        assert_relative_eq!(u, ud, epsilon = 1e-14);
        assert_relative_eq!(v, vd, epsilon = 1e-14);
        // The acceleration obeys the two-term recurrence, also over 4 steps.
        let s4 = s.doubled().doubled();
        let s4d = p.step(0.02);
        assert_relative_eq!(s4.m11, s4d.m11, epsilon = 1e-14);
        assert_relative_eq!(s4.b2, s4d.b2, epsilon = 1e-14);
        for n in 0..392 {
            assert!((a[n + 2] - (s.p * a[n + 1] + s.q * a[n])).abs() < 1e-14);
            assert!((a[n + 8] - (s4.p * a[n + 4] + s4.q * a[n])).abs() < 1e-14);
        }
    }

    #[test]
    fn reversal_time_zeroes_the_velocity() {
        for &(a, k, c) in &[
            (0.1, 10.0, 0.3),
            (0.5, 0.25, 0.1),
            (1.0, 0.2, 0.05),
            (0.3, 0.0, 0.2),
        ] {
            let p = LinearPhase::new(a, k, c);
            let (t, ur) = p.reversal(0.05, 0.2, 1.0).expect("reverses");
            let (u, v) = p.state_at(0.05, 0.2, t);
            assert!(v.abs() < 1e-15, "{a} {k} {c}: v = {v}");
            assert!((u - ur).abs() < 1e-15);
            let (_, vh) = p.state_at(0.05, 0.2, 0.5 * t);
            assert!(vh > 0.0);
        }
        // From rest, under-damped: half a damped period.
        let p = LinearPhase::new(0.1, 4.0, -0.5);
        let t = p.reversal_time(0.2, 0.0, -1.0).unwrap();
        assert_relative_eq!(
            t,
            std::f64::consts::PI / (4.0f64 - 0.01).sqrt(),
            epsilon = 1e-14
        );
        // From rest, over-damped: never.
        assert!(LinearPhase::new(2.0, 1.0, 0.0)
            .reversal_time(0.2, 0.0, -1.0)
            .is_none());
    }

    #[test]
    fn threshold_time_hits_the_target() {
        let p = LinearPhase::new(0.1, 10.0, 0.3);
        let tr = p.reversal_time(0.1, 0.0, -1.0).unwrap();
        let Reach::At { t, v } = p.time_to_reach(0.1, 0.0, -1.0, -0.05, tr, None) else {
            panic!("reaches")
        };
        let (u, vt) = p.state_at(0.1, 0.0, t);
        assert!((u + 0.05).abs() < 1e-15, "u = {u}, t = {t}, tr = {tr}");
        assert!((v - vt).abs() < 1e-15, "v = {v} against {vt}");
        assert!(matches!(
            p.time_to_reach(0.1, 0.0, -1.0, -5.0, tr, None),
            Reach::Beyond { .. }
        ));
    }

    /// In every regime and for targets all along the way to the reversal
    /// (so the search ends in the local series from every distance), the
    /// time found puts the closed form on the target, and the velocity
    /// returned is the closed form's there.
    #[test]
    fn threshold_search_is_exact_in_every_regime() {
        // (alpha, K, C): under, near critical, over, K = 0, K < 0, undamped.
        let cases = [
            (0.1, 10.0, 0.3),
            (0.05, 14.2, 0.02),
            (0.5, 0.25 + 1e-9, -0.1),
            (1.0, 0.2, 0.05),
            (0.3, 0.0, -0.2),
            (0.2, -0.5, -0.1),
            (0.0, 4.0, -1.0),
            (3.0, 400.0, 0.5),
        ];
        for &(a, k, c) in &cases {
            let p = LinearPhase::new(a, k, c);
            let (u0, v0) = (0.1, 0.4);
            let t_hi = p.reversal_time(u0, v0, 1.0).map_or(1.0, |t| t.min(1.0));
            let (u_hi, _) = p.state_at(u0, v0, t_hi);
            for frac in [1e-6, 0.01, 0.2, 0.5, 0.9, 0.999, 1.0 - 1e-9] {
                let x = u0 + frac * (u_hi - u0);
                let Reach::At { t, v } = p.time_to_reach(u0, v0, 1.0, x, t_hi, None) else {
                    panic!("{a} {k} {c}: {x} is on the way")
                };
                let (u, vt) = p.state_at(u0, v0, t);
                let scale = u0.abs().max(x.abs());
                assert!(
                    (u - x).abs() <= 16.0 * f64::EPSILON * scale,
                    "{a} {k} {c} frac {frac}: u {u} vs {x}"
                );
                assert!(
                    (v - vt).abs() <= 1e-14 * v0.abs(),
                    "{a} {k} {c} frac {frac}: v {v} vs {vt}"
                );
            }
        }
    }
}
