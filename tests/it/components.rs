//! The model made of components: every piecewise-linear combination of the
//! registry solved in closed form agrees with an independent Runge-Kutta
//! integration and with the numerical engine; each new catalog component
//! hidden in records of random parameter sets is ranked first; a user's own
//! force component (examples/custom_force_effect.rs) is added by the ladder.

use crate::common;

use hbis::criticism::{adopt, choose_noise, diagnose_model, diagnosis_of, fit_model, ladder};
use hbis::data::{synthesize, Aligned};
use hbis::inference::{MapSettings, Noise};
use hbis::model::{ForwardModel, Model, Params, Registry, Response, SimOptions};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

#[allow(dead_code)]
#[path = "../../examples/custom_force_effect.rs"]
mod custom_force_effect;

const SPRINGS: [&str; 3] = ["linear", "bilinear", "trilinear"];
const FRICTIONS: [&str; 3] = ["", "+coulomb", "+lcfm"];
const DAMPERS: [&str; 2] = ["", "+viscous"];

/// Plausible random parameters of the full model.
fn random_params(rng: &mut StdRng) -> Params {
    let f0 = rng.random_range(0.3..1.2);
    let uy = rng.random_range(0.003..0.03);
    let u3 = uy * rng.random_range(1.5..8.0);
    Params {
        u0: u3 * rng.random_range(0.3..1.6),
        uy,
        uf0: rng.random_range(0.0005..0.005),
        rf0: rng.random_range(-0.02..0.02),
        zeta0: rng.random_range(0.0..0.1),
        f0,
        f1: f0 * rng.random_range(0.5..0.95),
        f2: f0 * rng.random_range(0.4..0.95),
        u3,
    }
}

/// Every spring law, friction law, damper and (with friction) asymmetric
/// friction: the closed form's displacement against the reference
/// integration (1e-9 m) and its acceleration against the numerical engine
/// (1e-6 relative) away from the jumps.
#[test]
fn every_piecewise_linear_combination_agrees_with_runge_kutta_and_the_numerical_engine() {
    let registry = Registry::builtin();
    let mut rng = StdRng::seed_from_u64(91);
    let (mut worst_u, mut worst_a, mut combos) = (0.0f64, 0.0f64, 0);
    for spring in SPRINGS {
        for friction in FRICTIONS {
            for damper in DAMPERS {
                for asym in [false, true] {
                    if asym && friction.is_empty() {
                        continue;
                    }
                    let spec = format!(
                        "{spring}{friction}{damper}{}",
                        if asym { "+asymmetric-friction" } else { "" }
                    );
                    let model = registry.parse(&spec).unwrap();
                    assert!(model.closed_form(), "{spec}");
                    combos += 1;
                    for _ in 0..8 {
                        let p = model.spec().restrict(&random_params(&mut rng)).unwrap();
                        let a_f = if asym {
                            rng.random_range(-0.5..0.5)
                        } else {
                            0.0
                        };
                        let theta = model.theta_from_params(&p, &[("a_F", a_f)]).unwrap();
                        let (dt, n) = (0.005, 1601);
                        let duration = dt * (n - 1) as f64;
                        let system = model.system(&theta).unwrap();
                        let r =
                            Response::of_system(system, duration, &SimOptions::default()).unwrap();
                        let ours = r.sample_grid(dt).unwrap();
                        let reference =
                            common::reference::solve_asymmetric(&model.spec(), &p, a_f, dt, n)
                                .unwrap();
                        let mut numeric = vec![0.0; n];
                        model
                            .numeric_grid_into(&theta, 0.0, dt, &mut numeric)
                            .unwrap();
                        let mut jumps = reference.jumps.clone();
                        jumps.extend(
                            r.phases()
                                .iter()
                                .filter(|q| q.v_end == 0.0)
                                .map(|q| q.t_end),
                        );
                        for ((s, q), a) in ours.iter().zip(&reference.samples).zip(&numeric) {
                            let du = (s.u - q.u).abs();
                            assert!(du < 1e-9, "{spec} {p:?} a_F {a_f} at t = {}: {du:e}", s.t);
                            worst_u = worst_u.max(du);
                            if jumps.iter().any(|&tj| (tj - s.t).abs() < 1e-6) {
                                continue;
                            }
                            let da = (s.a - a).abs() / (1.0 + s.a.abs());
                            assert!(da < 1e-6, "{spec} {p:?} a_F {a_f} at t = {}: {da:e}", s.t);
                            worst_a = worst_a.max(da);
                        }
                    }
                }
            }
        }
    }
    eprintln!(
        "{combos} combinations: closed form vs Runge-Kutta worst {worst_u:.1e} m, \
         vs the numerical engine worst {worst_a:.1e} (relative)"
    );
    assert_eq!(combos, 30);
}

