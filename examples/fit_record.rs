//! Fit a release-test record from the library: read, align, build the
//! posterior, find the MAP.
//!
//! ```sh
//! cargo run --release --features examples --example fit_record -- path/to/record.csv trilinear+lcfm+viscous
//! ```
//! Without arguments it fits a synthetic Test 5 record made on the spot.

use hbis::data::{synthesize, Record};
use hbis::inference::{find_map, MapSettings, Noise, Posterior};
use hbis::model::{ForwardModel, Params, Registry};
use rand::{rngs::StdRng, SeedableRng};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let model = Registry::builtin().parse(args.get(1).map_or("trilinear+lcfm+viscous", |s| s))?;
    let mut rng = StdRng::seed_from_u64(42);
    let record = match args.first() {
        Some(path) => Record::read(path.as_ref())?,
        None => {
            let truth = model.theta_from_params(&Params::table_8_1(5).unwrap(), &[])?;
            synthesize(&model, &truth, 0.005, 2001, 0.015, &mut rng)?.record
        }
    };
    let data = record.aligned(None)?;
    let posterior = Posterior::with_default_priors(model.clone(), data, Noise::White)?;
    let map = find_map(&posterior, &MapSettings::default(), &mut rng)?;
    println!(
        "{}: e2 = {:.5} after {} evaluations",
        model.name(),
        map.eval.e2,
        map.evaluations()
    );
    for (name, value) in map.names.iter().zip(&map.theta) {
        println!("  {name:6} = {value:.6}");
    }
    Ok(())
}
