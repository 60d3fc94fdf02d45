//! Local polish of the MAP with `argmin`'s Nelder-Mead simplex.
//!
//! CMA-ES locates the basin; a simplex started on a small box around its
//! best point then refines the optimum to a tolerance CMA-ES would need
//! many more generations to reach. Nelder-Mead (Nelder & Mead 1965; argmin's
//! `NelderMead`) needs no derivatives, which matters here: the acceleration
//! depends on the parameters through event times, so the objective has
//! kinks where the phase sequence changes, and finite-difference gradients
//! would straddle them.
//!
//! The posterior implements argmin's `CostFunction` directly (cost = minus
//! the log-posterior), so any argmin solver can be run on it.

use argmin::core::{CostFunction, Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::neldermead::NelderMead;
use nalgebra::DVector;
use thiserror::Error;

/// Why the polish failed.
#[derive(Debug, Error)]
pub enum PolishError {
    /// A setting is out of range.
    #[error("polish setting `{name}`: {reason}")]
    Setting {
        name: &'static str,
        reason: &'static str,
    },
    /// The start is outside the support.
    #[error("polish must start where the cost is finite, got {cost} at {x:?}")]
    Start { x: Vec<f64>, cost: f64 },
    /// argmin reported an error (e.g. a NaN cost).
    #[error("Nelder-Mead failed: {0}")]
    Solver(String),
}

/// What the polish did.
#[derive(Debug, Clone)]
pub struct PolishOutcome {
    /// The refined point.
    pub x: Vec<f64>,
    /// Cost at the start.
    pub cost_before: f64,
    /// Cost at the end.
    pub cost_after: f64,
    /// Simplex iterations.
    pub iterations: u64,
    /// Cost evaluations by the simplex (besides the few to set it up).
    pub evaluations: u64,
    /// Why it stopped.
    pub termination: String,
}

/// Settings of the Nelder-Mead polish.
#[derive(Debug, Clone)]
pub struct Polish {
    max_iters: u64,
    sd_tolerance: f64,
    relative_step: f64,
}

impl Default for Polish {
    fn default() -> Self {
        Self {
            max_iters: 3000,
            sd_tolerance: 1e-10,
            relative_step: 1e-3,
        }
    }
}

impl Polish {
    /// At most `max_iters` simplex iterations (default 3,000).
    pub fn with_max_iters(mut self, max_iters: u64) -> Result<Self, PolishError> {
        if max_iters == 0 {
            return Err(PolishError::Setting {
                name: "max_iters",
                reason: "must be > 0",
            });
        }
        self.max_iters = max_iters;
        Ok(self)
    }

    /// Stop when the costs at the vertices have this standard deviation
    /// (default 1e-10).
    pub fn with_sd_tolerance(mut self, tol: f64) -> Result<Self, PolishError> {
        if !(tol > 0.0 && tol.is_finite()) {
            return Err(PolishError::Setting {
                name: "sd_tolerance",
                reason: "must be finite and > 0",
            });
        }
        self.sd_tolerance = tol;
        Ok(self)
    }

    /// Size of the initial simplex as a fraction of each `scale` entry
    /// (default 1e-3).
    pub fn with_relative_step(mut self, step: f64) -> Result<Self, PolishError> {
        if !(step > 0.0 && step.is_finite()) {
            return Err(PolishError::Setting {
                name: "relative_step",
                reason: "must be finite and > 0",
            });
        }
        self.relative_step = step;
        Ok(self)
    }

    /// Minimises `problem` from `x0`; the initial simplex spans
    /// `relative_step * scale[i]` along each axis, turned back if a vertex
    /// would leave the support.
    pub fn run<O>(
        &self,
        problem: O,
        x0: &[f64],
        scale: &[f64],
    ) -> Result<PolishOutcome, PolishError>
    where
        O: CostFunction<Param = DVector<f64>, Output = f64>,
    {
        let cost = |x: &DVector<f64>| {
            problem
                .cost(x)
                .map_err(|e| PolishError::Solver(e.to_string()))
        };
        let start = DVector::from_column_slice(x0);
        let cost_before = cost(&start)?;
        if !cost_before.is_finite() {
            return Err(PolishError::Start {
                x: x0.to_vec(),
                cost: cost_before,
            });
        }
        let mut simplex = vec![start.clone()];
        for i in 0..x0.len() {
            let mut v = start.clone();
            v[i] += self.relative_step * scale[i];
            if !cost(&v)?.is_finite() {
                v[i] = x0[i] - self.relative_step * scale[i];
            }
            if !cost(&v)?.is_finite() {
                // Both directions leave the support: stay on a tiny step inside.
                v[i] = x0[i] + 1e-9 * scale[i];
            }
            simplex.push(v);
        }
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(self.sd_tolerance)
            .map_err(|e| PolishError::Solver(e.to_string()))?;
        let res = Executor::new(problem, solver)
            .configure(|s| s.max_iters(self.max_iters).counting(true))
            .run()
            .map_err(|e| PolishError::Solver(e.to_string()))?;
        let state = res.state();
        let best = state.get_best_param().cloned().unwrap_or(start);
        let cost_after = state.get_best_cost();
        let termination = match state.get_termination_status() {
            TerminationStatus::Terminated(TerminationReason::SolverConverged) => {
                "converged".to_string()
            }
            TerminationStatus::Terminated(TerminationReason::MaxItersReached) => {
                "max_iters".to_string()
            }
            other => other.to_string(),
        };
        let (x, cost_after) = if cost_after <= cost_before {
            (best.iter().copied().collect(), cost_after)
        } else {
            (x0.to_vec(), cost_before)
        };
        Ok(PolishOutcome {
            x,
            cost_before,
            cost_after,
            iterations: state.get_iter(),
            evaluations: state
                .get_func_counts()
                .get("cost_count")
                .copied()
                .unwrap_or(0),
            termination,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Rosenbrock;

    impl CostFunction for Rosenbrock {
        type Param = DVector<f64>;
        type Output = f64;
        fn cost(&self, x: &DVector<f64>) -> Result<f64, argmin::core::Error> {
            Ok(x.as_slice()
                .windows(2)
                .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
                .sum())
        }
    }

    #[test]
    fn refines_rosenbrock_from_near_its_minimum() {
        let out = Polish::default()
            .with_max_iters(20_000)
            .unwrap()
            .with_sd_tolerance(1e-14)
            .unwrap()
            .run(Rosenbrock, &[0.9, 0.8, 0.7, 0.5], &[1.0; 4])
            .unwrap();
        assert!(out.cost_after < 1e-8, "{out:?}");
        assert!(out.x.iter().all(|v| (v - 1.0).abs() < 1e-3));
    }

    struct Quadratic;

    impl CostFunction for Quadratic {
        type Param = DVector<f64>;
        type Output = f64;
        fn cost(&self, x: &DVector<f64>) -> Result<f64, argmin::core::Error> {
            // Infeasible below zero in the first coordinate.
            if x[0] < 0.0 {
                return Ok(f64::INFINITY);
            }
            Ok((x[0] - 0.3).powi(2) + 10.0 * (x[1] + 0.2).powi(2))
        }
    }

    #[test]
    fn starts_on_the_feasible_side_of_a_boundary() {
        let out = Polish::default()
            .run(Quadratic, &[0.0, 0.0], &[1.0, 1.0])
            .unwrap();
        assert!(
            (out.x[0] - 0.3).abs() < 1e-4 && (out.x[1] + 0.2).abs() < 1e-4,
            "{out:?}"
        );
        assert!(Polish::default()
            .run(Quadratic, &[-1.0, 0.0], &[1.0, 1.0])
            .is_err());
    }
}
