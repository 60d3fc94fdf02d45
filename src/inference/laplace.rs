//! Laplace's approximation of the log-evidence, with the posterior
//! covariance from a finite-difference Hessian of the log-posterior.
//!
//! # Formula
//! ```text
//! ln Z  = ln p(D|theta*) + ln p(theta*) + (d/2) ln 2 pi + (1/2) ln det Sigma
//! Sigma = (-H)^-1,  H_jk = d2 ln p(theta|D) / d theta_j d theta_k  at theta*
//! H_jj ~ (f(x + 2h_j) + f(x - 2h_j) - f(x + h_j) - f(x - h_j)) / (3 h_j^2)
//! H_jk ~ (f(++) - f(+-) - f(-+) + f(--)) / (4 h_j h_k)
//! ```
//! (Beck & Yuen 2004). The steps `h_j` are [`STEP`] standard deviations
//! along each axis ([`axis_scales`]). The likelihood is only piecewise
//! smooth (a reversal crossing a sample instant moves one sample across a
//! friction jump), and a MAP of such a density sits on a spike above the
//! bulk: curvature taken over a tiny step, or through the MAP's own value,
//! sees the spike. Over two sds and without the centre (exact for a
//! quadratic, as the central formula is) it measures the bulk, which is what
//! the evidence integrates. The scales are measured from the bulk's value
//! ([`bulk_value`]), and `ln p(D|theta*) p(theta*)` is the log-mean-exp of
//! the log-posterior around the MAP ([`neighbourhood`]): the share of the
//! spike that has volume. Where a step would leave the prior's support the
//! difference is taken one-sided, into it (through the centre).
//!
//! Why not a sampled covariance (the earlier choice): a short ensemble run
//! from the MAP has not spread to the posterior's width on a misfitted,
//! correlated posterior; on the tutorial record `trilinear+coulomb` gave
//! ln Z from 5770 to 5826 over four seeds. The Hessian is deterministic:
//! the same MAP gives the same evidence whatever the seed. It is checked
//! against transitional MCMC in
//! `tests/it/evidence.rs` (5939.35 against a three-run TMCMC mean of 5939.24)
//! and against an exact evidence in `tests/it/evidence_analytic.rs` (+0.0057
//! nat). On the tutorial record four
//! seeds of the MAP search give the true model evidences within 0.44 nat
//! and the misfitted `trilinear+coulomb` within 2.4
//! (`examples/evidence_seeds.rs`).
//!
//! ```
//! use hbis::inference::laplace::hessian;
//! // f = -(x^2 + x y + 2 y^2): H = [[-2, -1], [-1, -4]] exactly.
//! let f = |x: &[f64]| Ok::<f64, ()>(-(x[0] * x[0] + x[0] * x[1] + 2.0 * x[1] * x[1]));
//! let h = hessian(&f, &[0.3, -0.2], &[0.1, 0.1], &[-1.0, -1.0], &[1.0, 1.0]).unwrap();
//! assert!((h[(0, 0)] + 2.0).abs() < 1e-9 && (h[(0, 1)] + 1.0).abs() < 1e-9);
//! assert!((h[(1, 1)] + 4.0).abs() < 1e-9);
//! ```

use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::Serialize;

/// The finite-difference step, in conditional standard deviations.
pub const STEP: f64 = 2.0;

/// The fall of the log-density, below the bulk's value at the MAP
/// ([`bulk_value`]), at which [`axis_scales`] measures a scale: two
/// standard deviations of a Gaussian, where the Hessian's own steps
/// ([`STEP`]) begin. Measured from the MAP's own value, a spike above the
/// bulk made the scale 1e-9 of the true one and the evidence of a true
/// effect 60 nats too low (a `velocity-friction` refit with a BIC gain of
/// 82, `criticism::calibration`). The evidence still depends on this
/// choice where the posterior is not Gaussian: on the record of
/// `tests/it/evidence.rs` (TMCMC 5939.24, three runs), 5941.9, 5940.9, 5939.4 and 5936.0
/// for falls of 0.5, 1, 2 and 4.5 nats.
pub const SCALE_DROP: f64 = 2.0;

