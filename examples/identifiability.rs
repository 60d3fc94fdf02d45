//! The identifiability ranking on records made from Tests 3, 5 and 7 of
//! Table 8.1 (1.5 % noise), and on a Test 3 record released from below the
//! second yield `u3` (its swing never reaches the third branch).
//!
//! ```sh
//! cargo run --release --features examples --example identifiability [seed]
//! ```
//! Prints each record's ranking (by posterior sd over prior sd), the sd
//! ratio of every parameter, the explanation of the weakest, and the design
//! table: how its sd would scale with the record's length, the release
//! amplitude, the noise and the sampling rate.

use hbis::data::synthesize;
use hbis::inference::Noise;
use hbis::model::{ModelSpec, Params};
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seed: u64 = std::env::args().nth(1).map_or(Ok(2026), |s| s.parse())?;
    let spec = ModelSpec::FULL;
    let mut cases: Vec<(String, Params)> = [3, 5, 7]
        .iter()
        .map(|&t| (format!("Test {t}"), Params::table_8_1(t).unwrap()))
        .collect();
    let mut below = Params::table_8_1(3).unwrap();
    below.u0 = 0.6 * below.u3;
    cases.push((
        format!(
            "Test 3 released from u0 = {:.4} m < u3 = {:.4} m",
            below.u0, below.u3
        ),
        below,
    ));
    for (k, (label, p)) in cases.iter().enumerate() {
        let truth = p.to_theta(&spec);
        let mut rng = StdRng::seed_from_u64(seed + k as u64);
        let syn = synthesize(
            &hbis::model::Model::from(spec),
            &truth,
            0.005,
            2001,
            0.015,
            &mut rng,
        )?;
        let options = FitOptions {
            seed: seed + k as u64,
            ..FitOptions::default()
        };
        let fit = fit_record(
            spec,
            syn.record.aligned(None)?,
            None,
            Noise::White,
            &options,
            &mut |_| {},
        )?;
        let id = fit.identifiability.as_ref().expect("sampled");
        println!("\n== {label}: ranking {}", id.ranking.join(", "));
        let ratios: Vec<String> = id
            .ranking
            .iter()
            .map(|n| {
                let p = &id.params.iter().find(|(m, _)| m == n).unwrap().1;
                format!("{n} {:.3} %", 100.0 * p.sd_ratio)
            })
            .collect();
        println!("   sd/prior: {}", ratios.join(", "));
        println!("   {}", id.explanation);
        if let Some(d) = &fit.design {
            let rows: Vec<String> = d
                .rows
                .iter()
                .map(|r| format!("{} x{}: {:.0} %", r.knob, r.factor, 100.0 * r.sd_ratio))
                .collect();
            println!("   design ({}): {}", d.parameter, rows.join(", "));
            println!("   {}", d.summary);
        }
    }
    Ok(())
}
