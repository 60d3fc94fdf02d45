//! The log-posterior of model parameters given an aligned record.
//!
//! `ln p(theta | record) = ln prior(theta) + ln L(record | theta)` with the
//! marginal likelihood of [`Noise`]. The model enters only through
//! [`ForwardModel`], so any model (a new physical effect, a user's own
//! component) is identified the same way.
//!
//! `-inf` means zero prior mass: outside a prior's support, or parameters
//! the model refuses (structural constraints such as `k0 > k1`). A NaN is a
//! bug and is returned as an error, never as a density.
//!
//! Evaluation allocates nothing after the first call on each thread: the
//! model writes into a thread-local buffer.
//!
//! ```
//! use hbis::data::synthesize;
//! use hbis::inference::{Noise, Posterior};
//! use hbis::model::{Params, Registry};
//! use rand::{rngs::StdRng, SeedableRng};
//!
//! let model = Registry::builtin().parse("trilinear+lcfm+viscous")?;
//! let truth = model.theta_from_params(&Params::table_8_1(5).unwrap(), &[])?;
//! let mut rng = StdRng::seed_from_u64(1);
//! let syn = synthesize(&model, &truth, 0.005, 2001, 0.015, &mut rng)?;
//! let data = syn.record.aligned(None)?;
//! let post = Posterior::with_default_priors(model, data, Noise::White)?;
//! let ev = post.evaluate(&truth)?;
//! assert!((ev.e2 / syn.noise_floor - 1.0).abs() < 0.1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::cell::RefCell;

use argmin::core::CostFunction;
use nalgebra::DVector;
use thiserror::Error;

use super::likelihood::{ar1_sum, marginal, sum_of_squared_differences, sum_of_squares, Noise};
use super::priors::{PriorError, Priors, RHO_BOUNDS};
use crate::data::Aligned;
use crate::model::{ForwardModel, Layout, ParamSpec, SimError};

/// Why the posterior could not be built or evaluated.
#[derive(Debug, Error)]
pub enum PosteriorError {
    /// The priors do not name the model's parameters in order.
    #[error("priors are for ({priors}) but the model needs ({model})")]
    Names { priors: String, model: String },
    /// A parameter vector has the wrong length.
    #[error("expected {expected} parameters, got {found}")]
    Dim { expected: usize, found: usize },
    /// The default priors could not be built.
    #[error(transparent)]
    Prior(#[from] PriorError),
    /// The density came out NaN: a bug, reported with its input.
    #[error("log-density is NaN at theta = {theta:?}")]
    NaN { theta: Vec<f64> },
}

/// One evaluation of the posterior, with its parts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evaluation {
    /// Log-prior (`-inf` outside the support).
    pub log_prior: f64,
    /// Marginal log-likelihood (`-inf` if the model refused the parameters).
    pub log_likelihood: f64,
    /// Their sum.
    pub log_posterior: f64,
    /// Sum of squared residuals (m^2/s^4).
    pub sse: f64,
    /// `sse / sum a_meas^2`.
    pub e2: f64,
}

impl Evaluation {
    fn outside(log_prior: f64) -> Self {
        Self {
            log_prior,
            log_likelihood: f64::NEG_INFINITY,
            log_posterior: f64::NEG_INFINITY,
            sse: f64::INFINITY,
            e2: f64::INFINITY,
        }
    }
}

