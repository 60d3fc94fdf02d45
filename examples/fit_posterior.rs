//! Fit one record from the library and print the posterior table and the
//! identifiability verdict.
//!
//! ```sh
//! cargo run --release --features examples --example fit_posterior -- path/to/record.csv [model]
//! ```
//! Without arguments it fits a synthetic Test 5 record made on the spot.

use hbis::data::{synthesize, Record};
use hbis::inference::Noise;
use hbis::model::{ModelSpec, Params};
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec: ModelSpec = args
        .get(1)
        .map_or("trilinear+lcfm+viscous", |s| s)
        .parse()?;
    let record = match args.first() {
        Some(path) => Record::read(path.as_ref())?,
        None => {
            let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
            let mut rng = StdRng::seed_from_u64(5);
            synthesize(
                &hbis::model::Model::from(spec),
                &truth,
                0.005,
                2001,
                0.015,
                &mut rng,
            )?
            .record
        }
    };
    let options = FitOptions {
        forces: Some((1180.0, 100.0)),
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
    let (sample, sums) = (
        fit.sample.as_ref().unwrap(),
        fit.summaries.as_ref().unwrap(),
    );
    println!(
        "{spec}: MAP e2 = {:.5}; {} draws, converged: {}",
        fit.map.eval.e2,
        sample.draws()[0].len(),
        sample.converged
    );
    println!(
        "{:6} {:>12} {:>10} {:>8} {:>12} {:>12} {:>7} {:>6}",
        "", "mean", "sd", "c.o.v.", "q05", "q95", "ESS", "R-hat"
    );
    for (k, (name, s)) in fit.names().iter().zip(sums).enumerate() {
        println!(
            "{name:6} {:>12.6} {:>10.2e} {:>7.1}% {:>12.6} {:>12.6} {:>7.0} {:>6.3}",
            s.mean,
            s.sd,
            100.0 * s.cov,
            s.q05,
            s.q95,
            sample.ess[k],
            sample.rhat[k]
        );
    }
    if let Some(phys) = &fit.physical {
        for (name, s) in phys {
            println!("{name:3} = {:.1} ± {:.1}", s.mean, s.sd);
        }
    }
    let id = fit.identifiability.as_ref().unwrap();
    println!(
        "\nbest to worst determined: {}\n{}",
        id.ranking.join(", "),
        id.explanation
    );
    Ok(())
}