/// A record of `model` at `theta`, 10 s at 200 Hz with `noise` times its
/// peak, and its noise floor: the `e2` of the truth on it (the realised
/// noise, which differs from its expectation by about 3 % at 2,001
/// samples).
fn record(model: &Model, theta: &[f64], noise: f64, seed: u64) -> (Aligned, f64) {
    let mut rng = StdRng::seed_from_u64(seed);
    let syn = synthesize(model, theta, 0.005, 2001, noise, &mut rng).unwrap();
    let floor = truth_e2(&syn.record.aligned(None).unwrap(), &syn.clean);
    (syn.record.aligned(None).unwrap(), floor)
}

/// `e2` of the noise-free record `clean` on `data`.
fn truth_e2(data: &Aligned, clean: &[f64]) -> f64 {
    let sse: f64 = data.a.iter().zip(clean).map(|(a, c)| (a - c).powi(2)).sum();
    sse / data.energy()
}

/// Table 8.1 column `test` perturbed by up to 10 %, kept so that the
/// release reaches the third branch.
fn random_truth(rng: &mut StdRng, test: u32) -> Params {
    let base = Params::table_8_1(test).unwrap();
    let mut p = base;
    for name in hbis::model::ParamName::ALL {
        let v = p.get(name) * (1.0 + 0.1 * (2.0 * rng.random::<f64>() - 1.0));
        p.set(name, v);
    }
    p.u3 = p.u3.min(0.8 * p.u0);
    p
}

/// How a hidden component is drawn and recorded.
struct Hidden {
    effect: &'static str,
    values: &'static dyn Fn(&mut StdRng) -> Vec<(&'static str, f64)>,
    /// Table 8.1 columns the random parameter sets are drawn around.
    tests: [u32; 2],
    /// Noise level, a fraction of the record's peak.
    noise: f64,
    seed: u64,
}

/// A component hidden in records of random parameter sets: `diagnose`
/// from `trilinear+lcfm+viscous` ranks it first and supported (so the
/// ladder, whose first step this is, adds it), and the fit the ladder
/// adopts reaches the noise floor within 2 %.
fn hidden(h: Hidden) {
    let Hidden {
        effect,
        values,
        tests,
        noise,
        seed,
    } = h;
    let registry = Registry::builtin();
    let start = registry.parse("trilinear+lcfm+viscous").unwrap();
    let truth_model = registry
        .parse(&format!("trilinear+lcfm+viscous+{effect}"))
        .unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    for (k, test) in tests.into_iter().enumerate() {
        let p = random_truth(&mut rng, test);
        let v = values(&mut rng);
        let theta = truth_model.theta_from_params(&p, &v).unwrap();
        let (data, floor) = record(&truth_model, &theta, noise, seed + k as u64);
        let (fit, _, ranked) = diagnose_model(
            &registry,
            &start,
            &data,
            Noise::White,
            &MapSettings::default(),
            1,
        )
        .unwrap();
        let names: Vec<(&str, f64, Option<f64>)> = ranked
            .iter()
            .map(|c| (c.effect.as_str(), c.delta_bic, c.delta_bic_off_jumps))
            .collect();
        assert_eq!(ranked[0].effect, effect, "{v:?}: {names:?}");
        assert!(ranked[0].supported, "{v:?}: {names:?}");
        let adopted = adopt(&ranked[0], &data, &MapSettings::default(), 2).unwrap();
        assert!(
            adopted.e2 <= 1.02 * floor,
            "{v:?}: e2 {} vs floor {floor} (start {}, screened {})",
            adopted.e2,
            fit.e2,
            ranked[0].e2
        );
        eprintln!(
            "{effect} {v:?}: start e2/floor {:.3}, screened {:.4}, adopted {:.4}; ranking {names:?}",
            fit.e2 / floor,
            ranked[0].e2 / floor,
            adopted.e2 / floor
        );
    }
}

