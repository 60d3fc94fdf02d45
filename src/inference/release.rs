//! The release instant between two samples.
//!
//! A record that starts before the release shows noise, then the jump of
//! the release; the first sample after the jump comes some `lag` in
//! `[0, dt)` after the release. The record alone cannot tell how much: at
//! the release the velocity is zero, so the acceleration starts flat
//! (`a(t) = a(0) (1 - (w t)^2 / 2 + ...)`), and the lag shows only in the
//! phase of the whole oscillation, where it trades off against the
//! frequencies and `u0`, which absorb most of it: a clean Test 3 record at
//! 200 Hz first sampled 3.1 ms after the release fits with `e2 = 1.2e-5` at
//! `lag = 0` (half a percent of the floor of 1.5 % noise), but the
//! parameters pay for it: over 30 random parameter sets with 1.5 % noise
//! and lags up to a step, the RMS error of `u0` was 1.1 % at `lag = 0` and
//! 0.4 % with the lag placed as below (`docs/inference.md`).
//!
//! So the lag is estimated with the model, as a nuisance parameter: the
//! profile over a grid of lags (each a Nelder-Mead polish of the model
//! parameters, from the `lag = 0` MAP for the first and from the optimum at
//! the lag before for the others), then a joint polish of both from the
//! best grid point. Later stages (MAP, posterior, criticism) hold it fixed
//! at this estimate: a plug-in, which ignores its uncertainty of a fraction
//! of a millisecond.
//!
//! ```
//! use hbis::data::synthesize;
//! use hbis::inference::release::fit_lag;
//! use hbis::inference::{Noise, Posterior};
//! use hbis::model::{ForwardModel, Model, ModelSpec, Params};
//! use rand::{rngs::StdRng, SeedableRng};
//!
//! // Test 5, sampled 2 ms after the release.
//! let model = Model::from(ModelSpec::FULL);
//! let truth = Params::table_8_1(5).unwrap().to_theta(&ModelSpec::FULL);
//! let mut rng = StdRng::seed_from_u64(1);
//! let mut data = synthesize(&model, &truth, 0.005, 2001, 0.0, &mut rng)
//!     .unwrap()
//!     .record
//!     .aligned(None)
//!     .unwrap();
//! let mut a = vec![0.0; data.a.len()];
//! model.accel_grid_into(&truth, 0.002, 0.005, &mut a).unwrap();
//! data.a = a;
//! let post = Posterior::with_default_priors(model, data, Noise::White).unwrap();
//! let fit = fit_lag(&post, &truth).unwrap();
//! assert!((fit.lag - 0.002).abs() < 1e-4, "lag {}", fit.lag);
//! ```

use nalgebra::DVector;
use thiserror::Error;

use crate::inference::polish::{Polish, PolishError};
use crate::inference::posterior::{Posterior, PosteriorError};
use crate::inference::priors::{Prior, Priors};
use crate::inference::Noise;
use crate::model::{ForwardModel, Layout, ParamSpec, SimError};

