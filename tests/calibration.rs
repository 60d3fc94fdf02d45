//! Simulation-based calibration in CI: 90 % credible intervals of a small
//! model on 80 synthetic records (known truth, 1.5 % noise) hold the truth
//! about 90 % of the time. The full-model study of 100 records is
//! `examples/calibration.rs`, recorded in docs/inference.md.

use hbis::inference::SampleSettings;
use hbis::model::ModelSpec;
use hbis::study::{coverage, FitOptions};

#[test]
fn ninety_percent_intervals_cover_the_truth_about_ninety_percent_of_the_time() {
    let spec: ModelSpec = "linear+coulomb+viscous".parse().unwrap();
    let options = FitOptions {
        sample: Some(SampleSettings::default().with_tau_multiple(20.0).unwrap()),
        ..FitOptions::default()
    };
    let records = 80;
    let cov = coverage(spec, records, 0.015, 0.1, 7, &options).unwrap();
    let n = (records * cov.names.len()) as f64;
    // Intervals of one record are correlated, so the binomial sd over all
    // n intervals understates the spread; 3.5 sd of the per-record count
    // (records, not intervals) bounds it safely.
    let sd = (0.9 * 0.1 / records as f64).sqrt();
    let overall = cov.overall();
    eprintln!(
        "coverage {overall:.3} over {n} intervals: {:?}",
        cov.covered
    );
    assert!(
        (overall - 0.9).abs() < 3.5 * sd,
        "coverage {overall:.3} (sd {sd:.3}); {:?}",
        cov.covered
    );
}
