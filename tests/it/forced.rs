//! The closed-form response to a ground acceleration against the numerical
//! engine (Dormand-Prince at tolerance 1e-12 on the same equation), on
//! random models, parameter sets and synthetic motions, sticking and
//! breakaway included.

use crate::common;

use hbis::data::ground_motion::KanaiTajimi;
use hbis::model::forced::{Excitation, Peaks};
use hbis::model::numeric::NumericSystem;
use hbis::model::{SimError, SimOptions, System};

/// A short motion of `seed` (6 s of shaking at 100 Hz, PGA `pga`).
fn motion(seed: u64, pga: f64, f_g: f64) -> Vec<f64> {
    let kt = KanaiTajimi {
        pga,
        f_g,
        duration: 6.0,
        t1: 0.5,
        t2: 3.0,
        decay: 0.8,
        ..KanaiTajimi::default()
    };
    kt.generate(seed).unwrap().ag
}

struct Run {
    u: Vec<f64>,
    peaks: Peaks,
}

fn both(system: &System, ex: &Excitation) -> Result<(Run, Run), SimError> {
    let mut uc = Vec::new();
    let closed = system.forced(ex, &SimOptions::default(), &mut uc)?;
    let mut un = Vec::new();
    let numeric = NumericSystem::with_terms(system.clone(), &[]).forced(ex, 1e-12, &mut un)?;
    Ok((
        Run {
            u: uc,
            peaks: closed,
        },
        Run {
            u: un,
            peaks: numeric,
        },
    ))
}

#[test]
fn closed_form_under_shaking_matches_the_numerical_engine() {
    let (mut worst, mut samples, mut stuck_runs) = (0.0f64, 0usize, 0usize);
    let (mut compared, mut diverged) = (0usize, 0usize);
    const CASES: usize = 120;
    for (i, case) in common::cases(41, CASES).into_iter().enumerate() {
        let ag = motion(100 + i as u64, [1.0, 3.0, 6.0][i % 3], [1.0, 2.5][i % 2]);
        let ex = Excitation::new(0.01, &ag, 4.0).unwrap();
        let system = System::new(&case.spec, &case.params);
        let (closed, numeric) = match both(&system, &ex) {
            Ok(r) => r,
            // A motion that drives a negative-stiffness branch away: no
            // response to compare, counted below.
            Err(SimError::Diverged { .. }) => {
                diverged += 1;
                continue;
            }
            Err(e) => panic!("{case:?}: {e}"),
        };
        compared += 1;
        assert_eq!(closed.u.len(), ex.len());
        for (j, (a, b)) in closed.u.iter().zip(&numeric.u).enumerate() {
            let err = (a - b).abs();
            assert!(err < 1e-9, "{case:?} sample {j}: closed {a} numeric {b}");
            worst = worst.max(err);
            samples += 1;
        }
        let (p, q) = (closed.peaks, numeric.peaks);
        assert!(
            (p.peak_displacement - q.peak_displacement).abs() < 1e-9,
            "{case:?}: {p:?} {q:?}"
        );
        assert!((p.residual_displacement - q.residual_displacement).abs() < 1e-9);
        assert!(
            (p.peak_base_shear - q.peak_base_shear).abs() < 1e-9 * (1.0 + q.peak_base_shear),
            "{case:?}: {p:?} {q:?}"
        );
        assert!(
            (p.peak_total_acceleration - q.peak_total_acceleration).abs()
                < 1e-9 * (1.0 + q.peak_total_acceleration),
            "{case:?}: {p:?} {q:?}"
        );
        assert!(
            (p.peak_base_shear - p.peak_total_acceleration).abs()
                < 1e-9 * (1.0 + p.peak_base_shear)
        );
        assert_eq!(p.deepest_branch, q.deepest_branch, "{case:?}");
        // The record ends at rest, stuck, when there is friction.
        if closed.u.windows(2).rev().take(50).all(|w| w[0] == w[1]) {
            stuck_runs += 1;
        }
    }
    eprintln!(
        "forced: {compared} of {CASES} cases compared ({diverged} diverged), {samples} samples, worst |du| {worst:.2e} m, {stuck_runs} runs end stuck"
    );
    assert_eq!(compared + diverged, CASES);
    assert!(compared >= 100, "only {compared} of {CASES} cases compared");
    assert!(samples > 20_000 && stuck_runs > 5);
}

/// A friction amplitude that falls to zero within the motion's reach
/// (`rF0 < 0`): floored in both engines, which still agree.
#[test]
fn a_falling_friction_is_floored_at_zero_in_both_engines() {
    let spec = "trilinear+lcfm+viscous".parse().unwrap();
    let mut p = hbis::model::Params::table_8_1(5).unwrap();
    p.uf0 = 0.004;
    p.rf0 = -0.08; // amplitude zero at |u| = 0.05 m
    let system = System::new(&spec, &p);
    let ag = motion(7, 4.0, 1.0);
    let ex = Excitation::new(0.01, &ag, 4.0).unwrap();
    let (closed, numeric) = both(&system, &ex).unwrap();
    assert!(closed.peaks.peak_displacement > 0.06, "{:?}", closed.peaks);
    assert!(closed.peaks.friction_floored && numeric.peaks.friction_floored);
    for (a, b) in closed.u.iter().zip(&numeric.u) {
        assert!((a - b).abs() < 1e-9, "{a} {b}");
    }
}

/// A component that runs only numerically (velocity-dependent friction):
/// with no velocity dependence (`r_mu = 1`) its forced response is the
/// closed form's; with it, the response changes.
#[test]
fn numerically_solved_components_respond_on_the_numerical_engine() {
    let registry = hbis::model::Registry::builtin();
    let base = registry.parse("trilinear+lcfm+viscous").unwrap();
    let slow = registry
        .parse("trilinear+lcfm+viscous+velocity-friction")
        .unwrap();
    assert!(!slow.closed_form());
    let p = hbis::model::Params::table_8_1(5).unwrap();
    let ag = motion(11, 3.0, 1.0);
    let ex = Excitation::new(0.01, &ag, 4.0).unwrap();
    let mut a = Vec::new();
    let pa = base
        .forced(&base.theta_from_params(&p, &[]).unwrap(), &ex, &mut a)
        .unwrap();
    let mut b = Vec::new();
    let theta = slow.theta_from_params(&p, &[("r_mu", 1.0)]).unwrap();
    let pb = slow.forced(&theta, &ex, &mut b).unwrap();
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-6, "{worst}");
    assert!((pa.peak_displacement - pb.peak_displacement).abs() < 1e-6);
    let theta = slow
        .theta_from_params(&p, &[("r_mu", 0.5), ("v_t", 0.02)])
        .unwrap();
    let pc = slow.forced(&theta, &ex, &mut b).unwrap();
    let moved = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(moved > 1e-4, "{moved}");
    assert!(
        (pc.peak_base_shear - pc.peak_total_acceleration).abs() < 1e-9,
        "{pc:?}"
    );
}