thread_local! {
    static BUFFER: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// Prior times likelihood for one model and one record.
#[derive(Debug, Clone)]
pub struct Posterior<M> {
    model: M,
    data: Aligned,
    priors: Priors,
    noise: Noise,
    names: Vec<String>,
    layout: Layout,
    energy: f64,
    /// `marginal(n, 1)`: the likelihood's constant part.
    ln_const: f64,
}

impl<M: ForwardModel> Posterior<M> {
    /// A posterior with the given priors, which must name the model's
    /// parameters (then `rho` for AR(1) noise) in order.
    pub fn new(
        model: M,
        data: Aligned,
        priors: Priors,
        noise: Noise,
    ) -> Result<Self, PosteriorError> {
        let names = Self::names_for(&model, noise);
        if priors.names() != names.as_slice() {
            return Err(PosteriorError::Names {
                priors: priors.names().join(", "),
                model: names.join(", "),
            });
        }
        let layout = Self::layout_for(&model, noise);
        let energy = data.energy();
        let ln_const = marginal(data.a.len(), 1.0);
        Ok(Self {
            model,
            data,
            priors,
            noise,
            names,
            layout,
            energy,
            ln_const,
        })
    }

    /// A posterior with the default uniform priors.
    pub fn with_default_priors(
        model: M,
        data: Aligned,
        noise: Noise,
    ) -> Result<Self, PosteriorError> {
        let priors = Self::default_priors(&model, noise);
        Self::new(model, data, priors, noise)
    }

    /// Uniform priors on the bounds the model's components declare (and
    /// [`RHO_BOUNDS`] for AR(1) noise).
    pub fn default_priors(model: &M, noise: Noise) -> Priors {
        let layout = Self::layout_for(model, noise);
        Priors::uniform(layout.names(), &layout.bounds()).expect("one bound per name")
    }

    /// The layout of `theta`: the model's parameters (block `model`), then
    /// the noise model's (block `noise`).
    pub fn layout_for(model: &M, noise: Noise) -> Layout {
        let mut layout = Layout::default();
        layout.push("model".into(), model.params());
        let extra = match noise {
            Noise::White => vec![],
            Noise::Ar1 => vec![ParamSpec::new("rho", "-", RHO_BOUNDS, 0.0)
                .symbol("rho")
                .meaning("lag-one correlation of the measurement error")
                .scale(0.05)],
        };
        layout.push("noise".into(), extra);
        layout
    }

    /// The layout of `theta`.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The model's part of `theta`.
    pub fn model_part<'a>(&self, theta: &'a [f64]) -> &'a [f64] {
        self.layout.values(theta, 0)
    }

    /// The noise model's part of `theta` (`[rho]` for AR(1), else empty).
    pub fn noise_part<'a>(&self, theta: &'a [f64]) -> &'a [f64] {
        self.layout.values(theta, 1)
    }

    /// `model` values followed by the noise model's neutral values (`rho =
    /// 0`): a start for this posterior from a white-noise fit.
    pub fn with_neutral_noise(&self, model: &[f64]) -> Vec<f64> {
        let mut theta = model.to_vec();
        theta.extend(self.layout.blocks()[1].params.iter().map(|p| p.neutral));
        theta
    }

    /// `model` values followed by a start for the noise model read from
    /// their residual: for AR(1), `rho` is the residual's lag-1
    /// autocorrelation (its conditional maximum-likelihood value), kept
    /// inside the prior's support. Started at `rho = 0` instead, the AR(1)
    /// search of strongly coloured records often ended in a worse basin:
    /// on three calibration null records with sensor noise it stood 66 to
    /// 138 nats below the white fit's parameters with `rho` near 0.81.
    /// The neutral values when the model cannot run there.
    ///
    /// # Formula
    /// ```text
    /// rho_0 = sum_t r_t r_(t-1) / sum_t r_(t-1)^2
    /// ```
    ///
    /// ```
    /// use hbis::data::Record;
    /// use hbis::inference::{Noise, Posterior};
    /// use hbis::model::{ForwardModel, Params, Registry};
    /// use rand::{rngs::StdRng, SeedableRng};
    /// use rand_distr::{Distribution, Normal};
    ///
    /// let model = Registry::builtin().parse("bilinear+coulomb")?;
    /// let theta = model.theta_from_params(&Params::table_8_1(5).unwrap(), &[])?;
    /// let mut a = vec![0.0; 2001];
    /// model.accel_into(&theta, 0.005, &mut a)?;
    /// // AR(1) noise, rho = 0.6.
    /// let (mut rng, mut e) = (StdRng::seed_from_u64(3), 0.0);
    /// let unit = Normal::new(0.0, 0.01)?;
    /// for x in a.iter_mut() {
    ///     e = 0.6 * e + unit.sample(&mut rng);
    ///     *x += e;
    /// }
    /// let t = (0..2001).map(|i| i as f64 * 0.005).collect();
    /// let data = Record::new(t, a)?.aligned(Some(0.0))?;
    /// let post = Posterior::with_default_priors(model, data, Noise::Ar1)?;
    /// let start = post.with_noise_from_residual(&theta);
    /// // rho's standard error on 2,001 samples is about 0.018.
    /// assert!((start[theta.len()] - 0.6).abs() < 0.08, "{}", start[theta.len()]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_noise_from_residual(&self, model: &[f64]) -> Vec<f64> {
        let mut theta = self.with_neutral_noise(model);
        if self.noise != Noise::Ar1 {
            return theta;
        }
        let Ok(r) = self.residual(&theta) else {
            return theta;
        };
        let lagged: f64 = r.windows(2).map(|w| w[1] * w[0]).sum();
        let scale: f64 = r[..r.len().saturating_sub(1)].iter().map(|v| v * v).sum();
        let rho = lagged / scale;
        let k = model.len();
        let (lo, hi) = self.priors.box_bounds();
        // Strictly inside: the AR(1) density is zero at |rho| = 1.
        let margin = 1e-3 * (hi[k] - lo[k]);
        if rho.is_finite() {
            theta[k] = rho.clamp(lo[k] + margin, hi[k] - margin);
        }
        theta
    }

    /// The parameter names a model and noise model need, in order.
    pub fn names_for(model: &M, noise: Noise) -> Vec<String> {
        let mut names = model.param_names();
        names.extend(noise.extra_names().iter().map(|s| s.to_string()));
        names
    }

    /// Parameter names in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of parameters.
    pub fn dim(&self) -> usize {
        self.names.len()
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The record.
    pub fn data(&self) -> &Aligned {
        &self.data
    }

    /// The priors.
    pub fn priors(&self) -> &Priors {
        &self.priors
    }

    /// The noise model.
    pub fn noise(&self) -> Noise {
        self.noise
    }

    /// The model's acceleration on the record's grid.
    pub fn model_accel(&self, theta: &[f64]) -> Result<Vec<f64>, SimError> {
        let mut out = vec![0.0; self.data.a.len()];
        self.data
            .model_accel_into(&self.model, self.model_part(theta), &mut out)?;
        Ok(out)
    }

    /// The residual, record minus model, on the record's grid.
    pub fn residual(&self, theta: &[f64]) -> Result<Vec<f64>, SimError> {
        let mut r = self.model_accel(theta)?;
        for (m, a) in r.iter_mut().zip(&self.data.a) {
            *m = a - *m;
        }
        Ok(r)
    }

    /// Evaluates prior, likelihood and `e2` at `theta`.
    pub fn evaluate(&self, theta: &[f64]) -> Result<Evaluation, PosteriorError> {
        if theta.len() != self.dim() {
            return Err(PosteriorError::Dim {
                expected: self.dim(),
                found: theta.len(),
            });
        }
        if theta.iter().any(|v| v.is_nan()) {
            return Err(PosteriorError::NaN {
                theta: theta.to_vec(),
            });
        }
        let mut log_prior = self.priors.ln_pdf(theta);
        if !self.model.in_support(self.model_part(theta)) {
            log_prior = f64::NEG_INFINITY;
        }
        if log_prior == f64::NEG_INFINITY {
            return Ok(Evaluation::outside(log_prior));
        }
        let rho = self.noise_part(theta).first().copied();
        // White noise needs only the sum: formed as the model is sampled
        // where the model can, else in one pass over the stored samples.
        let fused = match rho {
            None => self.data.model_sse(&self.model, self.model_part(theta)),
            Some(_) => None,
        };
        let result = match fused {
            // A model that refuses the parameters (or cannot finish them)
            // puts no mass there.
            Some(sse) => sse.ok().map(|sse| (sse, self.ln_marginal(sse))),
            None => self.sampled_likelihood(theta, rho),
        };
        let Some((sse, log_likelihood)) = result else {
            return Ok(Evaluation::outside(log_prior));
        };
        let ev = Evaluation {
            log_prior,
            log_likelihood,
            log_posterior: log_prior + log_likelihood,
            sse,
            e2: sse / self.energy,
        };
        if ev.log_posterior.is_nan() || ev.e2.is_nan() {
            return Err(PosteriorError::NaN {
                theta: theta.to_vec(),
            });
        }
        Ok(ev)
    }

    /// The log-posterior alone.
    pub fn log_posterior(&self, theta: &[f64]) -> Result<f64, PosteriorError> {
        Ok(self.evaluate(theta)?.log_posterior)
    }

    /// The likelihood with `sigma` integrated out, for a (pre-whitened)
    /// sum of squares `s` over the record's samples.
    fn ln_marginal(&self, s: f64) -> f64 {
        self.ln_const - 0.5 * self.data.a.len() as f64 * s.ln()
    }

    /// `(sse, log-likelihood)` from the model's acceleration sampled into
    /// a buffer; `None` where the model refuses the parameters.
    fn sampled_likelihood(&self, theta: &[f64], rho: Option<f64>) -> Option<(f64, f64)> {
        let n = self.data.a.len();
        BUFFER.with(|cell| {
            let mut buf = cell.borrow_mut();
            buf.resize(n, 0.0);
            // A model that refuses the parameters (or cannot finish them) puts
            // no mass there.
            if self
                .data
                .model_accel_into(&self.model, self.model_part(theta), &mut buf)
                .is_err()
            {
                return None;
            }
            // White noise needs only the sum: one pass, nothing stored.
            let Some(rho) = rho else {
                let sse = sum_of_squared_differences(&self.data.a, &buf);
                return Some((sse, self.ln_marginal(sse)));
            };
            for (m, a) in buf.iter_mut().zip(&self.data.a) {
                *m = a - *m;
            }
            let sse = sum_of_squares(&buf);
            let (s, jac) = ar1_sum(&buf, rho);
            let ln_l = self.ln_marginal(s) + jac;
            Some((sse, ln_l))
        })
    }
}

/// argmin sees the negative log-posterior as the cost to minimise.
impl<M: ForwardModel> CostFunction for Posterior<M> {
    type Param = DVector<f64>;
    type Output = f64;

    fn cost(&self, theta: &Self::Param) -> Result<f64, argmin::core::Error> {
        Ok(-self.log_posterior(theta.as_slice())?)
    }
}
