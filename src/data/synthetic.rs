//! Synthetic records: a model's acceleration plus white Gaussian noise, for
//! tests, the demo and calibration studies.
//!
//! "p % noise" means a noise standard deviation of p % of the clean record's
//! peak |a|. The record's noise floor is the `e2` the true parameters would
//! score on it in expectation: `n sigma^2 / sum a_meas^2`.

use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::record::{Record, MAX_SAMPLES};
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
    if n > MAX_SAMPLES {
        return Err(SimError::Grid {
            name: "n",
            value: n as f64,
            requirement: "more than the 2,000,000 samples a record may hold (MAX_SAMPLES: 10,000 s at 200 Hz)",
        });
    }
    let last = dt * n.saturating_sub(1) as f64;
    if dt.is_finite() && !last.is_finite() {
        return Err(SimError::Grid {
            name: "(n - 1) dt",
            value: last,
            requirement: "the last sample's time must be a finite number",
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
    // A step so small that the times do not increase in floating point.
    let record = Record::new(t, a).map_err(|_| SimError::Grid {
        name: "dt",
        value: dt,
        requirement: "the sample times i dt do not increase in floating point",
    })?;
    Ok(Synthetic {
        record,
        clean,
        sigma,
        noise_floor,
    })
}

/// A random parameter set over the range of real hybrid isolation systems,
/// not tied to a Table 8.1 column: `u0` 5 to 20 cm, `uy` 3 to 30 % of it,
/// `uF0` 0.5 to 4 mm, `rF0` within ±0.02, `zeta0` up to 8 %, `f0` 0.3 to
/// 1.2 Hz, `f1` 40 to 95 % of `f0`, `f2` 70 to 160 % of `f1` (kept below
/// `0.95 f0`), `u3` 30 to 90 % of `u0` (kept above `1.5 uy`). It makes the
/// records on which the MAP search's robustness is measured
/// (`examples/map_robustness.rs`).
///
/// ```
/// use hbis::data::random_wide_params;
/// use rand::{rngs::StdRng, SeedableRng};
/// let p = random_wide_params(&mut StdRng::seed_from_u64(1));
/// assert!(p.f1 < p.f0 && p.f2 < p.f0 && p.u3 > p.uy && p.u3 < p.u0);
/// ```
pub fn random_wide_params<R: Rng + ?Sized>(rng: &mut R) -> crate::model::Params {
    use rand::RngExt;
    let u0: f64 = rng.random_range(0.05..0.2);
    let f0: f64 = rng.random_range(0.3..1.2);
    let uy = u0 * rng.random_range(0.03..0.3);
    let u_f0 = rng.random_range(0.0005..0.004);
    let r_f0 = rng.random_range(-0.02..0.02);
    let zeta0 = rng.random_range(0.0..0.08);
    let f1: f64 = f0 * rng.random_range(0.4..0.95);
    let f2 = (f1 * rng.random_range(0.7..1.6)).min(0.95 * f0);
    let u3 = (u0 * rng.random_range(0.3..0.9)).max(1.5 * uy);
    crate::model::Params::from_array([u0, uy, u_f0, r_f0, zeta0, f0, f1, f2, u3])
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
