//! A sensor that reports the mean acceleration over its sample interval,
//! as anti-aliased data acquisition does, instead of the value at the
//! sample instant.
//!
//! An instantaneous sample of an acceleration that jumps at each reversal
//! (the friction force changes sign) makes the likelihood a staircase in
//! the event times: moving a reversal across a sample instant moves that
//! sample to the other side of the jump. The interval mean is the velocity
//! difference across the interval, continuous in the event times, so the
//! likelihood is continuous too.
//!
//! # Formula
//! ```text
//! a_record(t_i) = (v(t_i + dt/2) - v(t_i - dt/2)) / dt
//!               = (1/dt) * integral of a over [t_i - dt/2, t_i + dt/2]
//! ```
//! with `v = 0` before the release. The interval is centred on the sample
//! instant, so a smooth record is unchanged to `O(dt^2)`: for `a = sin(w t)`
//! the mean is `sin(w t) * sin(w dt/2) / (w dt/2)`.
//!
//! ```
//! use hbis::model::catalog::averaging::interval_mean_into;
//! // v = sin(w t) sampled at the interval ends: the mean of a = w cos(w t).
//! let (w, dt) = (2.0, 0.01);
//! let mut a = vec![0.0; 3];
//! interval_mean_into(0.5, dt, &mut a, |start, v| {
//!     for (i, x) in v.iter_mut().enumerate() {
//!         *x = (w * (start + i as f64 * dt)).sin();
//!     }
//!     Ok(())
//! })?;
//! let t = 0.5 + dt;
//! let exact = w * (w * t).cos() * (w * dt / 2.0).sin() / (w * dt / 2.0);
//! assert!((a[1] - exact).abs() < 1e-12);
//! # Ok::<(), hbis::model::SimError>(())
//! ```

use crate::model::component::{OutputComponent, ParamSpec};
use crate::model::SimError;

/// The interval-mean sensor (`averaging`): no parameters; the model forms
/// each sample from the velocity at the ends of its interval
/// ([`OutputComponent::interval_mean`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Averaging;

impl OutputComponent for Averaging {
    fn name(&self) -> &str {
        "averaging"
    }
    fn params(&self) -> Vec<ParamSpec> {
        Vec::new()
    }
    fn meaning(&self) -> &str {
        "a sensor that reports the mean acceleration over each sample interval (anti-aliased \
         acquisition), not its value at the instant"
    }
    fn interval_mean(&self) -> bool {
        true
    }
    /// Nothing to do on the samples: the model has already formed the means.
    fn apply(&self, _theta: &[f64], _dt: f64, _accel: &mut [f64]) {}
}

