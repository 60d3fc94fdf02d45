//! The hysteretic spring of the rubber bearings (HDRB), per unit mass.
//!
//! A tri-linear envelope (paper Fig. 4.1a, made explicit in
//! `docs/model.md`), elastic unloading with slope `k0` between the upper
//! envelope `U(u)` (followed while `u' > 0`) and the lower one
//! `L(u) = -U(-u)` (followed while `u' < 0`). The bi-linear spring is the
//! case `k2 = k1` (one envelope segment) and the linear spring never yields.
//!
//! # Formula
//!
//! With `u1 = 2 uy - u3`, `F2 = (k0 - k1) uy`, `F1 = F2 + k1 u1`,
//! `F3 = F2 + k1 u3`:
//!
//! ```text
//! U(u) = F1 + k2 (u - u1)   u <= u1        (plastic phase 1)
//!      = F2 + k1 u          u1 <= u <= u3  (plastic phase 2)
//!      = F3 + k2 (u - u3)   u >= u3        (plastic phase 3)
//! ```
//!
//! ```
//! use hbis::model::spring::Spring;
//! // k0 = 4, k1 = 1, uy = 0.01: F2 = 0.03 and U(0.05) = 0.03 + 0.05.
//! let s = Spring::bilinear(4.0, 1.0, 0.01);
//! assert!((s.envelope(1.0, 0.05) - 0.08).abs() < 1e-15);
//! assert!((s.virgin(0.005) - 0.02).abs() < 1e-15);
//! ```

/// One straight segment `F = intercept + slope * u` of the upper envelope,
/// valid for `lo <= u <= hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    lo: f64,
    hi: f64,
    slope: f64,
    intercept: f64,
    /// The paper's plastic phase number (1, 2, 3).
    phase: u8,
}

/// Hysteretic spring per unit mass (stiffnesses in 1/s^2, forces in m/s^2).
#[derive(Debug, Clone, PartialEq)]
pub struct Spring {
    k0: f64,
    uy: f64,
    /// Upper-envelope segments in increasing `u`; empty for a linear spring.
    segs: Vec<Segment>,
}

/// Which line the spring force follows during a phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpringBranch {
    /// Elastic unloading/reloading `F = f_i + k0 (u - u_i)` from `(u_i, f_i)`.
    Elastic { u_i: f64, f_i: f64 },
    /// On the envelope of side `side` (`+1` upper, `-1` lower), segment `seg`.
    Plastic { side: f64, seg: usize },
}

impl Spring {
    /// A spring that never yields, `F = k0 u`.
    pub fn linear(k0: f64) -> Self {
        Self {
            k0,
            uy: f64::INFINITY,
            segs: Vec::new(),
        }
    }

    /// Bi-linear spring: elastic slope `k0`, post-yield slope `k1`, yield
    /// displacement `uy`.
    pub fn bilinear(k0: f64, k1: f64, uy: f64) -> Self {
        let f2 = (k0 - k1) * uy;
        Self {
            k0,
            uy,
            segs: vec![Segment {
                lo: f64::NEG_INFINITY,
                hi: f64::INFINITY,
                slope: k1,
                intercept: f2,
                phase: 2,
            }],
        }
    }

    /// Tri-linear spring: slopes `k0 > k1`, `k0 > k2`, first yield `uy`,
    /// second yield `u3 > uy`.
    pub fn trilinear(k0: f64, k1: f64, k2: f64, uy: f64, u3: f64) -> Self {
        let f2 = (k0 - k1) * uy;
        let u1 = 2.0 * uy - u3;
        let f1 = f2 + k1 * u1;
        let f3 = f2 + k1 * u3;
        Self {
            k0,
            uy,
            segs: vec![
                Segment {
                    lo: f64::NEG_INFINITY,
                    hi: u1,
                    slope: k2,
                    intercept: f1 - k2 * u1,
                    phase: 1,
                },
                Segment {
                    lo: u1,
                    hi: u3,
                    slope: k1,
                    intercept: f2,
                    phase: 2,
                },
                Segment {
                    lo: u3,
                    hi: f64::INFINITY,
                    slope: k2,
                    intercept: f3 - k2 * u3,
                    phase: 3,
                },
            ],
        }
    }

    /// Elastic stiffness `k0`.
    pub fn k0(&self) -> f64 {
        self.k0
    }

    /// Envelope force on side `side` (`+1` upper `U`, `-1` lower `L`) at `u`.
    pub fn envelope(&self, side: f64, u: f64) -> f64 {
        let x = side * u;
        let s = &self.segs[self.seg_index(x, 1.0)];
        side * (s.intercept + s.slope * x)
    }

    /// Force on the virgin loading curve: `k0 u` up to yield, then the envelope.
    pub fn virgin(&self, u: f64) -> f64 {
        if self.segs.is_empty() || u.abs() <= self.uy {
            self.k0 * u
        } else {
            self.envelope(u.signum(), u)
        }
    }

