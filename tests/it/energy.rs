//! Energy balance: the work of the spring, the slider and the damper (the
//! damper's by an independent quadrature of `c v^2`) equals the change of
//! kinetic energy, on random parameters of every regime.

use crate::common;

use hbis::model::{Response, SimError};

#[test]
fn work_of_all_forces_equals_the_change_of_kinetic_energy() {
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    for case in common::cases(20261122, 600) {
        let duration = case.dt * (case.n - 1) as f64;
        let r = match Response::simulate(&case.spec, &case.params, duration) {
            Ok(r) => r,
            // A runaway response (net negative stiffness) has no balance to check.
            Err(SimError::Diverged { .. }) => continue,
            Err(e) => panic!("{case:?}: {e}"),
        };
        let w = r.work();
        let imbalance = w.relative_imbalance();
        assert!(imbalance < 1e-9, "{case:?}: {w:?} imbalance {imbalance:e}");
        worst = worst.max(imbalance);
        checked += 1;
    }
    assert!(checked >= 550, "only {checked} cases checked");
    eprintln!("energy balance: {checked} cases, worst relative imbalance {worst:.2e}");
}
