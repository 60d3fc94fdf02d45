//! Does an averaging sensor model remove the staircase from the
//! likelihood, and does the MAP search then converge?
//!
//! `trilinear+lcfm+viscous` records (2,001 samples at 5 ms, 1.5 % white
//! noise) from random parameter sets ([`random_wide_params`]), made twice
//! from the same truth and noise draw: sampled at the instant (the default
//! sensor) and as the mean over each sample interval (`+averaging`). Each
//! is fitted with its own sensor model, as `hbis fit --map-only` does it,
//! from three seeds. Per sensor it counts the MAP searches that reach the
//! noise floor (the truth's `e2` on the record), those that stop at their
//! evaluation budget, the evaluations, and how often the three seeds end
//! within 0.05 nats of each other (one basin found alike).
//!
//! ```sh
//! cargo run --release --features examples --example sensor_staircase -- 40 7000
//! ```
//! Arguments: records (40) and the first seed (7000); record `k` uses seed
//! `first + k` for its parameters and noise, and `3 (first + k) + j` for
//! fit `j`.

use hbis::data::{random_wide_params, synthesize};
use hbis::inference::{MapSettings, Noise, Posterior};
use hbis::model::Registry;
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};
use rayon::prelude::*;

/// One fit.
struct Run {
    /// MAP log-posterior.
    log_posterior: f64,
    /// `e2` over the truth's.
    ratio: f64,
    /// CMA-ES evaluations of the first search.
    evaluations: usize,
    /// Whether that search spent its budget.
    at_budget: bool,
}

/// Record `seed` under `sensor` ("" or "+averaging"), fitted from three seeds.
fn runs(seed: u64, sensor: &str) -> Vec<Run> {
    let registry = Registry::builtin();
    let model = registry
        .parse(&format!("trilinear+lcfm+viscous{sensor}"))
        .expect("a model");
    let mut rng = StdRng::seed_from_u64(seed);
    let p = random_wide_params(&mut rng);
    let truth = model.theta_from_params(&p, &[]).expect("in range");
    let syn = synthesize(&model, &truth, 0.005, 2001, 0.015, &mut rng).expect("simulates");
    let data = syn.record.aligned(None).expect("a release");
    let floor = Posterior::with_default_priors(model.clone(), data.clone(), Noise::White)
        .expect("priors")
        .evaluate(&truth)
        .expect("the truth runs")
        .e2;
    let budget = MapSettings::default().max_evals();
    (0..3)
        .map(|j| {
            let options = FitOptions::map_only(3 * seed + j);
            let fit = fit_record(
                model.clone(),
                data.clone(),
                None,
                Noise::White,
                &options,
                &mut |_| {},
            )
            .expect("a fit");
            Run {
                log_posterior: fit.map.eval.log_posterior,
                ratio: fit.map.eval.e2 / floor,
                evaluations: fit.map.cmaes_evaluations,
                at_budget: fit.map.cmaes_evaluations >= budget,
            }
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args.first().map_or(Ok(40), |s| s.parse())?;
    let first: u64 = args.get(1).map_or(Ok(7000), |s| s.parse())?;
    println!("records {n}, seeds {first}..{}", first + n);
    for (label, sensor) in [("instant", ""), ("averaging", "+averaging")] {
        let all: Vec<Vec<Run>> = (first..first + n)
            .into_par_iter()
            .map(|s| runs(s, sensor))
            .collect();
        let fits = all.iter().flatten().count();
        let reached = all
            .iter()
            .flatten()
            .filter(|r| r.ratio <= 1.0 + 1e-9)
            .count();
        let at_budget = all.iter().flatten().filter(|r| r.at_budget).count();
        let mut evals: Vec<usize> = all.iter().flatten().map(|r| r.evaluations).collect();
        evals.sort_unstable();
        let alike = all
            .iter()
            .filter(|rs| {
                let best = rs.iter().map(|r| r.log_posterior).fold(f64::MIN, f64::max);
                rs.iter().all(|r| r.log_posterior > best - 0.05)
            })
            .count();
        println!(
            "{label}: {reached} of {fits} fits reached the noise floor; {at_budget} stopped at the \
             budget; CMA-ES evaluations median {} (max {}); the three seeds agreed within \
             0.05 nats on {alike} of {n} records",
            evals[evals.len() / 2],
            evals[evals.len() - 1],
        );
    }
    Ok(())
}
