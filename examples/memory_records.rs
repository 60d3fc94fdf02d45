//! Out-of-catalog memory forces: how often criticism adds a catalog
//! stand-in, and how often `missing_form` names a memory term with the
//! right time constant. Each record is the paper's model at a random
//! parameter set around a Table 8.1 column (as the criticism calibration
//! draws them) plus a Maxwell element (the default catalog withholds
//! `maxwell`) of random size: `r_m` uniform in [0.05, 0.3], `tau_m`
//! log-uniform in [0.1, 1.5] s; 10 s at 200 Hz, 1.5 % white noise. Each is
//! diagnosed from `trilinear+lcfm+viscous`, and refitted with the truth
//! from its own parameters: a memory force whose truth does not beat the
//! start model by BIC 10 does not show on its record. Rates with
//! Clopper-Pearson 95 % intervals, over all records and over those where
//! the memory force shows. docs/criticism.md quotes its output.
//!
//! ```sh
//! cargo run --release --features examples --example memory_records -- [COUNT] [SEED]
//! ```

use hbis::criticism::calibration::random_truth;
use hbis::criticism::ranking::SUPPORT;
use hbis::criticism::{diagnose_model, fit_model, missing_form};
use hbis::data::synthesize;
use hbis::inference::{MapSettings, Noise};
use hbis::model::{ForwardModel, Model, Registry};
use rand::{rngs::StdRng, RngExt, SeedableRng};
use rayon::prelude::*;

/// Clopper-Pearson 95 % interval of `k` successes in `n`.
fn clopper_pearson(k: usize, n: usize) -> (f64, f64) {
    hbis::inference::proportion::clopper_pearson(k as f64, n as f64, 0.95)
}

struct Outcome {
    line: String,
    stand_in: bool,
    memory_named: bool,
    tau_right: bool,
    near_floor: bool,
    detectable: bool,
    /// The truth refitted from its own parameters puts `tau_m` within 30 %.
    oracle_tau_right: bool,
}

