//! Laplace's approximation of the log-evidence (used to rank effects) against
//! transitional MCMC on a real posterior.

use hbis::criticism::{fit_model, priors_for};
use hbis::data::synthesize;
use hbis::inference::tmcmc::{tmcmc, TmcmcSettings};
use hbis::inference::{MapSettings, Noise, Posterior};
use hbis::model::{ForwardModel, Model, ModelSpec, Params};
use rand::{rngs::StdRng, SeedableRng};

#[test]
fn laplace_evidence_agrees_with_tmcmc() {
    let spec: ModelSpec = "bilinear+coulomb+viscous".parse().unwrap();
    let truth = spec
        .restrict(&Params::table_8_1(5).unwrap())
        .unwrap()
        .to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(12);
    let data = synthesize(&spec, &truth, 0.005, 2001, 0.015, &mut rng)
        .unwrap()
        .record
        .aligned(None)
        .unwrap();
    let model = Model::from(spec);
    let fit = fit_model(
        &model,
        &data,
        Noise::White,
        None,
        &MapSettings::default(),
        3,
    )
    .unwrap();
    let post = Posterior::new(
        model.clone(),
        data,
        priors_for(&model, Noise::White),
        Noise::White,
    )
    .unwrap();
    let (lower, upper): (Vec<f64>, Vec<f64>) = model.bounds().into_iter().unzip();
    let ln_like = |x: &[f64]| {
        let e = post.evaluate(x).unwrap();
        e.log_likelihood
    };
    // TMCMC under-estimates ln Z when its Metropolis moves mix too little
    // (here 5930 with 2,000 particles and 3 steps, 5932 with 4,000 and 10);
    // 8,000 particles with 20 steps per stage are needed on this posterior.
    let settings = TmcmcSettings {
        particles: 8000,
        steps: 20,
        scale: 0.2,
    };
    let runs: Vec<f64> = (0..2)
        .map(|seed| {
            let mut rng = StdRng::seed_from_u64(seed);
            let r = tmcmc(&ln_like, &lower, &upper, &settings, &mut rng);
            eprintln!(
                "TMCMC seed {seed}: ln Z = {:.2} in {} stages, {} evaluations",
                r.log_evidence, r.stages, r.evaluations
            );
            r.log_evidence
        })
        .collect();
    let spread = (runs[0] - runs[1]).abs();
    let mean = 0.5 * (runs[0] + runs[1]);
    eprintln!(
        "Laplace ln Z = {:.2}; TMCMC {:.2} (two runs differ by {spread:.2})",
        fit.log_evidence, mean
    );
    // TMCMC's own error is of order its run-to-run spread; Laplace adds the
    // error of a Gaussian approximation to a posterior that is only
    // piecewise smooth (measured: 0.95 nat). Agreement within a nat is what
    // model ranking needs (the effects the ladder adds change ln Z by
    // hundreds); a Hessian through the MAP's own value is 6 nats low here.
    assert!(
        (fit.log_evidence - mean).abs() < 1.0 + 2.0 * spread,
        "Laplace {} vs TMCMC {mean}",
        fit.log_evidence
    );
}
