//! Records that start before the release, whose first sample after it comes
//! a fraction of a step late: given `t0`, the model is sampled exactly
//! there; detected, the fit places the release between the samples.

use hbis::data::Record;
use hbis::inference::Noise;
use hbis::model::{ForwardModel, ModelSpec, Params};
use hbis::study::{fit_record, FitOptions};

const DT: f64 = 0.005;

/// A clean Test 3 record on the clock of a logger: 0.5 s of rest, then
/// the release at `t = 2.0 + 0.5 - lag`, first sampled `lag` after it.
fn record(spec: &ModelSpec, truth: &[f64], lag: f64) -> Record {
    let mut post = vec![0.0; 1600];
    hbis::model::Model::from(*spec)
        .accel_grid_into(truth, lag, DT, &mut post)
        .unwrap();
    let (mut t, mut a) = (Vec::new(), Vec::new());
    for i in 0..100 {
        t.push(2.0 + i as f64 * DT);
        a.push(0.0);
    }
    for (i, &x) in post.iter().enumerate() {
        t.push(2.5 + i as f64 * DT);
        a.push(x);
    }
    Record::new(t, a).unwrap()
}

fn map_only() -> FitOptions {
    FitOptions {
        sample: None,
        ..FitOptions::default()
    }
}

#[test]
fn a_release_between_samples_is_placed_by_the_fit() {
    let spec: ModelSpec = "trilinear+lcfm+viscous".parse().unwrap();
    let truth = Params::table_8_1(3).unwrap().to_theta(&spec);
    let lag = 0.0031;
    let rec = record(&spec, &truth, lag);

    let given = rec.aligned(Some(2.5 - lag)).unwrap();
    assert!((given.lag - lag).abs() < 1e-12);
    let fit = fit_record(spec, given, None, Noise::White, &map_only(), &mut |_| {}).unwrap();
    assert!(fit.map.eval.e2 < 1e-12, "given: e2 {}", fit.map.eval.e2);

    let detected = rec.aligned(None).unwrap();
    assert!(detected.lag_unknown() && detected.first_index == 100);
    let fit = fit_record(spec, detected, None, Noise::White, &map_only(), &mut |_| {}).unwrap();
    let placed = fit.posterior.data();
    assert!(
        (placed.lag - lag).abs() < 1e-6 && (placed.t0 - (2.5 - lag)).abs() < 1e-6,
        "lag {} t0 {}",
        placed.lag,
        placed.t0
    );
    assert!(fit.map.eval.e2 < 1e-12, "detected: e2 {}", fit.map.eval.e2);

    // Taken at the first sample instead, the same record fits worse (the
    // other parameters absorb most of the shift: e2 about 1.2e-5).
    let at_sample = rec.aligned(Some(2.5)).unwrap();
    let fit = fit_record(
        spec,
        at_sample,
        None,
        Noise::White,
        &map_only(),
        &mut |_| {},
    )
    .unwrap();
    assert!(
        fit.map.eval.e2 > 1e-6,
        "lag ignored: e2 {}",
        fit.map.eval.e2
    );
}
