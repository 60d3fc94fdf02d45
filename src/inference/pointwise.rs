//! The pointwise log-likelihood of a record, for leave-one-out
//! cross-validation (PSIS-LOO: ArviZ's `az.loo` and `az.compare`).
//!
//! The posterior integrates the noise scale `sigma` out analytically
//! ([`super::likelihood`]), so a draw `theta` carries no `sigma` and the
//! marginal likelihood does not split into one term per sample. A draw
//! of the joint posterior `p(theta, sigma | y) = p(theta | y)
//! p(sigma | theta, y)` does: `sigma` is drawn from its conditional
//! posterior given each `theta` (under Jeffreys' prior, `sigma^2 = S /
//! chi^2_N`, with `S` the pre-whitened sum of squares over the `N`
//! samples), and the Gaussian density of each sample given `(theta,
//! sigma)` is its term. The terms of a draw sum to the log-likelihood of
//! the record at `(theta, sigma)`.
//!
//! For [`Noise::Ar1`] the terms are those of the prediction of each
//! sample from the one before (the innovations `r_i - rho r_(i-1)`, the
//! first sample from the stationary distribution): their sum is the AR(1)
//! likelihood, but the samples are not exchangeable, so LOO over them
//! measures one-step-ahead prediction and ranks models only against
//! fits with the same noise model (`docs/criticism.md`).
//!
//! # Formula
//! With residual `r = a - model(theta)` and `sigma` drawn as above,
//! ```text
//! white: l_i = -ln(2 pi sigma^2)/2 - r_i^2 / (2 sigma^2)
//! AR(1): l_1 = -ln(2 pi sigma^2 / (1 - rho^2))/2 - (1 - rho^2) r_1^2 / (2 sigma^2)
//!        l_i = -ln(2 pi sigma^2)/2 - (r_i - rho r_(i-1))^2 / (2 sigma^2),  i > 1
//! ```
//!
//! ```
//! use hbis::inference::pointwise::gaussian_terms;
//! use hbis::inference::Noise;
//!
//! let r = [0.1, -0.2, 0.05];
//! let mut l = [0.0; 3];
//! gaussian_terms(&r, Noise::White, None, 0.5, &mut l);
//! let by_hand = -0.5 * (2.0 * std::f64::consts::PI * 0.25).ln() - 0.01 / 0.5;
//! assert!((l[0] - by_hand).abs() < 1e-15);
//! ```
//!
//! No crate computes this: it is a few lines over the model's residual.

use rand::Rng;
use rand_distr::{ChiSquared, Distribution};

use super::likelihood::{ar1_sum, sum_of_squares, Noise};
use super::posterior::Posterior;
use crate::model::{ForwardModel, SimError};

/// The Gaussian terms of residual `r` at noise scale `sigma` (the
/// innovation's scale for AR(1), with `rho`), into `out`.
pub fn gaussian_terms(r: &[f64], noise: Noise, rho: Option<f64>, sigma: f64, out: &mut [f64]) {
    let var = sigma * sigma;
    let norm = -0.5 * (2.0 * std::f64::consts::PI * var).ln();
    match (noise, rho) {
        (Noise::Ar1, Some(rho)) => {
            let one_m = 1.0 - rho * rho;
            out[0] = norm + 0.5 * one_m.ln() - one_m * r[0] * r[0] / (2.0 * var);
            for i in 1..r.len() {
                let e = r[i] - rho * r[i - 1];
                out[i] = norm - e * e / (2.0 * var);
            }
        }
        _ => {
            for (o, v) in out.iter_mut().zip(r) {
                *o = norm - v * v / (2.0 * var);
            }
        }
    }
}