/// A stiffness that falls by 10-25 % over the test shows at 1.5 % noise.
#[test]
fn hidden_stiffness_degradation_is_found() {
    hidden(Hidden {
        effect: "degradation",
        values: &|rng| vec![("kappa_k", rng.random_range(0.15..0.4))],
        tests: [3, 5],
        noise: 0.015,
        seed: 300,
    });
}

/// Asymmetric friction is mostly a constant force while sliding, which a
/// shifted release displacement absorbs (docs/components.md): it shows at
/// 1.5 % noise only when large and the friction is strong (Tests 7, 8).
#[test]
fn hidden_asymmetric_friction_is_found() {
    hidden(Hidden {
        effect: "asymmetric-friction",
        values: &|rng| {
            let a: f64 = rng.random_range(0.45..0.6);
            vec![("a_F", if rng.random_bool(0.5) { a } else { -a })]
        },
        tests: [8, 7],
        noise: 0.015,
        seed: 310,
    });
}

/// Asymmetric friction's imprint is a period drift, and only where
/// friction grows with amplitude (its module doc): on a quiet record
/// (0.2 % noise, seed 330) with `rF0 = -0.03` the fit without it leaves a
/// significant period drift, which its refit removes, and it is accepted;
/// with `rF0 = 0` the shifted release absorbs it and it is not supported.
/// (When it targeted the offset, it was refused on the first record: the
/// offset went from 0.431 to 1.280.)
#[test]
fn asymmetric_friction_shows_as_a_period_drift_where_friction_grows_with_amplitude() {
    let registry = Registry::builtin()
        .with_candidates(&["asymmetric-friction"])
        .unwrap();
    let start = registry.parse("trilinear+lcfm+viscous").unwrap();
    let truth = registry
        .parse("trilinear+lcfm+viscous+asymmetric-friction")
        .unwrap();
    let mut p = Params {
        u0: 0.1,
        uy: 0.007,
        uf0: 0.00225,
        rf0: -0.03,
        zeta0: 0.043,
        f0: 0.536,
        f1: 0.41,
        f2: 0.21,
        u3: 0.065,
    };
    for (rf0, added) in [(-0.03, true), (0.0, false)] {
        p.rf0 = rf0;
        let theta = truth.theta_from_params(&p, &[("a_F", 0.5)]).unwrap();
        let (data, _) = record(&truth, &theta, 0.002, 330);
        let (_, diagnosis, ranked) = diagnose_model(
            &registry,
            &start,
            &data,
            Noise::White,
            &MapSettings::default(),
            1,
        )
        .unwrap();
        let drift = |fs: &[hbis::criticism::features::Feature]| {
            fs.iter()
                .find(|f| f.kind == hbis::model::FeatureKind::PeriodDrift)
                .unwrap()
                .clone()
        };
        let c = &ranked[0];
        let after = drift(&diagnosis_of(&c.extended, &c.fit, &data).unwrap().features);
        let before = drift(&diagnosis.features);
        eprintln!(
            "rF0 {rf0}: period drift {:.4} ({:.1} se) -> {:.4}; delta BIC {:+.1}; {}",
            before.magnitude, before.z, after.magnitude, c.delta_bic, c.reason
        );
        assert_eq!(c.effect, "asymmetric-friction");
        assert_eq!(c.accepted, added, "rF0 {rf0}: {}", c.reason);
        if added {
            assert!(before.significant && !after.significant);
        } else {
            assert!(!c.supported && !before.significant);
        }
    }
}

/// Friction that decays with travel looks like friction that grows with
/// amplitude (`lcfm`) in a free vibration; beyond `lcfm` it shows only in
/// a quiet record (0.3 % noise).
#[test]
fn hidden_friction_decay_is_found() {
    hidden(Hidden {
        effect: "friction-decay",
        values: &|rng| vec![("kappa_F", rng.random_range(1.5..3.0))],
        tests: [5, 8],
        noise: 0.003,
        seed: 320,
    });
}