    /// Index of the upper-envelope segment holding `x`; at a breakpoint, the
    /// one ahead in direction `dir`.
    fn seg_index(&self, x: f64, dir: f64) -> usize {
        let n = self.segs.len();
        (0..n)
            .find(|&j| {
                let s = &self.segs[j];
                if dir > 0.0 {
                    x < s.hi
                } else {
                    x <= s.hi
                }
            })
            .unwrap_or(n - 1)
    }

    /// Slope, intercept and plastic phase number (0 when elastic) of a branch.
    pub fn line(&self, b: SpringBranch) -> (f64, f64, u8) {
        match b {
            SpringBranch::Elastic { u_i, f_i } => (self.k0, f_i - self.k0 * u_i, 0),
            SpringBranch::Plastic { side, seg } => {
                let s = &self.segs[seg];
                // L(u) = -U(-u): same slope, opposite intercept.
                (s.slope, side * s.intercept, s.phase)
            }
        }
    }

    /// Spring force on branch `b` at `u`.
    pub fn force(&self, b: SpringBranch, u: f64) -> f64 {
        let (k, c, _) = self.line(b);
        c + k * u
    }

    /// The next displacement at which the branch changes when moving in
    /// direction `dir`, and the branch beyond it. `None` if it never does.
    pub fn next_event(&self, b: SpringBranch, dir: f64) -> Option<(f64, SpringBranch)> {
        match b {
            SpringBranch::Elastic { u_i, f_i } => self.meet(u_i, f_i, dir),
            SpringBranch::Plastic { side, seg } => {
                // On an envelope the motion is always forward in the
                // mirrored coordinate x = side*u.
                let hi = self.segs[seg].hi;
                hi.is_finite()
                    .then(|| (side * hi, SpringBranch::Plastic { side, seg: seg + 1 }))
            }
        }
    }

    /// Where the elastic line through `(u_i, f_i)` meets the envelope ahead
    /// in direction `dir`, and the envelope segment it lands on.
    fn meet(&self, u_i: f64, f_i: f64, dir: f64) -> Option<(f64, SpringBranch)> {
        if self.segs.is_empty() {
            return None;
        }
        // Mirror so that the motion is towards +x against the upper envelope;
        // g(x) = line - U is strictly increasing because k0 > k1, k2.
        let (xi, fi) = (dir * u_i, dir * f_i);
        let g = |s: &Segment, x: f64| fi + self.k0 * (x - xi) - (s.intercept + s.slope * x);
        let n = self.segs.len();
        let seg = (0..n)
            .find(|&j| {
                let s = &self.segs[j];
                !s.hi.is_finite() || g(s, s.hi) > 0.0
            })
            .unwrap_or(n - 1);
        let s = &self.segs[seg];
        let x = ((s.intercept - fi + self.k0 * xi) / (self.k0 - s.slope)).clamp(s.lo, s.hi);
        Some((dir * x, SpringBranch::Plastic { side: dir, seg }))
    }

    /// The elastic branch that starts at a reversal at `u` from branch `b`.
    pub fn unload(&self, b: SpringBranch, u: f64) -> SpringBranch {
        match b {
            SpringBranch::Elastic { .. } => b,
            SpringBranch::Plastic { .. } => SpringBranch::Elastic {
                u_i: u,
                f_i: self.force(b, u),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Spring {
        Spring::trilinear(10.0, 6.0, 4.0, 0.01, 0.08)
    }

    #[test]
    fn envelope_is_continuous_and_odd() {
        let s = tri();
        for &u in &[-0.06, 0.08, -0.08, 0.06, 0.0] {
            let a = s.envelope(1.0, u - 1e-12);
            let b = s.envelope(1.0, u + 1e-12);
            assert!((a - b).abs() < 1e-10);
            assert_eq!(s.envelope(-1.0, u), -s.envelope(1.0, -u));
        }
    }

    #[test]
    fn elastic_stretch_from_the_envelope_is_two_uy() {
        let s = tri();
        for &u in &[-0.1, -0.03, 0.0, 0.05, 0.09, 0.2] {
            let f = s.envelope(1.0, u);
            let (x, b) = s.meet(u, f, -1.0).unwrap();
            assert!((x - (u - 0.02)).abs() < 1e-14, "u={u}: x={x}");
            assert!((s.force(b, x) - s.envelope(-1.0, x)).abs() < 1e-14);
        }
    }

    #[test]
    fn virgin_curve_meets_the_envelope_at_yield() {
        let s = tri();
        assert!((s.virgin(0.01) - s.envelope(1.0, 0.01)).abs() < 1e-15);
        assert_eq!(s.virgin(-0.05), s.envelope(-1.0, -0.05));
        let (x, _) = s.meet(0.0, 0.0, -1.0).unwrap();
        assert!((x + 0.01).abs() < 1e-15);
    }

    #[test]
    fn linear_spring_never_yields() {
        let s = Spring::linear(3.0);
        assert_eq!(s.virgin(5.0), 15.0);
        assert!(s.meet(0.0, 0.0, 1.0).is_none());
    }
}
