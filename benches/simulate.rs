//! Speed of the closed-form forward model (issues: at most 5 us per
//! 2,001-sample evaluation, linear growth with the sample count; within 2x
//! of the sampling floor, `floor_2001`, measured beside it).

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

/// The sampling floor: the least work any sampler of a damped oscillation
/// does for 2,001 samples, with no events to find. Four interleaved complex
/// recurrences `z <- lambda^4 z` (the damped rotation over four samples),
/// each writing its real part, fill the record.
fn floor_fill(lambda: (f64, f64), z0: (f64, f64), out: &mut [f64]) {
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let l2 = mul(lambda, lambda);
    let l4 = mul(l2, l2);
    let mut z = [z0, mul(z0, lambda), mul(z0, l2), mul(mul(z0, l2), lambda)];
    let mut chunks = out.chunks_exact_mut(4);
    for chunk in &mut chunks {
        for k in 0..4 {
            chunk[k] = z[k].0;
            z[k] = mul(z[k], l4);
        }
    }
    for (slot, zk) in chunks.into_remainder().iter_mut().zip(&z) {
        *slot = zk.0;
    }
}

fn floor_2001(c: &mut Criterion) {
    // Test 5's rubber (f0 0.6 Hz) with zeta0 5 %, sampled at 200 Hz.
    let (w, zeta, dt) = (2.0 * std::f64::consts::PI * 0.6, 0.05, 0.005);
    let r = (-zeta * w * dt).exp();
    let phi = w * (1.0 - zeta * zeta).sqrt() * dt;
    let lambda = (r * phi.cos(), r * phi.sin());
    let mut out = vec![0.0; 2001];
    // Sanity: 10 s at 5 % damping leave a decayed, non-zero oscillation.
    floor_fill(lambda, (0.05, 0.0), &mut out);
    assert!(out[2000].abs() < 0.05 && out[2000] != 0.0);
    c.bench_function("floor_2001", |b| {
        b.iter(|| floor_fill(black_box(lambda), black_box((0.05, 0.0)), &mut out))
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
    // The core alone: parameters from the vector, the system resolved.
    c.bench_function("spec_test5_2001", |b| {
        b.iter(|| {
            let p = spec.params_from_slice(black_box(&theta)).unwrap();
            System::new(&spec, &p)
                .accel_grid_into(0.0, 0.005, &mut out, &SimOptions::default())
                .unwrap()
        })
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

/// The numerical engine on the same record: Test 5 with velocity-dependent
/// friction (Dormand-Prince with event location), and the closed-form
/// model itself solved numerically (its phases are affine: their exact
/// flow, `hbis::numeric::affine`). Criticism's refits of non-linear
/// effects spend most of their time here.
fn numeric_engine(c: &mut Criterion) {
    use hbis::model::{ForwardModel, Model};
    let p = Params::table_8_1(5).unwrap();
    let mut out = vec![0.0; 2001];
    let slow = Model::parse("trilinear+lcfm+viscous+velocity-friction").unwrap();
    let theta = slow
        .theta_from_params(&p, &[("r_mu", 0.4), ("v_t", 0.03)])
        .unwrap();
    c.bench_function("numeric_velocity_friction_test5_2001", |b| {
        b.iter(|| slow.accel_into(black_box(&theta), 0.005, &mut out).unwrap())
    });
    let plain = Model::parse("trilinear+lcfm+viscous")
        .unwrap()
        .numerically();
    let theta = plain.theta_from_params(&p, &[]).unwrap();
    c.bench_function("numeric_closed_form_test5_2001", |b| {
        b.iter(|| {
            plain
                .accel_into(black_box(&theta), 0.005, &mut out)
                .unwrap()
        })
    });
}

/// A component with memory (a Maxwell element, one state) on a 12 s,
/// 200 Hz record of Test 5, beside the closed form and the closed-form
/// model solved numerically on the same grid (each phase's exact flow).
/// The Maxwell element is affine: the engine solves it by the exact flow
/// too (the default with states since 2026-12-04).
fn memory_engine(c: &mut Criterion) {
    use hbis::model::{ForwardModel, Model, Registry};
    let p = Params::table_8_1(5).unwrap();
    let mut out = vec![0.0; 2401];
    let maxwell = Registry::builtin()
        .parse("trilinear+lcfm+viscous+maxwell")
        .unwrap();
    let theta = maxwell
        .theta_from_params(&p, &[("r_m", 0.15), ("tau_m", 0.4)])
        .unwrap();
    c.bench_function("numeric_maxwell_test5_2401", |b| {
        b.iter(|| {
            maxwell
                .accel_into(black_box(&theta), 0.005, &mut out)
                .unwrap()
        })
    });
    // A spring law with memory: smooth Bouc-Wen hysteresis.
    let bw = Registry::builtin().parse("bouc-wen+lcfm+viscous").unwrap();
    let theta = bw
        .theta_from_params(&p, &[("f2", p.f2), ("uy", p.uy), ("n", 1.5), ("beta", 0.6)])
        .unwrap();
    c.bench_function("numeric_bouc_wen_test5_2401", |b| {
        b.iter(|| bw.accel_into(black_box(&theta), 0.005, &mut out).unwrap())
    });
    // The same physics from the example effect file (expressions).
    let mut registry = Registry::builtin();
    registry
        .load_effect_file(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/effects/maxwell.toml"
        )))
        .unwrap();
    let file = registry
        .parse("trilinear+lcfm+viscous+maxwell-file")
        .unwrap();
    let theta = file
        .theta_from_params(&p, &[("r_mf", 0.15), ("tau_mf", 0.4)])
        .unwrap();
    c.bench_function("numeric_maxwell_file_test5_2401", |b| {
        b.iter(|| file.accel_into(black_box(&theta), 0.005, &mut out).unwrap())
    });
    let plain = Model::parse("trilinear+lcfm+viscous").unwrap();
    let theta = plain.theta_from_params(&p, &[]).unwrap();
    c.bench_function("closed_form_test5_2401", |b| {
        b.iter(|| {
            plain
                .accel_into(black_box(&theta), 0.005, &mut out)
                .unwrap()
        })
    });
    let numeric = plain.clone().numerically();
    c.bench_function("numeric_closed_form_test5_2401", |b| {
        b.iter(|| {
            numeric
                .accel_into(black_box(&theta), 0.005, &mut out)
                .unwrap()
        })
    });
}

criterion_group!(
    benches,
    floor_2001,
    record_2001,
    growth,
    record_100k,
    forward_model,
    numeric_engine,
    memory_engine
);
criterion_main!(benches);
