//! Measures the ESS stop rule's claimed Monte Carlo standard errors against
//! the observed errors of the posterior means, over many independent runs
//! on targets with known means, for several trust multiples.
//!
//! ```sh
//! cargo run --release --features examples --example ess_rule -- RUNS ESS SEED [K ...]
//! ```
//!
//! Targets: a correlated 10-D Gaussian, the Rosenbrock density, and the
//! posterior of `trilinear+lcfm+viscous` on a Test 5 record (10 s at 200
//! Hz, 1.5 % noise, seed 3: the inference bench's), whose means are taken
//! from one long run (ESS 100,000: its own error is a tenth of the short
//! runs' in sd, 1 % in variance).
//!
//! Defaults: 200 runs, ESS 1000, seed 1, K = 5 10 20 50. An argument
//! `moves=SPEC` (e.g. `moves=stretch`) sets the moves, `target=NAME` keeps
//! one target (`gaussian-10d` or `rosenbrock`).

use hbis::inference::ensemble::Moves;
use hbis::inference::stop_check::{check_rule, Target};
use hbis::inference::SampleSettings;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (named, args): (Vec<String>, Vec<String>) =
        std::env::args().skip(1).partition(|a| a.contains('='));
    let value = |key: &str| {
        named
            .iter()
            .find_map(|a| a.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
    };
    let moves = value("moves").map(Moves::parse).transpose()?;
    let only = value("target");
    let runs: usize = args.first().map_or(Ok(200), |s| s.parse())?;
    let ess: f64 = args.get(1).map_or(Ok(1000.0), |s| s.parse())?;
    let seed: u64 = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let ks: Vec<f64> = if args.len() > 3 {
        args[3..]
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![5.0, 10.0, 20.0, 50.0]
    };
    println!(
        "{runs} runs per row, ESS {ess}, seeds {seed}..{}, moves {}",
        seed + runs as u64 - 1,
        moves
            .as_ref()
            .map_or("default".to_string(), |m| m.to_string())
    );
    println!(
        "{:<14} {:>4} {:>9} {:>7} {:>10} {:>8} {:>12}  per-coordinate ratio",
        "target", "K", "converged", "steps", "evals", "pooled", "(+- se)"
    );
    let mut targets = vec![];
    for name in ["gaussian-10d", "rosenbrock", "test5-posterior"] {
        if only.is_some_and(|n| n != name) {
            continue;
        }
        targets.push(match name {
            "gaussian-10d" => Target::correlated_gaussian(),
            "rosenbrock" => Target::rosenbrock(),
            _ => {
                let t = std::time::Instant::now();
                let target = Target::test5_posterior(100_000.0)?;
                println!("test5 reference run: {:.0} s", t.elapsed().as_secs_f64());
                target
            }
        });
    }
    for target in &targets {
        for &k in &ks {
            let mut settings = SampleSettings::default()
                .with_ess(ess)?
                .with_trust_multiple(k)?;
            if let Some(m) = &moves {
                settings = settings.with_moves(m.clone());
            }
            let t = std::time::Instant::now();
            let c = check_rule(target, &settings, runs, seed)?;
            let ratios: Vec<String> = c.ratio.iter().map(|r| format!("{r:.2}")).collect();
            println!(
                "{:<14} {:>4} {:>9} {:>7.0} {:>10.0} {:>8.3} {:>12}  {}  ({:.1} s)",
                target.name,
                k,
                format!("{}/{}", c.converged, c.runs),
                c.steps,
                c.evaluations,
                c.pooled,
                format!("{:.3}", c.pooled_se),
                ratios.join(" "),
                t.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}
