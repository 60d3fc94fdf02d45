//! From a release test to an earthquake: fit a record, then take 500
//! posterior draws through a synthetic ground motion and report the peak
//! isolator displacement against a capacity.
//!
//! ```sh
//! cargo run --release --features examples --example earthquake -- [pga_m_s2] [capacity_m]
//! ```
//! The record is a synthetic Test 5 made on the spot (1.5 % noise).

use hbis::data::ground_motion::KanaiTajimi;
use hbis::data::synthesize;
use hbis::inference::Noise;
use hbis::model::{ForwardModel, ModelSpec, Params, Registry};
use hbis::predict::{predict, Draw, PredictOptions};
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let pga = args.first().copied().unwrap_or(3.0);
    let capacity = args.get(1).copied().unwrap_or(0.25);
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(5);
    let record = synthesize(
        &hbis::model::Model::from(spec),
        &truth,
        0.005,
        2001,
        0.015,
        &mut rng,
    )?
    .record;
    let fit = fit_record(
        spec,
        record.aligned(None)?,
        None,
        Noise::White,
        &FitOptions::default(),
        &mut |_| {},
    )?;
    let points = fit.sample.as_ref().expect("a posterior run").points();
    let draws: Vec<Draw> = (0..500)
        .map(|i| Draw::new(points[i * points.len() / 500].clone()))
        .collect();
    let model = Registry::builtin().parse(&spec.to_string())?;
    let motion = KanaiTajimi {
        pga,
        ..KanaiTajimi::default()
    }
    .generate(1)?;
    let p = predict(
        &model,
        &draws,
        motion.dt,
        &motion.ag,
        &PredictOptions {
            capacity: Some(capacity),
            ..PredictOptions::default()
        },
    )?;
    let d = &p.summary.peak_displacement;
    println!("{} under {}", model.name(), motion.source);
    println!(
        "peak displacement: median {:.1} mm, 90 % [{:.1}, {:.1}] mm; P(> {:.0} mm) = {:.3}",
        1e3 * d.q50,
        1e3 * d.q05,
        1e3 * d.q95,
        1e3 * capacity,
        p.p_exceed_capacity.unwrap_or(0.0)
    );
    let r = &p.summary.residual_displacement;
    println!("residual displacement: median {:.2} mm", 1e3 * r.q50);
    for w in &p.warnings {
        println!("note: {w}");
    }
    Ok(())
}