fn one(seed: u64) -> Result<Outcome, String> {
    let mut rng = StdRng::seed_from_u64(seed);
    let p = random_truth(&mut rng, &[3, 5, 6, 7, 8]);
    let r_m: f64 = rng.random_range(0.05..0.3);
    let tau: f64 = (rng.random_range(0.1f64.ln()..1.5f64.ln())).exp();
    let truth_model = Model::parse("trilinear+lcfm+viscous+maxwell").map_err(|e| e.to_string())?;
    let truth = truth_model
        .theta_from_params(&p, &[("r_m", r_m), ("tau_m", tau)])
        .map_err(|e| e.to_string())?;
    let data = synthesize(&truth_model, &truth, 0.005, 2001, 0.015, &mut rng)
        .map_err(|e| e.to_string())?
        .record
        .aligned(None)
        .map_err(|e| e.to_string())?;
    let mut clean = vec![0.0; data.a.len()];
    truth_model
        .accel_into(&truth, data.dt, &mut clean)
        .map_err(|e| e.to_string())?;
    let floor = data
        .a
        .iter()
        .zip(&clean)
        .map(|(x, m)| (x - m).powi(2))
        .sum::<f64>()
        / data.energy();
    let start = Model::parse("trilinear+lcfm+viscous").map_err(|e| e.to_string())?;
    let (fit, _, ranked) = diagnose_model(
        &Registry::builtin(),
        &start,
        &data,
        Noise::White,
        &MapSettings::default(),
        1,
    )
    .map_err(|e| e.to_string())?;
    let accepted = ranked.iter().find(|c| c.accepted).map(|c| c.effect.clone());
    // As `hbis diagnose` reports it.
    let form = missing_form(&start, &fit, &data, &MapSettings::default())
        .and_then(|f| {
            f.as_reported(
                accepted.is_some(),
                &start,
                &fit,
                &data,
                &MapSettings::default(),
            )
        })
        .map_err(|e| e.to_string())?;
    let memory = form.terms.iter().find(|t| t.kind == "memory");
    let found = memory.and_then(|t| t.time_constant_s);
    let kinds: Vec<&str> = form.terms.iter().map(|t| t.kind).collect();
    // The truth refitted from its own parameters: whether a memory force
    // of this size shows on this record at all (as the calibration's
    // `truth_delta_bic`).
    let oracle = fit_model(
        &truth_model,
        &data,
        Noise::White,
        Some(truth.clone()),
        &MapSettings::default(),
        2,
    )
    .map_err(|e| e.to_string())?;
    let truth_delta_bic = oracle.bic - fit.bic;
    // What the record itself determines: the true structure's own refit
    // of the time constant, the most a report of the form can hope for.
    let k = oracle
        .names
        .iter()
        .position(|n| n == "tau_m")
        .ok_or("the truth has no tau_m")?;
    let (oracle_tau, oracle_sd) = (oracle.theta[k], oracle.sd[k]);
    Ok(Outcome {
        line: format!(
            "seed {seed}: r_m {r_m:.3}, tau_m {tau:.3} s; start e2 {:.3} of the floor; the truth refitted: BIC {truth_delta_bic:+.1}, tau_m {oracle_tau:.3} s (sd {oracle_sd:.3}); accepted {accepted:?}; terms {kinds:?}, memory tau {found:?}; with them e2 {:?} of the floor",
            fit.e2 / floor,
            form.e2_with.map(|e| e / floor)
        ),
        stand_in: accepted.is_some(),
        memory_named: memory.is_some(),
        tau_right: found.is_some_and(|f| (f / tau - 1.0).abs() <= 0.3),
        near_floor: form.e2_with.is_some_and(|e| e / floor <= 1.03),
        detectable: truth_delta_bic < -SUPPORT,
        oracle_tau_right: (oracle_tau / tau - 1.0).abs() <= 0.3,
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count: usize = args.first().map_or(Ok(10), |s| s.parse())?;
    let seed: u64 = args.get(1).map_or(Ok(20_261_128), |s| s.parse())?;
    let outcomes: Vec<Outcome> = (0..count as u64)
        .into_par_iter()
        .map(|i| one(seed.wrapping_mul(1_000_003).wrapping_add(i)))
        .collect::<Result<_, _>>()?;
    for o in &outcomes {
        println!("{}", o.line);
    }
    let n = outcomes.len();
    let count = |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|o| f(o)).count();
    let detectable = count(&|o| o.detectable);
    for (what, k, of) in [
        ("a catalog stand-in accepted", count(&|o| o.stand_in), n),
        ("a memory term named", count(&|o| o.memory_named), n),
        ("its time constant within 30 %", count(&|o| o.tau_right), n),
        (
            "with the terms' effect file, e2 within 3 % of the floor",
            count(&|o| o.near_floor),
            n,
        ),
        (
            "the memory force detectable (the truth refitted: BIC below -10)",
            detectable,
            n,
        ),
        (
            "detectable: a memory term named",
            count(&|o| o.detectable && o.memory_named),
            detectable,
        ),
        (
            "detectable: its time constant within 30 %",
            count(&|o| o.detectable && o.tau_right),
            detectable,
        ),
        (
            "detectable: e2 within 3 % of the floor",
            count(&|o| o.detectable && o.near_floor),
            detectable,
        ),
        (
            "the truth refitted: its time constant within 30 %",
            count(&|o| o.oracle_tau_right),
            n,
        ),
        (
            "where the truth's refit is within 30 %: the form's too",
            count(&|o| o.oracle_tau_right && o.tau_right),
            count(&|o| o.oracle_tau_right),
        ),
    ] {
        if of == 0 {
            continue;
        }
        let (lo, hi) = clopper_pearson(k, of);
        println!(
            "{what}: {k} of {of} ({:.0} %, 95 % interval {:.0}-{:.0} %)",
            100.0 * k as f64 / of as f64,
            100.0 * lo,
            100.0 * hi
        );
    }
    Ok(())
}
