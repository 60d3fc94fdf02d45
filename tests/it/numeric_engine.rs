//! The numerical engine (Dormand-Prince with event location, used for
//! velocity-dependent friction) against the closed form on the piecewise
//! linear components: with `mu_slow = mu_fast` it must reproduce the
//! closed-form acceleration in every regime.

use crate::common;

use hbis::model::{Model, Response, SimError};

#[test]
fn numerical_engine_matches_the_closed_form_without_velocity_dependence() {
    let (mut worst, mut checked, mut skipped) = (0.0f64, 0usize, 0usize);
    for case in common::cases(11, 300) {
        let duration = case.dt * (case.n - 1) as f64;
        let r = match Response::simulate(&case.spec, &case.params, duration) {
            Ok(r) => r,
            Err(SimError::Diverged { .. }) => {
                skipped += 1;
                continue;
            }
            Err(e) => panic!("{case:?}: {e}"),
        };
        let closed = r.sample_grid(case.dt).unwrap();
        let mut numeric = vec![0.0; case.n];
        let model = Model::from(case.spec);
        let theta = model.theta_from_params(&case.params, &[]).unwrap();
        match model.numeric_grid_into(&theta, 0.0, case.dt, &mut numeric) {
            Ok(()) => {}
            Err(e) => panic!("{case:?}: numeric engine failed: {e}"),
        }
        // Samples within a hair of a jump (reversal, rest) may fall on
        // either side of it in the two engines.
        let jumps: Vec<f64> = r
            .phases()
            .iter()
            .filter(|p| p.v_end == 0.0)
            .map(|p| p.t_end)
            .collect();
        for (s, a) in closed.iter().zip(&numeric) {
            if jumps.iter().any(|&tj| (tj - s.t).abs() < 1e-6) {
                continue;
            }
            let err = (s.a - a).abs() / (1.0 + s.a.abs());
            assert!(
                err < 1e-6,
                "{case:?} at t = {}: closed {} numeric {a}",
                s.t,
                s.a
            );
            worst = worst.max(err);
            checked += 1;
        }
    }
    eprintln!("numeric vs closed form: {checked} samples, worst relative difference {worst:.2e}, {skipped} divergent cases skipped");
    assert!(checked > 100_000);
}

/// Both engines sample a grid that starts after the release (a record's
/// first sample comes a fraction of a step late) on the same curve.
#[test]
fn both_engines_sample_a_shifted_grid_alike() {
    use hbis::model::{ModelSpec, Params, SimOptions, System};
    let spec: ModelSpec = "trilinear+lcfm+viscous".parse().unwrap();
    let p = Params::table_8_1(3).unwrap();
    let mut closed = vec![0.0; 2000];
    System::new(&spec, &p)
        .accel_grid_into(0.0031, 0.005, &mut closed, &SimOptions::default())
        .unwrap();
    let mut numeric = vec![0.0; 2000];
    let model = Model::from(spec);
    let theta = model.theta_from_params(&p, &[]).unwrap();
    model
        .numeric_grid_into(&theta, 0.0031, 0.005, &mut numeric)
        .unwrap();
    let mut unshifted = vec![0.0; 2000];
    System::new(&spec, &p)
        .accel_into(0.005, &mut unshifted, &SimOptions::default())
        .unwrap();
    let worst = closed
        .iter()
        .zip(&numeric)
        .map(|(c, n)| (c - n).abs())
        .fold(0.0, f64::max);
    let shift = closed
        .iter()
        .zip(&unshifted)
        .map(|(c, u)| (c - u).abs())
        .fold(0.0, f64::max);
    // The shift itself moves samples by far more than the engines differ.
    assert!(
        worst < 1e-6 && shift > 1e-3,
        "engines {worst:.2e}, shift {shift:.2e}"
    );
}
