//! Speed of the closed-form forward model (issue: at most 5 us per
//! 2,001-sample evaluation, linear growth with the sample count).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use hbis::model::{ModelSpec, Params, SimOptions, System};

fn test5() -> System {
    System::new(&ModelSpec::FULL, &Params::table_8_1(5).unwrap())
}

/// The Solarino record: 10 s at 200 Hz.
fn record_2001(c: &mut Criterion) {
    let sys = test5();
    let mut out = vec![0.0; 2001];
    let opts = SimOptions::default();
    c.bench_function("test5_10s_200Hz_2001", |b| {
        b.iter(|| {
            black_box(&sys)
                .accel_into(black_box(0.005), &mut out, &opts)
                .unwrap()
        })
    });
}

/// The same 10 s sampled ever finer: the cost per sample once the events are
/// found.
fn growth(c: &mut Criterion) {
    let sys = test5();
    let opts = SimOptions::default();
    let mut g = c.benchmark_group("test5_10s_by_samples");
    for n in [2_001usize, 10_001, 100_001] {
        let dt = 10.0 / (n - 1) as f64;
        let mut out = vec![0.0; n];
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &dt, |b, &dt| {
            b.iter(|| sys.accel_into(black_box(dt), &mut out, &opts).unwrap())
        });
    }
    g.finish();
}

/// A long record: 100,000 samples at 200 Hz (500 s), with an undamped,
/// friction-free spring so that it never comes to rest.
fn record_100k(c: &mut Criterion) {
    let spec: ModelSpec = "trilinear".parse().unwrap();
    let p = spec.restrict(&Params::table_8_1(5).unwrap()).unwrap();
    let sys = System::new(&spec, &p);
    let opts = SimOptions::default();
    let mut out = vec![0.0; 100_000];
    c.bench_function("trilinear_500s_200Hz_100000", |b| {
        b.iter(|| sys.accel_into(black_box(0.005), &mut out, &opts).unwrap())
    });
}

/// The same record through the `ForwardModel` trait, as inference calls it
/// (parameters from a vector, the system resolved on every call).
fn forward_model(c: &mut Criterion) {
    use hbis::model::ForwardModel;
    let spec = ModelSpec::FULL;
    let theta = Params::table_8_1(5).unwrap().to_theta(&spec);
    let mut out = vec![0.0; 2001];
    c.bench_function("spec_test5_2001", |b| {
        b.iter(|| spec.accel_into(black_box(&theta), 0.005, &mut out).unwrap())
    });
    let model = hbis::model::Model::from(ModelSpec::FULL);
    let theta_m = model
        .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
        .unwrap();
    c.bench_function("model_test5_2001", |b| {
        b.iter(|| {
            model
                .accel_into(black_box(&theta_m), 0.005, &mut out)
                .unwrap()
        })
    });
}

criterion_group!(benches, record_2001, growth, record_100k, forward_model);
criterion_main!(benches);