/// The interval means at `t_i = start + i dt` into `out`, from
/// `velocity(grid_start, v)`, which samples the velocity at
/// `grid_start + j dt` into `v` (`grid_start >= 0`, the release at 0; the
/// velocity before it is zero).
pub fn interval_mean_into(
    start: f64,
    dt: f64,
    out: &mut [f64],
    mut velocity: impl FnMut(f64, &mut [f64]) -> Result<(), SimError>,
) -> Result<(), SimError> {
    // The velocity at the intervals' right ends fills `out` (no buffer per
    // evaluation); the left end of the first, from a two-sample grid.
    velocity(start + 0.5 * dt, out)?;
    let first = start - 0.5 * dt;
    let mut left = if first >= 0.0 {
        let mut two = [0.0; 2];
        velocity(first, &mut two)?;
        two[0]
    } else {
        // The first interval starts before the release, at rest.
        0.0
    };
    for o in out.iter_mut() {
        let right = *o;
        *o = (right - left) / dt;
        left = right;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::model::{ForwardModel, Params, Registry};

    fn models(spec: &str) -> (crate::model::Model, crate::model::Model) {
        let r = Registry::builtin();
        (
            r.parse(spec).unwrap(),
            r.parse(&format!("{spec}+averaging")).unwrap(),
        )
    }

    /// The means against the instantaneous acceleration averaged on a grid
    /// 2,000 times finer (midpoint rule; its error is at most the largest
    /// jump over 2,000, some 3e-4 m/s^2): an interval off centre by half a
    /// sample would be off by about `a' dt / 2`, 5e-3 m/s^2 here.
    #[test]
    fn samples_are_the_mean_over_their_interval() {
        let (instant, mean) = models("trilinear+lcfm+viscous");
        let p = Params::table_8_1(5).unwrap();
        let theta = instant.theta_from_params(&p, &[]).unwrap();
        let (dt, n, fine) = (0.005, 400, 2000);
        for start in [0.0, 0.0012, 0.004] {
            let mut a = vec![0.0; n];
            mean.accel_grid_into(&theta, start, dt, &mut a).unwrap();
            let h = dt / fine as f64;
            let mut worst: f64 = 0.0;
            for (i, &ai) in a.iter().enumerate().skip(1) {
                let from = start + (i as f64 - 0.5) * dt + 0.5 * h;
                let mut sub = vec![0.0; fine];
                instant.accel_grid_into(&theta, from, h, &mut sub).unwrap();
                let reference = sub.iter().sum::<f64>() / fine as f64;
                worst = worst.max((ai - reference).abs());
            }
            assert!(worst < 1e-3, "start {start}: worst {worst}");
        }
    }

    /// Both engines form the same means.
    #[test]
    fn the_engines_agree() {
        for spec in ["trilinear+lcfm+viscous", "bilinear+coulomb"] {
            let (_, mean) = models(spec);
            let p = Params::table_8_1(5).unwrap();
            let theta = mean.theta_from_params(&p, &[]).unwrap();
            let mut a = vec![0.0; 2001];
            let mut b = vec![0.0; 2001];
            mean.accel_grid_into(&theta, 0.001, 0.005, &mut a).unwrap();
            mean.clone()
                .numerically()
                .accel_grid_into(&theta, 0.001, 0.005, &mut b)
                .unwrap();
            let worst = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-5, "{spec}: {worst}");
        }
    }

    /// The sum of squares along a fine sweep of `uF0`: the instantaneous
    /// sensor's steps where a reversal crosses a sample instant, the
    /// averaging sensor's continuous curve (with kinks there: the velocity
    /// has one at each reversal). Measured by the largest change between
    /// neighbouring points of the sweep over the median change.
    #[test]
    fn the_likelihood_has_no_staircase() {
        let ratio = |model: &crate::model::Model| {
            let p = Params::table_8_1(5).unwrap();
            let theta = model.theta_from_params(&p, &[]).unwrap();
            let mut data = vec![0.0; 2001];
            model.accel_into(&theta, 0.005, &mut data).unwrap();
            let k = model.param_names().iter().position(|n| n == "uF0").unwrap();
            let sse: Vec<f64> = (0..400)
                .map(|j| {
                    let mut t = theta.clone();
                    t[k] *= 1.0 + 0.02 + 1e-4 * j as f64;
                    let mut a = vec![0.0; 2001];
                    model.accel_into(&t, 0.005, &mut a).unwrap();
                    a.iter().zip(&data).map(|(x, d)| (x - d) * (x - d)).sum()
                })
                .collect();
            let mut steps: Vec<f64> = sse.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
            let worst = steps.iter().cloned().fold(0.0, f64::max);
            steps.sort_by(f64::total_cmp);
            worst / steps[steps.len() / 2]
        };
        let (instant, mean) = models("trilinear+lcfm+viscous");
        let (r_instant, r_mean) = (ratio(&instant), ratio(&mean));
        println!("largest over median change: instant {r_instant:.1}, averaging {r_mean:.1}");
        assert!(r_instant > 10.0, "{r_instant}");
        assert!(r_mean < 3.0, "{r_mean}");
    }

    #[test]
    fn it_is_parsed_and_never_offered_unasked() {
        let r = Registry::builtin();
        let (instant, mean) = models("bilinear+coulomb");
        assert_eq!(mean.name(), "bilinear+coulomb+averaging");
        assert_eq!(mean.param_names(), instant.param_names());
        let theta = instant
            .theta_from_params(&Params::table_8_1(3).unwrap(), &[])
            .unwrap();
        assert!(r
            .candidates(&instant, &theta)
            .iter()
            .all(|c| c.effect != "averaging"));
        // A candidate built from an averaging model keeps its sensor.
        assert!(r
            .candidates(&mean, &theta)
            .iter()
            .all(|c| c.model.has("averaging")));
    }
}
