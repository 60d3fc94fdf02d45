//! The closed form against an independent adaptive Runge-Kutta integration
//! (Dormand-Prince 5(4), rtol 1e-12, event location) of the same equation of
//! motion, on random parameter sets across every regime: displacement within
//! 1e-9 m, acceleration within 1e-7 m/s^2 away from the jumps.

use crate::common;

use common::{Regime, REGIMES};
use hbis::model::{PhaseKind, Response, SimError};

#[test]
fn closed_form_agrees_with_runge_kutta_in_every_regime() {
    let mut per_regime = [0usize; REGIMES.len()];
    let (mut worst_u, mut worst_a): (f64, f64) = (0.0, 0.0);
    let mut diverged = 0;
    let mut phase_regimes = [0usize; 4];
    for case in common::cases(7, 1200) {
        let duration = case.dt * (case.n - 1) as f64;
        let r = match Response::simulate(&case.spec, &case.params, duration) {
            Ok(r) => r,
            Err(SimError::Diverged { .. }) => {
                // Net negative stiffness: the reference must run away too.
                assert!(
                    common::reference::solve(&case.spec, &case.params, case.dt, case.n).is_err(),
                    "{case:?}"
                );
                diverged += 1;
                continue;
            }
            Err(e) => panic!("{case:?}: {e}"),
        };
        for p in r.phases().iter().filter(|p| p.kind != PhaseKind::Rest) {
            let (k, a) = (p.lin.stiffness(), p.lin.alpha());
            let w2 = k - a * a;
            let scale = k.abs().max(a * a).max(1e-300);
            // [negative K, K = 0 (to round-off), over-damped, critical]
            let kinds = [
                k < 0.0 && k.abs() > 1e-9 * scale,
                k.abs() <= 1e-12,
                w2 < 0.0 && k > 0.0,
                w2.abs() <= 1e-9 * scale,
            ];
            for (n, hit) in phase_regimes.iter_mut().zip(kinds) {
                *n += hit as usize;
            }
        }
        let ours = r.sample_grid(case.dt).unwrap();
        let reference = common::reference::solve(&case.spec, &case.params, case.dt, case.n)
            .unwrap_or_else(|e| panic!("{case:?}: reference failed: {e}"));
        assert_eq!(ours.len(), reference.samples.len());
        // Jump times of both solutions: samples closer than this to one
        // straddle a jump whose time the two place a hair apart.
        let mut jumps: Vec<f64> = reference.jumps.clone();
        jumps.extend(
            r.phases()
                .iter()
                .filter(|p| p.v_end == 0.0)
                .map(|p| p.t_end),
        );
        for (i, (s, q)) in ours.iter().zip(&reference.samples).enumerate() {
            let du = (s.u - q.u).abs();
            assert!(
                du < 1e-9,
                "{case:?}\n sample {i} t={}: u {} vs {} (|du| = {du:e})",
                s.t,
                s.u,
                q.u
            );
            worst_u = worst_u.max(du);
            let near_jump = jumps.iter().any(|&tj| (tj - s.t).abs() < 1e-6);
            if !near_jump {
                let da = (s.a - q.a).abs();
                assert!(
                    da < 1e-7,
                    "{case:?}\n sample {i} t={}: a {} vs {} (|da| = {da:e})",
                    s.t,
                    s.a,
                    q.a
                );
                worst_a = worst_a.max(da);
            }
        }
        per_regime[REGIMES.iter().position(|&g| g == case.regime).unwrap()] += 1;
    }
    let checked: usize = per_regime.iter().sum();
    eprintln!(
        "checked {checked} (per regime {per_regime:?}), diverged {diverged}; phases with K<0, K=0, over-damped, critical: {phase_regimes:?}; worst |du| {worst_u:.1e} m, |da| {worst_a:.1e} m/s^2"
    );
    for (name, &n) in ["K < 0", "K = 0", "over-damped", "critical"]
        .iter()
        .zip(&phase_regimes)
    {
        assert!(n >= 20, "only {n} phases {name}");
    }
    assert!(checked >= 1000, "only {checked} parameter sets compared");
    for (g, &k) in REGIMES.iter().zip(&per_regime) {
        let floor = if *g == Regime::NegativeStiffness {
            50
        } else {
            150
        };
        assert!(k >= floor, "regime {g:?}: only {k} parameter sets");
    }
}
