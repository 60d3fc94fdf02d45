//! `off_corner` on a corner made on purpose: a model whose fit is exact at
//! one value of a parameter and spoilt in a moat 3e-6 of the range wide
//! around it, as a MAP on knife edges (reversals on sample instants) is
//! good at its own point and bad at every neighbour 1e-6 of a range away.
//! The search must leave the corner for a point with volume, keep the fit,
//! and leave a smooth maximum alone.

use hbis::inference::pipeline::{compare, off_corner, CORNER, CORNER_STEPS};
use hbis::inference::{Noise, Posterior, Priors};
use hbis::model::{ForwardModel, ParamSpec, SimError};
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// Where the corner sits in `c`'s range [0, 1].
const CORNER_AT: f64 = 0.5;
/// Half-width of the moat around it.
const MOAT: f64 = 3e-6;

/// `a(t) = b phi(t) + k(c) psi(t)`, `k(c) = 0.1` in the moat around
/// `CORNER_AT` (but not on it), else 0.
#[derive(Debug, Clone)]
struct Moat;

fn phi(t: f64) -> f64 {
    (-0.3 * t).exp() * (2.0 * std::f64::consts::PI * 0.4 * t).cos()
}

fn psi(t: f64) -> f64 {
    (-0.3 * t).exp() * (2.0 * std::f64::consts::PI * 0.4 * t).sin()
}

impl ForwardModel for Moat {
    fn name(&self) -> String {
        "moat".into()
    }

    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("b", "m/s^2", (-3.0, 3.0), 0.0),
            ParamSpec::new("c", "-", (0.0, 1.0), 0.5),
        ]
    }

    fn accel_grid_into(
        &self,
        theta: &[f64],
        start: f64,
        dt: f64,
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let gap = (theta[1] - CORNER_AT).abs();
        let k = if gap > 0.0 && gap < MOAT { 0.1 } else { 0.0 };
        for (i, o) in out.iter_mut().enumerate() {
            let t = start + i as f64 * dt;
            *o = theta[0] * phi(t) + k * psi(t);
        }
        Ok(())
    }
}

/// A 10 s, 200 Hz record of `b = -1` (noise sd 0.02 m/s^2, seed 41):
/// negative at first, as the record's polarity convention wants.
fn posterior() -> Posterior<Moat> {
    let (n, dt) = (2001, 0.005);
    let noise = Normal::new(0.0, 0.02).unwrap();
    let mut rng = StdRng::seed_from_u64(41);
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let a: Vec<f64> = t
        .iter()
        .map(|&t| -phi(t) + noise.sample(&mut rng))
        .collect();
    let data = hbis::data::Record::new(t, a)
        .unwrap()
        .aligned(Some(0.0))
        .unwrap();
    let names = vec!["b".to_string(), "c".to_string()];
    let priors = Priors::uniform(names, &[(-3.0, 3.0), (0.0, 1.0)]).unwrap();
    Posterior::new(Moat, data, priors, Noise::White).unwrap()
}

/// The sigma-profiled log-likelihood at `theta` (what `compare` bounds).
fn own(post: &Posterior<Moat>, theta: &[f64]) -> f64 {
    let r = post.residual(theta).unwrap();
    let s: f64 = r.iter().map(|x| x * x).sum();
    hbis::inference::pipeline::profile_log_likelihood(r.len(), s, None)
}

#[test]
fn a_corner_is_left_for_a_point_with_volume() {
    let post = posterior();
    let corner = [-1.0, CORNER_AT];
    let before = compare(&post, &corner).unwrap();
    // The made corner is one: its neighbours are worth far less than it.
    assert!(own(&post, &corner) - before.log_likelihood > 10.0 * CORNER);
    let (theta, after) = off_corner(&post, &corner).unwrap();
    println!(
        "corner {corner:?}: comparison {:.2} -> {:.2} at {theta:?}",
        before.log_likelihood, after.log_likelihood
    );
    assert_ne!(theta, corner.to_vec());
    // Off the moat, within the largest step searched.
    let gap = (theta[1] - CORNER_AT).abs();
    assert!((MOAT..=CORNER_STEPS[1] * 1.000_001).contains(&gap), "{gap}");
    // The comparison is what the point's neighbourhood is worth, and the
    // fit is kept: within a nat of the corner's own value.
    assert_eq!(after, compare(&post, &theta).unwrap());
    assert!(after.log_likelihood > before.log_likelihood + 10.0 * CORNER);
    assert!(after.log_likelihood > own(&post, &corner) - 1.0);
    assert!(after.bic < before.bic);
}

#[test]
fn a_smooth_maximum_is_left_where_it_is() {
    let post = posterior();
    let smooth = [-1.0, 0.2];
    let (theta, cmp) = off_corner(&post, &smooth).unwrap();
    assert_eq!(theta, smooth.to_vec());
    assert_eq!(cmp, compare(&post, &smooth).unwrap());
    assert!(own(&post, &smooth) - cmp.log_likelihood <= CORNER);
}