/// The fall [`axis_scales`] measures a MAP's scales at, where its
/// neighbourhood ([`neighbourhood`]) is `near`: [`SCALE_DROP`], raised by
/// the neighbourhood's spread where that exceeds [`STAIR`]. A likelihood
/// that is a staircase (a sample crossing a friction jump at each step)
/// has the MAP's cell and its neighbours' levels on both sides of the
/// median; a fall of [`SCALE_DROP`] alone is then met at the first cell
/// edge, and the scales came out as a cell's width, 1e-9 of the prior
/// range. On a calibration record with a hidden velocity friction (seed
/// 71403837210893, AR(1) noise) the steps were some 4.8 nats; the truth's
/// refit got sds of 1e-9 for four parameters, and the candidate lost 14.7
/// in log-evidence where BIC fell by 139.1. Raised by the spread, the
/// fall clears the steps: sds of 1.4e-5 to 2.3e-2, and the evidence rose
/// by 71.6 (docs/criticism.md, 2026-12-07).
///
/// # Formula
/// ```text
/// drop = SCALE_DROP + spread   where spread > STAIR
/// drop = SCALE_DROP            otherwise
/// ```
///
/// ```
/// use hbis::inference::laplace::{scale_drop, Neighbourhood, SCALE_DROP};
/// let smooth = Neighbourhood { median: 0.0, log_mean_exp: 0.0, spread: 1e-4 };
/// assert_eq!(scale_drop(&smooth), SCALE_DROP);
/// let stairs = Neighbourhood { median: 0.0, log_mean_exp: 1.6, spread: 4.8 };
/// assert!((scale_drop(&stairs) - 6.8).abs() < 1e-12);
/// ```
pub fn scale_drop(near: &Neighbourhood) -> f64 {
    if near.spread > STAIR {
        SCALE_DROP + near.spread
    } else {
        SCALE_DROP
    }
}

/// The spread (nats) of a MAP's neighbourhood above which it is taken
/// for a staircase ([`scale_drop`]): a smooth density moves by some 1e-4
/// nat over [`BULK_STEP`].
pub const STAIR: f64 = 1.0;

/// How the covariance of a Laplace approximation was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CovarianceMethod {
    /// `(-H)^-1` of the finite-difference Hessian.
    Hessian,
    /// The Hessian was not negative definite (the MAP is on a bound or a
    /// ridge): its non-negative curvatures were replaced by the conditional
    /// scales' before inverting.
    HessianRepaired,
}

/// Laplace's approximation at a MAP.
#[derive(Debug, Clone, Serialize)]
pub struct Laplace {
    /// The log-evidence.
    pub log_evidence: f64,
    /// The posterior covariance at the MAP.
    #[serde(skip)]
    pub covariance: DMatrix<f64>,
    /// How it was obtained.
    pub method: CovarianceMethod,
}

impl Laplace {
    /// Posterior standard deviation of coordinate `k`.
    pub fn sd(&self, k: usize) -> f64 {
        self.covariance[(k, k)].max(0.0).sqrt()
    }
}

