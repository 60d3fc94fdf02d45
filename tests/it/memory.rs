//! Components with memory (state variables) in the numerical engine,
//! checked against an independent integration written here: classic
//! fixed-step RK4 (not the engine's Dormand-Prince), reversals located by
//! bisection of the step, and the rest phase solved in closed form (at rest
//! the Maxwell element relaxes exponentially, so the restart time is a
//! logarithm; a Bouc-Wen spring does not change at rest). The Bouc-Wen
//! release state for `n = 2` is the exact `z = uy tanh(u0/uy)`.

use hbis::model::{ForwardModel, Model, Params, Registry};

/// The rubber with memory: a linear spring `k0` with a Maxwell element
/// (`km`, `tau`; state `q`, `q = u0` at the release), or a Bouc-Wen spring
/// (`k2`, `uy`, `n = 2`, `beta`; state `z`).
#[derive(Clone, Copy)]
enum Rubber {
    Maxwell { km: f64, tau: f64 },
    BoucWen { k2: f64, uy: f64, beta: f64 },
}

/// That rubber, Coulomb friction `F` and a damper `c` (all per unit mass),
/// released from `u0`.
struct Reference {
    k0: f64,
    f: f64,
    c: f64,
    rubber: Rubber,
    u0: f64,
}

impl Reference {
    /// The rubber's force at `y = (u, v, state)`.
    fn spring(&self, y: &[f64; 3]) -> f64 {
        match self.rubber {
            Rubber::Maxwell { km, .. } => self.k0 * y[0] + km * (y[0] - y[2]),
            Rubber::BoucWen { k2, .. } => k2 * y[0] + (self.k0 - k2) * y[2],
        }
    }

    fn accel(&self, d: f64, y: &[f64; 3]) -> f64 {
        -(self.spring(y) + d * self.f + self.c * y[1])
    }

    fn rhs(&self, d: f64, y: &[f64; 3]) -> [f64; 3] {
        let rate = match self.rubber {
            Rubber::Maxwell { tau, .. } => (y[0] - y[2]) / tau,
            Rubber::BoucWen { uy, beta, .. } => {
                let s = (y[1] * y[2]).signum();
                y[1] * (1.0 - (beta * s + 1.0 - beta) * (y[2] / uy).powi(2))
            }
        };
        [y[1], self.accel(d, y), rate]
    }

    fn release_state(&self) -> f64 {
        match self.rubber {
            Rubber::Maxwell { .. } => self.u0,
            Rubber::BoucWen { uy, .. } => uy * (self.u0 / uy).tanh(),
        }
    }

