//! How much the Laplace log-evidence and BIC of one model on one record
//! move with the seed of the MAP search: the numbers behind the stability
//! claims in `docs/criticism.md`.
//!
//! ```sh
//! cargo run --release -- demo   # writes hbis-demo/record-hidden.csv
//! cargo run --release --features examples --example evidence_seeds -- hbis-demo/record-hidden.csv trilinear+lcfm+viscous 4
//! ```

use hbis::criticism::fit_model;
use hbis::data::Record;
use hbis::inference::{MapSettings, Noise};
use hbis::model::{ForwardModel, Model};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: evidence_seeds RECORD MODEL [SEEDS]")?;
    let model = Model::parse(args.get(1).map_or("trilinear+lcfm+viscous", |s| s))?;
    let seeds: u64 = args.get(2).map_or(Ok(4), |s| s.parse())?;
    let data = Record::read(std::path::Path::new(path))?.aligned(None)?;
    let mut values = Vec::new();
    for seed in 1..=seeds {
        let fit = fit_model(
            &model,
            &data,
            Noise::White,
            None,
            &MapSettings::default(),
            seed,
        )?;
        println!(
            "{} seed {seed}: ln Z = {:.2}, BIC = {:.2}, e2 = {:.6}",
            model.name(),
            fit.log_evidence,
            fit.bic,
            fit.e2
        );
        values.push(fit.log_evidence);
    }
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    println!("range of ln Z over {seeds} seeds: {:.2}", hi - lo);
    Ok(())
}
