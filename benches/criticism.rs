//! Speed of model criticism (issue: `diagnose` on a 2,001-sample record
//! under 10 s, a full ladder under 30 s, on two cores).

use criterion::{criterion_group, criterion_main, Criterion};
use hbis::criticism::{diagnosis_of, fit_model, ladder, rank_candidates};
use hbis::data::{synthesize, Aligned};
use hbis::inference::{MapSettings, Noise};
use hbis::model::{Model, ModelSpec, Params, Registry};
use rand::{rngs::StdRng, SeedableRng};

/// A Test 8 record of the full model: `bilinear+coulomb` misses three
/// effects, and has eight candidates (trilinear, lcfm, viscous,
/// asymmetric-friction, velocity-friction, friction-decay, degradation,
/// offset).
fn record() -> Aligned {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(8).unwrap().to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(4);
    synthesize(&Model::from(spec), &truth, 0.005, 2001, 0.015, &mut rng)
        .unwrap()
        .record
        .aligned(None)
        .unwrap()
}

fn criticism(c: &mut Criterion) {
    let data = record();
    let start = Model::parse("bilinear+coulomb").unwrap();
    let registry = Registry::builtin();
    let settings = MapSettings::default();
    let mut g = c.benchmark_group("criticism_2001");
    g.sample_size(10);
    g.bench_function("diagnose_8_candidates", |b| {
        b.iter(|| {
            let fit = fit_model(&start, &data, Noise::White, None, &settings, 1).unwrap();
            let d = diagnosis_of(&start, &fit, &data).unwrap();
            let ranked = rank_candidates(&registry, &start, &fit, &data, &settings, 2).unwrap();
            assert_eq!(ranked.candidates.len(), 8);
            (d, ranked)
        })
    });
    g.bench_function("ladder_from_bilinear_coulomb", |b| {
        b.iter(|| {
            ladder(
                &registry,
                start.clone(),
                &data,
                Noise::White,
                &settings,
                1,
                6,
            )
            .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, criticism);
criterion_main!(benches);
