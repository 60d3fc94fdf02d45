//! The design table against brute force: its prediction of the weakest
//! parameter's posterior sd on another release test, checked by simulating
//! that test and sampling its posterior.

use hbis::data::Record;
use hbis::inference::Noise;
use hbis::model::{ForwardModel, ModelSpec, Params};
use hbis::study::{fit_record, Fit, FitOptions};
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, Normal};

const DT: f64 = 0.005;
const N: usize = 2001;

/// A Test 5 record released from `u0_factor` times the paper's `u0`,
/// with white noise of sd `sigma`.
fn record(u0_factor: f64, dt: f64, n: usize, sigma: f64, seed: u64) -> Record {
    let spec = ModelSpec::FULL;
    let mut truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    truth[0] *= u0_factor;
    let mut clean = vec![0.0; n];
    hbis::model::Model::from(spec)
        .accel_into(&truth, dt, &mut clean)
        .unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).unwrap();
    let a = clean.iter().map(|c| c + noise.sample(&mut rng)).collect();
    Record::new((0..n).map(|i| i as f64 * dt).collect(), a).unwrap()
}

fn fit(rec: &Record, seed: u64) -> Fit {
    let options = FitOptions {
        seed,
        ..FitOptions::default()
    };
    fit_record(
        ModelSpec::FULL,
        rec.aligned(None).unwrap(),
        None,
        Noise::White,
        &options,
        &mut |_| {},
    )
    .unwrap()
}

fn sd_of(fit: &Fit, name: &str) -> f64 {
    let k = fit.names().iter().position(|n| n == name).unwrap();
    fit.summaries.as_ref().unwrap()[k].sd
}

/// Measured on this record (base seed 11), sampled over predicted sd for
/// four designs (amplitude x1.5 and x2, rate x2, length x0.5), two noise
/// seeds each: 0.955 to 1.029, spread (sd) 2.5 % from the noise
/// realisation and Monte Carlo error together. The test allows four times
/// that spread. Central differences without the one-sided guard against
/// the reversal staircase predicted 0.270 here, 29 % off: that is the
/// error this test exists to catch.
const TOLERANCE: f64 = 0.10;

#[test]
fn predicted_sd_on_a_larger_release_matches_its_sampled_posterior() {
    let sigma = 0.01;
    let base = fit(&record(1.0, DT, N, sigma, 11), 11);
    let table = base.design.as_ref().unwrap();
    eprintln!("{}", table.summary);
    assert_eq!(table.parameter, "rF0");
    let row = table
        .rows
        .iter()
        .find(|r| r.knob == "amplitude" && r.factor == 2.0)
        .unwrap();
    // The design matters: a table that predicted no change would fail.
    assert!(row.sd_ratio < 0.5, "{row:?}");
    let other = fit(&record(2.0, DT, N, sigma, 12), 12);
    let sd = sd_of(&other, &table.parameter);
    eprintln!(
        "amplitude x2: predicted {:.3e} (ratio {:.3}), sampled {sd:.3e}",
        row.sd, row.sd_ratio
    );
    assert!(
        (sd / row.sd - 1.0).abs() < TOLERANCE,
        "sampled {sd:.3e} against predicted {:.3e}",
        row.sd
    );
    // Halving the noise halves the sd (to the prior's share): the table's
    // noise rows are exact for a posterior this narrow.
    let half = table
        .rows
        .iter()
        .find(|r| r.knob == "noise" && r.factor == 0.5)
        .unwrap();
    assert!((half.sd_ratio - 0.5).abs() < 1e-3, "{half:?}");
    // The motion stops before the record ends: a longer record adds nothing.
    let long = table
        .rows
        .iter()
        .find(|r| r.knob == "duration" && r.factor == 2.0)
        .unwrap();
    assert!((long.sd_ratio - 1.0).abs() < 1e-3, "{long:?}");
}
