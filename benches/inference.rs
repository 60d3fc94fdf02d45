//! Speed of the posterior and the MAP (issue: log-posterior within 1.5x of
//! the bare forward model on a 2,001-sample record; MAP under 1 s on two
//! cores).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use hbis::data::synthesize;
use hbis::inference::{find_map, MapSettings, Noise, Posterior};
use hbis::model::{ForwardModel, ModelSpec, Params};
use rand::{rngs::StdRng, SeedableRng};

fn posterior() -> (Posterior<ModelSpec>, Vec<f64>) {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(3);
    let syn = synthesize(&spec, &truth, 0.005, 2001, 0.015, &mut rng).unwrap();
    let data = syn.record.aligned(None).unwrap();
    (
        Posterior::with_default_priors(spec, data, Noise::White).unwrap(),
        truth,
    )
}

/// The forward model through the trait, and the log-posterior around it.
fn log_posterior(c: &mut Criterion) {
    let (post, theta) = posterior();
    let mut out = vec![0.0; 2001];
    let mut g = c.benchmark_group("posterior_2001");
    g.bench_function("forward_model", |b| {
        b.iter(|| {
            ModelSpec::FULL
                .accel_into(black_box(&theta), 0.005, &mut out)
                .unwrap()
        })
    });
    g.bench_function("log_posterior", |b| {
        b.iter(|| post.log_posterior(black_box(&theta)).unwrap())
    });
    g.finish();
}

/// CMA-ES with restarts and the polish, on a Test 5 record.
fn map(c: &mut Criterion) {
    let (post, _) = posterior();
    let mut g = c.benchmark_group("map_2001");
    g.sample_size(10);
    g.bench_function("cmaes_and_polish", |b| {
        b.iter(|| {
            let mut rng = StdRng::seed_from_u64(1);
            find_map(&post, &MapSettings::default(), &mut rng).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, log_posterior, map);
criterion_main!(benches);