    fn rk4(&self, d: f64, y: &[f64; 3], h: f64) -> [f64; 3] {
        let add = |a: &[f64; 3], k: &[f64; 3], s: f64| std::array::from_fn(|i| a[i] + s * k[i]);
        let k1 = self.rhs(d, y);
        let k2 = self.rhs(d, &add(y, &k1, h / 2.0));
        let k3 = self.rhs(d, &add(y, &k2, h / 2.0));
        let k4 = self.rhs(d, &add(y, &k3, h));
        std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    /// The direction the static drive (the rubber's force) starts the
    /// mass in, if it beats the friction.
    fn start(&self, y: &[f64; 3]) -> Option<f64> {
        let drive = self.spring(y);
        (drive.abs() > self.f).then(|| -drive.signum())
    }

    /// The acceleration and velocity on the grid `i dt`, `n` samples, and
    /// the times the mass came to rest and started again.
    fn solve(&self, dt: f64, n: usize, substeps: usize) -> (Vec<[f64; 2]>, Vec<(f64, f64)>) {
        let h = dt / substeps as f64;
        let mut y = [self.u0, 0.0, self.release_state()];
        let mut dir = self.start(&y);
        let mut t = 0.0;
        let mut out = Vec::with_capacity(n);
        let mut rests: Vec<(f64, f64)> = Vec::new();
        for i in 0..n {
            let ti = i as f64 * dt;
            while t < ti {
                let Some(d) = dir else {
                    let Rubber::Maxwell { km, tau } = self.rubber else {
                        // A Bouc-Wen spring rests for good.
                        t = ti;
                        continue;
                    };
                    // At rest: q relaxes towards u in closed form; the drive
                    // k0 u - km (q - u) reaches +-F at a logarithmic time.
                    let (u, q0) = (y[0], y[2]);
                    let restart = [1.0, -1.0]
                        .iter()
                        .filter_map(|&s: &f64| {
                            let ratio = (self.k0 * u - s * self.f) / (km * (q0 - u));
                            (ratio > 0.0 && ratio < 1.0).then(|| (-tau * ratio.ln(), s))
                        })
                        .fold(None, |best: Option<(f64, f64)>, c| match best {
                            Some(b) if b.0 <= c.0 => Some(b),
                            _ => Some(c),
                        });
                    let relax = |dt: f64| u + (q0 - u) * (-dt / tau).exp();
                    match restart {
                        Some((dt_r, s)) if t + dt_r < ti => {
                            t += dt_r;
                            y[2] = relax(dt_r);
                            dir = Some(-s);
                            if let Some(r) = rests.last_mut() {
                                r.1 = t;
                            }
                        }
                        _ => {
                            y[2] = relax(ti - t);
                            t = ti;
                        }
                    }
                    continue;
                };
                let step = h.min(ti - t);
                let next = self.rk4(d, &y, step);
                if d * next[1] > 0.0 {
                    y = next;
                    t += step;
                    continue;
                }
                // A reversal inside the step: bisect its length.
                let (mut lo, mut hi) = (0.0, step);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if d * self.rk4(d, &y, mid)[1] > 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                y = self.rk4(d, &y, hi);
                y[1] = 0.0;
                t += hi;
                dir = self.start(&y);
                if dir.is_none() {
                    rests.push((t, f64::INFINITY));
                }
            }
            out.push(match dir {
                Some(d) => [self.accel(d, &y), y[1]],
                None => [0.0, 0.0],
            });
        }
        (out, rests)
    }
}

fn params(f0: f64, uf0: f64, zeta0: f64, u0: f64) -> Params {
    Params {
        u0,
        uy: 0.01,
        uf0,
        rf0: 0.0,
        zeta0,
        f0,
        f1: f0,
        f2: f0,
        u3: 0.1,
    }
}

/// Compares the engine with the reference; returns the largest difference
/// away from the jumps and the reference's rests.
fn compare(p: &Params, r_m: f64, tau_m: f64, dt: f64, n: usize) -> (f64, Vec<(f64, f64)>) {
    let k0 = (2.0 * std::f64::consts::PI * p.f0).powi(2);
    let rubber = Rubber::Maxwell {
        km: r_m * k0,
        tau: tau_m,
    };
    compare_with(
        "linear+coulomb+viscous+maxwell",
        p,
        &[("r_m", r_m), ("tau_m", tau_m)],
        rubber,
        dt,
        n,
    )
}

fn compare_with(
    spec: &str,
    p: &Params,
    others: &[(&str, f64)],
    rubber: Rubber,
    dt: f64,
    n: usize,
) -> (f64, Vec<(f64, f64)>) {
    let model = Registry::builtin().parse(spec).unwrap();
    let theta = model.theta_from_params(p, others).unwrap();
    let mut engine = vec![0.0; n];
    model.accel_into(&theta, dt, &mut engine).unwrap();
    let k0 = (2.0 * std::f64::consts::PI * p.f0).powi(2);
    let reference = Reference {
        k0,
        f: p.uf0 * k0,
        c: 2.0 * p.zeta0 * k0.sqrt(),
        rubber,
        u0: p.u0,
    };
    let (expected, rests) = reference.solve(dt, n, 40);
    let motion = model.motion_grid(&theta, 0.0, dt, n).unwrap();
    // Samples next to a jump (reversal, stop, restart) of either solution
    // may fall on either side of it in the two integrations: the mode (at
    // rest, or the direction of sliding) must be the same at i - 1, i, i + 1.
    let mode = |v: f64| if v == 0.0 { 0.0 } else { v.signum() };
    let steady = |m: &dyn Fn(usize) -> f64, i: usize| m(i - 1) == m(i) && m(i) == m(i + 1);
    let mut worst = 0.0f64;
    for i in 1..n - 1 {
        if !steady(&|j| mode(motion[j].v), i) || !steady(&|j| mode(expected[j][1]), i) {
            continue;
        }
        worst = worst.max((engine[i] - expected[i][0]).abs() / (1.0 + expected[i][0].abs()));
    }
    (worst, rests)
}

#[test]
fn maxwell_engine_matches_an_independent_integration() {
    for (f0, uf0, zeta0, u0, r_m, tau_m) in [
        (0.5, 0.004, 0.05, 0.1, 0.3, 0.4),
        (0.8, 0.002, 0.02, 0.06, 0.8, 0.05),
        (0.4, 0.006, 0.0, 0.15, 0.1, 3.0),
    ] {
        let p = params(f0, uf0, zeta0, u0);
        let (worst, _) = compare(&p, r_m, tau_m, 0.005, 2001);
        eprintln!("maxwell f0 {f0} r_m {r_m} tau_m {tau_m}: worst relative difference {worst:.2e}");
        assert!(worst < 1e-6, "{worst}");
    }
}

/// At rest the element keeps relaxing; once the rubber alone beats the
/// friction the mass slides again. Both integrations must see the restart
/// at the same time and agree after it.
#[test]
fn a_relaxing_state_restarts_the_mass_at_rest() {
    // A stiff, slow element holds the mass off-centre after its first
    // swing; the rubber's force exceeds the friction once it relaxes.
    let p = params(0.5, 0.02, 0.0, 0.1);
    let (worst, rests) = compare(&p, 1.0, 1.5, 0.005, 3001);
    eprintln!("restart case: rests {rests:?}, worst relative difference {worst:.2e}");
    assert!(
        rests.iter().any(|r| r.1.is_finite()),
        "the case must rest and restart: {rests:?}"
    );
    assert!(worst < 1e-6, "{worst}");
    // The engine restarts too: rest samples followed by motion.
    let model = Registry::builtin()
        .parse("linear+coulomb+viscous+maxwell")
        .unwrap();
    let theta = model
        .theta_from_params(&p, &[("r_m", 1.0), ("tau_m", 1.5)])
        .unwrap();
    let m = model.motion_grid(&theta, 0.0, 0.005, 3001).unwrap();
    let (t_stop, t_go) = rests.iter().find(|r| r.1.is_finite()).copied().unwrap();
    let i_rest = ((t_stop + t_go) / 2.0 / 0.005) as usize;
    let i_move = (t_go / 0.005) as usize + 5;
    assert_eq!(m[i_rest].v, 0.0, "at rest at t = {}", i_rest as f64 * 0.005);
    assert!(
        m[i_move].v != 0.0,
        "moving again at t = {}",
        i_move as f64 * 0.005
    );
}

/// `r_m = 0`: the element exerts no force, and the engine that carries its
/// state reproduces the closed form in every regime.
#[test]
fn maxwell_with_no_stiffness_is_the_closed_form() {
    let registry = Registry::builtin();
    let mut checked = 0usize;
    for case in crate::common::cases(17, 60) {
        let base = Model::from(case.spec);
        let Ok(with) = registry.parse(&format!("{}+maxwell", base.name())) else {
            continue;
        };
        let theta = base.theta_from_params(&case.params, &[]).unwrap();
        let mut closed = vec![0.0; case.n];
        if base.accel_into(&theta, case.dt, &mut closed).is_err() {
            continue;
        }
        let theta_m = with
            .theta_from_params(&case.params, &[("r_m", 0.0), ("tau_m", 0.3)])
            .unwrap();
        let mut numeric = vec![0.0; case.n];
        with.accel_into(&theta_m, case.dt, &mut numeric).unwrap();
        let motion = base.motion_grid(&theta, 0.0, case.dt, case.n).unwrap();
        for i in 1..case.n - 1 {
            if motion[i - 1..=i + 1].iter().any(|m| m.v == 0.0)
                || motion[i - 1].v.signum() != motion[i + 1].v.signum()
            {
                continue;
            }
            let err = (closed[i] - numeric[i]).abs() / (1.0 + closed[i].abs());
            assert!(
                err < 1e-6,
                "{case:?} at {i}: {} vs {}",
                closed[i],
                numeric[i]
            );
            checked += 1;
        }
    }
    eprintln!("maxwell r_m = 0 against the closed form: {checked} samples");
    assert!(checked > 20_000, "{checked}");
}

/// Under shaking from rest (`q = 0`), an element that never relaxes
/// (`tau_m` far beyond the motion) is a linear spring `r_m k0` beside the
/// rubber: the closed form of a linear model with `k0 (1 + r_m)` (its
/// friction and damper rescaled to the same forces) gives the same motion,
/// sticking and breakaway included.
#[test]
fn an_unrelaxing_element_under_shaking_is_an_added_spring() {
    use hbis::data::ground_motion::KanaiTajimi;
    use hbis::model::forced::Excitation;

    let registry = Registry::builtin();
    let with = registry.parse("linear+coulomb+viscous+maxwell").unwrap();
    let plain = registry.parse("linear+coulomb+viscous").unwrap();
    let mut compared = 0usize;
    for (seed, r_m, uf0) in [(3u64, 0.5, 0.01), (4, 0.2, 0.03), (5, 1.0, 0.002)] {
        let ag = KanaiTajimi {
            pga: 3.0,
            duration: 6.0,
            t1: 0.5,
            t2: 3.0,
            decay: 0.8,
            ..KanaiTajimi::default()
        }
        .generate(seed)
        .unwrap()
        .ag;
        let ex = Excitation::new(0.01, &ag, 3.0).unwrap();
        let p = params(0.5, uf0, 0.05, 0.1);
        let theta = with
            .theta_from_params(&p, &[("r_m", r_m), ("tau_m", 1e7)])
            .unwrap();
        let stiff = 1.0 + r_m;
        let q = Params {
            f0: p.f0 * stiff.sqrt(),
            uf0: p.uf0 / stiff,
            zeta0: p.zeta0 / stiff.sqrt(),
            ..p
        };
        let (mut u_mem, mut u_lin) = (Vec::new(), Vec::new());
        let peaks = with.forced(&theta, &ex, &mut u_mem).unwrap();
        let expected = plain
            .forced(&plain.theta_from_params(&q, &[]).unwrap(), &ex, &mut u_lin)
            .unwrap();
        let scale = expected.peak_displacement;
        let worst = u_mem
            .iter()
            .zip(&u_lin)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "seed {seed} r_m {r_m}: peak {:.6} m against {:.6} m, worst difference {worst:.2e} m",
            peaks.peak_displacement, scale
        );
        assert!(worst < 1e-5 * scale, "{worst} against {scale}");
        assert!((peaks.peak_displacement - scale).abs() < 1e-5 * scale);
        compared += u_mem.len();
    }
    assert!(compared > 2_000, "{compared}");
}