/// The pointwise log-likelihood of `posterior`'s record at the draw
/// `theta`, `sigma` drawn from its conditional posterior with `rng`
/// (module docs), into `out` (one term per sample); returns that `sigma`.
pub fn pointwise_log_likelihood<M, R>(
    posterior: &Posterior<M>,
    theta: &[f64],
    rng: &mut R,
    out: &mut [f64],
) -> Result<f64, SimError>
where
    M: ForwardModel + Clone,
    R: Rng + ?Sized,
{
    let r = posterior.residual(theta)?;
    let noise = posterior.noise();
    let rho = posterior.noise_part(theta).first().copied();
    let s = match (noise, rho) {
        (Noise::Ar1, Some(rho)) => ar1_sum(&r, rho).0,
        _ => sum_of_squares(&r),
    };
    let chi2 = ChiSquared::new(r.len() as f64)
        .expect("a record has samples")
        .sample(rng);
    let sigma = (s / chi2).sqrt();
    gaussian_terms(&r, noise, rho, sigma, out);
    Ok(sigma)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AR(1) terms sum to the Gaussian AR(1) log-density, here built
    /// as a multivariate normal with covariance sigma^2 rho^|i-j| / (1 -
    /// rho^2).
    #[test]
    fn ar1_terms_sum_to_the_multivariate_normal_density() {
        let r = [0.3, -0.1, 0.25, 0.05];
        let (rho, sigma): (f64, f64) = (0.6, 0.4);
        let n = r.len();
        let cov = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            sigma * sigma * rho.powi((i as i32 - j as i32).abs()) / (1.0 - rho * rho)
        });
        let chol = cov.clone().cholesky().unwrap();
        let x = nalgebra::DVector::from_row_slice(&r);
        let quad = x.dot(&chol.solve(&x));
        let log_det: f64 = chol.l().diagonal().iter().map(|d: &f64| 2.0 * d.ln()).sum();
        let mvn = -0.5 * (n as f64 * (2.0 * std::f64::consts::PI).ln() + log_det + quad);
        let mut l = [0.0; 4];
        gaussian_terms(&r, Noise::Ar1, Some(rho), sigma, &mut l);
        let sum: f64 = l.iter().sum();
        assert!((sum - mvn).abs() < 1e-12, "{sum} against {mvn}");
    }

    /// At the truth of a synthetic record the drawn sigma scatters around
    /// the noise sd that made it (sd of sigma about sigma / sqrt(2N):
    /// within 4 of those over 200 draws' mean), and each draw's terms sum
    /// to the Gaussian log-density of the residual at that sigma.
    #[test]
    fn sigma_is_drawn_around_the_noise_and_the_terms_are_its_density() {
        use crate::data::synthesize;
        use crate::model::{Model, Params};
        use rand::{rngs::StdRng, SeedableRng};
        let seed = 17;
        println!("seed {seed}");
        let model = Model::parse("trilinear+lcfm+viscous").unwrap();
        let theta = model
            .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
            .unwrap();
        let mut rng = StdRng::seed_from_u64(seed);
        let syn = synthesize(&model, &theta, 0.005, 2001, 0.01, &mut rng).unwrap();
        let data = syn.record.aligned(None).unwrap().with_lag(0.0);
        let post = Posterior::with_default_priors(model, data, Noise::White).unwrap();
        let r = post.residual(&theta).unwrap();
        let s = sum_of_squares(&r);
        let n = r.len() as f64;
        let mut l = vec![0.0; r.len()];
        let draws: Vec<f64> = (0..200)
            .map(|_| {
                let sigma = pointwise_log_likelihood(&post, &theta, &mut rng, &mut l).unwrap();
                let density = -0.5 * n * (2.0 * std::f64::consts::PI * sigma * sigma).ln()
                    - s / (2.0 * sigma * sigma);
                let sum: f64 = l.iter().sum();
                assert!(
                    (sum - density).abs() < 1e-9 * density.abs(),
                    "{sum} vs {density}"
                );
                sigma
            })
            .collect();
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let se = syn.sigma / (2.0 * n).sqrt() / (draws.len() as f64).sqrt();
        // The realised noise differs from syn.sigma by about the same sd
        // once more (one record): allow for both.
        let tol = 4.0 * (se * se + (syn.sigma / (2.0 * n).sqrt()).powi(2)).sqrt();
        assert!(
            (mean - syn.sigma).abs() < tol,
            "{mean} vs {} (tol {tol})",
            syn.sigma
        );
    }
}
