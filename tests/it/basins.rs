//! A posterior with two basins: the intervals come from the sampler over
//! both, not from a Gaussian at the MAP, and fit.json says so.
//!
//! The record's offset is `s^2` (a user's output component): `s` and `-s`
//! fit equally, the posterior of `s` is exactly symmetric and each basin
//! holds half of it. A Laplace interval at the MAP covers one sign only.

use std::sync::Arc;

use hbis::data::synthesize;
use hbis::inference::sample::SampleSettings;
use hbis::inference::Noise;
use hbis::model::{ForwardModel, OutputComponent, ParamSpec, Params, Registry};
use hbis::study::outputs::{fit_report, ChainOptions, FitRun};
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};

/// An accelerometer offset `s^2`: its sign is not in the record.
struct SquaredOffset;

impl OutputComponent for SquaredOffset {
    fn name(&self) -> &str {
        "squared-offset"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("s", "(m/s^2)^0.5", (-0.5, 0.5), 0.0)]
    }
    fn meaning(&self) -> &str {
        "an offset s^2: two basins, s and -s"
    }
    fn apply(&self, theta: &[f64], _dt: f64, accel: &mut [f64]) {
        accel.iter_mut().for_each(|a| *a += theta[0] * theta[0]);
    }
}

#[test]
fn two_basins_are_sampled_both_and_reported() {
    const SEED: u64 = 29;
    const S_TRUE: f64 = 0.2;
    let mut registry = Registry::builtin();
    registry.register_output(Arc::new(SquaredOffset)).unwrap();
    let model = registry
        .parse("trilinear+lcfm+viscous+squared-offset")
        .unwrap();
    let truth = model
        .theta_from_params(&Params::table_8_1(5).unwrap(), &[("s", S_TRUE)])
        .unwrap();
    let mut rng = StdRng::seed_from_u64(SEED);
    let syn = synthesize(&model, &truth, 0.01, 1001, 0.015, &mut rng).unwrap();
    let options = FitOptions {
        seed: SEED,
        sample: Some(
            SampleSettings::default()
                .with_tau_multiple(30.0)
                .unwrap()
                .with_max_steps(6000)
                .unwrap(),
        ),
        design_target: None,
        ..FitOptions::default()
    };
    let data = syn.record.aligned(None).unwrap();
    let fit = fit_record(
        model.clone(),
        data,
        None,
        Noise::White,
        &options,
        &mut |_| {},
    )
    .unwrap();
    let k = fit.names().iter().position(|n| n == "s").unwrap();
    eprintln!("seed {SEED}; basins: {:?}", fit.basins);

    // The MAP search found both signs, apart by a deep fall.
    assert_eq!(fit.basins.len(), 2, "{:?}", fit.basins);
    let (a, b) = (fit.basins[0].theta[k], fit.basins[1].theta[k]);
    assert!(
        (a.abs() - S_TRUE).abs() < 0.05 && (a + b).abs() < 0.02,
        "{a} {b}"
    );
    assert!(fit.basins[1].barrier > 10.0, "{:?}", fit.basins[1]);
    assert!(fit.basins[1].below_map < 2.0, "{:?}", fit.basins[1]);

    // Each basin holds half of the posterior. The share is a two-state
    // chain per walker: its effective draws are at most the kept sign
    // changes (and the sampler's ESS of s, whose sign is the basin); the
    // standard error is at most 0.5 / sqrt of that: four of them.
    let sample = fit.sample.as_ref().unwrap();
    let mut flips = 0usize;
    for c in &sample.chains {
        for w in 0..c.walkers() {
            for st in sample.burn + 1..sample.steps() {
                flips += usize::from(c.get(st, w)[k].signum() != c.get(st - 1, w)[k].signum());
            }
        }
    }
    let ess = sample.ess[k].min(flips as f64);
    let share = fit.basins[1].share.unwrap();
    let tol = 4.0 * 0.5 / ess.sqrt();
    eprintln!(
        "share of the second basin {share:.3}; effective draws {ess:.0} (ESS of s {:.0}, kept sign changes {flips}); tolerance {tol:.3}; {} steps, converged {}",
        sample.ess[k],
        sample.steps(),
        sample.converged
    );
    assert!(
        ess >= 50.0,
        "the walkers crossed between the basins {flips} times"
    );
    assert!((share - 0.5).abs() < tol, "share {share}, effective {ess}");

    // The sampler's 90 % interval spans both signs; a Gaussian at the MAP
    // with the posterior's within-basin spread covers one.
    let s = &fit.summaries.as_ref().unwrap()[k];
    assert!(s.q05 < -0.15 && s.q95 > 0.15, "{s:?}");
    let within: Vec<f64> = sample.draws()[k]
        .iter()
        .copied()
        .filter(|v| v.signum() == a.signum())
        .collect();
    let mean = within.iter().sum::<f64>() / within.len() as f64;
    let sd = (within.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / within.len() as f64).sqrt();
    assert!(
        (a - 1.645 * sd) * (a + 1.645 * sd) > 0.0,
        "a Laplace interval would hold one sign"
    );

    // fit.json says so, with the numbers.
    let run = FitRun {
        source: "synthetic".into(),
        seed: SEED,
        noise: Noise::White,
        record_warnings: Vec::new(),
        chains: ChainOptions::default(),
    };
    let report = fit_report(&fit, &run, Vec::new(), None);
    assert_eq!(report.basins.len(), 2);
    let w = report
        .warnings
        .iter()
        .find(|w| w.code == "several-basins")
        .expect("a several-basins warning");
    assert!(
        w.message.contains("2 basins") && w.message.contains("sampler"),
        "{}",
        w.message
    );
    assert_eq!(model.param_names()[k], "s");
}
