//! An independent reference: the same equation of motion integrated by the
//! adaptive Dormand-Prince 5(4) solver with event location, in a different
//! formulation from the closed form. The spring force is a state variable
//! with rate `F_S' = k_tan u'` (`k0` elastic, the envelope slope plastic),
//! the envelope is written out here from the model notes, and every switch
//! (reversal and stop rule, reaching the envelope, kinks at `0`, `+-u1`,
//! `+-u3`) is an event of the integrator.

use hbis::model::{FrictionKind, ModelSpec, Params, SpringKind};
use hbis::numeric::ode::{Dopri5, Stop};

/// One sample of the reference solution.
#[derive(Debug, Clone, Copy)]
pub struct RefSample {
    pub u: f64,
    pub v: f64,
    pub a: f64,
}

/// The reference solution on a grid, and the times of the acceleration
/// jumps (reversals, release, rest).
pub struct RefSolution {
    pub samples: Vec<RefSample>,
    pub jumps: Vec<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Elastic,
    Plastic,
    Rest,
}

struct Model {
    k0: f64,
    k1: f64,
    k2: f64,
    uy: f64,
    u3: f64,
    yields: bool,
    ff0: f64,
    kf: f64,
    asym: f64,
    c: f64,
}

impl Model {
    fn new(spec: &ModelSpec, p: &Params, asym: f64) -> Self {
        let w2 = |f: f64| (2.0 * std::f64::consts::PI * f).powi(2);
        let k0 = w2(p.f0);
        let (k1, k2, u3) = match spec.spring {
            SpringKind::Linear => (k0, k0, f64::INFINITY),
            SpringKind::Bilinear => (w2(p.f1), w2(p.f1), f64::INFINITY),
            SpringKind::Trilinear => (w2(p.f1), w2(p.f2), p.u3),
        };
        let (ff0, kf) = match spec.friction {
            FrictionKind::None => (0.0, 0.0),
            FrictionKind::Coulomb => (p.uf0 * k0, 0.0),
            FrictionKind::Lcfm => (p.uf0 * k0, p.rf0 * k0),
        };
        Self {
            k0,
            k1,
            k2,
            uy: p.uy,
            u3,
            yields: spec.spring != SpringKind::Linear,
            ff0,
            kf,
            asym,
            c: 2.0 * p.zeta0 * k0.sqrt(),
        }
    }

    /// Upper envelope force and slope.
    fn upper(&self, u: f64) -> (f64, f64) {
        let f2 = (self.k0 - self.k1) * self.uy;
        if self.u3.is_infinite() {
            return (f2 + self.k1 * u, self.k1);
        }
        let u1 = -self.u3 + 2.0 * self.uy;
        if u <= u1 {
            (f2 + self.k1 * u1 + self.k2 * (u - u1), self.k2)
        } else if u <= self.u3 {
            (f2 + self.k1 * u, self.k1)
        } else {
            (f2 + self.k1 * self.u3 + self.k2 * (u - self.u3), self.k2)
        }
    }

    /// Envelope of side `dir` (upper for +1, lower `-U(-u)` for -1).
    fn envelope(&self, dir: f64, u: f64) -> (f64, f64) {
        let (f, k) = self.upper(dir * u);
        (dir * f, k)
    }

    fn accel(&self, mode: Mode, dir: f64, y: &[f64; 3]) -> f64 {
        if mode == Mode::Rest {
            return 0.0;
        }
        -(self.c * y[1] + y[2] + self.capacity(dir, y[0]) * dir)
    }

    /// Friction amplitude sliding in direction `dir` at `u`.
    fn capacity(&self, dir: f64, u: f64) -> f64 {
        (1.0 + self.asym * dir) * (self.ff0 + self.kf * u.abs())
    }

    fn kinks(&self) -> Vec<f64> {
        let mut k = vec![0.0];
        if self.u3.is_finite() {
            let u1 = -self.u3 + 2.0 * self.uy;
            k.extend([u1, self.u3, -u1, -self.u3]);
        }
        k
    }
}

