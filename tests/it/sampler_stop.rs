//! The stop rule on a 9-parameter record: a short tau multiple does not
//! stop the run on an early, too-small estimate of the autocorrelation
//! time, a run whose budget ends first says "not converged" with the
//! numbers, and the standard errors a run stopped by ESS claims are the
//! ones its means show.

use hbis::data::synthesize;
use hbis::inference::ensemble::Moves;
use hbis::inference::sample::{RHAT_MAX, TAU_TRUSTED};
use hbis::inference::stop_check::{check_rule, Target};
use hbis::inference::{Noise, PosteriorSample, SampleSettings};
use hbis::model::{ModelSpec, Params};
use hbis::study::{fit_record, FitOptions};
use rand::{rngs::StdRng, SeedableRng};

fn run(settings: SampleSettings) -> PosteriorSample {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(5);
    let syn = synthesize(
        &hbis::model::Model::from(spec),
        &truth,
        0.005,
        2001,
        0.015,
        &mut rng,
    )
    .unwrap();
    let options = FitOptions {
        seed: 5,
        sample: Some(settings),
        design_target: None,
        ..FitOptions::default()
    };
    let fit = fit_record(
        spec,
        syn.record.aligned(None).unwrap(),
        None,
        Noise::White,
        &options,
        &mut |_| {},
    )
    .unwrap();
    fit.sample.unwrap()
}

#[test]
fn a_short_tau_multiple_does_not_stop_on_an_early_estimate() {
    // The stretch move alone, as in the report that found the bug: at 100
    // steps its tau estimate was 7.5 against about 220 for the full run,
    // and `--tau-multiple 10` stopped there.
    let settings = SampleSettings::default()
        .with_tau_multiple(10.0)
        .unwrap()
        .with_moves(Moves::parse("stretch").unwrap());
    let s = run(settings);
    let tau_max = s.tau.iter().flatten().copied().fold(0.0, f64::max);
    let kept = (s.steps() - s.burn) as f64;
    let rhat = s.rhat.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "steps {}, burn {}, tau {tau_max:.1}, R-hat {rhat:.4}, converged {}",
        s.steps(),
        s.burn,
        s.converged
    );
    // Measured with emcee's estimate (trusted from 50 tau): 10,500 steps,
    // tau 214; without that trust rule the run stopped at 1,200 steps with
    // tau 73. With the multi-chain estimate (trusted from 5 tau): 5,200
    // steps, tau 302; with emcee's estimate and the trust multiple of 5 it
    // stopped at 600 steps (tau 42.5).
    assert!(s.steps() > 3000, "stopped at {} steps", s.steps());
    assert!(s.converged, "{}", s.not_converged);
    // The final chain bears out the rule the run stopped by: 10 tau (the
    // final tau is estimated on the same kept part as the check's).
    const { assert!(TAU_TRUSTED <= 10.0) };
    assert!(kept >= 10.0 * tau_max, "kept {kept}, tau {tau_max}");
    assert!(rhat <= RHAT_MAX + 0.005, "R-hat {rhat}");
}

#[test]
fn a_budget_too_small_says_not_converged_with_the_numbers() {
    let settings = SampleSettings::default()
        .with_max_steps(300)
        .unwrap()
        .with_moves(Moves::parse("stretch").unwrap());
    let s = run(settings);
    assert_eq!(s.steps(), 300);
    assert!(!s.converged);
    assert!(
        s.not_converged.contains("budget of 300 steps spent")
            && s.not_converged.contains("autocorrelation time estimate"),
        "{}",
        s.not_converged
    );
}

/// Runs stopped at ESS 1,000 (default moves and trust multiple) claim
/// Monte Carlo standard errors `sd / sqrt(ESS)` for their means: over
/// independent runs those must match the observed errors within 20 %
/// (issue 36). The pooled ratio's Monte Carlo sd is about 0.03-0.04 here,
/// so 0.2 is five of them. With emcee's single-walker estimate of tau
/// (the estimator before this check) the Gaussian's ratio was 1.39.
#[test]
fn claimed_standard_errors_match_the_observed_spread_of_means() {
    let settings = SampleSettings::default().with_ess(1000.0).unwrap();
    let (gauss_runs, post_runs, seed) = (100, 50, 36_000);
    eprintln!("seeds {seed}..{}", seed + gauss_runs as u64 - 1);
    let gaussian = Target::correlated_gaussian();
    let posterior = Target::test5_posterior(50_000.0).unwrap();
    for (target, runs) in [(gaussian, gauss_runs), (posterior, post_runs)] {
        let c = check_rule(&target, &settings, runs, seed).unwrap();
        eprintln!(
            "{}: {} of {} converged, {:.0} steps, {:.0} evaluations, pooled ratio {:.3} +- {:.3}, per coordinate {:.2?}",
            target.name, c.converged, c.runs, c.steps, c.evaluations, c.pooled, c.pooled_se, c.ratio
        );
        assert_eq!(c.converged, c.runs, "{}", target.name);
        assert!(
            (c.pooled - 1.0).abs() <= 0.2,
            "{}: claimed standard errors off by {:.3}",
            target.name,
            c.pooled
        );
    }
}
