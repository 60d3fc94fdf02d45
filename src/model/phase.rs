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
//! `c`, `s` use a power series in `w2 t^2` near critical damping, and `E`
//! switches to a divided difference of `expm1` or to its Taylor series where
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
}

/// The propagator over a fixed step `h`: `[u, v] <- M [u, v] + m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    pub m11: f64,
    pub m12: f64,
    pub m21: f64,
    pub m22: f64,
    pub b1: f64,
    pub b2: f64,
}

impl Step {
    /// Advance a state by one step.
    #[inline(always)]
    pub fn apply(&self, u: f64, v: f64) -> (f64, f64) {
        (
            self.m11.mul_add(u, self.m12.mul_add(v, self.b1)),
            self.m21.mul_add(u, self.m22.mul_add(v, self.b2)),
        )
    }
}

/// Where `|w2| t^2` is below this, `c` and `s` come from their power series.
const SERIES_Z: f64 = 0.5;

impl LinearPhase {
    /// A phase with damping `alpha`, effective stiffness `k` and constant
    /// force `c`, all per unit mass.
    pub fn new(alpha: f64, k: f64, c: f64) -> Self {
        Self {
            alpha,
            k,
            c,
            w2: k - alpha * alpha,
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
        -(2.0 * self.alpha).mul_add(v, self.k.mul_add(u, self.c))
    }

    /// `c(t)` and `s(t)` of the module formula (without the decay factor).
    #[inline]
    fn cs(&self, t: f64) -> (f64, f64) {
        let z = self.w2 * t * t;
        if z.abs() < SERIES_Z {
            // c = sum (-z)^n/(2n)!, s = t sum (-z)^n/(2n+1)!; 12 terms reach
            // 0.5^12/24! far below one ulp.
            let mut cn = 1.0;
            let mut sn = 1.0;
            let mut c = 1.0;
            let mut s = 1.0;
            for n in 1..12 {
                let n2 = 2.0 * n as f64;
                cn *= -z / ((n2 - 1.0) * n2);
                sn *= -z / (n2 * (n2 + 1.0));
                c += cn;
                s += sn;
            }
            (c, s * t)
        } else if self.w2 > 0.0 {
            let w = self.w2.sqrt();
            let (sn, cs) = (w * t).sin_cos();
            (cs, sn / w)
        } else {
            let g = (-self.w2).sqrt();
            let x = g * t;
            (x.cosh(), x.sinh() / g)
        }
    }

    /// Decayed basis `(e^(-alpha t) c, e^(-alpha t) s)` and step response `E(t)`.
    #[inline]
    fn basis(&self, t: f64) -> (f64, f64, f64) {
        let (c, s) = self.cs(t);
        let d = (-self.alpha * t).exp();
        let (ec, es) = (d * c, d * s);
        (ec, es, self.step_response(t, ec, es))
    }

    /// `E(t) = integral_0^t e^(-alpha r) s(r) dr`, the response to a unit
    /// constant force from rest.
    fn step_response(&self, t: f64, ec: f64, es: f64) -> f64 {
        let (a, k) = (self.alpha, self.k);
        if k.abs() * t * t >= 1e-2 {
            // The quotient loses at most ~2 digits here.
            return (1.0 - a.mul_add(es, ec)) / k;
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

    /// Displacement and velocity a time `t >= 0` after the state `(u0, v0)`.
    #[inline]
    pub fn state_at(&self, u0: f64, v0: f64, t: f64) -> (f64, f64) {
        let (ec, es, e) = self.basis(t);
        let g0 = self.k.mul_add(u0, self.c);
        let u = u0 + v0 * es - g0 * e;
        let v = v0 * ec - self.alpha.mul_add(v0, g0) * es;
        (u, v)
    }

    /// The exact propagator over a step `h`.
    pub fn step(&self, h: f64) -> Step {
        let (ec, es, e) = self.basis(h);
        Step {
            m11: 1.0 - self.k * e,
            m12: es,
            m21: -self.k * es,
            m22: ec - self.alpha * es,
            b1: -self.c * e,
            b2: -self.c * es,
        }
    }

    /// First time `t > 0` at which the velocity returns to zero, for a phase
    /// moving in direction `dir` (`+1` or `-1`) from `(u0, v0)` with
    /// `dir * v0 >= 0`; `None` when it never does, `Some(0)` when the state
    /// is already at rest with the acceleration against `dir`.
    pub fn reversal_time(&self, u0: f64, v0: f64, dir: f64) -> Option<f64> {
        // dir*v(t) = e^(-alpha t) [vp c(t) - bp s(t)].
        // +0.0, never -0.0: atan2(-0.0, x < 0) would be -pi.
        let vp = if dir * v0 > 0.0 { dir * v0 } else { 0.0 };
        let bp = dir * self.alpha.mul_add(v0, self.k.mul_add(u0, self.c));
        if self.w2 > 0.0 {
            let w = self.w2.sqrt();
            // atan2 keeps full relative precision as w -> 0 when bp > 0.
            let t = (w * vp).atan2(bp) / w;
            return (t >= 0.0 && t.is_finite()).then_some(t);
        }
        if bp <= 0.0 {
            return None;
        }
        if self.w2 == 0.0 {
            return Some(vp / bp);
        }
        let g = (-self.w2).sqrt();
        let x = g * vp / bp;
        if x >= 1.0 {
            return None;
        }
        let t = if x == 0.0 {
            0.0
        } else {
            (vp / bp) * (x.atanh() / x)
        };
        Some(t)
    }

    /// Time in `(0, t_hi]` at which `u` reaches `target`, moving in direction
    /// `dir` from `(u0, v0)`. The caller guarantees that `u` is monotonic on
    /// `[0, t_hi]` (no velocity zero inside); `None` if the target is not
    /// reached by `t_hi`.
    pub fn time_to_reach(&self, u0: f64, v0: f64, dir: f64, target: f64, t_hi: f64) -> Option<f64> {
        let f = |t: f64| {
            let (u, v) = self.state_at(u0, v0, t);
            (dir * (u - target), dir * v)
        };
        let f0 = dir * (u0 - target);
        if f0 >= 0.0 {
            return Some(0.0);
        }
        let (fh, vh) = f(t_hi);
        if fh < 0.0 {
            return None;
        }
        if fh == 0.0 {
            return Some(t_hi);
        }
        // Safeguarded Newton (rtsafe): f is increasing on [lo, hi].
        let (mut lo, mut hi) = (0.0, t_hi);
        // Start Newton from the end where the velocity is larger.
        let vp = dir * v0;
        let (mut t, mut ft, mut dt) = if vh >= vp { (t_hi, fh, vh) } else { (0.0, f0, vp) };
        let mut last_step = t_hi;
        for _ in 0..200 {
            if ft == 0.0 {
                return Some(t);
            }
            if ft < 0.0 {
                lo = t;
            } else {
                hi = t;
            }
            let newton = t - ft / dt;
            let step_ok = dt > 0.0 && newton > lo && newton < hi && (ft / dt).abs() < 0.5 * last_step;
            let next = if step_ok { newton } else { 0.5 * (lo + hi) };
            last_step = (next - t).abs();
            if last_step <= 4.0 * f64::EPSILON * next.abs().max(f64::MIN_POSITIVE) || hi - lo <= 4.0 * f64::EPSILON * hi {
                return Some(next.clamp(lo, hi));
            }
            t = next;
            (ft, dt) = f(t);
        }
        Some(t)
    }
}

#[cfg(test)]
mod tests {
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

    #[test]
    fn step_propagator_equals_direct_evaluation() {
        let p = LinearPhase::new(0.08, 7.0, 0.02);
        let s = p.step(0.005);
        let (mut u, mut v) = (0.1, 0.0);
        for _ in 0..400 {
            (u, v) = s.apply(u, v);
        }
        let (ud, vd) = p.state_at(0.1, 0.0, 2.0);
        assert_relative_eq!(u, ud, epsilon = 1e-14);
        assert_relative_eq!(v, vd, epsilon = 1e-14);
    }

    #[test]
    fn reversal_time_zeroes_the_velocity() {
        for &(a, k, c) in &[(0.1, 10.0, 0.3), (0.5, 0.25, 0.1), (1.0, 0.2, 0.05), (0.3, 0.0, 0.2)] {
            let p = LinearPhase::new(a, k, c);
            let t = p.reversal_time(0.05, 0.2, 1.0).expect("reverses");
            let (_, v) = p.state_at(0.05, 0.2, t);
            assert!(v.abs() < 1e-15, "{a} {k} {c}: v = {v}");
            let (_, vh) = p.state_at(0.05, 0.2, 0.5 * t);
            assert!(vh > 0.0);
        }
        // From rest, under-damped: half a damped period.
        let p = LinearPhase::new(0.1, 4.0, -0.5);
        let t = p.reversal_time(0.2, 0.0, -1.0).unwrap();
        assert_relative_eq!(t, std::f64::consts::PI / (4.0f64 - 0.01).sqrt(), epsilon = 1e-14);
        // From rest, over-damped: never.
        assert!(LinearPhase::new(2.0, 1.0, 0.0).reversal_time(0.2, 0.0, -1.0).is_none());
    }

    #[test]
    fn threshold_time_hits_the_target() {
        let p = LinearPhase::new(0.1, 10.0, 0.3);
        let tr = p.reversal_time(0.1, 0.0, -1.0).unwrap();
        let t = p.time_to_reach(0.1, 0.0, -1.0, -0.05, tr).unwrap();
        let (u, _) = p.state_at(0.1, 0.0, t);
        assert!((u + 0.05).abs() < 1e-15);
        assert!(p.time_to_reach(0.1, 0.0, -1.0, -5.0, tr).is_none());
    }
}