/// The user's gap spring of `examples/custom_force_effect.rs` among the
/// closed-form candidates (the catalog's numerically solved effects
/// withheld, which the full-suite test below keeps): `diagnose` from a
/// model without it ranks it first and accepts it, and its adopted fit
/// reaches the noise floor with the gap where the record put it.
#[test]
fn a_users_force_component_is_ranked_first_and_accepted() {
    let (registry, data, floor) = custom_force_effect::setup(5).unwrap();
    let registry = registry
        .withholding("velocity-friction")
        .withholding("friction-decay")
        .withholding("degradation");
    let start = Model::parse("trilinear+lcfm+viscous").unwrap();
    let settings = MapSettings::default();
    let (fit, _, ranked) =
        diagnose_model(&registry, &start, &data, Noise::White, &settings, 1).unwrap();
    let names: Vec<(&str, f64)> = ranked
        .iter()
        .map(|c| (c.effect.as_str(), c.delta_bic))
        .collect();
    assert_eq!(ranked[0].effect, "gap-spring", "{names:?}");
    assert!(ranked[0].accepted, "{}", ranked[0].reason);
    assert!(fit.e2 > 1.1 * floor, "start e2/floor {}", fit.e2 / floor);
    let adopted = adopt(&ranked[0], &data, &settings, 2).unwrap();
    assert!(
        adopted.e2 <= 1.02 * floor,
        "adopted e2/floor {}",
        adopted.e2 / floor
    );
    let model = registry.parse(&ranked[0].model).unwrap();
    let gap = model.layout().get(&adopted.theta, "gap").unwrap();
    assert!((gap - 0.08).abs() < 0.01, "gap {gap}");
}

/// The user's gap spring of `examples/custom_force_effect.rs`: the ladder
/// from a model without it, every catalog effect a candidate, adds it
/// first, reaches the noise floor and adds nothing after it.
#[test]
fn a_users_force_component_is_added_by_the_ladder() {
    let (registry, data, floor) = custom_force_effect::setup(5).unwrap();
    let start = Model::parse("trilinear+lcfm+viscous").unwrap();
    let steps = ladder(
        &registry,
        start,
        &data,
        Noise::White,
        &MapSettings::default(),
        1,
        3,
    )
    .unwrap();
    let models: Vec<(&str, f64)> = steps
        .iter()
        .map(|s| (s.model.as_str(), s.e2 / floor))
        .collect();
    assert_eq!(steps[1].added.as_deref(), Some("gap-spring"), "{models:?}");
    assert!(steps[0].e2 > 1.1 * floor, "{models:?}");
    assert!(steps[1].e2 <= 1.02 * floor, "{models:?}");
    let model = registry.parse(&steps[1].model).unwrap();
    let gap = model.layout().get(&steps[1].fit.theta, "gap").unwrap();
    assert!((gap - 0.08).abs() < 0.01, "gap {gap}");
    // Nothing the record lacks is added after it.
    assert_eq!(steps.len(), 2, "{models:?}");
    eprintln!("ladder: {models:?}");
}

/// `diagnose` and the ladder's first step are one computation. The
/// candidates on the numerical engine are withheld: they only make the
/// same comparison some 16 times costlier (the coloured-record test in
/// tests/it/cli_criticism.rs, in the full suite, keeps one).
#[test]
fn diagnose_and_the_ladders_first_step_agree() {
    let registry = Registry::builtin()
        .withholding("velocity-friction")
        .withholding("friction-decay")
        .withholding("degradation");
    let model = registry.parse("bilinear+coulomb+viscous").unwrap();
    let p = Params::table_8_1(5).unwrap();
    let truth_model = registry.parse("trilinear+lcfm+viscous").unwrap();
    let theta = truth_model.theta_from_params(&p, &[]).unwrap();
    let (data, _) = record(&truth_model, &theta, 0.015, 77);
    let settings = MapSettings::default();
    let (fit, _, ranked) =
        diagnose_model(&registry, &model, &data, Noise::White, &settings, 9).unwrap();
    let steps = ladder(
        &registry,
        model.clone(),
        &data,
        Noise::White,
        &settings,
        9,
        0,
    )
    .unwrap();
    assert_eq!(steps.len(), 1);
    assert_eq!(steps[0].e2, fit.e2);
    assert_eq!(steps[0].candidates.len(), ranked.len());
    for (a, b) in steps[0].candidates.iter().zip(&ranked) {
        assert_eq!(
            (&a.effect, a.e2, a.delta_bic),
            (&b.effect, b.e2, b.delta_bic)
        );
    }
    assert!(ranked.iter().all(|c| c.effect != "velocity-friction"));
    assert_eq!(model.param_names().len(), 6);
}