/// How a component offered on request is found: `diagnose` from
/// `trilinear+lcfm+viscous`, offering `offered`, on a Test 5 record made
/// with `truth` (1.5 % noise, record seed `seed`) ranks `effect` first and
/// supported, extending to `extended`, and the adopted fit reaches the
/// noise floor within 3 %.
struct Found<'a> {
    effect: &'a str,
    offered: &'a [&'a str],
    truth: &'a str,
    values: &'a [(&'a str, f64)],
    extended: &'a str,
    seed: u64,
}

fn found(f: Found) {
    use hbis::criticism::{adopt, diagnose_model};
    use hbis::inference::{MapSettings, Noise};

    let builtin = Registry::builtin();
    assert!(!builtin.offered().contains(&f.effect));
    let start = builtin.parse("trilinear+lcfm+viscous").unwrap();
    let registry = builtin.with_candidates(f.offered).unwrap();
    let truth_model = registry.parse(f.truth).unwrap();
    let theta = truth_model
        .theta_from_params(&Params::table_8_1(5).unwrap(), f.values)
        .unwrap();
    eprintln!("record seed {}, diagnosis seed 1", f.seed);
    let (_, data, floor) = crate::common::noisy_record(&truth_model, &theta, f.seed);
    let settings = MapSettings::default();
    let (fit, _, ranked) =
        diagnose_model(&registry, &start, &data, Noise::White, &settings, 1).unwrap();
    let names: Vec<(&str, f64)> = ranked
        .iter()
        .map(|c| (c.effect.as_str(), c.delta_bic))
        .collect();
    eprintln!("start e2/floor {:.4}; ranking {names:?}", fit.e2 / floor);
    assert_eq!(ranked[0].effect, f.effect, "{names:?}");
    assert_eq!(ranked[0].extended.name(), f.extended);
    assert!(ranked[0].supported, "{names:?}");
    let adopted = adopt(&ranked[0], &data, &settings, 2).unwrap();
    eprintln!("adopted e2/floor {:.4}", adopted.e2 / floor);
    assert!(adopted.e2 <= 1.03 * floor, "{} vs {floor}", adopted.e2);
}