/// Integrate a release test and sample it at `t_i = i dt`, `i < n`.
pub fn solve(spec: &ModelSpec, p: &Params, dt: f64, n: usize) -> Result<RefSolution, String> {
    solve_asymmetric(spec, p, 0.0, dt, n)
}

/// [`solve`] with friction `(1 + asym dir)` times its amplitude when
/// sliding in direction `dir`.
pub fn solve_asymmetric(
    spec: &ModelSpec,
    p: &Params,
    asym: f64,
    dt: f64,
    n: usize,
) -> Result<RefSolution, String> {
    let m = Model::new(spec, p, asym);
    let ode = Dopri5::new()
        .with_rtol(1e-13)
        .and_then(|o| o.with_atol(1e-16))
        .and_then(|o| o.with_h_max(0.01))
        .map_err(|e| e.to_string())?;
    let kinks = m.kinks();
    let n_events = 2 + kinks.len();

    // Release: on the virgin curve at u0, at rest.
    let u0 = p.u0;
    let fs0 = if !m.yields || u0.abs() <= m.uy {
        m.k0 * u0
    } else {
        m.envelope(u0.signum(), u0).0
    };
    let mut y = [u0, 0.0, fs0];
    let mut mode = Mode::Elastic;
    let mut dir = 0.0;
    let mut t = 0.0;
    let mut jumps = vec![0.0];
    // Stop rule (eq. 5.6) at a state at rest.
    let decide = |y: &[f64; 3]| -> Option<f64> {
        (y[2].abs() > m.capacity(-y[2].signum(), y[0])).then(|| -y[2].signum())
    };
    match decide(&y) {
        Some(d) => dir = d,
        None => mode = Mode::Rest,
    }

    let mut samples = Vec::with_capacity(n);
    samples.push(RefSample {
        u: y[0],
        v: y[1],
        a: m.accel(mode, dir, &y),
    });
    for i in 1..n {
        let t_next = i as f64 * dt;
        while t < t_next && mode != Mode::Rest {
            let (md, d) = (mode, dir);
            let rhs = |_t: f64, y: &[f64; 3]| {
                let ktan = if md == Mode::Elastic {
                    m.k0
                } else {
                    m.envelope(d, y[0]).1
                };
                [y[1], m.accel(md, d, y), ktan * y[1]]
            };
            let events = |_t: f64, y: &[f64; 3], g: &mut [f64]| {
                g[0] = y[1];
                g[1] = if md == Mode::Elastic && m.yields {
                    d * (y[2] - m.envelope(d, y[0]).0)
                } else {
                    -1.0
                };
                for (k, b) in kinks.iter().enumerate() {
                    g[2 + k] = y[0] - b;
                }
            };
            let out = ode
                .solve(rhs, t, y, t_next, n_events, events, |_| {})
                .map_err(|e| e.to_string())?;
            t = out.t;
            y = out.y;
            match out.stop {
                Stop::End => t = t_next,
                Stop::Event { index: 0 } => {
                    y[1] = 0.0;
                    mode = Mode::Elastic;
                    jumps.push(t);
                    match decide(&y) {
                        Some(nd) => dir = nd,
                        None => mode = Mode::Rest,
                    }
                }
                Stop::Event { index: 1 } => {
                    mode = Mode::Plastic;
                    y[2] = m.envelope(dir, y[0]).0;
                }
                // A kink: the integrator restarts on the other side.
                Stop::Event { .. } => {}
            }
            if !y.iter().all(|x| x.is_finite()) || y[0].abs() > 1e3 {
                return Err(format!("reference diverged at t = {t}"));
            }
        }
        if mode == Mode::Rest {
            y[1] = 0.0;
        }
        samples.push(RefSample {
            u: y[0],
            v: y[1],
            a: m.accel(mode, dir, &y),
        });
    }
    Ok(RefSolution { samples, jumps })
}
