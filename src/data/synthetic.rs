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
    if !(noise_fraction.is_finite() && noise_fraction >= 0.0) {
        return Err(SimError::Grid {
            name: "noise_fraction",
            value: noise_fraction,
            requirement: "must be a finite number >= 0",
        });
    }
    let mut clean = vec![0.0; n];
    model.accel_into(theta, dt, &mut clean)?;
    if let Some(i) = clean.iter().position(|a| !a.is_finite()) {
        return Err(SimError::NotFinite { t: i as f64 * dt });
    }
    let peak = clean.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let sigma = noise_fraction * peak;
    let a: Vec<f64> = match Normal::new(0.0, sigma) {
        Ok(normal) if sigma > 0.0 => clean.iter().map(|c| c + normal.sample(rng)).collect(),
        _ => clean.clone(),
    };
    let energy: f64 = a.iter().map(|v| v * v).sum();
    let noise_floor = if sigma > 0.0 {
        n as f64 * sigma * sigma / energy
    } else {
        0.0
    };
    let t = (0..n).map(|i| i as f64 * dt).collect();
    let record = Record::new(t, a).expect("a simulated record is finite and increasing");
    Ok(Synthetic {
        record,
        clean,
        sigma,
        noise_floor,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};

    /// A faulty component: NaN from the third sample on.
    struct Faulty;

    impl ForwardModel for Faulty {
        fn name(&self) -> String {
            "faulty".into()
        }
        fn params(&self) -> Vec<crate::model::ParamSpec> {
            vec![]
        }
        fn accel_grid_into(
            &self,
            _: &[f64],
            _: f64,
            _: f64,
            out: &mut [f64],
        ) -> Result<(), SimError> {
            for (i, a) in out.iter_mut().enumerate() {
                *a = if i < 2 { -1.0 } else { f64::NAN };
            }
            Ok(())
        }
    }

    #[test]
    fn a_faulty_model_or_noise_level_is_an_error_not_a_panic() {
        let mut rng = StdRng::seed_from_u64(1);
        let err = synthesize(&Faulty, &[], 0.01, 10, 0.01, &mut rng).unwrap_err();
        assert_eq!(err, SimError::NotFinite { t: 0.02 });
        for bad in [-0.1, f64::NAN] {
            let err = synthesize(&Faulty, &[], 0.01, 2, bad, &mut rng).unwrap_err();
            assert!(err.to_string().contains("noise_fraction"), "{err}");
        }
        let clean = synthesize(&Faulty, &[], 0.01, 2, 0.0, &mut rng).unwrap();
        assert_eq!((clean.sigma, clean.noise_floor), (0.0, 0.0));
    }
}