/// Why the lag could not be estimated.
#[derive(Debug, Error)]
pub enum LagError {
    /// The joint posterior could not be built or evaluated.
    #[error(transparent)]
    Posterior(#[from] PosteriorError),
    /// A polish failed.
    #[error(transparent)]
    Polish(#[from] PolishError),
}

/// Lags of the profile grid, as fractions of `dt`.
const GRID: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// The lag and the model parameters that go with it.
#[derive(Debug, Clone)]
pub struct LagFit {
    /// Time from the release to the first sample (s), in `[0, dt]`.
    pub lag: f64,
    /// Model parameters at the joint optimum.
    pub theta: Vec<f64>,
    /// Minus the log-posterior there.
    pub cost: f64,
    /// Posterior evaluations used.
    pub evaluations: u64,
}

/// `M` with its clock started `lag` (a block after the model's parameters)
/// before the grid.
#[derive(Debug, Clone)]
struct Delayed<M> {
    model: M,
    layout: Layout,
}

impl<M: ForwardModel> Delayed<M> {
    fn new(model: M, dt: f64) -> Self {
        let mut layout = Layout::default();
        layout.push("model".into(), model.params());
        layout.push(
            "lag".into(),
            vec![ParamSpec::new("lag", "s", (0.0, dt), 0.0)
                .meaning("time from the release to the first sample")],
        );
        Self { model, layout }
    }
}

impl<M: ForwardModel> ForwardModel for Delayed<M> {
    fn name(&self) -> String {
        self.model.name()
    }

    fn params(&self) -> Vec<ParamSpec> {
        self.layout.params().cloned().collect()
    }

    fn accel_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let lag = self.layout.values(theta, 1)[0];
        self.model
            .accel_grid_into(self.layout.values(theta, 0), start + lag, dt, out)
    }

    fn in_support(&self, theta: &[f64]) -> bool {
        self.model.in_support(self.layout.values(theta, 0))
    }
}

/// Estimates the lag of `posterior`'s record (white noise) from model
/// parameters `theta` near the MAP at the record's current lag; the result
/// is never worse than that start.
pub fn fit_lag<M: ForwardModel + Clone>(
    posterior: &Posterior<M>,
    theta: &[f64],
) -> Result<LagFit, LagError> {
    let model = posterior.model().clone();
    let theta = posterior.model_part(theta);
    let n = theta.len();
    let current = posterior.data().lag;
    let data = posterior.data().clone().with_lag(0.0);
    let dt = data.dt;
    let model_priors = posterior.priors().head(n);
    let mut names = model_priors.names().to_vec();
    let mut priors = model_priors.priors().to_vec();
    names.push("lag".into());
    priors.push(Prior::Uniform {
        lower: 0.0,
        upper: dt,
    });
    let priors = Priors::from_parts(names, priors).expect("one prior per name");
    let joint = Posterior::new(Delayed::new(model, dt), data, priors, Noise::White)?;
    let cost = |x: &[f64]| joint.log_posterior(x).map(|lp| -lp);
    // Simplex steps: 1 % of each parameter (of its prior range at zero).
    let (lo, hi) = joint.priors().box_bounds();
    let mut scale: Vec<f64> = (0..n)
        .map(|i| {
            let s = 0.01 * theta[i].abs();
            if s > 0.0 {
                s
            } else {
                1e-3 * (hi[i] - lo[i])
            }
        })
        .collect();
    let polish = Polish::default()
        .with_max_iters(1500)
        .and_then(|p| p.with_relative_step(1.0))?;
    let mut evaluations = 1;
    let mut start = theta.to_vec();
    start.push(current);
    let mut best = LagFit {
        lag: current,
        theta: theta.to_vec(),
        cost: cost(&start)?,
        evaluations: 0,
    };
    // Continuation: each lag starts from the optimum at the one before, as
    // the parameters that absorb a shift move smoothly with it.
    let mut from = theta.to_vec();
    for frac in GRID {
        let lag = frac * dt;
        // The profile: the model parameters re-fitted at this fixed lag.
        let fixed = |x: &DVector<f64>| {
            let mut full: Vec<f64> = x.iter().copied().collect();
            full.push(lag);
            cost(&full)
        };
        let out = polish.run(Profile(&fixed), &from, &scale)?;
        evaluations += out.evaluations;
        from.clone_from(&out.x);
        if out.cost_after < best.cost {
            best = LagFit {
                lag,
                theta: out.x,
                cost: out.cost_after,
                evaluations: 0,
            };
        }
    }
    let mut start = best.theta.clone();
    start.push(best.lag);
    scale.push(0.1 * dt);
    let both = |x: &DVector<f64>| cost(x.as_slice());
    let out = polish.run(Profile(&both), &start, &scale)?;
    evaluations += out.evaluations;
    let mut theta = out.x;
    let lag = theta.pop().expect("the lag is last");
    Ok(LagFit {
        lag,
        theta,
        cost: out.cost_after,
        evaluations,
    })
}

/// A cost function from a closure, for argmin.
struct Profile<F>(F);

impl<F> argmin::core::CostFunction for Profile<F>
where
    F: Fn(&DVector<f64>) -> Result<f64, PosteriorError>,
{
    type Param = DVector<f64>;
    type Output = f64;

    fn cost(&self, x: &Self::Param) -> Result<f64, argmin::core::Error> {
        (self.0)(x).map_err(|e| argmin::core::Error::msg(e.to_string()))
    }
}
