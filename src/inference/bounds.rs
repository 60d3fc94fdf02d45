//! Box constraints for an unconstrained optimiser: pycma's default
//! `BoundTransform`.
//!
//! CMA-ES works in an unbounded "genotype" space; the objective is evaluated
//! at the image of each genotype under a map onto the box that is the identity
//! in the interior, quadratic near each bound and periodic outside, so a
//! step across a bound folds back into the box instead of piling mass on it.
//! This is the linear-quadratic transformation of pycma's
//! `BoxConstraintsLinQuadTransformation` (Hansen, `cma.transformations`).
//!
//! # Formula
//! For bounds `[l, u]` with widths `a_l = min((u-l)/2, (1+|l|)/20)`,
//! `a_u = min((u-l)/2, (1+|u|)/20)`, a coordinate is first shifted by
//! multiples of the period `2 (u - l + a_l + a_u)` into
//! `[l - a_l, u + a_u]` (mirroring once if needed), then
//! ```text
//! x < l + a_l        ->  l + (x - (l - a_l))^2 / (4 a_l)
//! l + a_l <= x <= u - a_u  ->  x
//! x > u - a_u        ->  u - (x - (u + a_u))^2 / (4 a_u)
//! ```
//!
//! ```
//! use hbis::inference::BoxTransform;
//!
//! let b = BoxTransform::new(vec![0.0], vec![1.0]).unwrap();
//! let mut x = [2.37];
//! b.apply(&mut x);
//! assert!((0.0..=1.0).contains(&x[0]));
//! let mut inside = [0.5];
//! b.apply(&mut inside);
//! assert_eq!(inside[0], 0.5);
//! ```

use thiserror::Error;

/// Why a box could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BoundsError {
    /// Lower and upper bounds have different lengths.
    #[error("{lower} lower bounds but {upper} upper bounds")]
    Length { lower: usize, upper: usize },
    /// A bound is not finite or the interval is empty.
    #[error("bound {index}: need finite lower < upper, got [{lower}, {upper}]")]
    Interval {
        index: usize,
        lower: f64,
        upper: f64,
    },
}

/// The linear-quadratic periodic map onto a box (see the module docs).
#[derive(Debug, Clone)]
pub struct BoxTransform {
    lower: Vec<f64>,
    upper: Vec<f64>,
    al: Vec<f64>,
    au: Vec<f64>,
}

impl BoxTransform {
    /// A transform onto `[lower_i, upper_i]` for each coordinate.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self, BoundsError> {
        if lower.len() != upper.len() {
            return Err(BoundsError::Length {
                lower: lower.len(),
                upper: upper.len(),
            });
        }
        for (index, (&l, &u)) in lower.iter().zip(&upper).enumerate() {
            if !(l.is_finite() && u.is_finite() && l < u) {
                return Err(BoundsError::Interval {
                    index,
                    lower: l,
                    upper: u,
                });
            }
        }
        let al = lower
            .iter()
            .zip(&upper)
            .map(|(l, u)| ((u - l) / 2.0).min((1.0 + l.abs()) / 20.0))
            .collect();
        let au = lower
            .iter()
            .zip(&upper)
            .map(|(l, u)| ((u - l) / 2.0).min((1.0 + u.abs()) / 20.0))
            .collect();
        Ok(Self {
            lower,
            upper,
            al,
            au,
        })
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// Lower bounds.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    /// Upper bounds.
    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    /// Maps `x` onto the box in place.
    pub fn apply(&self, x: &mut [f64]) {
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = self.map_one(i, *xi);
        }
    }

    fn map_one(&self, i: usize, x: f64) -> f64 {
        let (l, u, al, au) = (self.lower[i], self.upper[i], self.al[i], self.au[i]);
        let mut x = x;
        if x < l - al || x > u + au {
            let period = 2.0 * (u - l + al + au);
            let start = l - 2.0 * al - (u - l) / 2.0;
            x -= period * ((x - start) / period).floor();
            if x > u + au {
                x -= 2.0 * (x - u - au);
            }
            if x < l - al {
                x += 2.0 * (l - al - x);
            }
        }
        if x < l + al {
            l + (x - (l - al)).powi(2) / (4.0 * al)
        } else if x <= u - au {
            x
        } else {
            u - (x - (u + au)).powi(2) / (4.0 * au)
        }
        .clamp(l, u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_inside_and_continuous_at_the_joins() {
        let b = BoxTransform::new(vec![-1.0], vec![3.0]).unwrap();
        let (al, au) = (b.al[0], b.au[0]);
        for &x in &[-1.0 + al + 1e-9, 0.0, 2.7, 3.0 - au] {
            assert_eq!(b.map_one(0, x), x);
        }
        let eps = 1e-9;
        for &join in &[-1.0 + al, 3.0 - au, -1.0 - al, 3.0 + au] {
            let d = (b.map_one(0, join + eps) - b.map_one(0, join - eps)).abs();
            assert!(d < 1e-8, "jump {d} at {join}");
        }
    }

    #[test]
    fn every_point_lands_in_the_box_and_the_map_is_periodic() {
        let b = BoxTransform::new(vec![0.2, -5.0], vec![0.3, 50.0]).unwrap();
        for k in -2000..2000 {
            let x = [k as f64 * 0.0137, k as f64 * 0.731];
            let mut y = x;
            b.apply(&mut y);
            assert!((0.2..=0.3).contains(&y[0]) && (-5.0..=50.0).contains(&y[1]));
            let period = 2.0 * (0.1 + b.al[0] + b.au[0]);
            let shifted = b.map_one(0, x[0] + 3.0 * period);
            assert!((shifted - y[0]).abs() < 1e-9);
        }
    }

    #[test]
    fn rejects_empty_or_infinite_intervals() {
        assert!(BoxTransform::new(vec![1.0], vec![1.0]).is_err());
        assert!(BoxTransform::new(vec![0.0], vec![f64::INFINITY]).is_err());
        assert!(BoxTransform::new(vec![0.0, 1.0], vec![1.0]).is_err());
    }
}
