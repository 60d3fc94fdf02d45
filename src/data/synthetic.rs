//! Synthetic records: a model's acceleration plus white Gaussian noise, for
//! tests, the demo and calibration studies.
//!
//! "p % noise" means a noise standard deviation of p % of the clean record's
//! peak |a|. The record's noise floor is the `e2` the true parameters would
//! score on it in expectation: `n sigma^2 / sum a_meas^2`.

use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::record::Record;
use crate::model::{ForwardModel, SimError};

/// A synthetic record with the truth it was made from.
#[derive(Debug, Clone)]
pub struct Synthetic {
    /// The noisy record (starting at the release, `t = 0`).
    pub record: Record,
    /// The clean model acceleration.
    pub clean: Vec<f64>,
    /// Noise standard deviation (m/s^2).
    pub sigma: f64,
    /// Expected `e2` of the truth on this record: `n sigma^2 / sum a^2`.
    pub noise_floor: f64,
}

/// Simulates `n` samples at step `dt` and adds noise of `noise_fraction`
/// times the peak |a|.
pub fn synthesize<M: ForwardModel + ?Sized, R: Rng + ?Sized>(
    model: &M,
    theta: &[f64],
    dt: f64,
    n: usize,
    noise_fraction: f64,
    rng: &mut R,
) -> Result<Synthetic, SimError> {
    let mut clean = vec![0.0; n];
    model.accel_into(theta, dt, &mut clean)?;
    let peak = clean.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let sigma = noise_fraction * peak;
    let a: Vec<f64> = match Normal::new(0.0, sigma) {
        Ok(normal) if sigma > 0.0 => clean.iter().map(|c| c + normal.sample(rng)).collect(),
        _ => clean.clone(),
    };
    let energy: f64 = a.iter().map(|v| v * v).sum();
    let noise_floor = n as f64 * sigma * sigma / energy;
    let t = (0..n).map(|i| i as f64 * dt).collect();
    let record = Record::new(t, a).expect("a simulated record is finite and increasing");
    Ok(Synthetic {
        record,
        clean,
        sigma,
        noise_floor,
    })
}
