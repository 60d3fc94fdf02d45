//! The linear Coulomb friction slider of the sliding bearings (LFSB), per
//! unit mass.
//!
//! # Formula
//!
//! ```text
//! F_F = (F_F0 + k_F |u|) sign(u'),   F_F0 = uF0 k0,   k_F = rF0 k0
//! ```
//!
//! Constant Coulomb friction (CCFM) is `k_F = 0`; no slider is
//! `F_F0 = k_F = 0`. Written as `k_F sign(u) sign(u') u + F_F0 sign(u')`, the
//! slider adds `+-k_F` to the stiffness of a phase and `+-F_F0` to its
//! constant force, so a phase also ends where `u` changes sign.
//!
//! A slider may rub harder one way than the other (the
//! `asymmetric-friction` component): the amplitude is then scaled by
//! `1 + a_F dir`, still constant within a phase.
//!
//! ```
//! use hbis::model::friction::Friction;
//! let f = Friction::new(0.02, -0.1);
//! assert!((f.amplitude(-0.05) - 0.015).abs() < 1e-15);
//! assert_eq!(f.phase_terms(1.0, -1.0), (0.1, 0.02));
//! ```

/// Friction slider per unit mass (`f_f0` in m/s^2, `k_f` in 1/s^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Friction {
    f_f0: f64,
    k_f: f64,
    asym: f64,
}

impl Friction {
    /// Slider with constant part `f_f0` and slope `k_f` per unit mass.
    pub fn new(f_f0: f64, k_f: f64) -> Self {
        Self {
            f_f0,
            k_f,
            asym: 0.0,
        }
    }

    /// The same slider with amplitude `(1 + a_f dir) (F_F0 + k_F |u|)` when
    /// sliding in direction `dir` (`|a_f| < 1`).
    pub fn with_asymmetry(self, a_f: f64) -> Self {
        Self { asym: a_f, ..self }
    }

    /// Friction amplitude when sliding (or about to slide) in direction
    /// `dir`: the most the slider can hold against a push that way.
    pub fn capacity(&self, u: f64, dir: f64) -> f64 {
        (1.0 + self.asym * dir) * self.amplitude(u)
    }

    /// Friction amplitude `F_F0 + k_F |u|` at `u`; the slider holds the mass
    /// at rest while the spring force does not exceed it (eq. 5.6).
    pub fn amplitude(&self, u: f64) -> f64 {
        self.k_f * u.abs() + self.f_f0
    }

    /// Sliding force when moving in direction `dir` at `u`.
    pub fn force(&self, u: f64, dir: f64) -> f64 {
        dir * self.capacity(u, dir)
    }

    /// Stiffness and constant force the slider adds to a phase moving in
    /// direction `dir` with displacement sign `sign_u`.
    pub fn phase_terms(&self, dir: f64, sign_u: f64) -> (f64, f64) {
        let m = 1.0 + self.asym * dir;
        (m * self.k_f * dir * sign_u, m * self.f_f0 * dir)
    }

    /// Where a falling amplitude `F_F0 + k_F |u|` (`k_F < 0`) reaches zero,
    /// `|u| = -F_F0 / k_F`; beyond it the law would push the mass along its
    /// motion. `None` when the amplitude never falls to zero.
    pub fn zero_amplitude_at(&self) -> Option<f64> {
        (self.k_f < 0.0 && self.f_f0 >= 0.0).then(|| -self.f_f0 / self.k_f)
    }

    /// Slope `k_F` of the amplitude per unit mass (1/s^2).
    pub fn slope(&self) -> f64 {
        self.k_f
    }

    /// `|a_F|`, the largest direction factor's excess over 1.
    pub fn asymmetry(&self) -> f64 {
        self.asym.abs()
    }

    /// Whether the amplitude depends on `u` (so phases split at `u = 0`).
    pub fn has_slope(&self) -> bool {
        self.k_f != 0.0
    }
}