/// Finite-difference Hessian of `f` at `x` with steps `h`, one-sided into
/// the box `[lo, hi]` where a central step would leave it.
///
/// The entries are computed side by side (rayon), each from its own
/// evaluations by the same formula: the result does not depend on the
/// thread count.
pub fn hessian<E: Send>(
    f: &(dyn Fn(&[f64]) -> Result<f64, E> + Sync),
    x: &[f64],
    h: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<DMatrix<f64>, E> {
    let d = x.len();
    let f0 = f(x)?;
    // Direction of the one-sided difference, or 0 for central.
    let side: Vec<f64> = (0..d)
        .map(|j| {
            if x[j] - h[j] >= lo[j] && x[j] + h[j] <= hi[j] {
                0.0
            } else if x[j] + 2.0 * h[j] <= hi[j] {
                1.0
            } else {
                -1.0
            }
        })
        .collect();
    let at = |moves: &[(usize, f64)]| -> Result<f64, E> {
        let mut y = x.to_vec();
        for &(j, s) in moves {
            y[j] += s * h[j];
        }
        f(&y)
    };
    let entry = |j: usize, k: usize| -> Result<f64, E> {
        if j == k {
            let room = x[j] - 2.0 * h[j] >= lo[j] && x[j] + 2.0 * h[j] <= hi[j];
            return Ok(if side[j] == 0.0 && room {
                // Without the centre: the MAP of a rugged log-density sits on a
                // local spike above the bulk's envelope.
                (at(&[(j, 2.0)])? + at(&[(j, -2.0)])? - at(&[(j, 1.0)])? - at(&[(j, -1.0)])?)
                    / (3.0 * h[j] * h[j])
            } else if side[j] == 0.0 {
                (at(&[(j, 1.0)])? - 2.0 * f0 + at(&[(j, -1.0)])?) / (h[j] * h[j])
            } else {
                let s = side[j];
                (at(&[(j, 2.0 * s)])? - 2.0 * at(&[(j, s)])? + f0) / (h[j] * h[j])
            });
        }
        Ok(if side[j] == 0.0 && side[k] == 0.0 {
            (at(&[(j, 1.0), (k, 1.0)])? - at(&[(j, 1.0), (k, -1.0)])? - at(&[(j, -1.0), (k, 1.0)])?
                + at(&[(j, -1.0), (k, -1.0)])?)
                / (4.0 * h[j] * h[k])
        } else {
            // Forward differences along the one-sided directions.
            let (sj, sk) = (
                if side[j] == 0.0 { 1.0 } else { side[j] },
                if side[k] == 0.0 { 1.0 } else { side[k] },
            );
            (at(&[(j, sj), (k, sk)])? - at(&[(j, sj)])? - at(&[(k, sk)])? + f0)
                / (sj * sk * h[j] * h[k])
        })
    };
    let pairs: Vec<(usize, usize)> = (0..d)
        .flat_map(|j| std::iter::once((j, j)).chain((0..j).map(move |k| (j, k))))
        .collect();
    let values: Vec<Result<f64, E>> = pairs.par_iter().map(|&(j, k)| entry(j, k)).collect();
    let mut m = DMatrix::zeros(d, d);
    for (&(j, k), v) in pairs.iter().zip(values) {
        let v = v?;
        m[(j, k)] = v;
        m[(k, j)] = v;
    }
    Ok(m)
}

/// The covariance `(-H)^-1`, repairing a Hessian that is not negative
/// definite: in the eigenbasis of `-H` with coordinates scaled by `h` (the
/// conditional sds), a curvature that is not positive is set to 1, one
/// conditional sd.
pub fn covariance_from(hess: &DMatrix<f64>, h: &[f64]) -> (DMatrix<f64>, CovarianceMethod) {
    let d = h.len();
    // Scaled so that a conditional sd is one unit: the eigenvalues are
    // comparable across parameters of very different units.
    let scaled = DMatrix::from_fn(d, d, |i, j| -hess[(i, j)] * h[i] * h[j]);
    let eig = nalgebra::SymmetricEigen::new(scaled);
    let floor = 1e-6;
    let method = if eig.eigenvalues.iter().all(|&l| l > floor) {
        CovarianceMethod::Hessian
    } else {
        CovarianceMethod::HessianRepaired
    };
    let inv_vals = eig
        .eigenvalues
        .map(|l| 1.0 / if l > floor { l } else { 1.0 });
    let inv = &eig.eigenvectors * DMatrix::from_diagonal(&inv_vals) * eig.eigenvectors.transpose();
    (
        DMatrix::from_fn(d, d, |i, j| inv[(i, j)] * h[i] * h[j]),
        method,
    )
}

/// `ln Z` from the log-posterior `lp` at the MAP and the covariance there.
pub fn log_evidence(lp: f64, cov: &DMatrix<f64>, h: &[f64]) -> f64 {
    let d = h.len();
    let half_log_det = match cov.clone().cholesky() {
        Some(c) => c.l().diagonal().iter().map(|v| v.ln()).sum::<f64>(),
        None => h.iter().map(|v| v.ln()).sum::<f64>(),
    };
    lp + 0.5 * d as f64 * (2.0 * std::f64::consts::PI).ln() + half_log_det
}

/// The relative step (of each parameter's prior range) at which
/// [`bulk_value`] looks beside a point: past the spikes of both engines
/// (the numerical engine locates events to some 1e-9 s, and its spikes
/// were measured up to 1e-7 of a value wide), and some 1e-2 of a posterior
/// sd, where the smooth part changes by some 1e-4 nat.
pub const BULK_STEP: f64 = 1e-6;

/// The value of a piecewise smooth `f` in the bulk at `x`: the median of
/// `f` at `x + s BULK_STEP range` for the sign patterns `s` of the rows of a
/// Sylvester-Hadamard matrix (all but the first, and their negatives: every
/// coordinate moves at once, in balanced directions, and the design is
/// fixed, not drawn), clamped to `[lo, hi]`; points where `f` is not finite
/// are left out.
///
/// An optimiser drives a MAP onto knife edges of the likelihood: where
/// reversals fall just before or just after sample instants, or where the
/// slider just holds or just lets go at a reversal (everything after
/// changes), choosing for each the side that fits best. There `f` stands
/// above most neighbours. Measured on calibration records
/// (`criticism::calibration`): four reversals within 2e-13 s of sample
/// instants, every move of one part in 1e12 lowering the log-likelihood by
/// 7 to 15 nats; and an `asymmetric-friction` refit of a record without it
/// 66 to 140 nats above most points 1e-6 of a range away. A move of
/// [`BULK_STEP`] leaves the smooth part unchanged and crosses such edges;
/// the median is what the bulk is worth there (a region covering less than
/// half the directions is a spike), and [`neighbourhood`]'s log-mean-exp
/// what the neighbourhood is worth to an integral.
///
/// ```
/// use hbis::inference::laplace::bulk_value;
/// // A spike of 5 at the origin on a smooth bowl.
/// let f = |x: &[f64]| Ok::<f64, ()>(if x == [0.0, 0.0] { 5.0 } else { -x[0] * x[0] - x[1] * x[1] });
/// let v = bulk_value(&f, &[0.0, 0.0], &[-1.0, -1.0], &[1.0, 1.0]).unwrap();
/// assert!(v.abs() < 1e-10);
/// // A wedge of +50 where x0 > 100 x1 (a sliver along one axis) is a spike too.
/// let g = |x: &[f64]| Ok::<f64, ()>(if x[0] > 100.0 * x[1].abs() { 50.0 } else { 0.0 });
/// assert_eq!(bulk_value(&g, &[0.0, 0.0], &[-1.0, -1.0], &[1.0, 1.0]).unwrap(), 0.0);
/// // On a smooth function it is the value itself.
/// let h = |x: &[f64]| Ok::<f64, ()>(-(x[0] - 0.3).powi(2));
/// assert!(bulk_value(&h, &[0.3, 0.0], &[-1.0, -1.0], &[1.0, 1.0]).unwrap().abs() < 1e-10);
/// ```
pub fn bulk_value<E: Send>(
    f: &(dyn Fn(&[f64]) -> Result<f64, E> + Sync),
    x: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<f64, E> {
    Ok(neighbourhood(f, x, lo, hi)?.median)
}

/// The points of [`bulk_value`]'s design around `x` at relative step
/// `step` of each range `hi - lo`: `x + s step (hi - lo)` for the sign
/// patterns `s` of the rows of a Sylvester-Hadamard matrix of order
/// `2^ceil(log2(d + 1))` (all but the first row, and their negatives),
/// clamped to `[lo, hi]` (a point on a bound moves only into the box
/// there). Fixed, not drawn: every coordinate moves at once, in balanced
/// directions.
///
/// ```
/// use hbis::inference::laplace::design;
/// // A step of a quarter of each range (2): 0.5.
/// let pts = design(&[0.0, 0.0], &[-1.0, -1.0], &[1.0, 1.0], 0.25);
/// // Order 4: rows 1-3 and their negatives.
/// assert_eq!(pts.len(), 6);
/// assert_eq!(pts[0], vec![-0.5, 0.5]);
/// assert_eq!(pts[1], vec![0.5, -0.5]);
/// // Each coordinate's steps balance over the design.
/// assert_eq!(pts.iter().map(|p| p[0]).sum::<f64>(), 0.0);
/// ```
pub fn design(x: &[f64], lo: &[f64], hi: &[f64], step: f64) -> Vec<Vec<f64>> {
    let d = x.len();
    let order = (d + 1).next_power_of_two();
    // Sylvester's Hadamard matrix: entry (i, j) is (-1)^popcount(i & j).
    let sign = |i: usize, j: usize| {
        if (i & j).count_ones() % 2 == 0 {
            1.0
        } else {
            -1.0
        }
    };
    (1..order)
        .flat_map(|i| [(i, 1.0), (i, -1.0)])
        .map(|(i, flip)| {
            (0..d)
                .map(|j| {
                    (x[j] + flip * sign(i, j + 1) * step * (hi[j] - lo[j])).clamp(lo[j], hi[j])
                })
                .collect()
        })
        .collect()
}

/// `f` on the points of [`bulk_value`]'s design around `x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbourhood {
    /// The median: the bulk's value.
    pub median: f64,
    /// `ln mean exp f`: what the neighbourhood is worth to an integral of
    /// `exp f`. The edges through a MAP are locally hyperplanes, so a
    /// favourable cell is a cone whose share of the directions is the same
    /// at every radius: this value counts that share of the bonus, which
    /// the median leaves out.
    pub log_mean_exp: f64,
    /// Highest minus lowest value on the design.
    pub spread: f64,
}

/// The median and the log-mean-exp of `f` on [`bulk_value`]'s design.
///
/// The points are evaluated side by side (rayon), the values kept in the
/// design's order: the result does not depend on the thread count.
pub fn neighbourhood<E: Send>(
    f: &(dyn Fn(&[f64]) -> Result<f64, E> + Sync),
    x: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<Neighbourhood, E> {
    let evaluated: Vec<Result<f64, E>> = design(x, lo, hi, BULK_STEP)
        .par_iter()
        .map(|y| f(y))
        .collect();
    let mut values = Vec::with_capacity(evaluated.len());
    for v in evaluated {
        let v = v?;
        if v.is_finite() {
            values.push(v);
        }
    }
    if values.is_empty() {
        let v = f(x)?;
        return Ok(Neighbourhood {
            median: v,
            log_mean_exp: v,
            spread: 0.0,
        });
    }
    values.sort_by(f64::total_cmp);
    let m = values.len();
    let median = if m % 2 == 1 {
        values[m / 2]
    } else {
        0.5 * (values[m / 2 - 1] + values[m / 2])
    };
    let top = values[m - 1];
    let mean = values.iter().map(|v| (v - top).exp()).sum::<f64>() / m as f64;
    Ok(Neighbourhood {
        median,
        log_mean_exp: top + mean.ln(),
        spread: top - values[0],
    })
}

/// Per-axis scales at `center`, where the bulk's value is `f0`
/// ([`bulk_value`]): on each side the distance at which the log-density
/// first falls by `drop` below `f0` (doubling, then bisection), the larger
/// side kept and divided by `sqrt(2 drop)` (one sd of a Gaussian). The
/// larger side, because a MAP of a piecewise smooth density often sits at
/// the edge of a small jump, which one side meets at once.
///
/// The `2 d` one-sided searches run side by side (rayon): the result does
/// not depend on the thread count.
pub fn axis_scales<E: Send>(
    f: &(dyn Fn(&[f64]) -> Result<f64, E> + Sync),
    center: &[f64],
    f0: f64,
    range: &[f64],
    drop: f64,
) -> Result<Vec<f64>, E> {
    // The distance at which the fall reaches `drop` along `sign` on axis `k`.
    let side = |k: usize, sign: f64| -> Result<f64, E> {
        let fall = |t: f64| -> Result<f64, E> {
            let mut x = center.to_vec();
            x[k] += sign * t;
            Ok(f0 - f(&x)?)
        };
        let (mut a, mut b) = (0.0, 1e-9 * range[k]);
        while fall(b)? < drop && b < range[k] {
            a = b;
            b *= 2.0;
        }
        if b >= range[k] {
            return Ok(range[k]);
        }
        for _ in 0..40 {
            let m = 0.5 * (a + b);
            if fall(m)? < drop {
                a = m;
            } else {
                b = m;
            }
        }
        Ok(0.5 * (a + b))
    };
    let searches: Vec<(usize, f64)> = (0..center.len())
        .flat_map(|k| [(k, 1.0), (k, -1.0)])
        .collect();
    let mut found = searches
        .par_iter()
        .map(|&(k, sign)| side(k, sign))
        .collect::<Vec<_>>()
        .into_iter();
    let mut out = Vec::with_capacity(center.len());
    for r in &range[..center.len()] {
        let mut best: f64 = 0.0;
        for _ in 0..2 {
            best = best.max(found.next().expect("two searches per axis")?);
        }
        out.push(if best > 0.0 {
            best / (2.0 * drop).sqrt()
        } else {
            1e-6 * r
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A Gaussian (sd 0.01 on each axis) under a staircase of +-2.4 nats
    /// in cells 1.3e-8 wide: the scales are the Gaussian's, not a cell's.
    #[test]
    fn scales_clear_a_staircase() {
        let sd = 0.01;
        let f = |x: &[f64]| -> Result<f64, ()> {
            let cell = (x[0] * 7.73e7).floor() as i64 + (x[1] * 7.73e7).floor() as i64;
            let step = if cell.rem_euclid(2) == 0 { 2.4 } else { -2.4 };
            Ok(-(x[0] * x[0] + x[1] * x[1]) / (2.0 * sd * sd) + step)
        };
        let (lo, hi) = ([-1.0, -1.0], [1.0, 1.0]);
        let x = [0.3e-8, 0.1e-8];
        let near = neighbourhood(&f, &x, &lo, &hi).unwrap();
        assert!(near.spread > 4.0, "{}", near.spread);
        let f0 = near.median.min(f(&x).unwrap());
        let scales = axis_scales(&f, &x, f0, &[2.0, 2.0], scale_drop(&near)).unwrap();
        for s in scales {
            assert!(s > 0.5 * sd && s < 1.5 * sd, "scale {s:e}, sd {sd}");
        }
    }

    /// A correlated Gaussian's evidence is exact: `ln Z` of
    /// `exp(-x' A x / 2)` is `(d/2) ln 2 pi - (1/2) ln det A`.
    #[test]
    fn gaussian_evidence_is_exact() {
        let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0]);
        let f = |x: &[f64]| -> Result<f64, ()> {
            let v = nalgebra::DVector::from_column_slice(x);
            Ok(-0.5 * (v.transpose() * &a * &v)[(0, 0)])
        };
        let h = [0.3, 0.4, 0.5];
        let hess = hessian(&f, &[0.0; 3], &h, &[-9.0; 3], &[9.0; 3]).unwrap();
        let (cov, method) = covariance_from(&hess, &h);
        assert_eq!(method, CovarianceMethod::Hessian);
        let exact = 1.5 * (2.0 * std::f64::consts::PI).ln() - 0.5 * a.determinant().ln();
        assert_relative_eq!(log_evidence(0.0, &cov, &h), exact, epsilon = 1e-9);
    }

    /// At a bound the differences go one-sided and stay exact for a
    /// quadratic.
    #[test]
    fn one_sided_at_a_bound() {
        let f = |x: &[f64]| -> Result<f64, ()> {
            Ok(-(x[0] * x[0] + 3.0 * x[0] * x[1] + 5.0 * x[1] * x[1]))
        };
        let hess = hessian(&f, &[0.0, 1.0], &[0.1, 0.1], &[0.0, 0.0], &[1.0, 1.0]).unwrap();
        assert_relative_eq!(hess[(0, 0)], -2.0, epsilon = 1e-9);
        assert_relative_eq!(hess[(0, 1)], -3.0, epsilon = 1e-9);
        assert_relative_eq!(hess[(1, 1)], -10.0, epsilon = 1e-9);
    }

    /// A flat direction is repaired to one conditional sd and said so.
    #[test]
    fn flat_direction_is_repaired() {
        let hess = DMatrix::from_row_slice(2, 2, &[-4.0, 0.0, 0.0, 0.0]);
        let (cov, method) = covariance_from(&hess, &[0.5, 2.0]);
        assert_eq!(method, CovarianceMethod::HessianRepaired);
        assert_relative_eq!(cov[(0, 0)], 0.25, epsilon = 1e-12);
        assert_relative_eq!(cov[(1, 1)], 4.0, epsilon = 1e-12);
    }
}
