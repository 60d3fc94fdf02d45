//! A small uncertainty-quantification study from the library: the five
//! Solarino tests of Table 8.1, each synthesised with 1.5 % noise and fitted;
//! each posterior, then the across-test mean and c.o.v. of the estimates as
//! the paper's Table 8.1 reports them, beside the within-test posterior
//! c.o.v. (how much of the scatter between tests the identification alone
//! explains).
//!
//! ```sh
//! cargo run --release --features examples --example uq_study
//! ```

use hbis::data::synthesize;
use hbis::inference::{Noise, SampleSettings};
use hbis::model::{ModelSpec, Params};
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};

const TESTS: [u32; 5] = [3, 5, 6, 7, 8];
/// Released force of each test (Table 8.2), kN.
const RELEASED: [f64; 5] = [1050.0, 1180.0, 1222.0, 868.0, 967.0];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let spec = ModelSpec::FULL;
    let names: Vec<String> = spec
        .param_names()
        .iter()
        .map(|p| p.as_str().to_string())
        .collect();
    let mut means: Vec<Vec<f64>> = Vec::new();
    let mut covs: Vec<Vec<f64>> = Vec::new();
    for (i, test) in TESTS.iter().enumerate() {
        let truth = Params::table_8_1(*test).unwrap().to_theta(&spec);
        let mut rng = StdRng::seed_from_u64(100 + *test as u64);
        let record = synthesize(
            &hbis::model::Model::from(spec),
            &truth,
            0.005,
            2001,
            0.015,
            &mut rng,
        )?
        .record;
        let options = FitOptions {
            seed: *test as u64,
            sample: Some(SampleSettings::default().with_tau_multiple(20.0)?),
            forces: Some((RELEASED[i], 100.0)),
            ..FitOptions::default()
        };
        let fit = fit_record(
            spec,
            record.aligned(None)?,
            None,
            Noise::White,
            &options,
            &mut |_| {},
        )?;
        let sums = fit.summaries.as_ref().unwrap();
        println!(
            "Test {test}: e2 = {:.5}, weakest {}",
            fit.map.eval.e2,
            fit.identifiability.as_ref().unwrap().weakest
        );
        for (name, s) in names.iter().zip(sums) {
            println!(
                "  {name:6} {:>11.6} ± {:.2e}  [{:.6}, {:.6}]",
                s.mean, s.sd, s.q05, s.q95
            );
        }
        if let Some(m) = fit
            .physical
            .as_ref()
            .and_then(|p| p.iter().find(|(n, _)| n == "m"))
        {
            println!("  m = {:.0} ± {:.0} t", m.1.mean, m.1.sd);
        }
        means.push(sums.iter().map(|s| s.mean).collect());
        covs.push(sums.iter().map(|s| s.cov).collect());
    }
    println!("\nAcross the five tests (as Table 8.1):");
    println!(
        "  {:6} {:>11} {:>16} {:>22}",
        "", "mean", "c.o.v. across", "mean posterior c.o.v."
    );
    for (k, name) in names.iter().enumerate() {
        let v: Vec<f64> = means.iter().map(|m| m[k]).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        let within = covs.iter().map(|c| c[k]).sum::<f64>() / covs.len() as f64;
        println!(
            "  {name:6} {mean:>11.6} {:>15.1}% {:>21.1}%",
            100.0 * sd / mean.abs(),
            100.0 * within
        );
    }
    Ok(())
}