/// Criticism under AR(1) noise: every fit carries `rho`, and on a record
/// whose only departure from the start model is correlated noise, no
/// component is supported and the residual, whitened by the fitted noise
/// model, is called white (under white noise it is not).
#[test]
fn criticism_fits_ar1_noise_and_finds_nothing_in_coloured_noise() {
    use rand_distr::{Distribution, Normal};
    let registry = Registry::builtin()
        .withholding("velocity-friction")
        .withholding("friction-decay")
        .withholding("degradation");
    let model = registry.parse("trilinear+lcfm+viscous").unwrap();
    let theta = model
        .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
        .unwrap();
    let clean = synthesize(
        &model,
        &theta,
        0.005,
        2001,
        0.0,
        &mut StdRng::seed_from_u64(1),
    )
    .unwrap()
    .clean;
    let peak = clean.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    let (rho, sd) = (0.6, 0.015 * peak * (1.0f64 - 0.36).sqrt());
    let normal = Normal::new(0.0, sd).unwrap();
    let mut rng = StdRng::seed_from_u64(5);
    let mut e = 0.0;
    let a: Vec<f64> = clean
        .iter()
        .map(|c| {
            e = rho * e + normal.sample(&mut rng);
            c + e
        })
        .collect();
    let t = (0..a.len()).map(|i| i as f64 * 0.005).collect();
    let data = hbis::data::Record::new(t, a)
        .unwrap()
        .aligned(None)
        .unwrap();
    let (fit, diagnosis, ranked) = diagnose_model(
        &registry,
        &model,
        &data,
        Noise::Ar1,
        &MapSettings::default(),
        3,
    )
    .unwrap();
    assert!(
        diagnosis
            .verdict
            .contains("whitened by the fitted AR(1) noise")
            && diagnosis.verdict.contains("consistent with white noise"),
        "{}",
        diagnosis.verdict
    );
    // `--noise auto` picks AR(1) here, white on a white-noise record.
    let choice = choose_noise(&model, &data, &MapSettings::default(), 4).unwrap();
    assert_eq!(choice.chosen, Noise::Ar1, "{}", choice.sentence());
    let (white_record, _) = record(&model, &theta, 0.015, 6);
    let choice = choose_noise(&model, &white_record, &MapSettings::default(), 4).unwrap();
    assert_eq!(choice.chosen, Noise::White, "{}", choice.sentence());
    let white = fit_model(
        &model,
        &data,
        Noise::White,
        None,
        &MapSettings::default(),
        3,
    )
    .unwrap();
    let d = diagnosis_of(&model, &white, &data).unwrap();
    assert!(d.verdict.contains("is not white noise"), "{}", d.verdict);
    assert!(d.lag1 > 0.5, "{}", d.lag1);
    assert_eq!(fit.names.last().map(String::as_str), Some("rho"));
    let rho_hat = *fit.theta.last().unwrap();
    assert!((rho_hat - rho).abs() < 0.05, "rho {rho_hat}");
    assert_eq!(ranked.len(), 2);
    assert!(
        ranked.iter().all(|c| !c.supported),
        "{:?}",
        ranked
            .iter()
            .map(|c| (&c.effect, c.delta_bic))
            .collect::<Vec<_>>()
    );
    assert!(ranked
        .iter()
        .all(|c| c.fit.names.last().map(String::as_str) == Some("rho")));
}