/// `maxwell` is parsed and fitted when named but offered as a candidate
/// only on request; offered, it is found.
#[test]
fn maxwell_is_offered_on_request_and_found() {
    found(Found {
        effect: "maxwell",
        offered: &["maxwell", "offset", "asymmetric-friction"],
        truth: "trilinear+lcfm+viscous+maxwell",
        values: &[("r_m", 0.1), ("tau_m", 0.3)],
        extended: "trilinear+lcfm+viscous+maxwell",
        seed: 44,
    });
}

/// A Bouc-Wen spring (`n = 2`, where the virgin curve is exact) against the
/// independent integration: the engine's release state (its own RK4 in `u`)
/// and its integration of `z` agree with the reference's.
#[test]
fn bouc_wen_engine_matches_an_independent_integration() {
    for (f0, f2, uy, beta, uf0, u0) in [
        (0.6, 0.3, 0.01, 0.5, 0.003, 0.1),
        (0.5, 0.2, 0.02, 0.9, 0.001, 0.15),
        (0.8, 0.5, 0.005, 0.1, 0.006, 0.05),
        // Released short of saturation: z = uy tanh(1.2), not uy.
        (0.5, 0.25, 0.05, 0.5, 0.002, 0.06),
    ] {
        let mut p = params(f0, uf0, 0.03, u0);
        p.uy = uy;
        let k2 = (2.0 * std::f64::consts::PI * f2).powi(2);
        let (worst, _) = compare_with(
            "bouc-wen+coulomb+viscous",
            &p,
            &[("f2", f2), ("uy", uy), ("n", 2.0), ("beta", beta)],
            Rubber::BoucWen { k2, uy, beta },
            0.005,
            2001,
        );
        eprintln!(
            "bouc-wen f0 {f0} f2 {f2} uy {uy} beta {beta}: worst relative difference {worst:.2e}"
        );
        assert!(worst < 1e-6, "{worst}");
    }
}

/// `bouc-wen` is offered on request; offered, on a record made with a
/// smooth Bouc-Wen spring the swap of the spring law is found
/// (`bouc-wen+lcfm+viscous`).
#[test]
fn the_spring_law_is_swapped_for_bouc_wen() {
    let p = Params::table_8_1(5).unwrap();
    found(Found {
        effect: "bouc-wen",
        offered: &["bouc-wen", "offset"],
        truth: "bouc-wen+lcfm+viscous",
        values: &[("f2", p.f2), ("uy", p.uy), ("n", 1.5), ("beta", 0.6)],
        extended: "bouc-wen+lcfm+viscous",
        seed: 45,
    });
}
